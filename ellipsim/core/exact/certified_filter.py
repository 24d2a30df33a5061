"""The certified float64 filter: decides a pair only when a rigorous error bound proves it.

Every decision is a certificate about the exact ellipsoids the float64 inputs define:

* separated: a separating direction (the centre line: bounding spheres, then the exact support
  functions), or some mu > 0 with f(mu) > 0.  f(0) = -alpha t3 < 0 and f(+inf) < 0, so
  f(mu) > 0 forces two distinct positive roots of the pencil: separated by the theorem of Wang,
  Wang & Kim (thesis ch. 4, Theorem 1).
* overlapping: a point strictly inside both.  First a point c_a + t (c_b - c_a) of the centre
  segment (t = 0 and t = 1 are the centres), then the Perram-Wertheim point y(mu*) in A's frame,
  where q_A and q_B are equal at the optimum: |y|^2 < 1 and (y - e)^T K_c (y - e) < alpha.

Each test compares a computed value with gamma_n * mag + TAU (pair_frame.py, tolerances.py).  Touching
pairs, and pairs too close to touching for float64, come back UNDECIDED for exact arithmetic.
Unlike tolerance-based tests (e.g. HOOMD-blue's ShapeEllipsoid.h, relative 1e-6), a decision
here is never wrong; an ill-conditioned float only makes the answer slower.

The centre-line tests settle ~80% of random pairs for ~20 ns; the rest pay for A's frame, its
error magnitudes and a few Newton steps of the Perram-Wertheim maximisation (`ellipsim bench`).
"""

import math

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..relation import OVERLAPPING, SEPARATED, UNDECIDED
from ..tolerances import (
    BOUNDING_INFLATION,
    ERR_POLY,
    ERR_SHORT,
    ERR_WITNESS,
    MU_MAX,
    MU_MIN,
    PW_MAX_ITER,
    PW_RTOL,
    PW_TRY_SEPARATED,
    RATIO_MAX,
    SCALE_MAX,
    SCALE_MIN,
    SUPPORT_SLACK,
    TAU,
)
from ..vec3 import load, matvec, norm2, reciprocal, rotate_t, rotate_t_mag
from .contact_scale import initial_mu, pw_step, pw_value
from .pair_frame import invariants, pencil, pencil_mag, shape


@stage
def _positive(value, mag, err):
    """True when `value`, computed with error at most err * mag + TAU, is certainly > 0."""
    return value > err * mag + TAU


@stage
def bounding_spheres_apart(ra, rb, dd):
    """|c_b - c_a|^2 = dd [4] beyond (rho_a + rho_b)^2: |x - c| <= r_max * BOUNDING_INFLATION on E."""
    rho = (max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])) * BOUNDING_INFLATION
    rr = rho * rho
    return _positive(dd - rr, dd + rr, ERR_SHORT) or (dd == math.inf and rr < 1e300)


@stage
def axis_separates(nd, mnd, nn, za, ra, zb, rb, rsum):
    """n . d > h_A(n) + h_B(-n): the plane normal to n separates A and B.

    nd = n . (c_b - c_a) with its mag mnd, nn = |n|^2, za = R_a^T n, zb = R_b^T n (floats).  The exact
    support is h(n) = |D R^{-1} n|; for a validated rotation ||R^{-1} - R^T|| <= 3.1e-6, and the
    float evaluation of |D R^T n| errs by < 1e-14 r_max |n|: SUPPORT_SLACK * (r_max,a + r_max,b) * |n|
    covers both.
    """
    ha = math.sqrt((ra[0] * za[0]) ** 2 + (ra[1] * za[1]) ** 2 + (ra[2] * za[2]) ** 2)
    hb = math.sqrt((rb[0] * zb[0]) ** 2 + (rb[1] * zb[1]) ** 2 + (rb[2] * zb[2]) ** 2)
    bound = ha + hb + SUPPORT_SLACK * rsum * math.sqrt(nn)
    return _positive(nd - bound, mnd + bound, ERR_SHORT)


@stage
def bisector_axis(Ra, ra, za, Rb, rb, zb):
    """The bisector of Q_A d and Q_B d: the normals where the centre line leaves A and B
    (za = R_a^T d, zb = R_b^T d).  It lies near the separating direction of most pairs the centre line
    misses.  Q d = R D^-2 R^T d is scaled by det(D)^2 > 0 (no divisions) and the bisector of u and w
    is u |w| + w |u|; any float vector is a valid candidate, the test itself is what is rigorous."""
    a0, a1, a2 = ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]
    b0, b1, b2 = rb[0] * rb[0], rb[1] * rb[1], rb[2] * rb[2]
    na = matvec(Ra, (za[0] * a1 * a2, za[1] * a0 * a2, za[2] * a0 * a1))
    nb = matvec(Rb, (zb[0] * b1 * b2, zb[1] * b0 * b2, zb[2] * b0 * b1))
    la, lb = math.sqrt(norm2(na)), math.sqrt(norm2(nb))
    return (na[0] * lb + nb[0] * la, na[1] * lb + nb[1] * la, na[2] * lb + nb[2] * la)


@stage
def bisector_separates(d, Ra, ra, za, Rb, rb, zb, rsum):
    """axis_separates along bisector_axis."""
    n = bisector_axis(Ra, ra, za, Rb, rb, zb)
    nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2]
    mnd = abs(n[0] * d[0]) + abs(n[1] * d[1]) + abs(n[2] * d[2])
    return axis_separates(nd, mnd, norm2(n), rotate_t(Ra, n), ra, rotate_t(Rb, n), rb, rsum)


@stage
def centre_segment_overlaps(ee, mee, qb, mqb):
    """A point c_a + t d of the centre segment strictly inside both: t^2 q_A(c_b) < 1, (1-t)^2 q_B(c_a) < 1.

    q_A(c_b) = ee [8] and q_B(c_a) = qb [8] with mags; t = sqrt(qb) / (sqrt(ee) + sqrt(qb)) equalises
    the two when 1 / sqrt(ee) + 1 / sqrt(qb) > 1.  t = 1 and t = 0 are the centre-inside tests.
    """
    sa, sb = math.sqrt(ee), math.sqrt(qb)
    t = sb / (sa + sb)
    s = 1.0 - t  # [1]
    return _positive(1.0 - t * t * ee, 1.0 + t * t * mee, ERR_SHORT) and _positive(
        1.0 - s * s * qb, 1.0 + s * s * mqb, ERR_SHORT
    )


@stage
def witness(mu, W, e, v, inv):
    """y(mu) = (mu I + K_c)^{-1} K_c e = (mu^2 g1 + mu (t1 g1 - g2) + t3 e) / P(mu), g_k = K_c^k e.

    Only a candidate point: whether it is inside both is checked rigorously afterwards.
    """
    t1, t2, t3 = inv[0], inv[1], inv[2]
    g1 = rotate_t(W, v)  # W^T v
    g2 = rotate_t(W, matvec(W, g1))
    ip = 1.0 / (((mu + t1) * mu + t2) * mu + t3)
    y0 = (mu * mu * g1[0] + mu * (t1 * g1[0] - g2[0]) + t3 * e[0]) * ip
    y1 = (mu * mu * g1[1] + mu * (t1 * g1[1] - g2[1]) + t3 * e[1]) * ip
    y2 = (mu * mu * g1[2] + mu * (t1 * g1[2] - g2[2]) + t3 * e[2]) * ip
    return y0, y1, y2


@stage
def inside_both(y, W, mW, e, me, alpha, malpha):
    """|y|^2 < 1 [4] and alpha - |W_c (y - e)|^2 > 0 [13], both certified."""
    yy = norm2(y)
    if not _positive(1.0 - yy, 1.0 + yy, ERR_WITNESS):
        return False
    u = (y[0] - e[0], y[1] - e[1], y[2] - e[2])  # [6]
    mu_ = (abs(y[0]) + me[0], abs(y[1]) + me[1], abs(y[2]) + me[2])
    return _positive(alpha - norm2(matvec(W, u)), malpha + norm2(matvec(mW, mu_)), ERR_WITNESS)


@stage
def pencil_positive(mu, inv, minv, alpha, malpha):
    """f(mu) > 0 certified: then the pencil has two distinct positive roots (separated)."""
    mu = min(max(mu, MU_MIN), MU_MAX)
    return _positive(pencil(mu, inv, alpha), pencil_mag(mu, minv, malpha), ERR_POLY)


@stage
def pencil_certificates(Ra, ra, Rb, ib, e, me, ee, qb):
    """The Perram-Wertheim iteration in A's frame, trying a certificate whenever it is likely to hold.

    F(mu) > 1 at any mu already proves separation, so f(mu) > 0 is tried at once.  The point y(mu)
    is inside both only near mu*, so it is tried once Newton's step (~ the distance to mu*) is
    small against 1 - F.
    """
    W, mW, alpha, malpha = shape(Ra, ra, Rb, ib, True)
    v, mv = matvec(W, e), matvec(mW, me)
    inv, minv = invariants(W, mW, e, me, v, mv)
    mu = initial_mu(ee, qb, alpha)
    # The sphere-exact starting point alone settles ~80% of the pairs that get here.
    if pw_value(mu, inv, alpha) > 1.0 + PW_TRY_SEPARATED:
        if pencil_positive(mu, inv, minv, alpha, malpha):
            return SEPARATED
    elif inside_both(witness(mu, W, e, v, inv), W, mW, e, me, alpha, malpha):
        return OVERLAPPING
    lo, hi = 0.0, math.inf
    for it in range(PW_MAX_ITER):
        new, lo, hi, value = pw_step(mu, inv, alpha, lo, hi)
        step = abs(new - mu)
        last = step <= PW_RTOL * mu or it == PW_MAX_ITER - 1
        if (value > 1.0 + PW_TRY_SEPARATED or last) and pencil_positive(mu, inv, minv, alpha, malpha):
            return SEPARATED
        if (value < 1.0 and step < 0.1 * (1.0 - value) * mu) or last:
            if inside_both(witness(mu, W, e, v, inv), W, mW, e, me, alpha, malpha):
                return OVERLAPPING
        if last:
            break
        mu = new
    return UNDECIDED


@stage
def _in_float_range(ra, rb):
    """The float path's domain (tolerances.RATIO_MAX, SCALE_MIN, SCALE_MAX)."""
    rmax = max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    return rmax <= RATIO_MAX * min(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2]) and SCALE_MIN <= rmax <= SCALE_MAX


@jit
def certify_pair(A, B):
    """SEPARATED (0), OVERLAPPING (2) when certain, else UNDECIDED (-1); A, B from vec3.load."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])  # [1]
    dd = norm2(d)  # [4]
    if dd == 0.0:  # concentric: the common centre is inside both
        return OVERLAPPING
    if bounding_spheres_apart(ra, rb, dd):
        return SEPARATED
    if not _in_float_range(ra, rb):
        return UNDECIDED
    rsum = max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])
    za, zb = rotate_t(Ra, d), rotate_t(Rb, d)  # [4]
    if axis_separates(dd, dd, dd, za, ra, zb, rb, rsum):  # the centre line
        return SEPARATED
    md = (abs(d[0]), abs(d[1]), abs(d[2]))
    mza, mzb = rotate_t_mag(Ra, md), rotate_t_mag(Rb, md)
    ia, ib = reciprocal(ra), reciprocal(rb)  # [1]
    e = (za[0] * ia[0], za[1] * ia[1], za[2] * ia[2])  # [5]: q_A(c_b) = |e|^2
    me = (mza[0] * ia[0], mza[1] * ia[1], mza[2] * ia[2])
    f = (zb[0] * ib[0], zb[1] * ib[1], zb[2] * ib[2])  # q_B(c_a) = |f|^2
    mf = (mzb[0] * ib[0], mzb[1] * ib[1], mzb[2] * ib[2])
    ee, qb = norm2(e), norm2(f)  # [8]
    if centre_segment_overlaps(ee, norm2(me), qb, norm2(mf)):
        return OVERLAPPING
    if bisector_separates(d, Ra, ra, za, Rb, rb, zb, rsum):
        return SEPARATED
    return pencil_certificates(Ra, ra, Rb, ib, e, me, ee, qb)


@stage
def centre_line_separates(A, B):
    """The first two of separated_by_axes's axes: the bounding spheres, then the centre line.  The
    narrow phase's first test (~10 ns): it settles most separated pairs before the warm-start table
    is read."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
    dd = norm2(d)
    if dd == 0.0:
        return False
    if bounding_spheres_apart(ra, rb, dd):
        return True
    if not _in_float_range(ra, rb):
        return False
    rsum = max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])
    return axis_separates(dd, dd, dd, rotate_t(Ra, d), ra, rotate_t(Rb, d), rb, rsum)


@stage
def bisector_separates_pair(A, B):
    """The last of separated_by_axes's axes, the bisector of the exit normals (bisector_separates)."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
    if norm2(d) == 0.0 or not _in_float_range(ra, rb):
        return False
    rsum = max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])
    return bisector_separates(d, Ra, ra, rotate_t(Ra, d), Rb, rb, rotate_t(Rb, d), rsum)


@jit
def separated_by_axes(A, B):
    """True when a separating plane normal to one of three cheap axes is certified: the bounding
    spheres, the centre line, the bisector of the exit normals.  The contact filter's test: it
    proves ~95% of the separated pairs a MuJoCo broad phase produces for ~40 ns, where the full
    certify_pair would spend ~100 ns more on every touching pair it must keep anyway."""
    return centre_line_separates(A, B) or bisector_separates_pair(A, B)


@jit
def _certify(Ca, Ra, ra, Cb, Rb, rb, out, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(lo, hi):
        ia, ib = i * sa, i * sb
        out[i] = certify_pair(load(Ca, Ra, ra, ia), load(Cb, Rb, rb, ib))


def certify(a, b, n, parallel):
    """int8 (n,): SEPARATED / OVERLAPPING where the float path is certain, UNDECIDED (-1) elsewhere."""
    out = np.empty(n, dtype=np.int8)
    threads.run(ext.certify, n, parallel, a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out)
    return out
