"""Bounding ellipsoids of triangle meshes, and MJCF limbs built from them.

`bounding_ellipsoid` encloses every vertex of a mesh (a ``trimesh.Trimesh`` or a mesh file) in one
ellipsoid, by one of two methods on the mesh's convex hull:

* ``"thesis"``: the covariance fit of D. Leung, *Studies on Collision Detection Using Ellipsoidal
  Bounding Volumes*, MPhil thesis, HKU 2000, chapter 3 "Building bounding ellipsoid" (the
  area-weighted convex-hull variant at its end): cheap, and tight for oval parts.
* ``"mvee"``: the minimum-volume enclosing ellipsoid (the problem of P. Schneider and D. Eberly,
  *Geometric Tools for Computer Graphics*, 2003, section 13.11.5, "Minimum-Volume Ellipsoid"),
  computed by Khachiyan's algorithm (L. G. Khachiyan, "Rounding of polytopes in the real number
  model of computation", Math. Oper. Res. 21, 1996) with the initialisation and away steps of
  M. J. Todd and E. A. Yildirim, "On Khachiyan's algorithm for the computation of minimum-volume
  enclosing ellipsoids", Discrete Appl. Math. 155, 2007 (their algorithm WA-TY), iterated until
  Khachiyan's gap is at most ``MVEE_TOL`` = 1e-12.  Where WA-TY's linear rate is too slow (hulls
  with many points almost on the optimum, e.g. finely tessellated smooth parts stored in float32)
  a primal-dual interior-point method on the same problem takes over after
  ``MVEE_KHACHIYAN_STEPS``; both deliver Khachiyan's weights and are judged by the same gap.

Either way the semi-axes are finally multiplied by the one factor that makes the largest
``|diag(1/r) R^T (v - c)|^2`` over all mesh vertices ``v`` at most 1 when evaluated in float64, so
the result always encloses the mesh.  `limbs_from_meshes` fits one ellipsoid per part mesh and
`limb_geom_xml` writes a fitted ellipsoid as an MJCF ellipsoid geom.

Lengths are in the units of the mesh (metres for MuJoCo).
"""

import dataclasses
import math
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from ..core.ellipsoids import Ellipsoids
from ..core.rotations import quaternions_to_rotations, rotations_to_quaternions
from .scenes import mjcf_numbers

#: The fitting methods of `bounding_ellipsoid`.
METHODS = ("thesis", "mvee")

#: Mesh file extensions `bounding_ellipsoid` reads (the ones trimesh loads as triangle meshes;
#: trimesh cannot read the thesis's .3ds).
MESH_FORMATS = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")

# --- Tolerances (here rather than in tolerances.py because only this module uses them) ---------

#: A mesh whose width along its least-variance direction is at most this fraction of its largest
#: width is flat (or a line): its bounding ellipsoid would have a semi-axis ratio beyond 1e9, its
#: convex hull is made of qhull's rounding (~1e-13 of the extent) and classify's float path stops
#: at ratio 2^40 ~ 1e12, so it is refused rather than fitted.
FLAT_RTOL = 1e-9

#: The MVEE solvers stop when Khachiyan's weights u satisfy max_j omega_j(u) <= (1 + MVEE_TOL) k,
#: omega_j = q_j^T X(u)^-1 q_j, k = d + 1 = 4 (Khachiyan's epsilon-primal feasibility).  The final
#: rescale factor is then at most sqrt(1 + MVEE_TOL k / d), so the volume is at most
#: (1 + 4/3 MVEE_TOL)^(3/2) ~ 1 + 2 MVEE_TOL times the minimum, and (log det being quadratic at the
#: optimum; derivation in tests/test_fit.py) every sorted semi-axis is within sqrt(2 MVEE_TOL)
#: = 1.4e-6 of the optimum's, relatively, and the centre within sqrt(4/3 MVEE_TOL) = 1.2e-6 in the
#: optimum's own norm.  omega is computed to ~1e-15 in whitened coordinates: 1e-12 is reachable.
MVEE_TOL = 1e-12

#: Khachiyan (WA-TY) steps before the interior-point method takes over.  WA-TY converges linearly,
#: but slowly when many hull points lie almost on the optimum.  Measured (whitened hulls, tol 1e-12):
#: a box or a regular-polygon cylinder converge in 0-30 steps, random hulls of 20-450 points in
#: 200-1000+ steps, a 10k-vertex sphere with 1e-6 radial noise (what a float32 .stl of an
#: ellipsoidal part looks like) is still at gap 4e-8 after 1e5 steps; the interior-point method
#: needs 10-20 iterations (5-100 ms at 1e4 points) on all of them.  A step costs 20-90 us.
MVEE_KHACHIYAN_STEPS = 500

#: The rank-one updates of X^-1 and omega are replaced by a fresh computation every this many steps
#: (each update adds a few ulps of drift) and always before the stopping test is accepted.
MVEE_REFRESH = 50

#: Iteration cap of the interior-point method (it needs 10-20 on every hull measured, down to 1e-13).
MVEE_IPM_MAX_ITER = 100

#: Fraction of the step to the boundary the interior-point method takes (the usual 0.99).
_IPM_STEP_FRACTION = 0.99

#: When the interior-point method stops short of MVEE_TOL (its Newton matrix reaches condition
#: ~1e16 near gap 1e-12 on some thin, far-off clouds), Khachiyan's steps polish its weights, with
#: weights below this fraction of the largest set to 0: those are the ~mu / s_j of points off the
#: optimum (relative size ~1e-15 there), which Khachiyan's away steps would drop one per step.
_IPM_WEIGHT_FLOOR = 1e-12

#: Relative growth of the semi-axes per retry when rounding leaves a vertex just outside.
_ENCLOSE_NUDGE = 4 * np.finfo(np.float64).eps


# --- Public functions -----------------------------------------------------------------------


def bounding_ellipsoid(mesh, *, method="thesis"):
    """A bounding ellipsoid of every vertex of `mesh`, as an `Ellipsoids` batch of length 1.

    mesh : trimesh.Trimesh, or a path (str or os.PathLike) to an .obj/.stl/.ply/.off/.glb/.gltf
        file, loaded with ``trimesh.load(path, force="mesh")`` (scenes are concatenated).  It needs
        at least 4 finite vertices that are not all in one plane.
    method : "thesis" (Leung 2000, chapter 3: area-weighted covariance of the convex hull) or
        "mvee" (minimum-volume enclosing ellipsoid: Khachiyan's algorithm, finished by an
        interior-point method when it is slow, to Khachiyan's gap ``MVEE_TOL``).

    The returned centre (1, 3) and radii (1, 3) are in mesh units; rotations (1, 3, 3) is proper
    (det +1) with the principal axes as columns, radii sorted by the method's axis order ("mvee":
    descending; "thesis": by descending variance).  Every vertex v satisfies
    ``|diag(1/r) R^T (v - c)|^2 <= 1`` evaluated in float64.  ValueError names the bad argument.

    The "mvee" fit is unique, so it moves with the mesh.  The "thesis" fit does only for hulls with
    triangular facets: qhull splits a flat facet (box, cylinder caps) along diagonals that change
    with the mesh's pose, and the thesis's vertex covariance, hence its axes, with them.
    """
    _check_method(method)
    label, vertices = _mesh_vertices(mesh)
    _check_solid(label, vertices)
    origin = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    local = vertices - origin  # fits run about the box centre: no cancellation for far-off meshes
    try:
        hull = ConvexHull(local)
    except QhullError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{label} is degenerate: qhull cannot build its convex hull ({first})") from exc
    if method == "thesis":
        center, rotation, radii = _fit_thesis(local[hull.vertices], local[hull.simplices])
    else:
        center, rotation, radii = _fit_mvee(local[hull.vertices])
    center = center + origin
    radii = _enclose(vertices, center, rotation, radii)
    return Ellipsoids(center[None], rotation[None], radii[None])


def limbs_from_meshes(parts, *, method="thesis"):
    """One bounding ellipsoid per part: {name: mesh or mesh path} -> {name: Ellipsoids (length 1)}.

    The limbs of a figure from its part meshes; see `bounding_ellipsoid` for `method` and for what a
    mesh may be.  A bad part raises ValueError naming ``parts[name]``.
    """
    _check_method(method)
    if not isinstance(parts, Mapping):
        raise ValueError(f"parts must be a mapping of limb names to meshes or mesh files, got {type(parts).__name__}")
    limbs = {}
    for name, mesh in parts.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"parts keys must be non-empty strings (limb names), got {name!r}")
        try:
            limbs[name] = bounding_ellipsoid(mesh, method=method)
        except ValueError as exc:
            raise ValueError(f"parts[{name!r}]: {exc}") from exc
    return limbs


def limb_geom_xml(name, ellipsoid):
    """MJCF ``<geom name=.. type="ellipsoid" pos="x y z" quat="w x y z" size="r0 r1 r2"/>`` for `ellipsoid`.

    name : str, the geom's name.  ellipsoid : Ellipsoids of length 1 (e.g. from `bounding_ellipsoid`),
    in the frame of the body the geom goes into, metres.  The quaternion comes from the rotation by
    ``mujoco.mju_mat2Quat``; numbers are written with repr precision (they round-trip exactly).
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    if not isinstance(ellipsoid, Ellipsoids) or len(ellipsoid) != 1:
        got = f"a batch of {len(ellipsoid)}" if isinstance(ellipsoid, Ellipsoids) else type(ellipsoid).__name__
        raise ValueError(f"ellipsoid must be an ellipsim.Ellipsoids of length 1, got {got}")
    quat = rotations_to_quaternions(ellipsoid.rotations[0])
    geom = ET.Element(
        "geom",
        name=name,
        type="ellipsoid",
        pos=mjcf_numbers(ellipsoid.centers[0]),
        quat=mjcf_numbers(quat),
        size=mjcf_numbers(ellipsoid.radii[0]),
    )
    return ET.tostring(geom, encoding="unicode", short_empty_elements=True)


@dataclasses.dataclass
class FittedLimb:
    """A bounding ellipsoid written with `digits` significant digits that still encloses its mesh.

    name : the geom's name; pos, quat, size : the MJCF attribute texts (centre, w x y z, semi-axes);
    ellipsoid : Ellipsoids (length 1) of exactly those numbers (the quaternion normalised, as MuJoCo
    does); volume_ratio : the ellipsoid's volume over the mesh's convex hull's (>= 1; 1 is a perfect fit).
    """

    name: str
    pos: str
    quat: str
    size: str
    ellipsoid: Ellipsoids
    volume_ratio: float


def fit_limb(name, mesh, *, method="thesis", digits=6):
    """`bounding_ellipsoid` of `mesh`, rounded for reading and writing: a FittedLimb.

    Lengths are rounded to `digits` significant digits of the largest semi-axis (so a centre far
    from the origin keeps the same absolute precision as the axes), quaternion components to
    `digits` decimals (w >= 0); then the semi-axes are recomputed for the rounded centre and
    orientation and rounded up, until every vertex is inside the ellipsoid the written numbers
    define, evaluated in float64.  Rounding noise (1e-15 of a unit) prints as 0.
    """
    if isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17:
        raise ValueError(f"digits must be an int from 1 to 17, got {digits!r}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    e = bounding_ellipsoid(mesh, method=method)
    _, vertices = _mesh_vertices(mesh)
    scale = float(e.radii.max())
    decimals = digits - 1 - math.floor(math.log10(scale))
    quantum = 10.0**-decimals
    pos = np.array([float(_decimal(x, decimals)) for x in e.centers[0]])
    quat = np.array([float(_decimal(q, digits)) for q in rotations_to_quaternions(e.rotations[0])])
    rotation = quaternions_to_rotations(quat / np.linalg.norm(quat))
    radii = e.radii[0] * math.sqrt(_max_level(vertices, pos, rotation, e.radii[0]))
    radii = np.ceil(radii / quantum) * quantum
    for _ in range(100):
        radii = np.array([float(_decimal(r, decimals)) for r in radii])
        if _max_level(vertices, pos, rotation, radii) <= 1.0:
            break
        radii = radii + quantum
    else:
        raise RuntimeError(f"could not round the fit of {name!r} to {digits} digits and keep every vertex inside")
    hull = ConvexHull(vertices - vertices.mean(axis=0))
    volume = 4.0 / 3.0 * math.pi * float(np.prod(radii))
    return FittedLimb(
        name=name,
        pos=" ".join(_decimal(x, decimals) for x in pos),
        quat=" ".join(_decimal(q, digits) for q in quat),
        size=" ".join(_decimal(r, decimals) for r in radii),
        ellipsoid=Ellipsoids(pos[None], rotation[None], radii[None]),
        volume_ratio=volume / hull.volume,
    )


def limbs_xml(limbs, *, method="thesis"):
    """An MJCF file of FittedLimbs: one ellipsoid geom each in the worldbody, in the meshes'
    coordinates (loads on its own; `<include file=..>` adds the geoms to another model's worldbody)."""
    root = ET.Element("mujoco", model="limbs")
    root.append(
        ET.Comment(
            f" bounding ellipsoids fitted by `ellipsim fit --method {method}`, one per mesh, "
            "in the mesh's coordinates: move each geom into the body its mesh belongs to "
        )
    )
    world = ET.SubElement(root, "worldbody")
    for limb in limbs:
        ET.SubElement(world, "geom", name=limb.name, type="ellipsoid", pos=limb.pos, quat=limb.quat, size=limb.size)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def summary_lines(limbs, *, method="thesis", digits=6):
    """The table `ellipsim fit` prints: one row per FittedLimb (centre, quaternion, semi-axes as
    written to MJCF, and the ellipsoid's volume over its mesh's hull's)."""
    width = max(len(limb.name) for limb in limbs)
    lines = [
        f"bounding ellipsoids ({method}), {digits} significant digits, every vertex inside as written:",
        f"  {'mesh':<{width}}  {'centre (pos)':<30} {'quaternion (w x y z)':<36} {'semi-axes (size)':<30} volume / hull",
    ]
    for limb in limbs:
        lines.append(f"  {limb.name:<{width}}  {limb.pos:<30} {limb.quat:<36} {limb.size:<30} {limb.volume_ratio:.3f}")
    return lines


def _decimal(value, decimals):
    """`value` rounded to `decimals` decimal places (decimals may be negative) as short text: no
    trailing zeros, no "-0"."""
    if decimals <= 0:
        text = str(int(round(value, decimals)))
    else:
        text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def mesh_vertices(mesh):
    """Vertices (n, 3) float64 of a trimesh.Trimesh or a mesh file (as bounding_ellipsoid reads them)."""
    return _mesh_vertices(mesh)[1]


# --- Input checks ----------------------------------------------------------------------------


def _check_method(method):
    """ValueError unless `method` is one of METHODS."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")


def _mesh_vertices(mesh):
    """(label naming `mesh` in messages, vertices (n, 3) float64) of a Trimesh or a mesh file; ValueError if bad."""
    if isinstance(mesh, (str, os.PathLike)):
        path = os.fspath(mesh)
        label = f"mesh file {path!r}"
        ext = os.path.splitext(path)[1].lower()
        if ext not in MESH_FORMATS:
            raise ValueError(
                f"{label} has an unsupported format {ext or '(no extension)'!r}; supported: {', '.join(MESH_FORMATS)}"
            )
        if not os.path.isfile(path):
            raise ValueError(f"{label} does not exist or is not a file")
        try:
            loaded = trimesh.load(path, force="mesh")
        except Exception as exc:  # trimesh raises many types for unreadable files; report them as bad input
            raise ValueError(f"{label} cannot be read as a mesh: {type(exc).__name__}: {exc}") from exc
        if not isinstance(loaded, trimesh.Trimesh):
            raise ValueError(f"{label} holds no triangle mesh (trimesh loaded a {type(loaded).__name__})")
        mesh, where = loaded, f"{label}: vertices"
    elif isinstance(mesh, trimesh.Trimesh):
        label, where = "mesh", "mesh.vertices"
    else:
        raise ValueError(f"mesh must be a trimesh.Trimesh or a path to a mesh file, got {type(mesh).__name__}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    bad = ~np.isfinite(vertices)
    if bad.any():
        i, j = (int(k) for k in np.argwhere(bad)[0])
        raise ValueError(f"{where}[{i}, {j}] must be finite, got {vertices[i, j]}")
    return label, np.ascontiguousarray(vertices)


def _check_solid(label, vertices):
    """ValueError if the vertices (n, 3) are fewer than 4, or all within FLAT_RTOL of a plane or a line."""
    n = len(vertices)
    if n < 4:
        raise ValueError(f"{label} must have at least 4 vertices not all in one plane, got {n}")
    centred = vertices - vertices.mean(axis=0)
    _, axes = np.linalg.eigh(centred.T @ centred)  # ascending variance
    widths = np.ptp(centred @ axes, axis=0)
    extent = widths.max()
    if extent == 0:
        raise ValueError(
            f"{label} has all {n} vertices at one point {vertices[0].tolist()}: "
            f"it has no bounding ellipsoid of positive volume"
        )
    if widths[0] <= FLAT_RTOL * extent:
        shape = "on a line" if widths[1] <= FLAT_RTOL * extent else "in a plane"
        raise ValueError(
            f"{label} is flat: its {n} vertices lie {shape} (width {widths[0]:.3g} across, "
            f"{widths[0] / extent:.3g} of the extent {extent:.3g}; the limit is {FLAT_RTOL:g}), "
            f"and a flat mesh has no bounding ellipsoid of positive volume"
        )


# --- Fits (in coordinates about the mesh's bounding-box centre) -------------------------------


def _proper(axes):
    """`axes` (3, 3) with its last column negated if needed so that det = +1."""
    if np.linalg.det(axes) < 0:
        axes = axes.copy()
        axes[:, 2] = -axes[:, 2]
    return axes


def _fit_thesis(points, triangles):
    """Leung 2000, ch. 3: centre, axes (3, 3), semi-axes (3,) from hull points (m, 3) and triangles (t, 3, 3).

    Centre and covariance are over the hull triangles' vertices, each weighted by its triangle's area
    (the thesis's weighting area / smallest area, normalised by the total so that a zero-area sliver
    of qhull's triangulation cannot divide by zero); axes are the covariance's eigenvectors; each
    semi-axis is the largest |projection| of a hull point on its axis.  The common rescale that
    puts every vertex inside is `_enclose`'s.  Coplanar hull facets are triangulated by qhull, and
    the covariance (not the centre) depends on which diagonals it picks.
    """
    edge1 = triangles[:, 1] - triangles[:, 0]
    edge2 = triangles[:, 2] - triangles[:, 0]
    area = 0.5 * np.linalg.norm(np.cross(edge1, edge2), axis=1)
    weight = area / area.sum()
    mean = np.einsum("t,tkj->j", weight, triangles) / 3.0
    dev = triangles - mean
    cov = np.einsum("t,tki,tkj->ij", weight, dev, dev) / 3.0
    _, axes = np.linalg.eigh(cov)
    axes = _proper(axes[:, ::-1])  # descending variance
    radii = np.abs((points - mean) @ axes).max(axis=0)
    return mean, axes, radii


def _fit_mvee(points):
    """Minimum-volume enclosing ellipsoid of hull points (m, 3) to MVEE_TOL: centre, axes (3, 3), radii (3,).

    Both solvers are affine invariant, so they run on whitened points (zero mean, unit covariance),
    which keeps X well conditioned for elongated meshes.  For Khachiyan's weights u the ellipsoid
    is {x : (x - c)^T (d S)^-1 (x - c) <= 1} with c = sum u_j p_j, S = sum u_j (p_j - c)(p_j - c)^T.
    """
    d = points.shape[1]
    mean = points.mean(axis=0)
    var, basis = np.linalg.eigh(np.cov(points - mean, rowvar=False, bias=True))
    to_world = basis * np.sqrt(var)  # x = mean + to_world @ y
    white = ((points - mean) @ basis) / np.sqrt(var)
    u, gap = _mvee_weights(white, MVEE_TOL)
    if gap > MVEE_TOL:
        warnings.warn(
            f"the minimum-volume ellipsoid stopped at gap {gap:.3g} (asked {MVEE_TOL:g}); the result "
            f"encloses the mesh, but its volume may exceed the minimum by a factor up to "
            f"1 + {(1 + (d + 1) / d * gap) ** (d / 2) - 1:.3g}",
            RuntimeWarning,
            stacklevel=3,
        )
    center_w = u @ white
    dev = white - center_w
    shape_w = (dev.T * u) @ dev  # S in whitened coordinates
    factor = to_world @ np.linalg.cholesky(d * shape_w)  # ellipsoid = center + factor @ unit ball
    axes, radii, _ = np.linalg.svd(factor)
    return mean + to_world @ center_w, _proper(axes), radii


def _mvee_weights(points, tol):
    """Khachiyan's weights u (m,) >= 0, sum 1, for points (m, d), and their gap max_j omega_j / k - 1.

    Khachiyan's algorithm (WA-TY) for MVEE_KHACHIYAN_STEPS steps; if it has not reached `tol` by
    then, the primal-dual interior-point method, polished by Khachiyan's steps if it stops short,
    and the better of the two.
    """
    u, gap = _khachiyan(points, tol, MVEE_KHACHIYAN_STEPS)
    if gap <= tol:
        return u, gap
    u_ipm, gap_ipm = _interior_point(points, tol, MVEE_IPM_MAX_ITER)
    if tol < gap_ipm < math.inf:
        # stopped by its own conditioning (near 1e-12 on thin far-off clouds): Khachiyan polishes
        # from its weights, without the ~mu / s_j weights of the points that do not touch
        start = np.where(u_ipm >= _IPM_WEIGHT_FLOOR * u_ipm.max(), u_ipm, 0.0)
        u_ipm, gap_ipm = _khachiyan(points, tol, MVEE_KHACHIYAN_STEPS, start=start / start.sum())
    return (u_ipm, gap_ipm) if gap_ipm < gap else (u, gap)


def _lift(points):
    """q_j = (p_j, 1): points (m, d) -> (m, d + 1)."""
    return np.hstack([points, np.ones((len(points), 1))])


def _omega(lifted, u):
    """X(u)^-1 (k, k) and omega (m,) = diag(Q X(u)^-1 Q^T) for lifted points Q (m, k), X(u) = Q^T diag(u) Q."""
    x_inv = np.linalg.inv((lifted.T * u) @ lifted)
    return x_inv, _quadratic_forms(lifted, x_inv)


def _quadratic_forms(lifted, mat):
    """q_j^T mat q_j for lifted points Q (m, k) and a symmetric mat (k, k) -> (m,)."""
    return ((lifted @ mat) * lifted).sum(axis=1)


def _kumar_yildirim_start(points):
    """Indices of the at most 2d initial support points of Kumar & Yildirim (2005), used by Todd & Yildirim.

    points : (m, d), full-dimensional.  For d directions, each orthogonal to the differences of the
    pairs chosen before, the points with the largest and the smallest projection.
    """
    d = points.shape[1]
    chosen, diffs = [], []
    direction = np.eye(d)[0]
    for i in range(d):
        proj = points @ direction
        hi, lo = int(np.argmax(proj)), int(np.argmin(proj))
        chosen += [hi, lo]
        diffs.append(points[hi] - points[lo])
        if i + 1 < d:  # the left singular vectors beyond the rank span the orthogonal complement
            direction = np.linalg.svd(np.array(diffs).T, full_matrices=True)[0][:, i + 1]
    return np.unique(chosen)


def _khachiyan(points, tol, max_steps, start=None):
    """Khachiyan's algorithm, WA-TY variant: weights u (m,) for points (m, d) and the gap reached.

    Todd & Yildirim (2007): from the Kumar-Yildirim start, Khachiyan's step towards the point of
    largest omega_j = q_j^T X(u)^-1 q_j (q_j = (p_j, 1), X(u) = sum_j u_j q_j q_j^T), or an away step
    from the supported point of smallest omega_j when that is further from k = d + 1, each with
    Khachiyan's exact line search (an away step stops where the weight reaches 0).  X^-1 and omega
    by rank-one (Sherman-Morrison) updates, O(m d) per step.  Stops at the first freshly computed
    state with gap = max_j omega_j / k - 1 <= tol, or after `max_steps` steps.  `start` (m,): initial
    weights (sum 1, spanning) instead of Kumar-Yildirim's.
    """
    m, d = points.shape
    lifted = _lift(points)
    k = d + 1
    if start is None:
        u = np.zeros(m)
        first = _kumar_yildirim_start(points)
        u[first] = 1.0 / len(first)
    else:
        u = np.array(start, dtype=np.float64)
    x_inv, omega = _omega(lifted, u)
    fresh = True
    step = 0
    while True:
        up = int(np.argmax(omega))
        gap = omega[up] / k - 1.0
        if gap <= tol or step >= max_steps:
            if fresh:
                return u, gap
            x_inv, omega = _omega(lifted, u)  # decide on fresh values only
            fresh = True
            continue
        support = np.flatnonzero(u > 0)
        down = int(support[np.argmin(omega[support])])
        away = 1.0 - omega[down] / k > gap
        j = down if away else up
        tau = (omega[j] - k) / (k * (omega[j] - 1.0)) if omega[j] > 1.0 else -math.inf
        dropped = away and tau <= -u[j] / (1.0 - u[j])
        if dropped:
            tau = -u[j] / (1.0 - u[j])
        y = x_inv @ lifted[j]
        denom = (1.0 - tau) + tau * omega[j]
        omega = (omega - tau * (lifted @ y) ** 2 / denom) / (1.0 - tau)
        x_inv = (x_inv - tau * np.outer(y, y) / denom) / (1.0 - tau)
        u *= 1.0 - tau
        u[j] = 0.0 if dropped else u[j] + tau
        step += 1
        fresh = step % MVEE_REFRESH == 0
        if fresh:
            x_inv, omega = _omega(lifted, u)


def _interior_point(points, tol, max_iter):
    """Primal-dual interior-point MVEE: Khachiyan's weights u (m,) for points (m, d) and the gap reached.

    Khachiyan's lifted problem  min -ln det M  s.t.  q_j^T M q_j + s_j = 1, s >= 0  (M (k, k), k = d+1)
    with multipliers u >= 0: optimal M^-1 = sum_j u_j q_j q_j^T and u / k are Khachiyan's weights.
    Newton steps on the perturbed KKT conditions u_j s_j = sigma mu, Mehrotra's predictor-corrector
    (S. Mehrotra, SIAM J. Optim. 2, 1992; interior-point MVEE as in P. Sun and R. M. Freund,
    Oper. Res. 52, 2004).  M lives in the basis E_a = e_i e_l^T + e_l e_i^T (i < l), e_i e_i^T, so
    each step solves one symmetric positive definite (k(k+1)/2)-square system: O(m k^4) per step.
    Stops when u / sum(u) has gap max_j omega_j / k - 1 <= tol, or after `max_iter` steps.
    """
    m, d = points.shape
    lifted = _lift(points)
    k = d + 1
    rows, cols = np.triu_indices(k)
    double = np.where(rows == cols, 1.0, 2.0)  # tr(E_a R) = double_a R[rows_a, cols_a]
    basis = np.zeros((len(rows), k, k))
    basis[np.arange(len(rows)), rows, cols] = 1.0
    basis[np.arange(len(rows)), cols, rows] = 1.0
    z = double * lifted[:, rows] * lifted[:, cols]  # (m, k(k+1)/2): q_j^T E_a q_j
    big = np.einsum("ij,ij->i", lifted, lifted).max()
    m_mat = np.eye(k) / (2.0 * big)  # strictly feasible: s_j >= 1/2
    s = 1.0 - _quadratic_forms(lifted, m_mat)
    u = np.full(m, k / m)
    best_u, best_gap = u / u.sum(), math.inf
    for _ in range(max_iter + 1):
        weights = u / u.sum()
        gap = _omega(lifted, weights)[1].max() / k - 1.0
        if gap < best_gap:
            best_u, best_gap = weights, gap
        if gap <= tol:
            break
        m_inv = np.linalg.inv(m_mat)
        dual_res = (lifted.T * u) @ lifted - m_inv
        primal_res = _quadratic_forms(lifted, m_mat) + s - 1.0
        mu = (u @ s) / m
        left = np.einsum("ij,ajk->aik", m_inv, basis)
        system = np.einsum("aij,bji->ab", left, left) + (z.T * (u / s)) @ z
        try:
            chol = np.linalg.cholesky(system)
        except np.linalg.LinAlgError:  # rounding at the end of the path: keep the best weights
            break

        def direction(comp_res):
            rhs = -double * dual_res[rows, cols] - z.T @ ((u * primal_res - comp_res) / s)
            x = np.linalg.solve(chol.T, np.linalg.solve(chol, rhs))
            ds = -primal_res - z @ x
            return np.einsum("a,aij->ij", x, basis), (-comp_res - u * ds) / s, ds

        d_m, d_u, d_s = direction(u * s)  # predictor (affine scaling)
        alpha = _max_step(m_mat, d_m, u, d_u, s, d_s)
        mu_aff = ((u + alpha * d_u) @ (s + alpha * d_s)) / m
        sigma = (mu_aff / mu) ** 3
        d_m, d_u, d_s = direction(u * s + d_u * d_s - sigma * mu)  # corrector
        alpha = _IPM_STEP_FRACTION * _max_step(m_mat, d_m, u, d_u, s, d_s)
        m_mat = m_mat + alpha * d_m
        u = u + alpha * d_u
        s = s + alpha * d_s
    return best_u, best_gap


def _max_step(m_mat, d_m, u, d_u, s, d_s):
    """Largest alpha <= 1 keeping u + alpha d_u >= 0, s + alpha d_s >= 0 and M + alpha d_M positive definite."""
    alpha = 1.0
    for value, change in ((u, d_u), (s, d_s)):
        falling = change < 0
        if falling.any():
            alpha = min(alpha, float((-value[falling] / change[falling]).min()))
    chol = np.linalg.cholesky(m_mat)
    half = np.linalg.solve(chol, d_m)
    lowest = np.linalg.eigvalsh(np.linalg.solve(chol, half.T)).min()  # of L^-1 dM L^-T
    if lowest < 0:
        alpha = min(alpha, -1.0 / lowest)
    return alpha


def _enclose(vertices, center, rotation, radii):
    """`radii` (3,) times the one factor after which max_v |diag(1/r) R^T (v - c)|^2 <= 1 in float64.

    vertices (n, 3), center (3,), rotation (3, 3): the smallest such factor up to a few ulps (it is
    sqrt of the largest level, then grown by _ENCLOSE_NUDGE while rounding leaves a vertex outside).
    """
    radii = radii * math.sqrt(_max_level(vertices, center, rotation, radii))
    for _ in range(64):
        level = _max_level(vertices, center, rotation, radii)
        if level <= 1.0:
            return radii
        radii = radii * (math.sqrt(level) * (1.0 + _ENCLOSE_NUDGE))
    raise RuntimeError(f"could not scale radii {radii.tolist()} to enclose the mesh (largest level {level!r})")


def _max_level(vertices, center, rotation, radii):
    """max over vertices (n, 3) of |diag(1/r) R^T (v - c)|^2 (1 on the surface)."""
    z = ((vertices - center) @ rotation) / radii
    return float(np.einsum("ij,ij->i", z, z).max())
