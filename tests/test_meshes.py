"""Ellipsoid x convex mesh and ellipsoid x height field in MuJoCo C (issue 48): the narrow phase's rows against
MuJoCo's own functions run tight on a terrain scene (free ellipsoids over a height field among convex mesh
props), the validation's verdicts on them, and the public forms (shape_distance's "mesh",
core.pairs.height_field.hfield_contacts) against an independent path: each prism built here with numpy and
solved as a mesh."""

import ctypes

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot

import ellipsim
import ellipsim.mujoco as em
from ellipsim.core.pairs.height_field import MAX_CONTACTS, HeightField, hfield_contacts
from ellipsim.core.pairs.hull import Hull, convex_hull
from ellipsim.mujoco import publish
from ellipsim.mujoco.context import ELLIPSOID, HFIELD, MESH
from ellipsim.mujoco.hull import mesh_hull, model_height_field
from ellipsim.mujoco.judge import KEYS
from ellipsim.native import ext

NARROW_T = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
)
PRECONTACT = 10  # doubles per mjPreContact: dist, pos (3), normal (3), tangent (3)


def terrain_xml(seed=0, n=12, nrow=30, ncol=30, meshes=4):
    """Free ellipsoids dropped over a nrow x ncol height field (2 m square, 10 cm of relief, 5 cm base) among
    `meshes` free convex meshes of 8 to 120 random points."""
    rng = np.random.default_rng(seed)
    assets, bodies = [], []
    for k in range(meshes):
        points = rng.normal(size=(int(rng.choice([8, 20, 40, 120])), 3)) * rng.uniform(0.05, 0.15, 3)
        assets.append(f'<mesh name="m{k}" vertex="{" ".join(f"{x:.6f}" for x in points.ravel())}"/>')
        x, y = rng.uniform(-0.6, 0.6, 2)
        bodies.append(f'<body pos="{x} {y} 0.35"><freejoint/><geom type="mesh" mesh="m{k}"/></body>')
    for _ in range(n):
        x, y = rng.uniform(-0.7, 0.7, 2)
        r = rng.uniform(0.03, 0.1, 3)
        z = rng.uniform(0.2, 0.6)
        bodies.append(
            f'<body pos="{x} {y} {z}"><freejoint/><geom type="ellipsoid" size="{r[0]} {r[1]} {r[2]}"/></body>'
        )
    elevation = " ".join(f"{v:.4f}" for v in rng.uniform(0, 1, nrow * ncol))
    return (
        f'<mujoco><option timestep="0.002"/><asset><hfield name="terrain" nrow="{nrow}" ncol="{ncol}" '
        f'size="1 1 0.1 0.05" elevation="{elevation}"/>{"".join(assets)}</asset>'
        f'<worldbody><geom type="hfield" hfield="terrain"/>{"".join(bodies)}</worldbody></mujoco>'
    )


def _functions():
    publish.fill_context()
    table, n = publish.collision_table()
    theirs = {t: NARROW_T(table[t[0] * n + t[1]]) for t in ((ELLIPSOID, MESH), (HFIELD, ELLIPSOID))}
    return NARROW_T(ext.mujoco.NARROWPHASE), theirs


def _call(fn, model, data, g1, g2, margin=0.0):
    con = np.zeros(MAX_CONTACTS * PRECONTACT)
    k = fn(model._address, data._address, con.ctypes.data, g1, g2, margin)
    return k, con[: k * PRECONTACT].reshape(-1, PRECONTACT)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_narrow_phase_makes_mujocos_contacts_run_tight(seed):
    """Along a trajectory of the terrain scene, every ellipsoid x mesh and ellipsoid x height-field pair gets
    the contacts MuJoCo's own function makes run tight (ccd_tolerance 1e-12, 1000 iterations): the same
    number, in the same order (the same prisms), each distance within 1e-9 of the ellipsoid's smallest
    semi-axis, the normals (from geom1 to geom2) within MuJoCo's tight EPA's 1e-4, the points within 1e-4 m."""
    model = mujoco.MjModel.from_xml_string(terrain_xml(seed))
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-12, 1000
    data = mujoco.MjData(model)
    ours, theirs = _functions()
    ell = np.flatnonzero(model.geom_type == ELLIPSOID)
    made = {MESH: 0, HFIELD: 0}
    with em.attach(model, data, mode="narrowphase") as att:
        for step in range(300):
            mujoco.mj_step(model, data)
            if step % 10:
                continue
            for e in ell:
                for g in np.flatnonzero(np.isin(model.geom_type, (MESH, HFIELD))):
                    t = int(model.geom_type[g])
                    g1, g2, key = (e, g, (ELLIPSOID, MESH)) if t == MESH else (g, e, (HFIELD, ELLIPSOID))
                    k, got = _call(ours, model, data, g1, g2)
                    kw, want = _call(theirs[key], model, data, g1, g2)
                    assert k == kw, (step, g1, g2)
                    made[t] += k
                    rmin = model.geom_size[e].min()
                    assert np.all(np.abs(got[:, 0] - want[:, 0]) <= 1e-9 * rmin), (step, g1, g2)
                    assert np.all(np.abs(got[:, 4:7] - want[:, 4:7]) <= 1e-4), (step, g1, g2)
                    assert np.all(np.abs(got[:, 1:4] - want[:, 1:4]) <= 1e-4), (step, g1, g2)
    assert made[HFIELD] > 100 and made[MESH] > 5, made
    assert att.counters["fallbacks"] == 0 and att.counters["contacts"] > 0


def test_attached_runs_are_reproducible_and_make_contacts():
    """Stepped attached twice from fresh datas: bit-identical trajectories, the same counters, and contacts on
    the terrain and the props."""

    def run():
        model = mujoco.MjModel.from_xml_string(terrain_xml(2))
        data = mujoco.MjData(model)
        with em.attach(model, data, mode="narrowphase") as att:
            out = []
            for _ in range(200):
                mujoco.mj_step(model, data)
                out.append(data.qpos.copy())
            types = model.geom_type[data.contact.geom[: data.ncon]]
        return np.array(out), att.counters, types

    a, ca, types = run()
    b, cb, _ = run()
    np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64))
    assert ca == cb and ca["contacts"] > 0
    assert (types == HFIELD).any(axis=1).sum() > 5


def test_validate_run_tight_agrees_on_every_mesh_and_height_field_pair():
    """validate over the terrain scene with MuJoCo run tight: the exact verdicts and MuJoCo's contacts agree on
    every ellipsoid x mesh and ellipsoid x height-field pair (no contact missing or extra on either side), and
    both types have contacts."""
    model = mujoco.MjModel.from_xml_string(terrain_xml(1))
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-12, 1000
    v = em.validate(model, mujoco.MjData(model), 300)
    k_mesh, k_field = KEYS.index("ellipsoid-mesh"), KEYS.index("ellipsoid-hfield")
    by = v.by_type.sum(axis=0)
    assert by[k_mesh, 0] > 10 and by[k_field, 0] > 1000, by
    assert by[k_mesh, 2:].sum() == 0 and by[k_field, 2:].sum() == 0, by
    assert not [d for d in v.disagreements if d.pair_type in ("ellipsoid-mesh", "ellipsoid-hfield")]


# --- the public forms ------------------------------------------------------------------------------------------


def _prism_hull(field, r, c, i):
    """The prism of triangle i of cell (r, c) of the field (mjc_ConvexHField's window), built here."""
    e, (sx, sy, sz, base) = field.elevation, field.size
    nrow, ncol = e.shape
    dx, dy = 2 * sx / (ncol - 1), 2 * sy / (nrow - 1)

    def point(rr, cc):
        return np.array([dx * cc - sx, dy * rr - sy, float(e[rr, cc]) * sz])

    tri = [point(r + 1, c - 1), point(r, c - 1), point(r + 1, c)] if i == 0 else [
        point(r, c - 1), point(r + 1, c), point(r, c)
    ]  # fmt: skip
    return convex_hull([[p[0], p[1], -base] for p in tri] + tri)


def test_hfield_contacts_are_the_prisms_solved_as_meshes():
    """hfield_contacts on random fields and ellipsoids (posed fields, margins 0 and 5 mm) against every prism
    of the field solved as a mesh (its hull from scipy) in MuJoCo's order: the same contacts, the distance
    within 1e-12 of the ellipsoid's smallest semi-axis, normal (flipped) and point to 1e-9."""
    rng = np.random.default_rng(5)
    total = 0
    for trial in range(6):
        nrow, ncol = rng.integers(3, 7, 2)
        field = HeightField(rng.uniform(0, 1, (nrow, ncol)).astype(np.float32), np.array([0.3, 0.25, 0.1, 0.05]))
        cF, RF = rng.normal(size=3) * 0.1, Rot.random(random_state=rng).as_matrix()
        r = rng.uniform(0.03, 0.12, 3)
        local = np.array([*rng.uniform(-0.25, 0.25, 2), rng.uniform(0.0, 0.15)])
        E = ellipsim.Ellipsoids(cF + RF @ local, RF @ Rot.random(random_state=rng).as_matrix(), r)
        margin = [0.0, 0.005][trial % 2]
        got = hfield_contacts(E, cF, RF, field, margin)
        want = []
        for row in range(nrow - 1):
            for col in range(1, ncol):
                for i in range(2):
                    d, n, p, s = ellipsim.shape_distance(E, "mesh", cF, RF, _prism_hull(field, row, col, i))
                    assert s[0] == 0
                    if d[0] < margin:
                        want.append((d[0], -n[0], p[0]))
        assert got.count[0] == len(want), trial
        total += len(want)
        for k, (d, n, p) in enumerate(want):
            assert abs(got.dist[0, k] - d) <= 1e-12 * r.min(), (trial, k)
            np.testing.assert_allclose(got.normal[0, k], n, atol=1e-9)
            np.testing.assert_allclose(got.pos[0, k], p, atol=1e-9)
    assert total > 10


def test_hfield_contacts_stop_at_maxcon_and_the_model_field_is_mujocos():
    """A flat ellipsoid sunk into a fine field touches many prisms: maxcon caps them in order (the first ones
    of the uncapped list); a model's height field is read as MuJoCo stores it."""
    model = mujoco.MjModel.from_xml_string(terrain_xml(0, nrow=40, ncol=40))
    field = model_height_field(model, 0)
    assert field.elevation.shape == (40, 40) and field.elevation.dtype == np.float32
    np.testing.assert_array_equal(field.size, model.hfield_size[0])
    E = ellipsim.Ellipsoids(np.array([0.0, 0.0, 0.05]), np.eye(3), np.array([0.3, 0.3, 0.05]))
    every = hfield_contacts(E, np.zeros(3), np.eye(3), field, maxcon=10_000)
    capped = hfield_contacts(E, np.zeros(3), np.eye(3), field)
    assert every.count[0] > MAX_CONTACTS and capped.count[0] == MAX_CONTACTS
    np.testing.assert_array_equal(capped.dist[0], every.dist[0, :MAX_CONTACTS])


def test_narrow_phase_counts_the_height_field_calls_that_hit_the_cap():
    """An attached data's height-field call that makes mjMAXCONPAIR contacts is counted as capped (nothing the
    cap drops goes unsaid); a call under the cap is not."""
    xml = terrain_xml(0, n=0, nrow=40, ncol=40, meshes=0).replace(
        "</worldbody>",
        '<body pos="0 0 {z}"><freejoint/><geom type="ellipsoid" size="0.3 0.3 0.05"/></body></worldbody>',
    )
    for z, capped in ((0.05, 1), (0.14, 0)):  # sunk flat into the field (254 prisms); resting on its tops (6)
        model = mujoco.MjModel.from_xml_string(xml.format(z=z))
        data = mujoco.MjData(model)
        with em.attach(model, data, mode="narrowphase") as att:
            mujoco.mj_forward(model, data)
            counters = att.counters
        field = model_height_field(model, 0)
        E = ellipsim.Ellipsoids(data.geom_xpos[1], data.geom_xmat[1].reshape(3, 3), model.geom_size[1])
        every = hfield_contacts(E, data.geom_xpos[0], data.geom_xmat[0].reshape(3, 3), field, maxcon=10_000)
        assert (every.count[0] > MAX_CONTACTS) == bool(capped) and counters["capped"] == capped
        assert every.count[0] > 0
        assert data.ncon == min(int(every.count[0]), MAX_CONTACTS) and counters["fallbacks"] == 0


def test_shape_distance_mesh_is_the_kernel_and_takes_points_or_a_hull():
    """shape_distance(..., "mesh", ...) gives the kernel's bits (_ellipsim.testing.polytope_ellipsoid) for a Hull
    or for its points, broadcasting one pose or one ellipsoid; a MuJoCo mesh's hull is the points' hull."""
    rng = np.random.default_rng(7)
    points = rng.normal(size=(30, 3)) * 0.1
    hull = convex_hull(points)
    n = 50
    E = ellipsim.Ellipsoids(rng.normal(size=(n, 3)) * 0.15, Rot.random(n, random_state=rng).as_matrix(),
                            rng.uniform(0.03, 0.1, (n, 3)))  # fmt: skip
    cP, RP = rng.normal(size=(n, 3)) * 0.05, Rot.random(n, random_state=rng).as_matrix()
    d, nrm, p, s = ellipsim.shape_distance(E, "mesh", cP, RP, hull)
    out = np.empty((n, 9))
    ext.testing.polytope_ellipsoid(E.centers, E.rotations, E.radii, cP, RP, *hull, out, 0, n)
    np.testing.assert_array_equal(d, out[:, 1])
    np.testing.assert_array_equal(nrm, out[:, 2:5])
    assert (s == 0).all() and (d < 0).sum() > 5
    d2, *_ = ellipsim.shape_distance(E, "mesh", cP, RP, points)
    np.testing.assert_array_equal(d2, d)
    d3, *_ = ellipsim.shape_distance(E[:1], "mesh", cP[0], RP[0], hull)
    np.testing.assert_array_equal(d3, d[:1])
    xml = f'<mujoco><asset><mesh name="m" vertex="{" ".join(map(str, points.ravel()))}"/></asset>' \
          '<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>'  # fmt: skip
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mh = mesh_hull(model, 0)
    assert len(mh.vertices) == len(hull.vertices)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda E: ellipsim.shape_distance(E, "mesh", np.zeros(3), np.eye(3), np.zeros((3, 3))), "m >= 4"),
        (lambda E: ellipsim.shape_distance(E, "mesh", np.zeros(3), np.eye(3), np.eye(3).tolist() * 2), "span a volume"),
        (lambda E: ellipsim.shape_distance(E, "mesh", np.zeros(3), np.eye(3), CUBE._replace(edges=CUBE.edges + 8)), "hull.edges"),
        (lambda E: ellipsim.shape_distance(E, "mesh", np.zeros(3), 2 * np.eye(3), CUBE), "rotations"),
        (lambda E: ellipsim.shape_distance(E, "mesh", np.zeros(3), np.eye(3), CUBE, derivatives=1), "derivatives"),
        (lambda E: hfield_contacts(E, np.zeros(3), np.eye(3), "field"), "HeightField"),
        (lambda E: hfield_contacts(E, np.zeros(3), np.eye(3), FIELD._replace(elevation=FIELD.elevation + 2)), "[0, 1]"),
        (lambda E: hfield_contacts(E, np.zeros(3), np.eye(3), FIELD._replace(size=np.array([1, 1, 0.1, -1]))), "field.size"),
        (lambda E: hfield_contacts(E, np.zeros(3), np.eye(3), FIELD, maxcon=0), "maxcon"),
        (lambda E: hfield_contacts(E, np.zeros(3), np.eye(3), FIELD, margin=np.inf), "margin"),
    ],
)  # fmt: skip
def test_mistakes_are_clear_errors(call, message):
    E = ellipsim.Ellipsoids(np.zeros(3), np.eye(3), np.array([0.1, 0.2, 0.3]))
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        call(E)


CUBE = convex_hull(np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * 0.1)
FIELD = HeightField(np.zeros((3, 3), np.float32), np.array([1.0, 1.0, 0.1, 0.05]))
assert isinstance(CUBE, Hull)


def test_two_models_with_different_meshes_attached_at_once_keep_their_own_hulls():
    """Two terrain scenes of different meshes and fields, attached together and stepped in turn: each data's
    trajectory is its solo run's, bit for bit (the hull table is per data, read through its registry row)."""

    def solo(xml, steps):
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        with em.attach(model, data, mode="narrowphase"):
            for _ in range(steps):
                mujoco.mj_step(model, data)
        return data.qpos.copy()

    xmls = [terrain_xml(3, n=6, meshes=3), terrain_xml(4, n=6, meshes=2, nrow=20, ncol=25)]
    want = [solo(x, 150) for x in xmls]
    models = [mujoco.MjModel.from_xml_string(x) for x in xmls]
    datas = [mujoco.MjData(m) for m in models]
    with em.attach(models[0], datas[0], mode="narrowphase"), em.attach(models[1], datas[1], mode="narrowphase"):
        for _ in range(150):
            for m, d in zip(models, datas):
                mujoco.mj_step(m, d)
    for d, w in zip(datas, want):
        np.testing.assert_array_equal(d.qpos.view(np.int64), w.view(np.int64))


def test_a_mesh_contact_within_the_margin_is_mujocos_rule_and_a_fields_is_its_distance():
    """With a 1 cm margin: an ellipsoid 5 mm from a mesh gets a contact whose dist is the signed distance (MuJoCo's
    mjc_Convex run tight gives the same), and one 5 mm above a field's prism a contact per prism within the
    margin, dist the prism's signed distance (MuJoCo's own field function raises its prisms by the margin
    instead: module docstring of pairs/height_field.hpp)."""
    points = np.random.default_rng(8).normal(size=(20, 3)) * 0.1
    xml = (
        f'<mujoco><asset><mesh name="m" vertex="{" ".join(f"{x:.6f}" for x in points.ravel())}"/></asset>'
        '<worldbody><geom name="mesh" type="mesh" mesh="m" margin="0.005"/>'
        '<body name="e" pos="0 0 0.5"><freejoint/><geom name="e" type="ellipsoid" size=".1 .06 .05" margin="0.005"/>'
        "</body></worldbody></mujoco>"
    )
    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-12, 1000
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    e, m = 1, 0
    E = ellipsim.Ellipsoids(data.geom_xpos[e], data.geom_xmat[e].reshape(3, 3), model.geom_size[e])
    d, n, _, _ = ellipsim.shape_distance(
        E, "mesh", data.geom_xpos[m], data.geom_xmat[m].reshape(3, 3), mesh_hull(model, 0)
    )
    data.qpos[:3] += (d[0] - 0.005) * n[0]  # 5 mm apart (n from the ellipsoid), within the 1 cm margin
    mujoco.mj_forward(model, data)
    ours, theirs = _functions()
    k, got = _call(ours, model, data, m, e, 0.01)  # (not attached: MuJoCo's own)
    kt, want = _call(theirs[(ELLIPSOID, MESH)], model, data, e, m, 0.01)
    with em.attach(model, data, mode="narrowphase"):
        k, got = _call(ours, model, data, e, m, 0.01)
    assert k == kt == 1 and abs(got[0, 0] - 0.005) < 1e-12 and abs(want[0, 0] - 0.005) < 1e-9
    field = HeightField(np.full((3, 3), 0.5, np.float32), np.array([1.0, 1.0, 0.2, 0.1]))
    E = ellipsim.Ellipsoids([0.3, 0.2, 0.1 + 0.05 + 0.005], np.eye(3), [0.2, 0.15, 0.05])
    c = hfield_contacts(E, np.zeros(3), np.eye(3), field, margin=0.01)
    dist = c.dist[0, : c.count[0]]  # the prism under the lowest point, and its cell's other one within 1 cm
    assert c.count[0] == 2 and abs(dist.min() - 0.005) < 1e-12 and (dist < 0.01).all()
    assert hfield_contacts(E, np.zeros(3), np.eye(3), field, margin=0.004).count[0] == 0


def test_the_prisms_adjacency_is_the_builders():
    """pairs/height_field.hpp's constant adjacency of a prism is polytope.hpp's build_adjacency of its edges and
    triangles (the kernel's descent and fans rest on it being exactly theirs)."""
    import re
    from pathlib import Path

    text = (Path(ellipsim.__file__).parent / "native/include/ellipsim/pairs/height_field.hpp").read_text()

    def constant(name):
        body = re.search(rf"constexpr int {name}\[[^\]]*\] = \{{([^}}]*)\}};", text).group(1)
        return np.array([int(x) for x in body.split(",")], np.int32)

    edges, faces = constant("EDGES").reshape(-1, 2), constant("FACES").reshape(-1, 3)
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
    out = [np.empty(k, np.int32) for k in (7, 2 * len(edges), 7, 3 * len(faces))]
    ext.hull_adjacency(points, edges, np.zeros((len(faces), 3)), faces, *out)
    for name, got in zip(("ADJ_START", "ADJ", "VFACE_START", "VFACE"), out):
        np.testing.assert_array_equal(constant(name), got, err_msg=name)


# --- derivatives -----------------------------------------------------------------------------------------------

SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def test_mesh_derivatives_of_a_box_given_as_a_hull_are_the_box_kernels():
    """200 boxes given as their hulls (triangulated faces: diagonals as extra edges): the same DerivativeStatus and
    ContactFeature (FACE, EDGE, VERTEX) as shape_distance(..., "box", derivatives=True), and the same derivatives
    with respect to the ellipsoid and the box's pose (columns 0-14) to 1e-12; the mesh's size columns zero."""
    rng = np.random.default_rng(4)
    n = 200
    rE, sK = rng.uniform(0.05, 0.3, (n, 3)), rng.uniform(0.05, 0.3, (n, 3))
    RE, RK = Rot.random(n, random_state=rng).as_matrix(), Rot.random(n, random_state=rng).as_matrix()
    cE = rng.uniform(-0.1, 0.1, (n, 3))
    cK = cE + rng.normal(size=(n, 3)) * 0.25
    E = ellipsim.Ellipsoids(cE, RE, rE)
    *_, box = ellipsim.shape_distance(E, "box", cK, RK, sK, derivatives=True)
    features = set()
    for i in range(n):
        *_, mesh = ellipsim.shape_distance(
            E[i : i + 1], "mesh", cK[i], RK[i], convex_hull(SIGNS * sK[i]), derivatives=True
        )
        assert (mesh.status[0], mesh.feature[0]) == (box.status[i], box.feature[i]), i
        features.add(int(mesh.feature[0]))
        np.testing.assert_allclose(mesh.dist[0, :15], box.dist[i, :15], atol=1e-12)
        np.testing.assert_allclose(mesh.normal[0, :, :15], box.normal[i, :, :15], atol=1e-12)
        np.testing.assert_allclose(mesh.pos[0, :, :15], box.pos[i, :, :15], atol=1e-12)
        assert not mesh.dist[0, 15:].any() and not mesh.pos[0, :, 15:].any()
    assert features == {ellipsim.ContactFeature.FACE, ellipsim.ContactFeature.EDGE, ellipsim.ContactFeature.VERTEX}


def test_mesh_derivatives_are_the_finite_differences_and_one_sided_at_a_faces_edge():
    """Random hulls of 30 points, 100 poses apart and deep: d dist, d normal, d pos with respect to the ellipsoid's
    centre, rotation and semi-axes and the hull's centre and rotation within 1e-6 of central differences
    (h = 1e-6); a sphere over a cube's top edge, its witness on the edge: ONE_SIDED, as the box kernel says."""
    rng = np.random.default_rng(3)
    hull = convex_hull(rng.normal(size=(30, 3)) * 0.1)
    n = 100
    E = ellipsim.Ellipsoids(rng.normal(size=(n, 3)) * 0.15, Rot.random(n, random_state=rng).as_matrix(),
                            rng.uniform(0.03, 0.1, (n, 3)))  # fmt: skip
    cP, RP = rng.normal(size=(n, 3)) * 0.05, Rot.random(n, random_state=rng).as_matrix()
    d, _, _, _, der = ellipsim.shape_distance(E, "mesh", cP, RP, hull, derivatives=True)
    assert (der.status <= 1).all() and (d < 0).sum() > 20 and (d > 0).sum() > 20
    h = 1e-6
    for col in range(15):
        block, axis = divmod(col, 3)
        e = np.eye(3)[axis]
        sides = []
        for sign in (1, -1):
            c, R, r, c2, R2 = E.centers.copy(), E.rotations.copy(), E.radii.copy(), cP.copy(), RP.copy()
            turn = Rot.from_rotvec(sign * h * e).as_matrix()
            if block == 0:
                c[:, axis] += sign * h
            elif block == 1:
                R = turn @ R
            elif block == 2:
                r[:, axis] += sign * h
            elif block == 3:
                c2[:, axis] += sign * h
            else:
                R2 = turn @ R2
            sides.append(ellipsim.shape_distance(ellipsim.Ellipsoids(c, R, r), "mesh", c2, R2, hull)[:3])
        (dp, np_, pp), (dm, nm, pm) = sides
        np.testing.assert_allclose(der.dist[:, col], (dp - dm) / (2 * h), atol=1e-6, err_msg=str(col))
        np.testing.assert_allclose(der.normal[:, :, col], (np_ - nm) / (2 * h), atol=1e-6, err_msg=str(col))
        np.testing.assert_allclose(der.pos[:, :, col], (pp - pm) / (2 * h), atol=1e-6, err_msg=str(col))
    ball = ellipsim.Ellipsoids([0.1, 0.03, 0.2], np.eye(3), [0.05, 0.05, 0.05])
    *_, box = ellipsim.shape_distance(ball, "box", np.zeros(3), np.eye(3), [0.1, 0.1, 0.1], derivatives=True)
    *_, mesh = ellipsim.shape_distance(ball, "mesh", np.zeros(3), np.eye(3), convex_hull(SIGNS * 0.1), derivatives=True)
    assert box.status[0] == mesh.status[0] == ellipsim.DerivativeStatus.ONE_SIDED
    assert box.feature[0] == mesh.feature[0]
