"""The certified float64 filter: decides a pair only when a rigorous error bound proves it.

Every decision is a certificate about the exact ellipsoids the float64 inputs define:

* separated: a separating direction (the centre line: bounding spheres, then the exact support
  functions), or some mu > 0 with f(mu) > 0.  f(0) = -alpha t3 < 0 and f(+inf) < 0, so
  f(mu) > 0 forces two distinct positive roots of the pencil: separated by the theorem of Wang,
  Wang & Kim (thesis ch. 4, Theorem 1).
* overlapping: a point strictly inside both.  First a point c_a + t (c_b - c_a) of the centre
  segment (t = 0 and t = 1 are the centres), then the Perram-Wertheim point y(mu*) in A's frame,
  where q_A and q_B are equal at the optimum: |y|^2 < 1 and (y - e)^T K_c (y - e) < alpha.

Each test compares a computed value with gamma_n * mag + TAU (frame.py, tolerances.py).  Touching
pairs, and pairs too close to touching for float64, come back UNDECIDED for exact arithmetic.
Unlike tolerance-based tests (e.g. HOOMD-blue's ShapeEllipsoid.h, relative 1e-6), a decision
here is never wrong; an ill-conditioned float only makes the answer slower.

The centre-line tests settle ~80% of random pairs for ~20 ns; the rest pay for A's frame, its
error magnitudes and a few Newton steps of the Perram-Wertheim maximisation (bench/).
"""

import math

import numpy as np

from ._jit import jit, prange, stage
from .contact import initial_mu, pw_step
from .frame import invariants, load, matvec, norm2, offset, pencil, pencil_mag, shape, tmatvec
from .roots import OVERLAPPING, SEPARATED
from .tolerances import (
    BOUNDING_INFLATION,
    ERR_POLY,
    ERR_SHORT,
    ERR_WITNESS,
    MU_MAX,
    MU_MIN,
    PW_MAX_ITER,
    PW_STAGES,
    RATIO_MAX,
    SUPPORT_SLACK,
    TAU,
)

UNDECIDED = -1


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
def _support(R, r, d):
    """|D R^T d|: the support function of E along d when R is orthonormal, in float."""
    z0 = R[0] * d[0] + R[3] * d[1] + R[6] * d[2]
    z1 = R[1] * d[0] + R[4] * d[1] + R[7] * d[2]
    z2 = R[2] * d[0] + R[5] * d[1] + R[8] * d[2]
    return math.sqrt((r[0] * z0) ** 2 + (r[1] * z1) ** 2 + (r[2] * z2) ** 2)


@stage
def centre_axis_separates(ra, Ra, rb, Rb, d, dd):
    """d . d > h_A(d) + h_B(-d): the plane normal to the centre line separates A and B.

    The exact support is h(d) = |D R^{-1} d|.  For a validated rotation, ||R^{-1} - R^T|| <= 3.1e-6,
    and the float evaluation of |D R^T d| errs by < 1e-15 relative plus 2 gamma_4 r_max |d|;
    SUPPORT_SLACK * r_max * |d| covers both.
    """
    h = _support(Ra, ra, d) + _support(Rb, rb, d)
    slack = SUPPORT_SLACK * (max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])) * math.sqrt(dd)
    bound = h + slack
    return _positive(dd - bound, dd + bound, ERR_SHORT)


@stage
def centre_segment_overlaps(ee, mee, qb, mqb):
    """A point c_a + t d of the centre segment strictly inside both: t^2 q_A(c_b) < 1, (1-t)^2 q_B(c_a) < 1.

    q_A(c_b) = ee [8] and q_B(c_a) = qb [8] with mags; t = sqrt(qb) / (sqrt(ee) + sqrt(qb)) equalises
    the two when 1 / sqrt(ee) + 1 / sqrt(qb) > 1.  t = 1 and t = 0 are the centre-inside tests.
    """
    sa, sb = math.sqrt(ee), math.sqrt(qb)
    t = sb / (sa + sb)
    s = 1.0 - t
    return _positive(1.0 - t * t * ee, 1.0 + t * t * mee, ERR_SHORT) and _positive(
        1.0 - s * s * qb, 1.0 + s * s * mqb, ERR_SHORT
    )


@stage
def witness(mu, W, e, v, inv):
    """y(mu) = (mu I + K_c)^{-1} K_c e = (mu^2 g1 + mu (t1 g1 - g2) + t3 e) / P(mu), g_k = K_c^k e.

    Only a candidate point: whether it is inside both is checked rigorously afterwards.
    """
    t1, t2, t3 = inv[0], inv[1], inv[2]
    g1 = tmatvec(W, v)
    g2 = tmatvec(W, matvec(W, g1))
    p = ((mu + t1) * mu + t2) * mu + t3
    y0 = (mu * mu * g1[0] + mu * (t1 * g1[0] - g2[0]) + t3 * e[0]) / p
    y1 = (mu * mu * g1[1] + mu * (t1 * g1[1] - g2[1]) + t3 * e[1]) / p
    y2 = (mu * mu * g1[2] + mu * (t1 * g1[2] - g2[2]) + t3 * e[2]) / p
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


@jit
def certify_pair(A, B):
    """SEPARATED (0), OVERLAPPING (2) when certain, else UNDECIDED (-1); A, B from frame.load."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])  # [1]
    dd = norm2(d)  # [4]
    if dd == 0.0:  # concentric: the common centre is inside both
        return OVERLAPPING
    if bounding_spheres_apart(ra, rb, dd):
        return SEPARATED
    if max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2]) > RATIO_MAX * min(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2]):
        return UNDECIDED
    if centre_axis_separates(ra, Ra, rb, Rb, d, dd):
        return SEPARATED
    e, me = offset(ca, Ra, ra, cb)  # q_A(c_b) = |e|^2
    f, mf = offset(cb, Rb, rb, ca)  # q_B(c_a) = |f|^2
    ee, qb = norm2(e), norm2(f)
    if centre_segment_overlaps(ee, norm2(me), qb, norm2(mf)):
        return OVERLAPPING
    # A's frame and the Perram-Wertheim optimum, certified at widening precision.
    W, mW, alpha, malpha = shape(Ra, ra, Rb, rb, True)
    v, mv = matvec(W, e), matvec(mW, me)
    inv, minv = invariants(W, mW, e, me, v, mv)
    mu = initial_mu(ee, qb, alpha)
    lo, hi = 0.0, math.inf
    stage_ = 0
    for it in range(PW_MAX_ITER):
        new, lo, hi = pw_step(mu, inv, alpha, lo, hi)
        done = abs(new - mu) <= PW_STAGES[stage_] * mu
        mu = new
        if done or it == PW_MAX_ITER - 1:
            if pencil_positive(mu, inv, minv, alpha, malpha):
                return SEPARATED
            if inside_both(witness(mu, W, e, v, inv), W, mW, e, me, alpha, malpha):
                return OVERLAPPING
            if stage_ == len(PW_STAGES) - 1:
                break
            stage_ += 1
    return UNDECIDED


@jit
def _certify_serial(Ca, Ra, ra, Cb, Rb, rb, out):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(out.shape[0]):
        ia, ib = i * sa, i * sb
        out[i] = certify_pair(load(Ca, Ra, ra, ia), load(Cb, Rb, rb, ib))


@jit(parallel=True)
def _certify_parallel(Ca, Ra, ra, Cb, Rb, rb, out):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in prange(out.shape[0]):
        ia, ib = i * sa, i * sb
        out[i] = certify_pair(load(Ca, Ra, ra, ia), load(Cb, Rb, rb, ib))


def certify(a, b, n, parallel):
    """int8 (n,): SEPARATED / OVERLAPPING where the float path is certain, UNDECIDED (-1) elsewhere."""
    out = np.empty(n, dtype=np.int8)
    kernel = _certify_parallel if parallel else _certify_serial
    kernel(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out)
    return out
