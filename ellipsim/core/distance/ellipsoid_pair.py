"""Signed distance, contact normal and contact point of two ellipsoids (the narrow phase).

The signed distance of two convex bodies is the maximum over unit directions n of

    sigma(n) = n . (c_B - c_A) - h_A(n) - h_B(-n),    h(n) = |D R^T n|  (ellipsoid support function),

positive when separated (the distance), negative when penetrating (minus the depth); at the
maximiser n* the normal is n* (from A to B, MuJoCo's convention) and the contact point is the
midpoint of the support points c_A + grad h_A(n*) and c_B - grad h_B(n*), as mjc_Convex reports it
(engine_collision_convex.c: pos = (x1 + x2) / 2, dist = margin + depth of the margin-grown bodies).

One Newton run (sphere_newton.py) from the bisector seed finds a local maximum; it is the global one
* when sigma > 0: a concave function maximised over the unit ball has its maximum on the sphere;
* when the depth is below rho = rolling_radius(A) + rolling_radius(B): A + (-B) is a convex body plus
  a ball of radius rho, so depth - rho is minus the distance from the centre offset to a convex set,
  which has one local extremum;
* for two spheres (sigma = n.d - r_a - r_b);
* for concentric ellipsoids with the same axes, or spheroids about a common axis (pair_signed_distance:
  a concave function's minimum over a simplex lies at a vertex);
* for a deeper converged maximum that the ellipsoid inside A + (-B) touching it there proves
  (inner_sum.py: one Cholesky factorisation; 89-99 % of random deep crossings, leaves included).
Deeper penetrations it leaves, and a first run that does not converge, go to spheroids.py when the two are
spheroids (or a sphere and a spheroid) with parallel axes of revolution, to within the tolerance (the
maximum is then one of two ellipses in a plane: a branch and bound over one angle proves it, circles
of maxima included); spheroids whose axes are nearly parallel go to spheroids.tilted_max (a branch and
bound over the angles about A's axis with second-order bounds: along the circle the maxima are flat,
across it they are not), and the rest to branch_and_bound.py: a branch and bound
over the sphere with concave majorants that proves its answer within
TOL = max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of the global maximum, or reports UNPROVEN
when its budget runs out (two spheroids at any angle then get tilted_max as a second chance; still
UNPROVEN, the MuJoCo glue calls MuJoCo's own function and keeps the better of both normals).
"""

import math

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..ellipsoids import check_pair, check_parallel
from ..tolerances import (
    BB_ERR_SIGMA_ULPS,
    BB_FRAME_ULPS,
    BB_MAX_PATCHES,
    BB_TOL_REL,
    BB_TOL_ULPS,
    FIRST_RUN_ITER,
    NEWTON_MAX_ITER,
    SMALL_BATCH_PAIRS,
    WARM_SCALE_MAX,
    WARM_SCALE_MIN,
    WARM_SIGMA_SLACK_ULPS,
    U,
)
from ..vec3 import load, matvec, norm2, rotate_t, rotation_defect, scaled, unit_scale
from . import derivatives as dv
from .branch_and_bound import GLOBAL as BB_GLOBAL
from .branch_and_bound import SEPARATED_MAX, climb, global_max, sigma_only
from .branch_and_bound import UNPROVEN as BB_UNPROVEN
from .inner_sum import inner_sum_bound
from .sphere_newton import CONVERGED, a_frame, bisector_seed, newton, rolling_radius, unit
from .spheroids import parallel_max, tilted_max

#: What signed_distance reports per pair: GLOBAL (the returned maximum is proven global, to the
#: module's TOL), UNPROVEN (the branch and bound's budget ran out: the best maximum found, no proof).
GLOBAL, UNPROVEN = 0, 1


@stage
def _column_match(Ra, k, Rb):
    """The column of R_b equal to column k of R_a or to its negative, exactly; -1 if none."""
    j = -1
    for i in range(3):
        same = Ra[k] == Rb[i] and Ra[3 + k] == Rb[3 + i] and Ra[6 + k] == Rb[6 + i]
        opposite = Ra[k] == -Rb[i] and Ra[3 + k] == -Rb[3 + i] and Ra[6 + k] == -Rb[6 + i]
        if same or opposite:
            j = i
    return j


@stage
def _concentric_coaxial_axis(d, Ra, Rb, ra, rb):
    """For concentric ellipsoids (c_b - c_a = 0) the axis k of A along which sigma is largest, when that
    is the global maximum (see pair_signed_distance), else -1.  Two cases:
    * the axes coincide (every column of R_b is a column of R_a or its negative, exactly): sigma depends
      on n through (n_1^2, n_2^2, n_3^2) on the simplex;
    * both are spheroids about a common axis (a column of R_b is column k of R_a or its negative,
      exactly, and each has equal semi-axes across it; B's other columns may be any rotation about
      it): sigma depends on n through (n_k^2, 1 - n_k^2), and across the axis A's axis k+1 is as good
      as any direction (up to B's rotation defect, which the module's TOL counts)."""
    if d[0] != 0.0 or d[1] != 0.0 or d[2] != 0.0:
        return -1
    best, kbest = -math.inf, -1
    for k in range(3):
        j = _column_match(Ra, k, Rb)
        if j < 0:
            kbest = -1
            break
        v = -(ra[k] + rb[j])
        if v > best:
            best, kbest = v, k
    if kbest >= 0:
        return kbest
    for k in range(3):
        j = _column_match(Ra, k, Rb)
        k1, k2, j1, j2 = (k + 1) % 3, (k + 2) % 3, (j + 1) % 3, (j + 2) % 3
        if j >= 0 and ra[k1] == ra[k2] and rb[j1] == rb[j2]:
            return k if -(ra[k] + rb[j]) >= -(ra[k1] + rb[j1]) else k1
    return -1


@stage
def _parallel_spheroids(d, Ra, ra, Rb, rb, e, Ub, tol_bb, S, rmin):
    """spheroids.parallel_max for the pair in A's frame, or, when A is a sphere (MuJoCo passes a sphere geom
    as g1, its frame the body's, unrelated to the limb's axis), in B's frame (a sphere is one in any
    frame): (proven, unit n in A's frame, nodes).  In B's frame the tolerance is B's (its rotation's
    defect in place of A's), less 16 u S for taking n back to A's frame (sigma is S-Lipschitz, n moves by ~4 u); n is
    (0, 0, 0) when parallel_max gives no direction."""
    if not (ra[0] == ra[1] == ra[2]):
        return parallel_max(e, ra, Ub, rb, tol_bb, S)
    if rb[0] == rb[1] == rb[2]:
        return False, (0.0, 0.0, 0.0), 0
    eb, _, _, Ua = a_frame(((0.0, 0.0, 0.0), Rb, rb), ((-d[0], -d[1], -d[2]), Ra, ra))
    delta = rotation_defect(Rb) + 4.0 * U
    tol = max(BB_TOL_REL * rmin, (BB_TOL_ULPS * U + 6.0 * delta) * S)
    ok, nb, count = parallel_max(eb, rb, Ua, ra, tol - (BB_FRAME_ULPS * U + 6.0 * delta + 16.0 * U) * S, S)
    if norm2(nb) < 0.5:
        return False, nb, count
    # from B to A in B's frame -> from A to B in A's frame
    w = matvec(Rb, nb)
    return ok, unit(rotate_t(Ra, (-w[0], -w[1], -w[2]))), count


@jit
def pair_signed_distance(A, B, max_iter=NEWTON_MAX_ITER):
    """(status, dist, normal (3,), pos (3,), work) of two ellipsoids in world coordinates.

    A, B as from vec3.load.  dist > 0: distance; < 0: minus the penetration depth.  normal: unit,
    from A to B.  pos: midpoint of the two support points (MuJoCo's contact position).  status:
    GLOBAL or UNPROVEN (see the module docstring).  work: Newton steps of the first run plus
    branch-and-bound nodes.
    """
    return _pair(A, B, max_iter, (0.0, 0.0, 0.0))


@jit
def pair_signed_distance_from(A, B, seed):
    """pair_signed_distance with the first Newton run started at `seed` (world frame, any length;
    (0, 0, 0), or a vector too short to normalise, for the bisector seed): the warm start of the
    MuJoCo glue, seeded with the pair's normal of the previous step.

    The seed only chooses where the first run starts: which local maximum is proven global, and how,
    is decided as in pair_signed_distance (the rolling-radius and concavity arguments hold for any
    local maximum, the branch and bound does not depend on its incumbent's origin), so the result
    satisfies the same contract from any seed, a wrong one included; from a good one Newton
    converges in 1-2 steps instead of 3-5."""
    return _pair(A, B, NEWTON_MAX_ITER, seed)


@stage
def _deep_tolerance(e, Ra, ra, rb):
    """(r_min, S, delta, tol_bb): the deep branch's scale, R_A's orthonormality defect and the tolerance
    left to its proof once the frame change is paid: the returned maximum is within TOL = max(BB_TOL_REL
    r_min, (BB_TOL_ULPS u + 6 delta) S) of the global one (module docstring)."""
    rmin = min(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    S = math.sqrt(norm2(e)) + max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])
    delta = rotation_defect(Ra) + 4.0 * U
    tol = max(BB_TOL_REL * rmin, (BB_TOL_ULPS * U + 6.0 * delta) * S)
    return rmin, S, delta, tol - (BB_FRAME_ULPS * U + 6.0 * delta) * S


@stage
def _inner_sum_proves(n, e, Ra, ra, Ub, rb):
    """Whether inner_sum.py's bound proves sigma(n) within the deep branch's tolerance of max sigma
    (sigma(n) as evaluated, its rounding BB_ERR_SIGMA_ULPS u S counted against it)."""
    _, S, _, tol_bb = _deep_tolerance(e, Ra, ra, rb)
    v = sigma_only(n, e, ra, Ub, rb)
    return inner_sum_bound(n, e, ra, Ub, rb, v) <= v - BB_ERR_SIGMA_ULPS * U * S + tol_bb


@stage
def _pair(A, B, max_iter, seed):
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    # the pair in units of vec3.unit_scale (1.0 unless a semi-axis is beyond 2^+-50): A at the origin
    u = unit_scale(ra, rb)
    ra, rb = scaled(ra, u), scaled(rb, u)
    d = ((cb[0] - ca[0]) * u, (cb[1] - ca[1]) * u, (cb[2] - ca[2]) * u)
    e, a2, M, Ub = a_frame(((0.0, 0.0, 0.0), Ra, ra), (d, Rb, rb))
    rb2 = (rb[0] * rb[0], rb[1] * rb[1], rb[2] * rb[2])
    scale = max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    rho = rolling_radius(ra) + rolling_radius(rb)
    ss = norm2(seed)
    if 1e-6 < ss < 1e6:  # (a torn or garbage seed is only a worse start: see pair_signed_distance_from)
        start = unit(rotate_t(Ra, seed))
    else:
        start = bisector_seed(e, a2, Ub, rb2)
    n, value, run, steps = newton(start, e, a2, M, scale, -math.inf, min(max_iter, FIRST_RUN_ITER))
    status = GLOBAL
    spheres = ra[0] == ra[1] == ra[2] and rb[0] == rb[1] == rb[2]
    shallow = run == CONVERGED and (value >= -rho or spheres)
    k = _concentric_coaxial_axis(d, Ra, Rb, ra, rb)
    if k >= 0:
        # sigma = -(sqrt(sum a_i^2 x_i) + sqrt(sum b_j(i)^2 x_i)) with x_i = n_i^2 on the simplex: the sum
        # of square roots of linear functions is concave in x, so its minimum lies at a vertex, an axis
        # (Rockafellar, Convex Analysis, Cor. 32.3.2).  Its maxima form circles when semi-axes repeat,
        # which the branch and bound cannot isolate.
        n = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        value = sigma_only(n, e, ra, Ub, rb)
    elif not shallow and run == CONVERGED and _inner_sum_proves(n, e, Ra, ra, Ub, rb):
        # deep: the first run's maximum, proven global by the ellipsoid inside A + (-B) touching there
        value = sigma_only(n, e, ra, Ub, rb)
    elif not shallow:
        # deep, or the first run stalled: spheroids with parallel axes (maxima on circles, or nearly
        # flat along them) by the 1-D branch and bound of spheroids.py, else the branch and bound
        # over the sphere, seeded with the first run's maximum
        rmin, S, _, tol_bb = _deep_tolerance(e, Ra, ra, rb)
        ok, nc, count = _parallel_spheroids(d, Ra, ra, Rb, rb, e, Ub, tol_bb, S, rmin)
        if ok:
            n = nc
            value = sigma_only(n, e, ra, Ub, rb)
        else:
            have = run == CONVERGED
            near = norm2(nc) > 0.5
            if near:  # nearly parallel spheroids: a climb from the parallel model's maximiser
                _, m, _ = climb(nc, e, ra, M, scale)  # converged or not (along the circle sigma is
                vc, v = sigma_only(nc, e, ra, Ub, rb), sigma_only(m, e, ra, Ub, rb)  # flat), the better
                if vc > v:
                    m, v = nc, vc
                if not have or v > value:
                    n, value, have = m, v, True
            bb = BB_UNPROVEN
            if near:  # nearly parallel: the 2-D branch and bound first (spheroids.tilted_max), from the climb
                ok, n, c2 = tilted_max(e, ra, Ub, rb, tol_bb, S, n)
                count += c2
                value = sigma_only(n, e, ra, Ub, rb)
                if ok:
                    bb = BB_GLOBAL
            if bb != BB_GLOBAL:
                bb, n, value, c2, _ = global_max(n, value, have, e, ra, Ub, rb, M, scale, tol_bb, BB_MAX_PATCHES)
                count += c2
            if bb == BB_UNPROVEN and not near:  # two spheroids at any angle: the 2-D one as a second chance
                ok, m, c2 = tilted_max(e, ra, Ub, rb, tol_bb, S, n)
                count += c2
                if ok:
                    bb, n, value = BB_GLOBAL, m, sigma_only(m, e, ra, Ub, rb)
            status = GLOBAL if bb == BB_GLOBAL or bb == SEPARATED_MAX else UNPROVEN
        steps += count
    return _contact_at(ca, Ra, ra, rb, e, Ub, n, u, value, k < 0 and shallow, status, steps)


@stage
def _contact_at(ca, Ra, ra, rb, e, Ub, n, u, value, recompute, status, steps):
    """(status, dist, normal, pos, steps) at the unit n of A's frame: dist the given value, or, with
    recompute, sigma(n); the contact point the midpoint of the support points (pair_signed_distance)."""
    # h_A, h_B at n through U (as global_max.sigma_only: errs by <= 11 u S, where through
    # M = U diag(b^2) U^T it errs by ~u max b^2 / h_B, beyond 1e-12 r_min for 100:1 ellipsoids) ...
    x = (ra[0] * n[0], ra[1] * n[1], ra[2] * n[2])
    w = rotate_t(Ub, n)
    y = (rb[0] * w[0], rb[1] * w[1], rb[2] * w[2])
    ha = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])
    hb = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    if recompute:  # sigma at Newton's maximiser (sigma_only's expression)
        value = n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - ha - hb
    # ... and the support points grad h_A(n) = diag(a) x / h_A, grad h_B(n) = U diag(b) y / h_B, in A's
    # frame, their midpoint with B's taken from its centre e, then world
    inv = 0.5 / (ha * hb)
    ia, ib = hb * inv, ha * inv
    b = matvec(Ub, (rb[0] * y[0], rb[1] * y[1], rb[2] * y[2]))
    mid = (
        ra[0] * x[0] * ia + 0.5 * e[0] - b[0] * ib,
        ra[1] * x[1] * ia + 0.5 * e[1] - b[1] * ib,
        ra[2] * x[2] * ia + 0.5 * e[2] - b[2] * ib,
    )
    normal = matvec(Ra, n)
    p = matvec(Ra, mid)
    iu = 1.0 / u  # exact: u is a power of two
    pos = (ca[0] + p[0] * iu, ca[1] + p[1] * iu, ca[2] + p[2] * iu)
    return status, value * iu, normal, pos, steps


@jit
def contact_at(A, B, n):
    """(sigma, normal, pos) of two ellipsoids at the direction n (world frame, nonzero, any length):
    the lower bound sigma(n / |n|) on their signed distance (no proof it is the maximum), the unit
    normal and the contact point as pair_signed_distance gives them at its maximiser.  The MuJoCo
    glue's answer for a pair whose maximum is not proven, at the better of ellipsim's and MuJoCo's
    normals."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    u = unit_scale(ra, rb)
    ra, rb = scaled(ra, u), scaled(rb, u)
    d = ((cb[0] - ca[0]) * u, (cb[1] - ca[1]) * u, (cb[2] - ca[2]) * u)
    e, _, _, Ub = a_frame(((0.0, 0.0, 0.0), Ra, ra), (d, Rb, rb))
    _, value, normal, pos, _ = _contact_at(ca, Ra, ra, rb, e, Ub, unit(rotate_t(Ra, n)), u, 0.0, True, UNPROVEN, 0)
    return value, normal, pos


@jit
def sigma_lower_bound(A, B, n):
    """A lower bound on the signed distance of A and B from one direction n (world frame, any
    nonzero length): sigma(n / |n|) minus its rounding allowance; -inf where no bound is given.

    The signed distance is the maximum of sigma over unit directions (module docstring), so sigma at
    any direction bounds it from below; with the body taken as c + R diag(r) ball for the float R
    as given (MuJoCo's support mapping), h = |diag(r) R^T n| exactly, orthonormal R or not.  Rounding,
    S = |d|_1 + max r_A + max r_B: the normalised n has |n| = 1 +- 4 u (sigma moves by <= 4 u S),
    n.d with d = c_B - c_A rounded errs by <= 8 u |d|_1, each h by <= 10 u max r (R^T n: gamma_3 of
    |R^T| |n|, with |R| within 1e-6 of a rotation as MuJoCo's geom_xmat is; the products, the sum of
    squares, the root), the two subtractions by 2 u S:
    <= 34 u S; WARM_SIGMA_SLACK_ULPS of it is taken.  Only for semi-axes and |d| within
    [WARM_SCALE_MIN, WARM_SCALE_MAX] (no underflow in the squares, no overflow)."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    nn = norm2(n)
    if not 1e-6 < nn < 1e6:
        return -math.inf
    s = 1.0 / math.sqrt(nn)
    m = (n[0] * s, n[1] * s, n[2] * s)
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
    amax, bmax = max(ra[0], ra[1], ra[2]), max(rb[0], rb[1], rb[2])
    S = abs(d[0]) + abs(d[1]) + abs(d[2]) + amax + bmax
    lo = min(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    if not (lo >= WARM_SCALE_MIN and S <= WARM_SCALE_MAX):
        return -math.inf
    za, zb = rotate_t(Ra, m), rotate_t(Rb, m)
    x0, x1, x2 = ra[0] * za[0], ra[1] * za[1], ra[2] * za[2]
    y0, y1, y2 = rb[0] * zb[0], rb[1] * zb[1], rb[2] * zb[2]
    v = (
        m[0] * d[0]
        + m[1] * d[1]
        + m[2] * d[2]
        - math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        - math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    )
    return v - WARM_SIGMA_SLACK_ULPS * U * S


@stage
def _distance_into(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, i):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    st, v, nrm, p, _ = pair_signed_distance(load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb), max_iter)
    dist[i], status[i] = v, st
    for k in range(3):
        normal[i, k] = nrm[k]
        pos[i, k] = p[k]


@jit
def _distances(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, lo, hi):
    for i in range(lo, hi):
        _distance_into(Ca, Ra, ra, Cb, Rb, rb, max_iter, dist, normal, pos, status, i)


def signed_distance(a, b, *, max_iter=NEWTON_MAX_ITER, parallel=None, derivatives=False):
    """Signed distance, contact normal and contact point for the pairs (a[i], b[i]), and optionally their
    exact first derivatives.

    a, b : Ellipsoids (a batch of length 1 broadcasts)
    max_iter : Newton steps allowed per run (the default converges; smaller caps trade accuracy
        for time, see `ellipsim bench`; a capped run that does not converge hands over to the
        branch and bound)
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : dist (n,) metres (> 0 distance, < 0 minus the penetration depth), normal (n, 3) unit,
        from a to b, pos (n, 3) metres (midpoint of the support points, as MuJoCo reports contacts),
        status (n,) int8: GLOBAL (proven within the module's tolerance of the global maximum) or
        UNPROVEN (the proof's budget ran out; the best found)
    derivatives : also return a fifth result, derivatives.DistanceDerivatives: d dist, d normal and
        d pos with respect to each body's centre, rotation vector (R -> expm([omega]_x) R) and semi-axes
        (18 columns, derivatives.PARAMETERS), and a DerivativeStatus per pair (NaN where not defined:
        a flat or unproven maximum; see derivatives.py)
    """
    n = check_pair(a, b)
    if not (type(max_iter) is int and 1 <= max_iter <= 1_000_000) and (  # (the usual case in one test)
        isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or not 1 <= max_iter <= 1_000_000
    ):
        raise ValueError(f"max_iter must be an integer from 1 to 1000000, got {max_iter!r}")
    if not isinstance(derivatives, (bool, np.bool_)):
        raise ValueError(f"derivatives must be True or False, got {derivatives!r}")
    dist, normal, pos = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    status = np.empty(n, dtype=np.int8)
    arrays = (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    parallel = check_parallel(parallel, n)
    if n <= SMALL_BATCH_PAIRS:  # in one piece, as threads.run would run it, without its call (issue 20)
        ext.signed_distances(*arrays, int(max_iter), dist, normal, pos, status, 0, n)
    else:
        threads.run(ext.signed_distances, n, parallel, *arrays, int(max_iter), dist, normal, pos, status)
    if not derivatives:
        return dist, normal, pos, status
    out = dv.DistanceDerivatives(np.empty((n, 18)), np.empty((n, 3, 18)), np.empty((n, 3, 18)), np.empty(n, np.int8))
    threads.run(ext.derivatives, n, parallel, *arrays, normal, status, *out)
    return dist, normal, pos, status, out
