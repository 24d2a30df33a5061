"""ellipsim.warp on Warp's CPU device: the kernel against the CPU narrow phase on the same float32 poses,
attached models against plain MuJoCo Warp (contacts, trajectories, tables), two models, overflow,
sleeping, SAP, and what the hook may not do (allocate, read back)."""

import subprocess
import sys

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp
from mujoco_warp._src import types as mjw_types
from native_checks import assert_same_bits
from scipy.spatial.transform import Rotation as Rot

import ellipsim
import ellipsim.warp as ew
from ellipsim.core.samples import STRESS, generic_pairs, stress_pairs
from ellipsim.native import ext
from ellipsim.warp import kernels

SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = 2, 3, 4, 5, 6

#: Tests that run mjw.collision, mjw.forward or mjw.step: on a machine where Warp has not compiled them
#: yet, 20 s to minutes of compiling (pyproject's slow marker; they stay in the README's test run).
SLOW = pytest.mark.slow


@pytest.fixture(autouse=True)
def cpu():
    with wp.ScopedDevice("cpu"):
        yield


def _cpu(ca, Ra, ra, cb, Rb, rb):
    """ellipsim's CPU narrow phase on float32 poses widened to float64 (the kernel's reading)."""
    w = lambda x: np.asarray(x, np.float32).astype(np.float64)  # noqa: E731
    return ellipsim.signed_distance(ellipsim.Ellipsoids(w(ca), w(Ra), w(ra)), ellipsim.Ellipsoids(w(cb), w(Rb), w(rb)))


def _f32(*xs):
    return [np.asarray(x, np.float32) for x in xs]


def _same_as_cpu(ca, Ra, ra, cb, Rb, rb):
    """Warp's kernel and the CPU API on the same float32 poses widened: the core's same function on the same
    numbers, so the same bits (distance, normal, point, status); returns (dist, status)."""
    ca, Ra, ra, cb, Rb, rb = _f32(ca, Ra, ra, cb, Rb, rb)
    dw, nw, pw, sw = kernels.pair_distances(ca, Ra, ra, cb, Rb, rb)
    dc, nc, pc, sc = _cpu(ca, Ra, ra, cb, Rb, rb)
    assert_same_bits(dw, dc, "dist")
    assert_same_bits(nw, nc, "normal")
    assert_same_bits(pw, pc, "pos")
    np.testing.assert_array_equal(sw, sc)
    return dw, sw


def test_the_kernel_is_the_cpu_narrow_phase_on_the_same_float32_poses():
    a, b = generic_pairs(600, seed=3)
    dw, sw = _same_as_cpu(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    assert (dw > 0).sum() > 100 and (dw < 0).sum() > 100  # both sides of contact
    assert np.all(sw == kernels.GLOBAL)  # deep pairs too: the branch and bound's proof


@pytest.mark.parametrize("category", STRESS)
def test_the_stress_sets_are_the_cpus_bit_for_bit_and_all_proven(category):
    """core/samples.py's numerically hard categories (near-tangent to 1e-15, exactly tangent, spheres,
    coaxial spheroids, identical and contained, aspect to 1e4, offsets to 1e7 m, scales 1e-6 and 1e6)."""
    a, b = stress_pairs(category, 120, seed=7)
    _, sw = _same_as_cpu(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    assert np.all(sw == kernels.GLOBAL)


def _spheroid_set(seed, places, frame, turn=True):
    """test_spheroids' pairs (prolate and oblate; B's axis onto A's, then tilted by 0 to 1e-1 rad), 10 per
    place and tilt, in world poses: frame "axes" keeps A's frame the world's, "turned" turns the pair."""
    from test_spheroids import spheroid_pair

    rng = np.random.default_rng(seed)
    rows = []
    for tilt in (0.0, 1e-9, 1e-6, 1e-3, 1e-1):
        for where in places:
            for _ in range(10):
                P = spheroid_pair(rng, where, tilt=tilt, turn=turn)
                Q = np.eye(3) if frame == "axes" else Rot.random(random_state=rng).as_matrix()
                c = rng.uniform(-1, 1, 3)
                rows.append((c, Q, P.a, c + Q @ P.e, Q @ P.Um, P.b))
    return [np.array(x) for x in zip(*rows)]


@pytest.mark.parametrize("frame", ["axes", "turned"])
def test_deep_and_off_axis_spheroids_parallel_or_nearly_are_proven_on_warp(frame):
    """Parallel and nearly parallel spheroids, deep or anywhere off the axis: the hand port left 67 of 240 such
    pairs unproven; the core's spheroid searches prove every one, as on the CPU, on the float32 poses."""
    dw, sw = _same_as_cpu(*_spheroid_set(21, ["deep", "anywhere"], frame))
    assert len(dw) == 100 and np.all(sw == kernels.GLOBAL)
    assert (dw < 0).sum() > 50


def test_spheroids_on_their_common_axis_are_proven_on_float32_poses_as_on_the_cpu():
    """On the axis, concentric or within 1e-9 of it the maxima form a circle; a float32 rotation, orthonormal only
    to ~6e-8, leaves B a spheroid only to that, the circle a nearly flat ring: the core's ring_max proves them (the
    hand port, and the core before it, left 39 of these 150 unproven), on Warp as on the CPU, the same bits."""
    _, sw = _same_as_cpu(*_spheroid_set(23, ["axis", "concentric", "near axis"], "turned"))
    assert len(sw) == 150 and np.all(sw == kernels.GLOBAL)
    _, sw = _same_as_cpu(*_spheroid_set(24, ["axis", "concentric", "near axis"], "axes"))
    assert np.all(sw == kernels.GLOBAL)


@pytest.mark.parametrize("offset", [0.0, 100.0])
@pytest.mark.parametrize("gap", [-0.5, -1e-6, 0.0, 1e-6, 0.01])
def test_touching_shallow_and_apart_pairs_near_the_origin_and_100_m_away(offset, gap):
    """B moved along the CPU's normal so its distance from A is `gap` times A's smallest semi-axis."""
    rng = np.random.default_rng(int(1e6 * gap) % 1000 + int(offset))
    n = 120
    ra = rng.uniform(0.05, 0.5, (n, 3)) * rng.choice([1.0, 10.0], (n, 1)) ** np.array([1, 0, 0])
    rb = rng.uniform(0.05, 0.5, (n, 3))
    Ra, Rb = Rot.random(n, random_state=rng).as_matrix(), Rot.random(n, random_state=rng).as_matrix()
    ca = offset + rng.uniform(-1, 1, (n, 3))
    cb = ca + rng.normal(size=(n, 3)) * 0.2
    d, nrm, _, _ = _cpu(ca, Ra, ra, cb, Rb, rb)
    rmin = np.minimum(ra.min(1), rb.min(1))
    cb = cb + nrm * (gap * rmin - d)[:, None]
    _same_as_cpu(ca, Ra, ra, cb, Rb, rb)


def test_spheres_against_ellipsoids():
    rng = np.random.default_rng(9)
    n = 200
    r = rng.uniform(0.02, 0.3, n)
    ra = np.repeat(r[:, None], 3, 1)
    rb = rng.uniform(0.02, 0.6, (n, 3))
    ca = rng.uniform(-1, 1, (n, 3))
    cb = ca + rng.normal(size=(n, 3)) * 0.3
    _same_as_cpu(ca, np.broadcast_to(np.eye(3), (n, 3, 3)), ra, cb, Rot.random(n, random_state=rng).as_matrix(), rb)


def _cpu_pair(kind, ce, Re, ra, ck, Rk, rk):
    """The C++ core's pairs/capsule.hpp, box.hpp or cylinder.hpp kernel (ext.testing's capsule_ellipsoid,
    box_ellipsoid, cylinder_ellipsoid) on float32 poses widened to float64: (dist, normal, pos, status)."""
    kernel = getattr(ext.testing, f"{kind}_ellipsoid")
    w = lambda x, *shape: np.asarray(x, np.float32).astype(np.float64).reshape(-1, *shape)  # noqa: E731
    out = np.empty((len(ce), 9))  # status, dist, normal, pos, ub per pair
    kernel(w(ce, 3), w(Re, 3, 3), w(ra, 3), w(ck, 3), w(Rk, 3, 3), w(rk, 3), out, 0, len(ce))
    return out[:, 1], out[:, 2:5], out[:, 5:8], out[:, 0].astype(int)


@pytest.mark.parametrize("offset", [0.0, 100.0])
@pytest.mark.parametrize("kind", ["capsule", "box", "cylinder"])
def test_capsules_boxes_and_cylinders_are_the_cpu_kernels_on_the_same_float32_poses(kind, offset):
    """test_capsule's, test_box's and test_cylinder's categories (separated, touching at 0 and +-1e-9,
    shallow, deep, and each type's own: parallel axes, capsule inside, ellipsoid around the segment; a
    flush face, a box inside, a floor box; a flush cap or side, a cylinder inside), near the origin and
    100 m away, on float32 rotations (orthonormal only to ~1e-7: the box read as the parallelepiped of its
    axes, the cylinder's axis normalised): the CPU's proven maximum (certified or enumerated), to the
    rounding of a few operations, every status GLOBAL."""
    make_poses = __import__(f"test_{kind}").make_poses
    distances = getattr(kernels, f"{kind}_distances")
    P, cat, _ = make_poses(seed=5, per=25)
    ce, Re, ra, ck, Rk, rk = _f32(P["cE"] + offset, P["RE"], P["rE"], P["cK"] + offset, P["RK"], P["sK"])
    dw, nw, pw, sw = distances(ce, Re, ra, ck, Rk, rk)
    dc, nc, pc, _ = _cpu_pair(kind, ce, Re, ra, ck, Rk, rk)
    assert np.all(sw == kernels.GLOBAL)
    assert_same_bits(dw, dc, "dist")
    assert_same_bits(nw, nc, "normal")
    assert_same_bits(pw, pc, "pos")
    assert (dw < 0).sum() > 40 and (dw > 0).sum() > 20  # deep, shallow and apart pairs all present


def test_pair_distances_checks_its_shapes():
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        kernels.pair_distances(
            np.zeros((2, 3)), np.zeros((2, 3, 3)), np.ones((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)), np.ones((2, 3))
        )


# -- attached models ------------------------------------------------------------------------------

PILE = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 .1"/>
    {bodies}
  </worldbody>
</mujoco>
"""


def _pile(n=8, seed=0, sleep=False, extra=""):
    """n free bodies, each an ellipsoid (some a sphere, one with a margin), in a heap that overlaps,
    a box, a capsule and a cylinder among them, and a box and a capsule apart that stay with Warp (x box,
    x plane)."""
    rng = np.random.default_rng(seed)
    bodies = []
    for i in range(n):
        x, y, z = rng.uniform(-0.08, 0.08), rng.uniform(-0.08, 0.08), 0.12 + 0.06 * i
        euler = " ".join(f"{v:.3f}" for v in rng.uniform(-90, 90, 3))
        if i % 4 == 3:
            geom = f'<geom type="sphere" size="{rng.uniform(0.04, 0.08):.3f}"/>'
        elif i == 1:
            geom = f'<geom type="box" size="{rng.uniform(0.03, 0.08):.3f} {rng.uniform(0.03, 0.08):.3f} .04"/>'
        elif i == 4:
            geom = f'<geom type="cylinder" size="{rng.uniform(0.03, 0.07):.3f} {rng.uniform(0.02, 0.06):.3f}"/>'
        elif i % 4 == 1:
            geom = f'<geom type="capsule" size="{rng.uniform(0.02, 0.05):.3f} {rng.uniform(0.03, 0.1):.3f}"/>'
        else:
            size = " ".join(f"{v:.3f}" for v in rng.uniform(0.03, 0.14, 3))
            margin = ' margin="0.01"' if i == 2 else ""
            geom = f'<geom type="ellipsoid" size="{size}"{margin}/>'
        bodies.append(f'<body pos="{x:.3f} {y:.3f} {z:.3f}" euler="{euler}"><freejoint/>{geom}</body>')
    bodies.append('<body pos="0.4 0 0.1"><freejoint/><geom type="box" size=".05 .05 .05"/></body>')
    bodies.append('<body pos="0.4 0.02 0.2"><freejoint/><geom type="capsule" size=".03 .05"/></body>')
    xml = PILE.format(bodies="\n    ".join(bodies))
    if sleep:
        xml = xml.replace('<option timestep="0.002"/>', '<option timestep="0.002"><flag sleep="enable"/></option>')
    return mujoco.MjModel.from_xml_string(xml.replace("</worldbody>", extra + "</worldbody>"))


def _warp(mjm, nworld=3, naconmax=512, seed=1):
    """A mujoco_warp model and data of mjm, each world's free bodies nudged differently."""
    mjd = mujoco.MjData(mjm)
    rng = np.random.default_rng(seed)
    m = mjw.put_model(mjm)
    d = mjw.put_data(mjm, mjd, nworld=nworld, naconmax=naconmax)
    qpos = np.tile(mjm.qpos0, (nworld, 1))
    for j in range(mjm.njnt):
        if mjm.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            a = mjm.jnt_qposadr[j]
            qpos[1:, a : a + 3] += rng.normal(scale=0.01, size=(nworld - 1, 3))
    d.qpos.assign(qpos.astype(np.float32))
    return m, d


def _contacts(d):
    """The contacts of d as a sorted list of (world, g1, g2, dist, pos, frame row 0) tuples."""
    n = min(int(d.nacon.numpy()[0]), d.naconmax)
    c = d.contact
    rows = zip(c.worldid.numpy()[:n], c.geom.numpy()[:n], c.dist.numpy()[:n], c.pos.numpy()[:n], c.frame.numpy()[:n])
    return sorted((int(w), int(g[0]), int(g[1]), float(s), tuple(p), tuple(f[0])) for w, g, s, p, f in rows)


def _ellipsim_pairs(mjm, att):
    return {(int(a), int(b)) for a, b in att.pairs}


@SLOW
def test_attach_takes_the_ellipsoid_pairs_and_appends_the_cpu_contacts():
    mjm = _pile()
    m, d = _warp(mjm)
    mjw.forward(m, d)
    plain = _contacts(d)
    att = ew.attach(m)
    assert att.npairs > 0 and "attached" in repr(att)
    assert att._counters.dtype == wp.int64  # totals over thousands of worlds and steps: int32 would wrap
    mjw.forward(m, d)
    got = _contacts(d)
    taken = _ellipsim_pairs(mjm, att)
    # every other contact is plain Warp's, bit for bit
    assert [c for c in got if (c[1], c[2]) not in taken] == [c for c in plain if (c[1], c[2]) not in taken]
    # ellipsim's: exactly the pairs the CPU narrow phase puts within margin + gap, its distance in float32
    xpos, xmat, size = d.geom_xpos.numpy(), d.geom_xmat.numpy(), m.geom_size.numpy()[0]
    radii = lambda g: np.repeat(size[g][:1], 3) if mjm.geom_type[g] == SPHERE else size[g]  # noqa: E731
    expected = []
    for w in range(d.nworld):
        for g1, g2 in att.pairs:
            one = lambda a, g: a[w, g][None]  # noqa: E731
            if mjm.geom_type[g1] == CAPSULE:  # (g1 the capsule: the CPU kernel takes the ellipsoid first)
                dist, *_ = _cpu_pair(
                    "capsule",
                    one(xpos, g2),
                    one(xmat, g2),
                    size[g2][None],
                    one(xpos, g1),
                    one(xmat, g1),
                    size[g1][None],
                )
            elif mjm.geom_type[g2] in (BOX, CYLINDER):
                kind = "box" if mjm.geom_type[g2] == BOX else "cylinder"
                dist, *_ = _cpu_pair(
                    kind, one(xpos, g1), one(xmat, g1), size[g1][None], one(xpos, g2), one(xmat, g2), size[g2][None]
                )
            else:
                dist, nrm, pos, st = _cpu(xpos[w, g1], xmat[w, g1], radii(g1), xpos[w, g2], xmat[w, g2], radii(g2))
            margin = mjm.geom_margin[g1] + mjm.geom_margin[g2] + mjm.geom_gap[g1] + mjm.geom_gap[g2]
            if dist[0] < margin:
                expected.append((w, int(g1), int(g2), float(np.float32(dist[0]))))
    mine = [c[:4] for c in got if (c[1], c[2]) in taken]
    assert len(expected) >= 3 * d.nworld  # the heap overlaps
    assert {int(mjm.geom_type[g]) for g in att.pairs.ravel()} == {SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX}
    kinds = {(int(mjm.geom_type[e[1]]), int(mjm.geom_type[e[2]])) for e in expected}
    assert {(CAPSULE, ELLIPSOID), (ELLIPSOID, BOX), (ELLIPSOID, CYLINDER)} <= kinds  # each type in contact
    assert sorted(mine) == sorted(expected)
    assert att.counters["contacts"] == len(expected) and att.counters["overflow"] == 0
    att.detach()
    mjw.forward(m, d)
    assert _contacts(d) == plain  # detached: plain Warp again


@SLOW
def test_a_model_without_ellipsoid_pairs_steps_bit_identically_and_two_models_are_independent():
    # ellipsoid x plane is Warp's own analytic pair; box and capsule do not collide with the ellipsoid
    mjm = mujoco.MjModel.from_xml_string(
        PILE.format(
            bodies='<body pos="0 0 .2" euler="20 30 0"><freejoint/><geom type="ellipsoid" size=".1 .05 .03"/></body>'
            '<body pos=".3 0 .2"><freejoint/><geom type="box" size=".05 .05 .05" contype="2" conaffinity="2"/></body>'
            '<body pos=".3 0 .4"><freejoint/><geom type="capsule" size=".03 .05" contype="2" conaffinity="2"/></body>'
        ).replace('type="plane"', 'type="plane" contype="3" conaffinity="3"')
    )
    runs = []
    for attached in (False, True):
        m, d = _warp(mjm, nworld=2)
        att = ew.attach(m) if attached else None
        for _ in range(30):
            mjw.step(m, d)
        runs.append(d.qpos.numpy().copy())
        if att:
            assert att.npairs == 0
    np.testing.assert_array_equal(runs[0], runs[1])
    # two models in one process: attaching one leaves the other plain
    heap = _pile(n=6)
    m1, d1 = _warp(heap)
    m2, d2 = _warp(heap)
    m3, d3 = _warp(heap)
    with ew.attach(m1) as att1:
        att2 = ew.attach(m2)
        for _ in range(5):
            for m, d in ((m1, d1), (m2, d2), (m3, d3)):
                mjw.step(m, d)
        assert att1.counters["pairs"] > 0 and att2.counters["pairs"] > 0
        assert att1.counters == att2.counters  # same model, same motion
        np.testing.assert_array_equal(d1.qpos.numpy(), d2.qpos.numpy())
    assert not att1.attached and att2.attached
    m4, d4 = _warp(heap)
    for _ in range(5):
        mjw.step(m4, d4)
    np.testing.assert_array_equal(d3.qpos.numpy(), d4.qpos.numpy())  # m3 ran plain Warp


@SLOW
def test_detach_restores_the_tables_and_the_previous_hook_and_errors_are_clear():
    mjm = _pile(n=4)
    m, _ = _warp(mjm)
    calls = []
    m.callback.contactfilter = lambda m_, d_: calls.append(1)
    before = {k: getattr(m, k) for k in ("nxn_geom_pair_filtered", "nxn_pairid_filtered", "nxn_pairid")}
    count = m.geom_pair_type_count
    att = ew.attach(m)
    assert m.nxn_geom_pair_filtered.shape[0] == before["nxn_geom_pair_filtered"].shape[0] - att.npairs
    with pytest.raises(ValueError, match="already attached"):
        ew.attach(m)
    d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=1, naconmax=64)
    mjw.collision(m, d)
    assert calls == [1]  # the user's hook still runs, after ellipsim's contacts
    att.detach()
    att.detach()
    assert all(getattr(m, k) is v for k, v in before.items()) and m.geom_pair_type_count == count
    mjw.collision(m, d)
    assert calls == [1, 1]
    with pytest.raises(TypeError, match="mujoco_warp Model"):
        ew.attach(mjm)
    with pytest.raises(RuntimeError, match="collision"):
        with ew.attach(m) as att:
            att._hook(m, d)  # not called by mujoco_warp's collision()


@SLOW
def test_overflow_is_counted_and_nothing_is_written_past_naconmax():
    mjm = _pile()
    m, d = _warp(mjm, nworld=2, naconmax=512)
    with ew.attach(m) as att:
        mjw.kinematics(m, d)
        mjw.collision(m, d)
        full = att.counters["contacts"]
        builtin = int(d.nacon.numpy()[0]) - full
        assert full >= 4
        small = builtin + full // 2
        m2, d2 = _warp(mjm, nworld=2, naconmax=small)
        with ew.attach(m2) as att2:
            mjw.kinematics(m2, d2)
            mjw.collision(m2, d2)
            c = att2.counters
            assert c["contacts"] == full and c["overflow"] == full - full // 2
            assert int(d2.nacon.numpy()[0]) == builtin + full  # Warp's own overflow signal: nacon > naconmax
            assert d2.contact.dist.shape[0] == small


@SLOW
def test_sleeping_incremental_pass_adds_only_the_pairs_the_first_pass_skipped():
    mjm = _pile(n=8, sleep=True)
    m, d = _warp(mjm, nworld=2)
    awake, asleep = int(mjw_types.SleepState.AWAKE), int(mjw_types.SleepState.ASLEEP)
    with ew.attach(m):
        mjw.kinematics(m, d)
        state = d.body_awake.numpy().copy()
        everyone = state.copy()
        everyone[:, 1:] = awake
        d.body_awake.assign(everyone)
        mjw.collision(m, d)
        reference = _contacts(d)
        before = everyone.copy()
        before[:, 1:5] = asleep  # four bodies asleep in pass 1, awake for pass 2
        d.body_awake.assign(before)
        mjw.collision(m, d)
        first = _contacts(d)
        d.body_awake.assign(everyone)
        mjw.collision(m, d, awake_prev=wp.array(before, dtype=int))
        both = _contacts(d)
    assert len(first) < len(reference)
    assert sorted(both) == sorted(reference)  # nothing twice, nothing missed


@SLOW
def test_sap_broad_phase_gives_the_nxn_contacts():
    mjm = _pile()
    out = []
    for phase in (mjw_types.BroadphaseType.NXN, mjw_types.BroadphaseType.SAP_TILE):
        m, d = _warp(mjm)
        m.opt.broadphase = phase
        with ew.attach(m):
            mjw.forward(m, d)
            out.append(_contacts(d))
    assert out[0] == out[1] and len(out[0]) > 0


@SLOW
def test_the_hook_allocates_nothing_and_reads_nothing_back(monkeypatch):
    """What graph capture on CUDA needs, checked on CPU: launch makes no array and calls no .numpy()."""
    mjm = _pile(n=6)
    m, d = _warp(mjm)
    att = ew.attach(m)
    mjw.kinematics(m, d)
    att.launch(d)  # compiled and warm
    made = []
    monkeypatch.setattr(type(d.nacon), "numpy", lambda self: made.append("numpy"))
    for name in ("array", "empty", "zeros", "clone", "empty_like", "zeros_like", "synchronize"):
        real = getattr(wp, name)
        monkeypatch.setattr(wp, name, lambda *a, _real=real, _name=name, **k: made.append(_name) or _real(*a, **k))
    att.launch(d)
    monkeypatch.undo()
    assert made == []
    att.detach()


def test_import_ellipsim_loads_no_warp_and_a_missing_extra_names_it():
    code = "import sys, ellipsim; print('warp' in sys.modules, 'mujoco_warp' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
    code = "import sys; sys.modules['warp'] = None\ntry:\n import ellipsim.warp\nexcept ImportError as e:\n print(e)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "pip install 'ellipsim[warp]'" in out.stdout and len(out.stdout.strip().splitlines()) == 1


@SLOW
def test_an_explicit_pair_is_taken_with_its_own_margin():
    mjm = mujoco.MjModel.from_xml_string(
        """<mujoco><worldbody>
        <body><freejoint/><geom name="a" type="ellipsoid" size=".2 .1 .05" contype="0" conaffinity="0"/></body>
        <body pos=".05 .02 .11" euler="0 0 30"><freejoint/>
          <geom name="b" type="ellipsoid" size=".1 .1 .05" contype="0" conaffinity="0"/></body>
        </worldbody><contact><pair geom1="b" geom2="a" margin="0.02"/></contact></mujoco>"""
    )
    m, d = _warp(mjm, nworld=1)
    with ew.attach(m) as att:
        assert att.npairs == 1
        mjw.kinematics(m, d)
        mjw.collision(m, d)
        (w, g1, g2, dist, _, _), *rest = _contacts(d)
    assert rest == [] and (g1, g2) == (0, 1)  # ordered as Warp orders a pair: by type, then index
    xpos, xmat = d.geom_xpos.numpy()[0], d.geom_xmat.numpy()[0]
    expected = _cpu(xpos[0], xmat[0], mjm.geom_size[0], xpos[1], xmat[1], mjm.geom_size[1])[0][0]
    assert 0 < expected < 0.02 and dist == np.float32(expected)
    assert d.contact.includemargin.numpy()[0] == np.float32(0.02)


def _epa_iterations(m):
    """collision_convex.convex_narrowphase's choice of EPA iterations, from the model's pair counts."""
    from mujoco_warp._src.collision_driver import MJ_COLLISION_TABLE

    n = len(mjw_types.GeomType)
    trid = lambda i, j: (min(i, j) * (2 * n - min(i, j) - 1)) // 2 + max(i, j)  # noqa: E731
    convex = [trid(a.value, b.value) for (a, b), k in MJ_COLLISION_TABLE.items() if k == mjw_types.CollisionType.CONVEX]
    box = m.geom_pair_type_count[trid(6, 6)]
    return 16 if box == sum(m.geom_pair_type_count[i] for i in convex) else m.opt.ccd_iterations


@SLOW
def test_box_pairs_keep_warps_own_epa_settings_beside_an_attachment():
    """Warp runs box x box EPA for 16 iterations when they are all its convex pairs (collision_convex.py):
    taking the ellipsoid pairs away must not switch that on."""
    bodies = (
        '<body pos="0 0 .05"><freejoint/><geom type="box" size=".05 .05 .05" contype="2" conaffinity="2"/></body>'
        '<body pos=".02 .01 .145" euler="5 7 40"><freejoint/>'
        '<geom type="box" size=".05 .05 .05" contype="2" conaffinity="2"/></body>'
        '<body pos="1 0 .1"><freejoint/><geom type="ellipsoid" size=".1 .05 .05"/></body>'
        '<body pos="1.05 0 .19" euler="20 0 0"><freejoint/><geom type="ellipsoid" size=".1 .05 .05"/></body>'
    )
    # boxes and ellipsoids do not meet: box x box and ellipsoid x ellipsoid are the only convex pairs
    mjm = mujoco.MjModel.from_xml_string(
        PILE.format(bodies=bodies).replace('type="plane"', 'type="plane" contype="3" conaffinity="3"')
    )
    out, epa = [], []
    for attached in (False, True):
        m, d = _warp(mjm, nworld=1)
        att = ew.attach(m) if attached else None
        assert att is None or att.npairs == 1
        epa.append(_epa_iterations(m))
        mjw.kinematics(m, d)
        mjw.collision(m, d)
        out.append([c for c in _contacts(d) if mjm.geom_type[c[1]] == mujoco.mjtGeom.mjGEOM_BOX])
    assert len(out[0]) > 0 and out[0] == out[1]
    assert epa[0] == epa[1]  # Warp's own choice, as plain


# -- the command line -----------------------------------------------------------------------------


@SLOW
def test_run_engine_warp_steps_every_world_and_reports_them(tmp_path, capsys):
    from ellipsim.app import cli

    path = tmp_path / "heap.xml"
    mujoco.mj_saveLastXML(str(path), _pile(n=6))
    assert cli.main(["run", str(path), "--engine", "warp", "--worlds", "3", "--steps", "40"]) == 0
    out = capsys.readouterr().out
    assert "40 steps x 3 worlds" in out and "world-steps/s in total" in out
    line = next(x for x in out.splitlines() if "Warp contacts per world" in x)
    assert line.count(",") >= 2  # one mean per world
    assert "ellipsim on Warp:" in out and "0 contacts over naconmax" in out


@SLOW
def test_compare_engine_warp_counts_add_up(tmp_path, capsys):
    from ellipsim.app import cli

    path = tmp_path / "heap.xml"
    mujoco.mj_saveLastXML(str(path), _pile(n=6))
    report, recording = tmp_path / "warp.json", tmp_path / "warp.rrd"
    argv = ["compare", str(path), "--engine", "warp", "--worlds", "2", "--steps", "6", "--json", str(report)]
    assert cli.main([*argv, "--record", str(recording)]) == 0
    out = capsys.readouterr().out
    r = __import__("json").loads(report.read_text())
    assert r["engine"] == "warp" and r["worlds"] == 2 and r["steps"] == 6
    assert r["pairs"] > 0 and r["ellipsim_contacts"] > 0
    kinds = ("mujoco_extra", "mujoco_missed", "near_tangent", "normal_off")
    assert ", ".join(f"{r[k]} {k}" for k in kinds) in out
    assert [sum(d["kind"] == k for d in r["disagreements"]) for k in kinds] == [r[k] for k in kinds]
    # one vocabulary: the same counters, pair types and disagreement fields as `compare` on MuJoCo C
    c_report = tmp_path / "c.json"
    assert cli.main(["compare", str(path), "--steps", "6", "--json", str(c_report)]) == 0
    c = __import__("json").loads(c_report.read_text())
    from ellipsim.app.comparison import COUNTERS, disagreement_json
    from tests.test_compare_record import fake

    assert set(COUNTERS) <= set(r) and set(COUNTERS) <= set(c) and r["normal_off_deg"] == c["normal_off_deg"]
    assert (
        list(r["by_pair_type"])
        == list(c["by_pair_type"])
        == [
            "ellipsoid-ellipsoid",
            "ellipsoid-sphere",
            "ellipsoid-capsule",
            "ellipsoid-box",
            "ellipsoid-cylinder",
            "ellipsoid-mesh",
            "ellipsoid-hfield",
        ]
    )
    assert all(set(x) == set(COUNTERS) for x in [*r["by_pair_type"].values(), *c["by_pair_type"].values()])
    fields = set(disagreement_json(fake(0, "mujoco_extra")))
    assert all(set(d) == fields | {"world"} for d in r["disagreements"])
    assert all(set(d) == fields for d in c["disagreements"])
    # the recording: world 0, every step, Warp's contacts, and its disagreements where the JSON says
    from tests.test_record import Recording

    rec = Recording(recording)
    frames, _, counts = rec.temporal("/counts/contacts/all", "Scalars:scalars")
    assert frames == list(range(6)) and sum(c[0] for c in counts) > 0
    _, _, positions = rec.temporal("/world/contacts", "Points3D:positions")
    assert [len(p) for p in positions] == [c[0] for c in counts]  # Warp's contacts of world 0, drawn
    world0 = sorted((d["step"], d["kind"]) for d in r["disagreements"] if d["world"] == 0)
    frames, _, texts = rec.temporal("/events/disagreements", "TextLog:text")
    assert sorted((f, t[0].split(":")[1].strip()) for f, t in zip(frames, texts)) == world0
    (name,) = rec.static("/counts/pairs/builtin", "SeriesLines:names")[-1]
    assert name == "Warp (dist < margin)"


@pytest.mark.parametrize(
    "argv, shown",
    [
        (["run", "handshake", "--worlds", "2"], "--worlds is for --engine warp"),
        (["compare", "pile", "--nconmax", "100", "--njmax", "9"], "--nconmax and --njmax are for --engine warp"),
        (["compare", "pile", "--engine", "warp", "--plot", "x.png"], "--plot and --between-frames are for"),
        (["run", "pile", "--engine", "warp", "--mode", "filter"], "--mode filter is MuJoCo C's"),
        (["run", "crowd", "--engine", "warp"], 'crowd: its mode "filter" is MuJoCo C\'s; on Warp, --mode narrowphase'),
        (["run", "replay", "--engine", "warp", "--between-frames"], "--between-frames is for --engine mujoco"),
    ],
)
def test_engine_warp_mistakes_are_one_line_errors(argv, shown, capsys):
    from ellipsim.app import cli

    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("ellipsim: error: ") and shown in err and err.count("\n") == 1


def test_device_cuda_is_refused_where_warp_finds_none():
    from ellipsim.app import warp_run
    from ellipsim.app.errors import UserError

    if wp.get_cuda_device_count() > 0:
        assert warp_run.check_device("cuda") == "cuda"
    else:
        with pytest.raises(UserError, match="--device cuda: Warp finds no CUDA device"):
            warp_run.check_device("cuda")


def test_a_filter_scenario_is_refused_on_warp_not_run_as_narrowphase():
    """crowd.toml's mode is "filter" (MuJoCo C's contact filter): warp_run.run refuses it, as it refuses any mode
    but builtin and narrowphase, before building anything; an explicit mode runs it."""
    from ellipsim.app import scenario, warp_run

    crowd = scenario.load("crowd")
    assert crowd.mode == "filter"
    for mode in (None, "filter", "exact"):
        with pytest.raises(ValueError, match="mode must be one of builtin, narrowphase on Warp"):
            warp_run.run(crowd, steps=1, nworld=1, mode=mode)
    assert warp_run.run(crowd, steps=1, nworld=1, mode="builtin").steps == 1


def test_worlds_of_a_seeded_figure_scene_start_from_other_layouts():
    from ellipsim.app import scenario, simulate, warp_run

    s = scenario.load("pile")  # twelve figures dropped by a seed
    model, data = simulate.build(s)
    qpos, seeds = warp_run.world_states(s, model, data, 3)
    assert seeds == 3 and qpos.shape == (3, model.nq)
    np.testing.assert_array_equal(qpos[0], data.qpos)
    assert not np.array_equal(qpos[1], qpos[0]) and not np.array_equal(qpos[2], qpos[1])
    crowd = scenario.load("crowd")  # planted roots: the layout is in the model, not in qpos
    model, data = simulate.build(crowd)
    qpos, seeds = warp_run.world_states(crowd, model, data, 3)
    assert seeds == 1 and all(np.array_equal(q, data.qpos) for q in qpos)


@SLOW
def test_an_overflow_is_a_counted_explained_line_not_warps_print(tmp_path):
    """Buffers too small for the heap as it falls (--nconmax, --njmax just above the initial state's): `run`
    and `compare` say how many frames or steps overflowed, which buffer and which option raises it; Warp's
    own kernel prints stay off.  Below the initial state's, a one-line error."""
    path = tmp_path / "heap.xml"
    model = _pile(n=6)
    mujoco.mj_saveLastXML(str(path), model)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cases = [
        ("run", ["--nconmax", str(data.ncon + 1)], "raise --nconmax"),
        ("compare", ["--nconmax", str(data.ncon + 1)], "raise --nconmax"),
        ("run", ["--njmax", str(data.nefc + 2)], "raise --njmax"),
    ]
    for command, small, hint in cases:
        argv = [command, str(path), "--engine", "warp", "--steps", "60", *small]
        proc = subprocess.run([sys.executable, "-m", "ellipsim", *argv], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        out = proc.stdout + proc.stderr
        assert "please increase" not in out and "overflow -" not in out, out[-2000:]
        line = next(x for x in proc.stdout.splitlines() if "warning: Warp's buffers overflowed" in x)
        assert hint in line, line
    proc = subprocess.run(
        [sys.executable, "-m", "ellipsim", "run", str(path), "--engine", "warp", "--steps", "60"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0 and "overflowed" not in proc.stdout  # the defaults hold the heap
    argv = ["run", str(path), "--engine", "warp", "--steps", "2", "--nconmax", str(max(data.ncon - 1, 0) or 1)]
    if data.ncon > 1:
        proc = subprocess.run([sys.executable, "-m", "ellipsim", *argv], capture_output=True, text=True)
        assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
        assert proc.stderr.strip().endswith("contacts of the initial state") and proc.stderr.count("\n") == 1


# -- the CUDA build (NVRTC runs here without a GPU) -----------------------------------------------


def _ptx(module, tmp_path):
    """The PTX (sm_90) NVRTC makes of a Warp module, compiled ahead of time: Warp's CUDA path, no GPU needed."""
    wp.compile_aot_module(module, arch=90, module_dir=str(tmp_path), use_ptx=True)
    (ptx,) = tmp_path.glob("*.ptx")
    return ptx.read_text()


@SLOW
def test_the_core_compiles_for_cuda_and_nvrtc_contracts_nothing(tmp_path):
    """NVRTC has no C or C++ library header: the core compiles there through ellipsim/math.hpp (every row of
    the contact kernel's glue, the mujoco_warp functions it calls).  With fuse_fp False a product and a sum
    stay mul.rn and add.rn: a kernel of the certified filters (no call into CUDA's math library, whose own
    polynomials use fma by design) has no fma, where fuse_fp True makes them."""
    kernel = kernels.contact_kernel(False, False, 1)
    assert "ellipsim_contacts" in _ptx(kernel.module, tmp_path / "contacts")

    @wp.func_native("out = ellipsim::pairs::box::centre_line_bound(ellipsim::warp_glue::pose(c1, R1, r1), "
                    "ellipsim::warp_glue::pose(c2, R2, r2));")  # fmt: skip
    def bound(c1: wp.vec3d, R1: wp.mat33d, r1: wp.vec3d, c2: wp.vec3d, R2: wp.mat33d, r2: wp.vec3d,
              out: wp.ref[wp.float64]): ...  # fmt: skip

    def filters(fuse):
        @wp.kernel(module="unique", module_options={**kernels.MODULE_OPTIONS, "fuse_fp": fuse})
        def centre_lines(c: wp.array[wp.vec3d], R: wp.array[wp.mat33d], out: wp.array[wp.float64]):
            i = wp.tid()
            v = wp.float64(0.0)
            bound(c[i], R[i], c[i + 1], c[i + 2], R[i + 1], c[i + 3], v)
            out[i] = v

        return _ptx(centre_lines.module, tmp_path / f"filters-{fuse}")

    exact, fused = filters(False), filters(True)
    assert "mul.rn.f64" in exact and "fma.rn.f64" not in exact
    assert "fma.rn.f64" in fused


def test_a_cutoff_stops_only_pairs_proven_beyond_it():
    """The contact kernel's margin + gap: a pair the centre line or a Newton iterate proves beyond the cutoff is
    APART (its dist 0, or sigma at the iterate: at least the cutoff, at most the distance); every other pair is the
    CPU's answer, bit for bit."""
    a, b = generic_pairs(600, seed=4)
    x = _f32(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    dc, nc, pc, sc = _cpu(*x)
    cutoff = 0.05
    dw, nw, pw, sw = kernels.pair_distances(*x, cutoff=cutoff)
    apart = sw == kernels.APART
    assert apart.sum() > 100 and (~apart).sum() > 100
    assert np.all(dc[apart] >= cutoff)  # none stopped that the CPU puts below the cutoff
    assert np.all((dw[apart] == 0) | ((dw[apart] >= cutoff) & (dw[apart] <= dc[apart] + 1e-12)))
    assert_same_bits(dw[~apart], dc[~apart], "dist")
    assert_same_bits(nw[~apart], nc[~apart], "normal")
    np.testing.assert_array_equal(sw[~apart], sc[~apart])


@SLOW
def test_the_gpu_check_runs_on_the_cpu_device_and_refuses_a_missing_device(tmp_path):
    """bench/gpu.sh, as the GPU machine runs it (python -P: the installed package, not this tree's sources), at
    the CPU's sizes: both tables, every scene and world count, its report and results written; a device Warp
    does not find is a one-line error (after Warp's own warning where no CUDA driver loads), exit 2."""
    import json
    import os
    import pathlib

    script = pathlib.Path(__file__).resolve().parents[1] / "bench" / "gpu.sh"
    env = {**os.environ, "PYTHON": sys.executable}
    argv = [
        str(script),
        "--device",
        "cpu",
        "--worlds",
        "1,2",
        "--pairs",
        "4",
        "--launches",
        "1",
        "--out",
        str(tmp_path),
    ]
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "## Accuracy against ellipsim's CPU answer" in proc.stdout and "## Scenes" in proc.stdout
    results = json.loads((tmp_path / "results.json").read_text())
    assert [(r["scene"], r["nworld"]) for r in results["scenes"]] == [
        (s, n) for s in ("16 figures in a heap", "pile of 100 ellipsoids") for n in (1, 2)
    ]
    for r in results["scenes"]:
        assert r["attached"]["counters"]["pairs"] > 0 and r["attached"]["counters"]["unproven"] == 0
        assert r["plain"]["contacts"] > 0 and r["attached"]["contacts"] > 0
    ours = [a for a in results["accuracy"] if a["method"] == "ellipsim on Warp"]
    assert len(ours) == 50 and all(a["mujoco_missed"] == 0 and a["mujoco_extra"] == 0 for a in ours)
    assert (tmp_path / "report.md").read_text().startswith("# ellipsim on MuJoCo Warp: the GPU check")
    bad = subprocess.run([str(script), "--device", "cuda:7"], capture_output=True, text=True, env=env)
    last = bad.stderr.strip().splitlines()[-1]  # (after Warp's own warning where it finds no CUDA driver)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr, bad.stderr
    assert last == "bench/gpu.sh: error: --device 'cuda:7': Warp finds no such device here", bad.stderr


def test_every_warp_module_of_ellipsim_compiles_without_contraction_or_fast_math():
    """kernels.py's own module and each contact kernel's (module "unique"): fuse_fp and fast_math off, the core's
    headers on both compilers' include paths and in the module hash; no other module of ellipsim defines kernels."""
    import pathlib

    modules = [kernels._pair_distances.module] + [
        kernels.contact_kernel(sleep, incr, per).module for sleep, incr, per in ((False, False, 16), (True, True, 1))
    ]
    for module in modules:
        assert module.options["fuse_fp"] is False and module.options["fast_math"] is False, module.name
        build = module.options["extra_build_options"]
        assert str(kernels.NATIVE / "include") in build.extra_cpu_include_dirs
        assert str(kernels.NATIVE / "include") in build.extra_cuda_include_dirs
        assert str(kernels.NATIVE / "include" / "ellipsim" / "math.hpp") in build.extra_build_dependencies
    package = pathlib.Path(ew.__file__).resolve().parents[1]
    defining = {p.relative_to(package).as_posix() for p in package.rglob("*.py") if "@wp." in p.read_text()}
    assert defining == {"warp/kernels.py"}
