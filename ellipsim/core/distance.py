"""Signed distance, contact normal and contact point of two ellipsoids (the narrow phase).

The signed distance of two convex bodies is the maximum over unit directions n of

    sigma(n) = n . (c_B - c_A) - h_A(n) - h_B(-n),    h(n) = |D R^T n|  (ellipsoid support function),

positive when separated (the distance), negative when penetrating (minus the depth); at the
maximiser n* the normal is n* (from A to B, MuJoCo's convention) and the contact point is the
midpoint of the support points c_A + grad h_A(n*) and c_B - grad h_B(n*), as mjc_Convex reports it
(engine_collision_convex.c: pos = (x1 + x2) / 2, dist = margin + depth of the margin-grown bodies).

sigma is positively homogeneous of degree 1 and concave on R^3 (h is convex).  We maximise it on the
unit sphere by Riemannian Newton in A's principal frame; there the Hessian of sigma restricted to
the tangent plane is H - sigma I with H <= 0 (Hessian of -h_A - h_B), so:
* separated (sigma > 0): every Newton step is well-posed and the local maximum is global (a concave
  function maximised over the unit ball, whose maximum sits on the sphere);
* penetrating: sigma may have several local maxima (crossed, elongated limbs), so Newton runs from
  the three best of 15 cheap seed directions (centre line, principal axes of both, the cross product
  of the long axes), with a Levenberg shift where H - sigma I is not negative definite.  Three of 15
  found the global maximum in every one of 1791 random penetrating pairs (the first release's narrow-phase benchmark).
A run that does not converge in NEWTON_MAX_ITER steps is reported, and the MuJoCo glue falls back to
MuJoCo's own function for that pair.
"""

import math

import numpy as np

from ._jit import jit, prange, stage
from .ellipsoids import check_pair, check_parallel
from .vec3 import load, matvec, norm2, rotate_t, sandwich, scaled, unit_scale
from .tolerances import FIRST_RUN_ITER, NEWTON_MAX_ITER, NEWTON_STEP_TOL, SAME_BASIN_COS

#: What signed_distance reports per pair: GLOBAL (a converged maximum proven global), BEST_OF_SEEDS
#: (the best of the maxima Newton reached from several seeds: deep penetrations, not proven global),
#: NOT_CONVERGED (a run did not converge; the MuJoCo glue falls back to MuJoCo's own function).
GLOBAL, NOT_CONVERGED, BEST_OF_SEEDS = 0, 1, 3

#: How one Newton run ended: at a local maximum, or abandoned (its bound stays below a known value).
CONVERGED, ABANDONED = 0, 2


@stage
def _tmatmul(A, B):
    """A^T B for row-major 3x3 tuples."""
    return (
        A[0] * B[0] + A[3] * B[3] + A[6] * B[6], A[0] * B[1] + A[3] * B[4] + A[6] * B[7], A[0] * B[2] + A[3] * B[5] + A[6] * B[8],
        A[1] * B[0] + A[4] * B[3] + A[7] * B[6], A[1] * B[1] + A[4] * B[4] + A[7] * B[7], A[1] * B[2] + A[4] * B[5] + A[7] * B[8],
        A[2] * B[0] + A[5] * B[3] + A[8] * B[6], A[2] * B[1] + A[5] * B[4] + A[8] * B[7], A[2] * B[2] + A[5] * B[5] + A[8] * B[8],
    )  # fmt: skip


@stage
def a_frame(A, B):
    """The pair in A's principal frame: (e = R_A^T (c_B - c_A), a2 = r_A^2, M = U diag(r_B^2) U^T as a
    symmetric 9-tuple, U = R_A^T R_B (columns: B's axes in A's frame))."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    e = rotate_t(Ra, (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]))
    U = _tmatmul(Ra, Rb)
    b0, b1, b2 = rb[0] * rb[0], rb[1] * rb[1], rb[2] * rb[2]
    m00, m01, m02, m11, m12, m22 = sandwich(U, b0, b1, b2)
    M = (m00, m01, m02, m01, m11, m12, m02, m12, m22)
    return e, (ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]), M, U


@stage
def sigma(n, e, a2, M):
    """sigma(n) for any nonzero n, scaled to unit length."""
    s = 1.0 / math.sqrt(norm2(n))
    u = (n[0] * s, n[1] * s, n[2] * s)
    ha = math.sqrt(a2[0] * u[0] * u[0] + a2[1] * u[1] * u[1] + a2[2] * u[2] * u[2])
    mu = matvec(M, u)
    hb = math.sqrt(u[0] * mu[0] + u[1] * mu[1] + u[2] * mu[2])
    return u[0] * e[0] + u[1] * e[1] + u[2] * e[2] - ha - hb


@stage
def _unit(v):
    s = norm2(v)
    if s == 0.0:
        return (1.0, 0.0, 0.0)
    s = 1.0 / math.sqrt(s)
    return (v[0] * s, v[1] * s, v[2] * s)


@stage
def _tangent_basis(n):
    """Two unit vectors completing the unit n to an orthonormal frame."""
    if abs(n[0]) < 0.6:
        t = (0.0, n[2], -n[1])  # e_x x n
    else:
        t = (-n[2], 0.0, n[0])  # e_y x n
    s = 1.0 / math.sqrt(norm2(t))
    t1 = (t[0] * s, t[1] * s, t[2] * s)
    t2 = (n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])
    return t1, t2


@stage
def newton(n, e, a2, M, scale, target, max_iter):
    """Maximise sigma on the unit sphere from the unit vector n: (n*, sigma before the last step,
    status, steps); the last step is below NEWTON_STEP_TOL, so sigma(n*) differs by O(tol^2).

    Riemannian Newton with the retraction n <- (n + x) / |n + x|, x in the tangent plane: a step of at
    most 0.5 rad, halved while it would decrease sigma (steps over 0.1 rad), a Levenberg shift where
    the tangent Hessian is not negative definite, and a 0.3 rad escape along the curvature direction
    from saddles.  Converged when a negative definite Newton step falls below NEWTON_STEP_TOL rad.

    target: a value another run already reached.  Where the tangent Hessian is negative definite
    with smallest curvature lam >= det / -trace, the quadratic model bounds this run's maximum by
    sigma + |g|^2 / (2 lam); a run whose bound stays below target is ABANDONED (-inf for none).
    """
    value = 0.0
    for it in range(max_iter):
        a = (a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
        b = matvec(M, n)
        ha = math.sqrt(a[0] * n[0] + a[1] * n[1] + a[2] * n[2])
        hb = math.sqrt(b[0] * n[0] + b[1] * n[1] + b[2] * n[2])
        inv = 1.0 / (ha * hb)
        ia, ib = hb * inv, ha * inv
        value = n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - ha - hb
        t1, t2 = _tangent_basis(n)
        # gradient e - a/ha - b/hb in the tangent basis
        at1, at2 = a[0] * t1[0] + a[1] * t1[1] + a[2] * t1[2], a[0] * t2[0] + a[1] * t2[1] + a[2] * t2[2]
        bt1, bt2 = b[0] * t1[0] + b[1] * t1[1] + b[2] * t1[2], b[0] * t2[0] + b[1] * t2[1] + b[2] * t2[2]
        g1 = e[0] * t1[0] + e[1] * t1[1] + e[2] * t1[2] - at1 * ia - bt1 * ib
        g2 = e[0] * t2[0] + e[1] * t2[1] + e[2] * t2[2] - at2 * ia - bt2 * ib
        gg = g1 * g1 + g2 * g2
        # Hessian of sigma: -(diag(a2)/ha - a a^T/ha^3) - (M/hb - b b^T/hb^3), then minus sigma I
        m1, m2 = matvec(M, t1), matvec(M, t2)
        ia3, ib3 = ia * ia * ia, ib * ib * ib
        d11 = a2[0] * t1[0] * t1[0] + a2[1] * t1[1] * t1[1] + a2[2] * t1[2] * t1[2]
        d12 = a2[0] * t1[0] * t2[0] + a2[1] * t1[1] * t2[1] + a2[2] * t1[2] * t2[2]
        d22 = a2[0] * t2[0] * t2[0] + a2[1] * t2[1] * t2[1] + a2[2] * t2[2] * t2[2]
        q11 = t1[0] * m1[0] + t1[1] * m1[1] + t1[2] * m1[2]
        q12 = t2[0] * m1[0] + t2[1] * m1[1] + t2[2] * m1[2]
        q22 = t2[0] * m2[0] + t2[1] * m2[1] + t2[2] * m2[2]
        h11 = -(d11 * ia - at1 * at1 * ia3) - (q11 * ib - bt1 * bt1 * ib3) - value
        h12 = -(d12 * ia - at1 * at2 * ia3) - (q12 * ib - bt1 * bt2 * ib3)
        h22 = -(d22 * ia - at2 * at2 * ia3) - (q22 * ib - bt2 * bt2 * ib3) - value
        det = h11 * h22 - h12 * h12
        shift = 0.0
        if h11 < -1e-12 * scale and det > 1e-24 * scale * scale:  # negative definite
            if value - 0.5 * gg * (h11 + h22) / det < target:
                return n, value, ABANDONED, it + 1
        else:
            top = 0.5 * (h11 + h22) + math.sqrt(0.25 * (h11 - h22) ** 2 + h12 * h12)
            if gg <= (1e-14 * scale) ** 2 and top <= 1e-10 * scale:
                return n, value, CONVERGED, it + 1  # a flat maximum (concentric spheres): any n is optimal
            if gg < 1e-4 * top * top:
                # near a saddle or a minimum: leave along the direction of positive curvature,
                # 0.3 rad to the side where sigma is larger (gradient steps would stall here)
                v1, v2 = top - h22, h12  # eigenvector of top: the larger of its two forms
                if v1 * v1 + v2 * v2 < h12 * h12 + (top - h11) ** 2:
                    v1, v2 = h12, top - h11
                if not v1 * v1 + v2 * v2 > 0.0:  # underflow: h is diagonal to rounding
                    v1, v2 = (1.0, 0.0) if h11 >= h22 else (0.0, 1.0)
                vs = 0.3 / math.sqrt(v1 * v1 + v2 * v2)
                v1, v2 = v1 * vs, v2 * vs
                p = (n[0] + v1 * t1[0] + v2 * t2[0], n[1] + v1 * t1[1] + v2 * t2[1], n[2] + v1 * t1[2] + v2 * t2[2])
                q = (n[0] - v1 * t1[0] - v2 * t2[0], n[1] - v1 * t1[1] - v2 * t2[1], n[2] - v1 * t1[2] - v2 * t2[2])
                n = _unit(p) if sigma(p, e, a2, M) >= sigma(q, e, a2, M) else _unit(q)
                continue
            shift = max(top, 0.0) + 1e-3 * scale + math.sqrt(gg)
            h11, h22 = h11 - shift, h22 - shift
            det = h11 * h22 - h12 * h12
        idet = 1.0 / det
        x1 = -(h22 * g1 - h12 * g2) * idet
        x2 = -(h11 * g2 - h12 * g1) * idet
        step2 = x1 * x1 + x2 * x2
        if step2 > 0.25:
            f = 0.5 / math.sqrt(step2)
            x1, x2, step2 = x1 * f, x2 * f, 0.25
        m = (n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2])
        if step2 > 1e-2:  # beyond 0.1 rad the quadratic model may overshoot: backtrack until sigma grows
            for _ in range(10):
                if sigma(m, e, a2, M) >= value:
                    break
                x1, x2, step2 = 0.5 * x1, 0.5 * x2, 0.25 * step2
                m = (n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2])
        s = 1.0 / math.sqrt(1.0 + step2)  # |n + x|^2 = 1 + |x|^2: x is tangent, n unit
        n = (m[0] * s, m[1] * s, m[2] * s)
        if step2 <= NEWTON_STEP_TOL * NEWTON_STEP_TOL and shift == 0.0:
            return n, value, CONVERGED, it + 1
    return n, value, NOT_CONVERGED, max_iter


@stage
def _long_axis(a2):
    """Unit vector of the longest principal axis of a diagonal form."""
    if a2[0] >= a2[1] and a2[0] >= a2[2]:
        return (1.0, 0.0, 0.0)
    if a2[1] >= a2[2]:
        return (0.0, 1.0, 0.0)
    return (0.0, 0.0, 1.0)


@stage
def _better(best, cand):
    """Keep the three (value, direction) pairs with the largest values, sorted."""
    (v1, n1), (v2, n2), (v3, n3) = best
    v, n = cand
    if v > v1:
        return (v, n), (v1, n1), (v2, n2)
    if v > v2:
        return (v1, n1), (v, n), (v2, n2)
    if v > v3:
        return (v1, n1), (v2, n2), (v, n)
    return best


@stage
def seeds(e, a2, M, U, rb2):
    """The three best of 15 seed directions by sigma: the centre line, +-the principal axes of A and of B,
    +-the cross product of their long axes."""
    ninf = -math.inf
    z = (1.0, 0.0, 0.0)
    best = ((ninf, z), (ninf, z), (ninf, z))
    c = _unit(e)
    best = _better(best, (sigma(c, e, a2, M), c))
    for k in range(3):
        ax = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        bx = (U[k], U[3 + k], U[6 + k])
        for sgn in (1.0, -1.0):
            u = (sgn * ax[0], sgn * ax[1], sgn * ax[2])
            best = _better(best, (sigma(u, e, a2, M), u))
            w = (sgn * bx[0], sgn * bx[1], sgn * bx[2])
            best = _better(best, (sigma(w, e, a2, M), w))
    la = _long_axis(a2)
    if rb2[0] >= rb2[1] and rb2[0] >= rb2[2]:
        lb = (U[0], U[3], U[6])
    elif rb2[1] >= rb2[2]:
        lb = (U[1], U[4], U[7])
    else:
        lb = (U[2], U[5], U[8])
    x = (la[1] * lb[2] - la[2] * lb[1], la[2] * lb[0] - la[0] * lb[2], la[0] * lb[1] - la[1] * lb[0])
    if norm2(x) > 1e-12:
        x = _unit(x)
        best = _better(best, (sigma(x, e, a2, M), x))
        xm = (-x[0], -x[1], -x[2])
        best = _better(best, (sigma(xm, e, a2, M), xm))
    return best


@stage
def bisector_seed(e, a2, U, rb2):
    """The bisector of Q_A d and Q_B d (the normals where the centre line leaves A and B), in A's frame;
    the start that needs the fewest Newton steps on touching pairs (the first release's narrow-phase benchmark).
    Q d is taken times det(D)^2 (no divisions) and the bisector of u and w is u |w| + w |u|."""
    na = (e[0] * a2[1] * a2[2], e[1] * a2[0] * a2[2], e[2] * a2[0] * a2[1])
    z = rotate_t(U, e)  # in B's axes
    nb = matvec(U, (z[0] * rb2[1] * rb2[2], z[1] * rb2[0] * rb2[2], z[2] * rb2[0] * rb2[1]))
    la, lb = math.sqrt(norm2(na)), math.sqrt(norm2(nb))
    return _unit((na[0] * lb + nb[0] * la, na[1] * lb + nb[1] * la, na[2] * lb + nb[2] * la))


@stage
def rolling_radius(r):
    """Smallest radius of curvature of an ellipsoid, c^2 / a: a ball of this radius rolls freely inside it."""
    lo, hi = min(r[0], r[1], r[2]), max(r[0], r[1], r[2])
    return lo * lo / hi


@jit
def pair_signed_distance(A, B, max_iter=NEWTON_MAX_ITER):
    """(status, dist, normal (3,), pos (3,), newton steps) of two ellipsoids in world coordinates.

    A, B as from vec3.load.  dist > 0: distance; < 0: minus the penetration depth.  normal: unit,
    from A to B.  pos: midpoint of the two support points (MuJoCo's contact position).
    status: GLOBAL, BEST_OF_SEEDS or NOT_CONVERGED (then the result is the best found).

    One Newton run from bisector_seed.  Its local maximum is the global one when sigma > 0 (concave
    problem) or when the depth -sigma < rho = rolling_radius(A) + rolling_radius(B): A + (-B) is a
    convex body plus a ball of radius rho, so depth - rho is minus the distance from the centre offset
    to a convex set, which has one local extremum.  Deeper penetrations get the multi-start.
    """
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    # the pair in units of vec3.unit_scale (1.0 unless a semi-axis is beyond 2^+-50): A at the origin
    u = unit_scale(ra, rb)
    ra, rb = scaled(ra, u), scaled(rb, u)
    d = ((cb[0] - ca[0]) * u, (cb[1] - ca[1]) * u, (cb[2] - ca[2]) * u)
    e, a2, M, U = a_frame(((0.0, 0.0, 0.0), Ra, ra), (d, Rb, rb))
    rb2 = (rb[0] * rb[0], rb[1] * rb[1], rb[2] * rb[2])
    scale = max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    rho = rolling_radius(ra) + rolling_radius(rb)
    n, value, status, steps = newton(bisector_seed(e, a2, U, rb2), e, a2, M, scale, -math.inf, min(max_iter, FIRST_RUN_ITER))
    if status != CONVERGED or value < -rho:
        # Deep (the global maximum may lie elsewhere), or the first run stalled (a needle seen along its
        # length puts sigma on a sharp ridge): climb from the three best of 15 seeds.
        found = status == CONVERGED
        stalled = False
        if not found:
            value = -math.inf
        for _, cand in seeds(e, a2, M, U, rb2):
            if found and cand[0] * n[0] + cand[1] * n[1] + cand[2] * n[2] > SAME_BASIN_COS:
                continue  # starts next to a maximum already found: it would climb into it again
            m, v, st, k = newton(cand, e, a2, M, scale, value + 1e-12 * scale if found else -math.inf, max_iter)
            steps += k
            if st == NOT_CONVERGED:
                stalled = True
            elif st == CONVERGED and v > value:
                n, value, found = m, v, True
        if found and (value > 0.0 or value > -rho):
            status = GLOBAL  # a converged local maximum inside the certificate is the global one
        elif not found or stalled:
            status = NOT_CONVERGED
        else:
            status = BEST_OF_SEEDS  # no proof for the best of several local maxima
    # sigma and the support points at n, in A's frame, then world
    a = (a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
    b = matvec(M, n)
    ha = math.sqrt(a[0] * n[0] + a[1] * n[1] + a[2] * n[2])
    hb = math.sqrt(b[0] * n[0] + b[1] * n[1] + b[2] * n[2])
    value = n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - ha - hb
    inv = 0.5 / (ha * hb)
    ia, ib = hb * inv, ha * inv
    mid = (
        a[0] * ia + 0.5 * e[0] - b[0] * ib,
        a[1] * ia + 0.5 * e[1] - b[1] * ib,
        a[2] * ia + 0.5 * e[2] - b[2] * ib,
    )
    normal = matvec(Ra, n)
    p = matvec(Ra, mid)
    iu = 1.0 / u  # exact: u is a power of two
    pos = (ca[0] + p[0] * iu, ca[1] + p[1] * iu, ca[2] + p[2] * iu)
    return status, value * iu, normal, pos, steps


@stage
def _distance_into(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, i):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    st, v, nrm, p, _ = pair_signed_distance(load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb), max_iter)
    dist[i], status[i] = v, st
    for k in range(3):
        normal[i, k] = nrm[k]
        pos[i, k] = p[k]


@jit(parallel=True)
def _distances(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status):
    for i in prange(dist.shape[0]):
        _distance_into(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, i)


@jit
def _distances_serial(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status):
    for i in range(dist.shape[0]):
        _distance_into(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, i)


def signed_distance(a, b, *, max_iter=NEWTON_MAX_ITER, parallel=None):
    """Signed distance, contact normal and contact point for the pairs (a[i], b[i]).

    a, b : Ellipsoids (a batch of length 1 broadcasts)
    max_iter : Newton steps allowed per run (the default converges; smaller caps trade accuracy
        for time, see `ellipsim bench`)
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : dist (n,) metres (> 0 distance, < 0 minus the penetration depth), normal (n, 3) unit,
        from a to b, pos (n, 3) metres (midpoint of the support points, as MuJoCo reports contacts),
        status (n,) int8: GLOBAL, BEST_OF_SEEDS or NOT_CONVERGED (see the module docstring)
    """
    n = check_pair(a, b)
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or not 1 <= max_iter <= 1_000_000:
        raise ValueError(f"max_iter must be an integer from 1 to 1000000, got {max_iter!r}")
    kernel = _distances if check_parallel(parallel, n) else _distances_serial
    dist, normal, pos = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    status = np.empty(n, dtype=np.int8)
    kernel(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, int(max_iter), dist, normal, pos, status)
    return dist, normal, pos, status
