"""Signed distance of ellipsoids and capsules, boxes, cylinders or convex meshes, batched, with optional exact
derivatives.

    dist, normal, pos, status = ellipsim.shape_distance(ellipsoids, "box", centers, rotations, sizes)
    dist, normal, pos, status, der = ellipsim.shape_distance(..., derivatives=True)
    dist, normal, pos, status = ellipsim.shape_distance(ellipsoids, "mesh", centers, rotations, hull)

The narrow phase's proven maxima (capsule.py, box.py, cylinder.py: what ellipsim's MuJoCo glue runs for
these pair types), with the derivatives of derivatives.py.  The other bodies take MuJoCo's conventions
(geom_xpos, geom_xmat reshaped to 3x3, geom_size): a box's sizes are its half-sizes; a capsule's and a
cylinder's are (radius, half-length, ignored), the axis the rotation's third column.  A mesh is one convex
hull (hull.py: a Hull, or points whose convex hull it is; MuJoCo collides a mesh through its hull) posed per
pair (polytope.hpp's proven maximum).
"""

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import Ellipsoids, as_poses, as_shape_poses, check_choice, check_parallel, check_rotations
from . import derivatives as dv

KINDS = ("capsule", "box", "cylinder")
#: the kinds shape_distance takes: KINDS' (the derivatives' codes) and a convex mesh
SHAPES = (*KINDS, "mesh")


def _check_shapes(kind, centers, rotations, sizes):
    check_choice("kind", kind, SHAPES)
    c, rot, s = as_poses(centers, rotations, sizes, "sizes")
    used = 3 if kind == "box" else 2
    nonpos = s[:, :used] <= 0
    if nonpos.any():
        i, j = (int(k) for k in np.argwhere(nonpos)[0])
        what = "a half-size" if kind == "box" else ("the radius" if j == 0 else "the half-length")
        raise ValueError(f"sizes[{i}, {j}] ({what} of a {kind}) must be positive, got {s[i, j]}")
    check_rotations(rot)
    return c, rot, s


def shape_distance(ellipsoids, kind, centers, rotations, sizes, *, parallel=None, derivatives=False):
    """Signed distance, contact normal and contact point of each ellipsoid and capsule, box, cylinder or mesh.

    ellipsoids : Ellipsoids (a batch of length 1 broadcasts)
    kind : "capsule", "box", "cylinder" or "mesh", the other bodies' type
    centers (n, 3), rotations (n, 3, 3), sizes (n, 3) : the other bodies, as MuJoCo's geom_xpos, geom_xmat
        and geom_size (module docstring); one body may be given unbatched, and a batch of 1 broadcasts.  For
        "mesh", `sizes` is the mesh: one Hull (hull.py, its vertices in the mesh's frame) or the points whose
        convex hull it is, posed at each (centre, rotation)
    parallel : run on all cores; default: from PARALLEL_MIN_PAIRS pairs on
    returns : dist (n,) metres (< 0: minus the penetration depth), normal (n, 3) unit, from the ellipsoid
        to the other body, pos (n, 3) the midpoint of the witness points (MuJoCo's contact position),
        status (n,) int8 DistanceStatus (GLOBAL: proven; UNPROVEN: a cylinder rim's branch and bound out
        of budget, the best found)
    derivatives : also return a fifth result, derivatives.ShapeDerivatives: d dist, d normal and d pos
        with respect to the ellipsoid's centre, rotation vector and semi-axes and the other body's centre,
        rotation vector and sizes (18 columns, derivatives.PARAMETERS), a DerivativeStatus and the
        ContactFeature per pair (derivatives.py: ONE_SIDED where the contact sits where two features meet);
        for a mesh its FACE, EDGE or VERTEX, and its size columns zero
    """
    if not isinstance(ellipsoids, Ellipsoids):
        raise ValueError(f"ellipsoids must be an ellipsim.Ellipsoids batch, got {type(ellipsoids).__name__}")
    if kind == "mesh":
        return _mesh_distance(ellipsoids, centers, rotations, sizes, parallel, derivatives)
    c, rot, s = _check_shapes(kind, centers, rotations, sizes)
    if not isinstance(derivatives, (bool, np.bool_)):
        raise ValueError(f"derivatives must be True or False, got {derivatives!r}")
    ne, nk = len(ellipsoids.centers), len(c)
    if ne != nk and ne != 1 and nk != 1:
        raise ValueError(
            f"ellipsoids and the {kind}s must have the same length or one of them length 1, got {ne} and {nk}"
        )
    n = 0 if ne == 0 or nk == 0 else max(ne, nk)
    code = KINDS.index(kind)
    arrays = (ellipsoids.centers, ellipsoids.rotations, ellipsoids.radii, c, rot, s, code)
    dist, normal, pos, status = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int8)
    parallel = check_parallel(parallel, n)
    threads.run(ext.shape_distances, n, parallel, *arrays, dist, normal, pos, status)
    if not derivatives:
        return dist, normal, pos, status
    out = dv.ShapeDerivatives(
        np.empty((n, 18)), np.empty((n, 3, 18)), np.empty((n, 3, 18)), np.empty(n, np.int8), np.empty(n, np.int8)
    )
    threads.run(ext.shape_derivatives, n, parallel, *arrays, normal, status == 0, *out)
    return dist, normal, pos, status, out


def _mesh_distance(ellipsoids, centers, rotations, mesh, parallel, derivatives):
    """shape_distance's "mesh" kind: the ellipsoids against one convex hull posed at each (centre, rotation)."""
    from .hull import as_hull

    if not isinstance(derivatives, (bool, np.bool_)):
        raise ValueError(f"derivatives must be True or False, got {derivatives!r}")
    hull = as_hull(mesh)
    c, rot, n = as_shape_poses(ellipsoids, centers, rotations, "mesh")
    dist, normal, pos, status = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int8)
    parallel = check_parallel(parallel, n)
    e = ellipsoids
    threads.run(
        ext.mesh_distances, n, parallel, e.centers, e.rotations, e.radii, c, rot, *hull, dist, normal, pos, status
    )
    if not derivatives:
        return dist, normal, pos, status
    out = dv.ShapeDerivatives(
        np.empty((n, 18)), np.empty((n, 3, 18)), np.empty((n, 3, 18)), np.empty(n, np.int8), np.empty(n, np.int8)
    )
    arrays = (e.centers, e.rotations, e.radii, c, rot, *hull, normal, status == 0)
    threads.run(ext.mesh_derivatives, n, parallel, *arrays, *out)
    return dist, normal, pos, status, out
