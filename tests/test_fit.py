"""Bounding ellipsoids of meshes (ellipsim.fit) and the MJCF limbs built from them.

Tolerances (d = 3, k = d + 1 = 4, eps = fit.MVEE_TOL = 1e-12):

* Enclosure: max over vertices of |diag(1/r) R^T (v - c)|^2 <= 1 + 1e-12.  The fit makes its own
  float64 evaluation <= 1; this file evaluates in another order, a few ulps apart.  The rescale is
  also the smallest: the same maximum is >= 1 - 1e-12.
* MVEE accuracy.  The solvers stop at Khachiyan weights u with max_j omega_j(u) <= (1 + eps) k.  E(u)
  has at most the minimum volume (u is dual feasible), the rescale factor is <= sqrt(1 + eps k / d),
  so the result has volume <= (1 + delta) vol*, delta = (1 + 4 eps / 3)^(3/2) - 1 ~ 2 eps.
  For any enclosing {x : (x - c)^T A (x - c) <= 1} and the optimum's weights u*, averaging the
  constraints with u* gives tr(A S*) + (c - c*)^T A (c - c*) <= 1, S* = sum u*_j (p_j - c*)(p_j - c*)^T,
  A* = (d S*)^-1.  With A*^-1/2 A A*^-1/2 = I + X: tr X <= 0 and det(I + X) >= (1 + delta)^-2, so
  sum x_i^2 <= 4 delta (to first order) and |x_i| <= 2 sqrt(delta).  The eigenvalues of A are those
  of A* times factors in [1 + min x, 1 + max x] (Ostrowski), so sorted semi-axes are within
  sqrt(delta) = sqrt(2 eps) = 1.4e-6, relatively, and ||A - A*|| <= 2 sqrt(delta) ||A*||; and
  (c - c*)^T A (c - c*) <= 1 - det(I + X)^(1/d) <= 2 delta / 3: the centre is within
  sqrt(4 eps / 3) = 1.2e-6 in units of the semi-axes.  The tests allow 1.1 times these bounds (for
  the second-order terms), twice them when two fits are compared.
"""

import math
import re
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import nnls
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from ellipsim import Ellipsoids
from ellipsim.app import fit
from ellipsim.app.fit import bounding_ellipsoid, limb_geom_xml, limbs_from_meshes

EPS = fit.MVEE_TOL
DELTA = (1 + 4 * EPS / 3) ** 1.5 - 1  # volume excess bound of an mvee fit (module docstring)
RADII_RTOL = 1.1 * math.sqrt(DELTA)  # 1.6e-6: sorted semi-axes of an mvee fit vs the optimum
CENTRE_TOL = 1.1 * math.sqrt(2 * DELTA / 3)  # 1.3e-6: centre offset in units of the semi-axes
SHAPE_RTOL = 2.2 * math.sqrt(DELTA)  # ||A - A*|| / ||A*||
ENCLOSE_TOL = 1e-12
SQRT3 = math.sqrt(3.0)


def _meshes():
    """The hand-picked test meshes, in their own frames (metres)."""
    rng = np.random.default_rng(7)
    return {
        "box": trimesh.creation.box(extents=(1.0, 2.5, 4.0)),
        "icosphere": trimesh.creation.icosphere(subdivisions=3, radius=0.7),
        "capsule": trimesh.creation.capsule(height=1.0, radius=0.3),
        "cylinder": trimesh.creation.cylinder(radius=0.4, height=2.0, sections=48),
        "random hull": trimesh.convex.convex_hull(rng.normal(size=(300, 3)) * [3.0, 2.0, 1.0]),
    }


MESHES = _meshes()


def rigid(seed, scale=1.0):
    """A random proper rotation (3, 3) and translation (3,) of size ~scale."""
    rng = np.random.default_rng(seed)
    return Rotation.random(random_state=seed).as_matrix(), rng.normal(size=3) * scale


def moved(mesh, rotation, translation):
    """A copy of `mesh` with x -> rotation @ x + translation."""
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = rotation, translation
    out = mesh.copy()
    out.apply_transform(transform)
    return out


def levels(points, e):
    """|diag(1/r) R^T (p - c)|^2 per point (n,) for an Ellipsoids of length 1."""
    z = ((points - e.centers[0]) @ e.rotations[0]) / e.radii[0]
    return (z * z).sum(axis=1)


def shape(e):
    """A = R diag(1/r^2) R^T of an Ellipsoids of length 1: E = {x : (x - c)^T A (x - c) <= 1}."""
    return (e.rotations[0] / e.radii[0] ** 2) @ e.rotations[0].T


def volume(e):
    return 4.0 / 3.0 * math.pi * float(np.prod(e.radii[0]))


def assert_same_ellipsoid(a, b, *, radii_rtol, centre_tol, shape_rtol):
    """Two fits of one mesh agree: sorted radii, centre (in units of the radii), shape matrix."""
    np.testing.assert_allclose(np.sort(a.radii[0]), np.sort(b.radii[0]), rtol=radii_rtol, atol=0)
    offset = ((b.centers[0] - a.centers[0]) @ a.rotations[0]) / a.radii[0]
    assert np.linalg.norm(offset) <= centre_tol
    assert np.linalg.norm(shape(a) - shape(b), 2) <= shape_rtol * np.linalg.norm(shape(a), 2)


# --- Enclosure -------------------------------------------------------------------------------


@pytest.mark.parametrize("method", fit.METHODS)
@pytest.mark.parametrize("name", list(MESHES))
@pytest.mark.parametrize("seed, scale", [(0, 0.0), (1, 10.0), (2, 1000.0)])
def test_every_vertex_is_inside_and_the_rescale_is_tight(method, name, seed, scale):
    mesh = moved(MESHES[name], *rigid(seed, scale))
    e = bounding_ellipsoid(mesh, method=method)
    assert isinstance(e, Ellipsoids) and len(e) == 1
    worst = levels(mesh.vertices, e).max()
    assert 1 - ENCLOSE_TOL <= worst <= 1 + ENCLOSE_TOL
    rot = e.rotations[0]
    assert abs(np.linalg.det(rot) - 1) <= 1e-12
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), rtol=0, atol=1e-14)
    assert (e.radii > 0).all()


def thesis_reference(mesh):
    """Leung 2000, ch. 3, written out per triangle and per vertex: (centre (3,), axes (3, 3), radii (3,)).

    On trimesh's own convex hull; weighting_i = area_i / smallest area, and the sums are divided by
    3 x the total weighting (the thesis prints 3n x total weighting, which would not be a mean).
    """
    hull = mesh.convex_hull
    weighting = hull.area_faces / hull.area_faces.min()
    mean = sum(w * (t[0] + t[1] + t[2]) for t, w in zip(hull.triangles, weighting)) / (3 * weighting.sum())
    cov = sum(w * sum(np.outer(v - mean, v - mean) for v in t) for t, w in zip(hull.triangles, weighting))
    axes = np.linalg.eigh(cov / (3 * weighting.sum()))[1][:, ::-1]
    first = np.array([max(abs((v - mean) @ axes[:, j]) for v in hull.vertices) for j in range(3)])
    scale = max(sum(((v - mean) @ axes[:, j] / first[j]) ** 2 for j in range(3)) for v in mesh.vertices)
    return mean, axes, first * math.sqrt(scale)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_thesis_fit_matches_a_per_triangle_reference(seed):
    """On a generic hull (unique triangulation, distinct covariance eigenvalues), to rounding: 1e-12
    for the centre, 1e-9 for axes and radii (eigenvectors err by ~1e-16 / relative eigenvalue gap)."""
    rng = np.random.default_rng(seed)
    mesh = moved(trimesh.convex.convex_hull(rng.normal(size=(150, 3)) * [2.0, 1.5, 1.0]), *rigid(seed, 3.0))
    centre, axes, radii = thesis_reference(mesh)
    e = bounding_ellipsoid(mesh, method="thesis")
    np.testing.assert_allclose(e.centers[0], centre, rtol=0, atol=1e-12 * np.abs(mesh.vertices).max())
    np.testing.assert_allclose(np.abs(np.sum(e.rotations[0] * axes, axis=0)), 1.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(e.radii[0], radii, rtol=1e-9, atol=0)


# --- Known optima of the minimum-volume ellipsoid ---------------------------------------------


@pytest.mark.parametrize("cap", [False, True], ids=["box", "box with a cap vertex"])
def test_mvee_of_a_box_is_centred_with_sqrt3_times_its_half_sizes(cap):
    """The box's corners with uniform weights meet Khachiyan's optimality condition omega_j = k.
    A cap vertex at 1.5 c on the top face's normal lies inside that ellipsoid (level 0.75), so the
    optimum stays, but the solver has to drive the cap's weight to 0."""
    half = np.array([0.5, 1.25, 2.0])
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T * half
    points = np.vstack([corners, [[0.0, 0.0, 1.5 * half[2]]]]) if cap else corners
    rot, shift = rigid(3, 5.0)
    mesh = trimesh.convex.convex_hull(points @ rot.T + shift)
    assert len(mesh.vertices) == len(points)
    e = bounding_ellipsoid(mesh, method="mvee")
    optimum = Ellipsoids(shift, rot, SQRT3 * half)
    assert_same_ellipsoid(optimum, e, radii_rtol=RADII_RTOL, centre_tol=CENTRE_TOL, shape_rtol=SHAPE_RTOL)


def test_mvee_of_a_regular_prism_is_known():
    """trimesh's cylinder (regular 48-gon of radius rho, half-height h): uniform weights on its 96
    rim vertices give S = diag(rho^2/2, rho^2/2, h^2), and every rim vertex has level
    (rho^2 / (3 rho^2 / 2)) + h^2 / (3 h^2) = 1, Khachiyan's optimality condition, so the
    optimum has semi-axes (sqrt(3/2) rho, sqrt(3/2) rho, sqrt(3) h)."""
    rho, h = 0.4, 1.0
    rot, shift = rigid(4, 2.0)
    e = bounding_ellipsoid(moved(MESHES["cylinder"], rot, shift), method="mvee")
    optimum = Ellipsoids(shift, rot, [math.sqrt(1.5) * rho, math.sqrt(1.5) * rho, SQRT3 * h])
    assert_same_ellipsoid(optimum, e, radii_rtol=RADII_RTOL, centre_tol=CENTRE_TOL, shape_rtol=SHAPE_RTOL)


def test_icosphere_radii_are_its_radius():
    """icosphere(subdivisions=3, radius r): its 642 vertices are on the sphere, symmetric under the
    icosahedral group, so uniform weights are optimal and the mvee is the sphere (to RADII_RTOL).
    The thesis fit is centred at 0 by central symmetry; its covariance is isotropic, so its axes
    are arbitrary.  Each first semi-axis is the hull's support in that direction, in [h, r] with h
    the hull's inradius, and the common rescale is at most r / h: its radii lie in [h, r^2 / h];
    for this faceting h = 0.99547 r, i.e. [0.99547 r, 1.00455 r]."""
    r = 0.7
    mesh = MESHES["icosphere"]
    h = -ConvexHull(mesh.vertices).equations[:, 3].max()
    assert 0.995 * r < h < 0.996 * r
    mvee = bounding_ellipsoid(mesh, method="mvee")
    np.testing.assert_allclose(mvee.radii[0], r, rtol=RADII_RTOL, atol=0)
    assert np.linalg.norm(mvee.centers[0]) <= CENTRE_TOL * r
    thesis = bounding_ellipsoid(mesh, method="thesis")
    assert (thesis.radii[0] >= h * (1 - 1e-12)).all() and (thesis.radii[0] <= r * r / h * (1 + 1e-12)).all()
    assert np.linalg.norm(thesis.centers[0]) <= 1e-12 * r


def test_mvee_of_a_float32_ellipsoid_mesh_from_an_stl_file(tmp_path, monkeypatch):
    """An icosphere scaled to semi-axes (0.3, 0.2, 0.1) and stored as float32 .stl: its vertices
    sit within 2^-24 |v| of the ellipsoid, i.e. within 1.8e-7 of the smallest semi-axis, and the
    affine image of the icosphere's vertices has the ellipsoid itself as mvee; so the fit is within
    1.8e-7 + RADII_RTOL of (0.3, 0.2, 0.1).  Many hull points lie almost on the optimum: Khachiyan's
    algorithm is slow here and the interior-point method must finish (checked with a spy)."""
    semi = np.array([0.3, 0.2, 0.1])
    ico = trimesh.creation.icosphere(subdivisions=4)
    path = tmp_path / "oval.stl"
    trimesh.Trimesh(ico.vertices * semi, ico.faces).export(path)
    calls = []
    real = fit._interior_point
    monkeypatch.setattr(fit, "_interior_point", lambda *a: calls.append(real(*a)) or calls[-1])
    e = bounding_ellipsoid(path, method="mvee")
    assert len(calls) == 1 and calls[0][1] <= EPS
    np.testing.assert_allclose(e.radii[0], semi, rtol=1.8e-7 + RADII_RTOL, atol=0)
    np.testing.assert_allclose(np.abs(e.rotations[0]), np.eye(3), rtol=0, atol=1e-5)
    assert np.linalg.norm(e.centers[0]) <= 1e-6 * semi.min()


# --- mvee against the thesis, and its optimality --------------------------------------------


@pytest.mark.parametrize("name", list(MESHES))
def test_mvee_volume_is_at_most_the_thesis_volume(name):
    """The minimum-volume ellipsoid is no larger than any enclosing ellipsoid, the thesis fit
    included; the mvee fit is within (1 + DELTA) of that minimum (module docstring)."""
    for seed in (5, 6):
        mesh = moved(MESHES[name], *rigid(seed, 1.0))
        mvee = bounding_ellipsoid(mesh, method="mvee")
        thesis = bounding_ellipsoid(mesh, method="thesis")
        assert volume(mvee) <= volume(thesis) * (1 + 1.1 * DELTA + 1e-14)


def johns_residual(points, e, near=1e-4):
    """Least-squares residual of John's conditions for e to be the minimum-volume ellipsoid of points.

    John (1948): E = c + R diag(r) B is the MVEE iff there are contact points z_j (unit vectors,
    points of the set in E's normalised coordinates) and lambda_j >= 0 with sum lambda_j z_j z_j^T = I
    and sum lambda_j z_j = 0.  Points with level >= 1 - near count as contacts (an mvee fit is within
    ~3e-6 of the optimum, so the optimum's contacts have levels within ~1e-5 of 1 in it);
    lambda by non-negative least squares: an independent check of the solvers.
    """
    z = ((points - e.centers[0]) @ e.rotations[0]) / e.radii[0]
    lv = (z * z).sum(axis=1)
    contact = z[lv >= 1 - near] / np.sqrt(lv[lv >= 1 - near])[:, None]
    rows, cols = np.triu_indices(3)
    system = np.vstack([(contact[:, rows] * contact[:, cols]).T, contact.T])
    target = np.concatenate([np.eye(3)[rows, cols], np.zeros(3)])
    return nnls(system, target)[1]


@settings(max_examples=40)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(4, 80),
    aspect=st.floats(1.0, 30.0),
    far=st.sampled_from([0.0, 1.0, 1e4]),
)
def test_mvee_meets_johns_optimality_conditions(seed, n, aspect, far):
    rng = np.random.default_rng(seed)
    rot, shift = rigid(seed % 1000, far)
    points = (rng.normal(size=(n, 3)) * [aspect, 1.0, 1.0 / aspect]) @ rot.T + shift
    e = bounding_ellipsoid(trimesh.Trimesh(points, process=False), method="mvee")
    assert levels(points, e).max() <= 1 + ENCLOSE_TOL
    assert johns_residual(points, e) <= 1e-4


def test_johns_residual_rejects_a_non_minimal_ellipsoid():
    """The check above has teeth: the thesis fit of the random hull fails it."""
    mesh = MESHES["random hull"]
    assert johns_residual(mesh.vertices, bounding_ellipsoid(mesh, method="thesis")) > 1e-2
    assert johns_residual(mesh.vertices, bounding_ellipsoid(mesh, method="mvee")) <= 1e-4


@pytest.mark.parametrize("name", ["random hull", "capsule", "cylinder", "box"])
def test_khachiyan_and_the_interior_point_method_agree(name, monkeypatch):
    """Each solver alone (the other disabled) reaches MVEE_TOL, so both fits are within the bound of
    the one optimum."""
    mesh = moved(MESHES[name], *rigid(8, 1.0))
    monkeypatch.setattr(fit, "MVEE_KHACHIYAN_STEPS", 0)
    ipm = bounding_ellipsoid(mesh, method="mvee")
    monkeypatch.setattr(fit, "MVEE_KHACHIYAN_STEPS", 100_000)
    monkeypatch.setattr(fit, "MVEE_IPM_MAX_ITER", 0)
    khachiyan = bounding_ellipsoid(mesh, method="mvee")
    assert_same_ellipsoid(
        ipm, khachiyan, radii_rtol=2 * RADII_RTOL, centre_tol=2 * CENTRE_TOL, shape_rtol=2 * SHAPE_RTOL
    )


def test_a_capped_solver_warns_and_still_encloses(monkeypatch):
    monkeypatch.setattr(fit, "MVEE_KHACHIYAN_STEPS", 1)
    monkeypatch.setattr(fit, "MVEE_IPM_MAX_ITER", 0)
    mesh = MESHES["random hull"]
    with pytest.warns(RuntimeWarning, match=r"stopped at gap .* exceed the minimum by a factor up to 1 \+ "):
        e = bounding_ellipsoid(mesh, method="mvee")
    assert levels(mesh.vertices, e).max() <= 1 + ENCLOSE_TOL


# --- Invariance under rigid motions ----------------------------------------------------------


@pytest.mark.parametrize("name", list(MESHES))
def test_mvee_is_invariant_under_rigid_motions(name):
    """The minimum-volume ellipsoid is unique, so fits of a moved mesh agree with the moved fit to
    twice the accuracy bound."""
    base = bounding_ellipsoid(MESHES[name], method="mvee")
    for seed in (9, 10):
        rot, shift = rigid(seed, 3.0)
        e = bounding_ellipsoid(moved(MESHES[name], rot, shift), method="mvee")
        expected = Ellipsoids(rot @ base.centers[0] + shift, rot @ base.rotations[0], base.radii[0])
        assert_same_ellipsoid(
            expected, e, radii_rtol=2 * RADII_RTOL, centre_tol=2 * CENTRE_TOL, shape_rtol=2 * SHAPE_RTOL
        )


@pytest.mark.parametrize("seed", [0, 1])
def test_thesis_fit_is_invariant_under_rigid_motions_of_a_generic_hull(seed):
    """For points in general position the hull's triangles are unique, its centre and covariance
    move with the mesh, and distinct covariance eigenvalues fix the axes: the fit agrees with the
    moved fit to rounding (1e-9: eigenvectors err by ~1e-16 / relative eigenvalue gap).  Not for
    hulls with coplanar facets (box, cylinder, capsule), whose qhull triangulation, and with it the
    thesis's vertex covariance, changes with the motion; nor for an isotropic covariance (sphere)."""
    rng = np.random.default_rng(seed)
    mesh = trimesh.convex.convex_hull(rng.normal(size=(200, 3)) * [2.0, 1.5, 1.0])
    base = bounding_ellipsoid(mesh, method="thesis")
    rot, shift = rigid(seed + 20, 3.0)
    e = bounding_ellipsoid(moved(mesh, rot, shift), method="thesis")
    expected = Ellipsoids(rot @ base.centers[0] + shift, rot @ base.rotations[0], base.radii[0])
    assert_same_ellipsoid(expected, e, radii_rtol=1e-9, centre_tol=1e-9, shape_rtol=1e-9)
    np.testing.assert_allclose(e.radii[0], base.radii[0], rtol=1e-9)  # same axis order too


# --- Files -----------------------------------------------------------------------------------


@pytest.mark.parametrize("ext", ["stl", "obj", "ply", "off"])
@pytest.mark.parametrize("method", fit.METHODS)
def test_a_mesh_file_is_fitted_like_the_mesh_it_holds(ext, method, tmp_path):
    mesh = moved(MESHES["capsule"], *rigid(11, 1.0))
    path = tmp_path / f"part.{ext}"
    mesh.export(path)
    from_file = bounding_ellipsoid(path, method=method)
    from_str = bounding_ellipsoid(str(path), method=method)
    loaded = bounding_ellipsoid(trimesh.load(path, force="mesh"), method=method)
    for e in (from_str, loaded):
        np.testing.assert_array_equal(e.centers, from_file.centers)
        np.testing.assert_array_equal(e.radii, from_file.radii)
    # the file may hold float32 (stl) or shortened decimals: the original is inside to that rounding
    assert levels(mesh.vertices, from_file).max() <= 1 + 1e-6


def test_a_glb_scene_is_concatenated(tmp_path):
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.5).apply_translation([3.0, 0.0, 0.0])
    path = tmp_path / "parts.glb"
    trimesh.Scene([box, ball]).export(path)
    e = bounding_ellipsoid(path, method="mvee")
    both = np.vstack([box.vertices, ball.vertices])
    assert levels(both, e).max() <= 1 + 1e-6  # glb stores float32
    assert levels(both, e).max() >= 1 - 1e-6
    assert e.radii[0].max() > 1.75  # spans both parts, 3.5 m apart end to end


# --- MJCF limbs ------------------------------------------------------------------------------


def limb_parts(tmp_path):
    """Three part meshes, moved away from their own frames; the upper arm as a file."""
    arm = moved(MESHES["capsule"], *rigid(12, 0.5))
    arm.export(tmp_path / "upper_arm.stl")
    return {
        "head": moved(MESHES["icosphere"], *rigid(13, 0.5)),
        "upper_arm": tmp_path / "upper_arm.stl",
        "thigh": moved(MESHES["cylinder"], *rigid(14, 0.5)),
    }


@pytest.mark.parametrize("method", fit.METHODS)
def test_limbs_from_meshes_fits_each_part(method, tmp_path):
    parts = limb_parts(tmp_path)
    limbs = limbs_from_meshes(parts, method=method)
    assert list(limbs) == list(parts)
    for name, part in parts.items():
        alone = bounding_ellipsoid(part, method=method)
        np.testing.assert_array_equal(limbs[name].centers, alone.centers)
        np.testing.assert_array_equal(limbs[name].rotations, alone.rotations)
        np.testing.assert_array_equal(limbs[name].radii, alone.radii)


@pytest.mark.parametrize("method", fit.METHODS)
def test_limb_geoms_compile_in_mujoco_and_match_the_fit(method, tmp_path):
    """geom_size is the fitted radii exactly (repr round-trips); the body sits at the world origin,
    so geom_xpos is the centre to rounding; geom_xmat comes back from the quaternion to ~1e-16."""
    limbs = limbs_from_meshes(limb_parts(tmp_path), method=method)
    geoms = "".join(limb_geom_xml(name, e) for name, e in limbs.items())
    model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody><body>{geoms}</body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for name, e in limbs.items():
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        assert g >= 0 and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID
        np.testing.assert_array_equal(model.geom_size[g], e.radii[0])
        np.testing.assert_allclose(data.geom_xpos[g], e.centers[0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(data.geom_xmat[g].reshape(3, 3), e.rotations[0], rtol=0, atol=1e-14)


def test_limb_geom_xml_writes_repr_numbers_and_escapes_the_name():
    e = bounding_ellipsoid(moved(MESHES["random hull"], *rigid(15, 1.0)), method="mvee")
    text = limb_geom_xml('arm "l" & <r>', e)
    number = r"-?\d[\d.e+-]*"
    assert re.fullmatch(
        rf'<geom name="[^"]*" type="ellipsoid" pos="{number}( {number}){{2}}" '
        rf'quat="{number}( {number}){{3}}" size="{number}( {number}){{2}}" />',
        text,
    )
    geom = ET.fromstring(text)
    assert geom.get("name") == 'arm "l" & <r>'
    pos, quat, size = (np.array(geom.get(key).split(), dtype=float) for key in ("pos", "quat", "size"))
    np.testing.assert_array_equal(pos, e.centers[0])
    np.testing.assert_array_equal(size, e.radii[0])
    back = Ellipsoids.from_quaternions(pos, quat, size)
    np.testing.assert_allclose(back.rotations[0], e.rotations[0], rtol=0, atol=1e-14)


# --- Bad input -------------------------------------------------------------------------------


def _mesh(vertices):
    return trimesh.Trimesh(np.asarray(vertices, dtype=float), process=False)


_SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float) @ rigid(16)[0].T
_NAN = np.eye(4, 3)
_NAN[2, 1] = np.nan
_INF = np.eye(4, 3)
_INF[0, 0] = np.inf


@pytest.mark.parametrize(
    "mesh, match",
    [
        (_mesh(_SQUARE), r"^mesh is flat: its 4 vertices lie in a plane .*no bounding ellipsoid of positive volume"),
        (_mesh(np.outer(np.arange(5.0), [1, 2, 3])), r"^mesh is flat: its 5 vertices lie on a line"),
        (trimesh.creation.box(extents=(1, 1, 1e-12)), r"^mesh is flat: its 8 vertices lie in a plane"),
        (_mesh(np.eye(3)), r"^mesh must have at least 4 vertices not all in one plane, got 3$"),
        (_mesh(np.ones((4, 3))), r"^mesh has all 4 vertices at one point \[1.0, 1.0, 1.0\]"),
        (_mesh(_NAN), r"^mesh\.vertices\[2, 1\] must be finite, got nan$"),
        (_mesh(_INF), r"^mesh\.vertices\[0, 0\] must be finite, got inf$"),
        (np.zeros((4, 3)), r"^mesh must be a trimesh\.Trimesh or a path to a mesh file, got ndarray$"),
        ("part.3ds", r"^mesh file 'part\.3ds' has an unsupported format '\.3ds'; supported: \.obj, \.stl"),
        ("part", r"^mesh file 'part' has an unsupported format '\(no extension\)'"),
        ("/nonexistent/missing.stl", r"^mesh file '/nonexistent/missing\.stl' does not exist"),
    ],
    ids=["flat", "line", "thin box", "3 vertices", "one point", "nan", "inf", "array", "3ds", "no ext", "missing"],
)
@pytest.mark.parametrize("method", fit.METHODS)
def test_bad_meshes_raise_value_errors_naming_them(mesh, match, method):
    with pytest.raises(ValueError, match=match):
        bounding_ellipsoid(mesh, method=method)


def test_a_thin_but_solid_mesh_is_fitted():
    """Width 1e-6 of the extent is above FLAT_RTOL = 1e-9: a thin ellipsoid, not an error."""
    mesh = trimesh.creation.box(extents=(1, 1, 1e-6))
    for method in fit.METHODS:
        e = bounding_ellipsoid(mesh, method=method)
        assert levels(mesh.vertices, e).max() <= 1 + ENCLOSE_TOL
        assert e.radii[0].min() < 1e-5


def test_bad_mesh_files_raise_value_errors_naming_them(tmp_path):
    garbage = tmp_path / "garbage.stl"
    garbage.write_bytes(b"not an stl at all " * 8)
    with pytest.raises(ValueError, match=r"^mesh file '.*garbage\.stl' must have at least 4 vertices.*got 0$"):
        bounding_ellipsoid(garbage)
    flat = tmp_path / "flat.obj"
    trimesh.Trimesh(_SQUARE, [[0, 1, 2], [0, 2, 3]], process=False).export(flat)
    with pytest.raises(ValueError, match=r"^mesh file '.*flat\.obj' is flat: its 4 vertices lie in a plane"):
        bounding_ellipsoid(flat, method="mvee")


def test_bad_method_raises_value_error_naming_it():
    with pytest.raises(ValueError, match=r"^method must be one of \('thesis', 'mvee'\), got 'pca'$"):
        bounding_ellipsoid(MESHES["box"], method="pca")
    with pytest.raises(ValueError, match=r"^method must be one of \('thesis', 'mvee'\), got None$"):
        limbs_from_meshes({"box": MESHES["box"]}, method=None)


def test_bad_parts_and_geoms_raise_value_errors_naming_them():
    with pytest.raises(ValueError, match=r"^parts must be a mapping of limb names to meshes or mesh files, got list$"):
        limbs_from_meshes([MESHES["box"]])
    with pytest.raises(ValueError, match=r"^parts keys must be non-empty strings \(limb names\), got 3$"):
        limbs_from_meshes({3: MESHES["box"]})
    with pytest.raises(ValueError, match=r"^parts\['head'\]: mesh is flat: its 4 vertices lie in a plane"):
        limbs_from_meshes({"torso": MESHES["box"], "head": _mesh(_SQUARE)})
    e = bounding_ellipsoid(MESHES["box"])
    with pytest.raises(ValueError, match=r"^ellipsoid must be an ellipsim\.Ellipsoids of length 1, got a batch of 2$"):
        limb_geom_xml("box", Ellipsoids.concatenate([e, e]))
    with pytest.raises(ValueError, match=r"^ellipsoid must be an ellipsim\.Ellipsoids of length 1, got ndarray$"):
        limb_geom_xml("box", np.ones(3))
    with pytest.raises(ValueError, match=r"^name must be a non-empty string, got ''$"):
        limb_geom_xml("", e)
