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

The kernels are C++, ellipsim/native/include/ellipsim/distance/ellipsoid_pair.hpp (bound in the _ellipsim module).
"""

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import check_pair, check_parallel
from ..tolerances import (
    NEWTON_MAX_ITER,
    SMALL_BATCH_PAIRS,
)
from . import derivatives as dv

#: What signed_distance reports per pair: GLOBAL (the returned maximum is proven global, to the
#: module's TOL), UNPROVEN (the branch and bound's budget ran out: the best maximum found, no proof).
GLOBAL, UNPROVEN = 0, 1


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
