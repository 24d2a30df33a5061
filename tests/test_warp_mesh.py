"""ellipsim.warp's ellipsoid x convex mesh row on Warp's CPU device: the core's pairs/polytope.hpp
polytope_ellipsoid (the function MuJoCo C's narrow phase runs for a mesh) against the CPU API's
shape_distance(E, "mesh", ...) on the same float32 poses widened, bit for bit; an attached terrain run writes those
contacts and drops none; a hull over the row's scratch stays with Warp."""

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp
from native_checks import assert_same_bits
from scipy.spatial.transform import Rotation as Rot
from test_meshes import terrain_xml

import ellipsim
import ellipsim.warp as ew
from ellipsim.core.pairs.hull import convex_hull
from ellipsim.pair_table import ELLIPSOID, MESH
from ellipsim.warp import attachment, kernels

SLOW = pytest.mark.slow


@pytest.fixture(autouse=True)
def cpu():
    with wp.ScopedDevice("cpu"):
        yield


def _wide(x):
    return np.asarray(x, np.float32).astype(np.float64)


def _poses(seed, n):
    """n ellipsoids (3-10 cm semi-axes) around a mesh posed off the origin, from deep inside it to 10 cm off its
    surface, and the mesh's pose, all float32."""
    rng = np.random.default_rng(seed)
    cm = np.array([0.3, -0.2, 0.1])
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    ce = cm + direction * rng.uniform(0.0, 0.3, (n, 1))
    return [
        np.asarray(x, np.float32)
        for x in (ce, Rot.random(n, random_state=rng).as_matrix(), rng.uniform(0.03, 0.1, (n, 3)),
                  np.tile(cm, (n, 1)), np.tile(Rot.random(random_state=rng).as_matrix(), (n, 1, 1)))
    ]  # fmt: skip


@pytest.mark.parametrize("npoints", [8, 40, 300, 1200])
@pytest.mark.parametrize("cutoff", [np.inf, 0.0, 0.005])
def test_the_mesh_row_is_the_cpus_shape_distance_bit_for_bit(npoints, cutoff):
    """Hulls of 8, 40 and 300 random points (the last about 60 vertices: stored in the row's scratch) and of 200
    points on an ellipsoid (200 vertices: the posed path): every pair the row does not prove beyond the cutoff has
    shape_distance's distance, normal and point on the float32 poses widened, bit for bit; a pair it proves
    beyond has a distance at least the cutoff on the CPU."""
    rng = np.random.default_rng(npoints)
    points = rng.normal(size=(npoints, 3)) * [0.1, 0.07, 0.05]
    if npoints == 300:  # points near a sphere: most are the hull's vertices
        points = points / np.linalg.norm(points, axis=1)[:, None] * 0.08
        points = points[:60]
    if npoints == 1200:
        points = points[:200] / np.linalg.norm(points[:200], axis=1)[:, None] * [0.1, 0.08, 0.06]
    hull = convex_hull(points)
    assert (len(hull.vertices) <= kernels.MAX_HULL_VERTICES) == (npoints != 1200), len(hull.vertices)
    ce, Re, re, cm, Rm = _poses(npoints, 400)
    dist, normal, pos, status, deep = kernels.mesh_distances(ce, Re, re, cm, Rm, hull, cutoff=cutoff)
    E = ellipsim.Ellipsoids(_wide(ce), _wide(Re), _wide(re))
    dc, nc, pc, _ = ellipsim.shape_distance(E, "mesh", _wide(cm), _wide(Rm), hull)
    solved = status == kernels.GLOBAL
    assert np.all(solved | (status == kernels.APART))
    assert_same_bits(dist[solved], dc[solved], "dist")
    assert_same_bits(normal[solved], nc[solved], "normal")
    assert_same_bits(pos[solved], pc[solved], "pos")
    assert np.all(dc[~solved] >= cutoff) and np.all(dist[~solved] >= cutoff)
    assert (dc < 0).sum() > 50 and (dc > 0.01).sum() > 50  # crossings and pairs well apart
    if cutoff == np.inf:
        assert solved.all()
    else:
        assert (~solved).sum() > 50  # proven apart at the walking start
    assert deep.sum() > 0 or npoints == 8  # enumerated (deep crossings) among them


def test_the_posed_path_is_the_stored_paths_bits():
    """The core's polytope_ellipsoid_posed (no hull stored: what the mesh row runs above MAX_HULL_VERTICES) gives
    polytope_ellipsoid's bits (the CPU's shape_distance) on every pair of hulls of 8 to 120 points, both run on
    the CPU through ext.testing."""
    from ellipsim.native import ext

    rng = np.random.default_rng(5)
    for npoints in (8, 40, 120):
        hull = convex_hull(rng.normal(size=(npoints, 3)) * [0.1, 0.07, 0.05])
        ce, Re, re, cm, Rm = (_wide(x) for x in _poses(npoints, 300))
        args = (ce, Re, re, cm, Rm, *(np.ascontiguousarray(x) for x in hull))
        for cutoff in (np.inf, 0.0):
            stored, posed = (np.empty((len(ce), 9)) for _ in range(2))
            ext.testing.polytope_ellipsoid(*args, stored, 0, len(ce), cutoff=cutoff)
            ext.testing.polytope_ellipsoid(*args, posed, 0, len(ce), cutoff=cutoff, posed=True)
            assert_same_bits(posed, stored, f"{npoints} points, cutoff {cutoff}")
            assert len(np.unique(stored[:, 0])) == (2 if cutoff == np.inf else 3)  # every status among them


def _terrain(nworld=2, naconmax=4000):
    mjm = mujoco.MjModel.from_xml_string(terrain_xml(2, n=8, nrow=10, ncol=10, meshes=3))
    m = mjw.put_model(mjm)
    d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=nworld, naconmax=naconmax)
    return mjm, m, d


@SLOW
def test_an_attached_terrain_run_writes_the_cpus_mesh_contacts_and_drops_none():
    """8 ellipsoids dropped among 3 free meshes on a field, 2 worlds, 100 steps on Warp with ellipsim attached:
    the ellipsoid x mesh pairs are ellipsim's, and at every fifth step each (world, ellipsoid, mesh)'s
    contact is shape_distance's on the same float32 poses (none where its distance is not below 0), rounded to
    float32 as Warp's write_contact stores it (the frame's normal within make_frame's renormalisation); no
    overflow, no failed pair."""
    mjm, m, d = _terrain()
    meshes = np.flatnonzero(mjm.geom_type == MESH)
    ells = np.flatnonzero(mjm.geom_type == ELLIPSOID)
    hulls = attachment.mesh_hulls(m)
    assert all(h is not None for h in hulls)
    candidates = ew.candidate_pairs(m)
    made = 0
    with ew.attach(m) as att:
        np.testing.assert_array_equal(att.pairs, candidates)
        assert {(int(e), int(g)) for e in ells for g in meshes} <= {(int(a), int(b)) for a, b in att.pairs}
        for step in range(100):
            mjw.step(m, d)
            if step % 5 != 4:
                continue
            # the contacts of the step's collision, on its poses (forward again: step moved the poses after it)
            d.nacon.zero_()
            mjw.collision(m, d)
            n = int(d.nacon.numpy()[0])
            c = d.contact
            world, geom, dist = c.worldid.numpy()[:n], c.geom.numpy()[:n], c.dist.numpy()[:n]
            pos, normal = c.pos.numpy()[:n], c.frame.numpy()[:n, 0]
            xpos, xmat = d.geom_xpos.numpy(), d.geom_xmat.numpy()
            size = m.geom_size.numpy()[0]
            for w in range(d.nworld):
                E = ellipsim.Ellipsoids(_wide(xpos[w, ells]), _wide(xmat[w, ells]), _wide(size[ells]))
                for g in meshes:
                    hull = hulls[mjm.geom_dataid[g]]
                    dc, nc, pc, _ = ellipsim.shape_distance(E, "mesh", _wide(xpos[w, g]), _wide(xmat[w, g]), hull)
                    for i, e in enumerate(ells):
                        at = np.flatnonzero((world == w) & (geom[:, 0] == e) & (geom[:, 1] == g))
                        if not np.float32(dc[i]) < 0:
                            assert len(at) == 0, (step, w, e, g, dc[i])
                            continue
                        assert len(at) == 1, (step, w, e, g, dc[i])
                        assert dist[at[0]] == np.float32(dc[i])
                        np.testing.assert_array_equal(pos[at[0]], pc[i].astype(np.float32))
                        np.testing.assert_allclose(normal[at[0]], nc[i], atol=1e-6)
                        made += 1
        counters = att.counters
    assert made > 20, made  # 48 measured
    assert counters["overflow"] == 0 and counters["failed"] == 0, counters


def test_a_hull_over_the_rows_limit_stays_with_warp():
    """A mesh of 3100 points on a sphere (3100 hull vertices, over MAX_POSED_HULL_VERTICES) beside one of 20: the
    large one's ellipsoid pairs stay in Warp's own pair table, the small one's are ellipsim's."""
    rng = np.random.default_rng(3)
    big = rng.normal(size=(3100, 3))
    big = 0.1 * big / np.linalg.norm(big, axis=1)[:, None]
    small = rng.normal(size=(20, 3)) * 0.05
    vert = lambda p: " ".join(f"{x:.6f}" for x in p.ravel())  # noqa: E731
    xml = f"""<mujoco><asset><mesh name="big" vertex="{vert(big)}"/><mesh name="small" vertex="{vert(small)}"/></asset>
      <worldbody><body pos="0 0 0.3"><freejoint/><geom type="mesh" mesh="big"/></body>
      <body pos="0.5 0 0.3"><freejoint/><geom type="mesh" mesh="small"/></body>
      <body pos="0.2 0 0.3"><freejoint/><geom type="ellipsoid" size="0.05 0.04 0.03"/></body></worldbody></mujoco>"""
    mjm = mujoco.MjModel.from_xml_string(xml)
    m = mjw.put_model(mjm)
    hulls = attachment.mesh_hulls(m)
    assert hulls[0] is None and len(hulls[1].vertices) <= kernels.MAX_HULL_VERTICES
    assert mjm.mesh_graph[mjm.mesh_graphadr[0]] > kernels.MAX_POSED_HULL_VERTICES  # MuJoCo's hull: every point
    big_geom, small_geom, ell = 0, 1, 2
    with ew.attach(m) as att:
        taken = {(int(a), int(b)) for a, b in att.pairs}
        assert taken == {(ell, small_geom)}, taken
        kept = {tuple(sorted(map(int, p))) for p in m.nxn_geom_pair_filtered.numpy()}
        assert (big_geom, ell) in kept and (small_geom, ell) not in kept


def test_the_glues_hull_limits_and_table_are_the_headers():
    """kernels.py's MAX_HULL_VERTICES, MAX_HULL_FACES, MAX_POSED_HULL_VERTICES and HULL_COLUMNS are
    narrowphase.hpp's (the scratch's size and the table's layout); a hull over the posed limit is refused by
    hull_arrays, naming the mesh."""
    import re

    header = (kernels.NATIVE / "warp" / "narrowphase.hpp").read_text()
    assert int(re.search(r"MAX_HULL_VERTICES = (\d+);", header).group(1)) == kernels.MAX_HULL_VERTICES
    assert "MAX_HULL_FACES = 2 * MAX_HULL_VERTICES - 4;" in header
    assert kernels.MAX_HULL_FACES == 2 * kernels.MAX_HULL_VERTICES - 4
    assert int(re.search(r"HULL_COLUMNS = (\d+);", header).group(1)) == kernels.HULL_COLUMNS
    posed = int(re.search(r"MAX_POSED_HULL_VERTICES = (\d+);", header).group(1))
    assert posed == kernels.MAX_POSED_HULL_VERTICES
    points = np.random.default_rng(0).normal(size=(3100, 3))
    with pytest.raises(ValueError, match="mesh 1's hull has 3100 vertices"):
        kernels.hull_arrays([None, convex_hull(points / np.linalg.norm(points, axis=1)[:, None])])
