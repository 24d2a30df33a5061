"""Ellipsoid x capsule: the kernel (core/capsule.py) against an independent reference, and the
narrow phase inside MuJoCo against MuJoCo's own GJK/EPA run tight.  That a data not attached stays
plain MuJoCo to the bit on a capsule pile is tested with the other scope tests (test_scope.py)."""

import itertools
import math
import re

import mujoco
import numpy as np
import pytest

import ellipsim.mujoco as em
from ellipsim.core import capsule
from ellipsim.core.tolerances import ANGLE_TOL, DIST_TOL, NEAR_TANGENT, POS_TOL
from ellipsim.mujoco import callbacks, nativecache, scenes, structs
from reference import dense_maximum

CAP, ELL = int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)

# --- an independent reference (reference.dense_maximum) ------------------------------------------
# sigma(n) = n.(cK - cE) - |rE (RE^T n)| - L |n.z| - r written out in world coordinates with numpy,
# nothing of ellipsim; its kink is the great circle n.z = 0.


def ref_sigma(P, n):
    """sigma of the poses P at the directions n (m, k, 3), normalised here."""
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    v = np.einsum("mkj,mj->mk", n, P["cK"] - P["cE"])
    loc = np.einsum("mkj,mji->mki", n, P["RE"]) * P["rE"][:, None, :]
    a = np.einsum("mkj,mj->mk", n, P["RK"][:, :, 2])
    return v - np.sqrt(np.sum(loc * loc, -1)) - P["sK"][:, None, 1] * np.abs(a) - P["sK"][:, None, 0]


def reference(P):
    return dense_maximum(ref_sigma, P, P["RK"][:, None, :, 2])


# --- poses ------------------------------------------------------------------------------------


def _rotations(rng, m):
    q = rng.normal(size=(m, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], 1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], 1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], 1),
    ], 1)  # fmt: skip


def _kernel(P, i):
    E = (tuple(P["cE"][i]), tuple(P["RE"][i].ravel()), tuple(P["rE"][i]))
    K = (tuple(P["cK"][i]), tuple(P["RK"][i].ravel()), tuple(P["sK"][i]))
    return capsule.capsule_ellipsoid(E, K)


def make_poses(seed=0, per=60):
    """Categories of `per` poses: separated, touching (gap 0 and +-1e-9), shallow, deep, parallel axes
    (side or end against a tip of E), capsule inside the ellipsoid, ellipsoid around the segment."""
    rng = np.random.default_rng(seed)
    names = ("separated", "touching", "shallow", "deep", "parallel", "capsule inside", "around segment")
    m = per * len(names)
    cat = np.repeat(np.arange(len(names)), per)
    rE = rng.uniform(0.02, 0.3, (m, 3))
    sK = np.stack([rng.uniform(0.01, 0.1, m), rng.uniform(0.02, 0.3, m), np.zeros(m)], 1)
    RE, RK = _rotations(rng, m), _rotations(rng, m)
    cE = rng.uniform(-1, 1, (m, 3))
    d = rng.normal(size=(m, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    cK = cE + d * (2 * (np.linalg.norm(rE, axis=1) + np.linalg.norm(sK, axis=1)) + 0.1)[:, None]
    P = dict(cE=cE, RE=RE, rE=rE, cK=cK, RK=RK, sK=sK)
    # place separated / touching / shallow poses along the normal of a far pose: the distance of convex
    # bodies shrinks by exactly the translation while they stay apart (the exact value is measured
    # afterwards by the reference, not assumed)
    gap = np.where(cat == 0, 10 ** rng.uniform(-6, -1, m), 0.0)
    gap = np.where(cat == 1, rng.choice([0.0, 1e-9, -1e-9], m), gap)
    small = np.minimum(sK[:, 0], rE.min(1))
    gap = np.where(cat == 2, -rng.uniform(1e-6, 0.5, m) * small, gap)
    for i in np.flatnonzero(cat <= 2):
        _, dist, normal, _, _ = _kernel(P, i)
        cK[i] = cK[i] - np.array(normal) * (dist - gap[i])
    deep = cat == 3
    cK[deep] = cE[deep] + rng.uniform(-0.3, 0.3, (int(deep.sum()), 3)) * rE[deep].min(1)[:, None]
    # parallel: the capsule's axis along E's axis k, its side (or end) against E's axis j (or k)
    par = np.flatnonzero(cat == 4)
    for i in par:
        k = rng.integers(3)
        j = (k + rng.integers(1, 3)) % 3
        z = RE[i][:, k]
        x = np.cross(z, rng.normal(size=3))
        x /= np.linalg.norm(x)
        RK[i] = np.stack([x, np.cross(z, x), z], 1)
        g = rng.choice([0.0, 1e-9, -1e-9, 1e-4, -1e-4, -0.3 * small[i]])
        side = rng.choice([-1.0, 1.0])
        if rng.random() < 0.5:
            cK[i] = cE[i] + side * RE[i][:, j] * (rE[i, j] + sK[i, 0] + g) + z * rng.uniform(-0.9, 0.9) * sK[i, 1]
        else:
            cK[i] = cE[i] + side * z * (rE[i, k] + sK[i, 1] + sK[i, 0] + g)
    inside = cat == 5  # a small capsule deep inside a large ellipsoid
    rE[inside] = rng.uniform(0.2, 0.3, (int(inside.sum()), 3))
    sK[inside, 0], sK[inside, 1] = rng.uniform(0.01, 0.03, int(inside.sum())), rng.uniform(0.02, 0.06, int(inside.sum()))
    cK[inside] = cE[inside] + rng.uniform(-0.05, 0.05, (int(inside.sum()), 3))
    around = np.flatnonzero(cat == 6)  # a small ellipsoid centred on a long capsule's segment
    rE[around] = rng.uniform(0.01, 0.05, (len(around), 3))
    sK[around, 0], sK[around, 1] = rng.uniform(0.04, 0.1, len(around)), rng.uniform(0.1, 0.3, len(around))
    cK[around] = cE[around] - RK[around][:, :, 2] * (rng.uniform(-0.9, 0.9, len(around)) * sK[around, 1])[:, None]
    return P, cat, names


@pytest.fixture(scope="module")
def poses():
    P, cat, names = make_poses()
    out = np.array([_kernel(P, i)[:2] + (_kernel(P, i)[4],) for i in range(len(cat))])
    normals = np.array([_kernel(P, i)[2] for i in range(len(cat))])
    value, _ = reference(P)
    return P, cat, names, out, normals, value


def test_kernel_matches_the_reference_within_1e12_of_the_smaller_half_size(poses):
    P, cat, names, out, normals, ref = poses
    status, dist, ub = out[:, 0], out[:, 1], out[:, 2]
    s_min = np.minimum(P["rE"].min(1), P["sK"][:, 0])
    scale = np.linalg.norm(P["cK"] - P["cE"], axis=1) + np.maximum(P["rE"].max(1), P["sK"][:, :2].max(1))
    slack = 64 * 2.0**-53 * scale  # the rounding allowance of sigma (tolerances.PAIR_SIGMA_SLACK_ULPS)
    below = (ref - dist) / s_min  # ours below the reference: a missed maximum
    above = (dist - ref) / s_min  # ours above it: the reference's polish stopped short, or ours is wrong
    for k, name in enumerate(names):
        sel = cat == k
        assert below[sel].max() <= 1e-12, f"{name}: {below[sel].max():.3g} s_min below the reference"
        assert above[sel].max() <= 1e-12, f"{name}: {above[sel].max():.3g} s_min above the reference"
    assert set(np.unique(status)) <= {capsule.CERTIFIED, capsule.ENUMERATED}
    certified = status == capsule.CERTIFIED
    assert np.all(ref[certified] <= ub[certified] + slack[certified])  # the certificate holds
    assert np.all(ub[certified] - dist[certified] <= 1e-12 * s_min[certified] + slack[certified])
    # our dist is sigma at our normal, evaluated independently
    at_ours = ref_sigma(P, normals[:, None, :])[:, 0]
    np.testing.assert_allclose(at_ours, dist, rtol=0, atol=1e-14 * scale.max())
    assert (dist[cat == 3] < 0).all() and (dist[cat == 5] < 0).all() and (dist[cat == 0] > 0).all()


def test_kernel_hand_picked_cases():
    I = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    E = ((0.0, 0.0, 0.0), I, (0.3, 0.2, 0.1))
    # end on: the capsule along z above E's shortest axis, 0.25 m apart
    st, dist, normal, pos, _ = capsule.capsule_ellipsoid(E, ((0.0, 0.0, 0.5), I, (0.05, 0.15, 0.0)))
    assert dist == pytest.approx(0.5 - 0.15 - 0.05 - 0.1, abs=1e-15) and normal == pytest.approx((0, 0, 1), abs=1e-15)
    assert pos == pytest.approx((0.0, 0.0, 0.1 + 0.1), abs=1e-15)
    # side on, axis along y through E's centre: the shortest way out is along z
    Ry = (1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0)
    st, dist, normal, _, _ = capsule.capsule_ellipsoid(E, ((0.0, 0.0, 0.0), Ry, (0.05, 0.2, 0.0)))
    assert dist == pytest.approx(-0.15, abs=1e-15) and abs(normal[2]) == pytest.approx(1.0, abs=1e-15)
    # the centre-line bound never exceeds the distance
    K = ((0.3, 0.4, 0.2), Ry, (0.05, 0.2, 0.0))
    assert capsule.centre_line_bound(E, K) <= capsule.capsule_ellipsoid(E, K)[1]


# --- inside MuJoCo ------------------------------------------------------------------------------

def capsule_pile_xml(n=30, seed=1, margin=0.0):
    """scenes.pile_xml with every other ellipsoid a capsule (radius, half-length: its first two
    semi-axes), and `margin` on every third geom: capsules and ellipsoids heaped in a bin."""
    k = itertools.count()

    def swap(m):
        i = next(k)
        geom = f'type="capsule" size="{m[1]} {m[2]}"' if i % 2 else m[0]
        return geom + (f' margin="{margin}"' if margin and i % 3 == 0 else "")

    return re.sub(r'type="ellipsoid" size="(\S+) (\S+) \S+"', swap, scenes.pile_xml(n, seed=seed))


def _capsule_contacts(model, data):
    """{(g1, g2): (dist, normal, pos, includemargin)} of the capsule x ellipsoid contacts."""
    out = {}
    for c in data.contact[: data.ncon]:
        if model.geom_type[c.geom1] == CAP and model.geom_type[c.geom2] == ELL:
            out[(int(c.geom1), int(c.geom2))] = (c.dist, c.frame[:3].copy(), c.pos.copy(), c.includemargin)
    return out


@pytest.mark.parametrize("margin", [0.0, 0.01])
def test_pile_agrees_with_tight_mujoco(margin):
    """Each step's capsule x ellipsoid contacts of the attached data against MuJoCo's mjc_Convex run
    tight (ccd_tolerance 1e-10, 1000 iterations) at the same state: within the issue's 2e-6 m, 1e-3
    rad, 1e-3 m (tolerances.py); near-tangent pairs (|dist| < 2e-6) may exist on one side only."""
    xml = capsule_pile_xml(margin=margin)
    model = mujoco.MjModel.from_xml_string(xml)
    tight = mujoco.MjModel.from_xml_string(xml)
    tight.opt.ccd_tolerance, tight.opt.ccd_iterations = 1e-10, 1000
    data, check = mujoco.MjData(model), mujoco.MjData(tight)
    compared = 0
    with em.attach(model, data, mode="narrowphase") as att:
        for step in range(500):
            qpos, qvel = data.qpos.copy(), data.qvel.copy()
            mujoco.mj_step(model, data)  # data.contact: the contacts at qpos
            if step % 4:
                continue
            check.qpos[:], check.qvel[:] = qpos, qvel
            mujoco.mj_forward(tight, check)  # not attached: MuJoCo's own function
            ours, theirs = _capsule_contacts(model, data), _capsule_contacts(tight, check)
            for key in ours.keys() | theirs.keys():
                if key not in ours or key not in theirs:
                    dist, _, _, inc = ours.get(key) or theirs.get(key)
                    assert dist >= inc - NEAR_TANGENT, f"step {step} pair {key}: contact on one side only, dist {dist}"
                    continue
                (d1, n1, p1, _), (d2, n2, p2, _) = ours[key], theirs[key]
                assert abs(d1 - d2) <= DIST_TOL, f"step {step} pair {key}: dist {d1} vs {d2}"
                if abs(d1) < NEAR_TANGENT:
                    continue  # MuJoCo's normal is arbitrary at a tangency
                angle = math.acos(min(1.0, float(n1 @ n2)))
                assert angle <= ANGLE_TOL, f"step {step} pair {key}: normals {angle} rad apart"
                assert np.linalg.norm(p1 - p2) <= POS_TOL, f"step {step} pair {key}: pos {p1} vs {p2}"
                compared += 1
    counts = att.counters
    assert compared > 100 and counts["fallbacks"] == 0 and counts["contacts"] > 100
    assert counts["calls"] >= counts["separated"] + counts["contacts"]


def test_capsule_entry_is_installed_and_restored():
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom type="capsule" size=".05 .1"/></body>'
        '<body pos="0 0 .3"><freejoint/><geom type="ellipsoid" size=".1 .1 .2"/></body></worldbody></mujoco>'
    )
    table, n = structs.collision_table()
    before = table[CAP * n + ELL]
    with em.attach(model, mujoco.MjData(model), mode="narrowphase") as att:
        assert att.installed and table[CAP * n + ELL] == nativecache.function("narrowphase").address
    assert table[CAP * n + ELL] == before
    with em.attach(model, mujoco.MjData(model), mode="filter") as att:
        assert not att.installed  # the filter handles no capsule pair


def test_an_error_status_answers_with_mujocos_capsule_function():
    """The wrapper's error path (callbacks._wrapper_for) for a capsule pair: MuJoCo's own contact."""
    from test_startup import failing_narrowphase

    nativecache.fill_context()
    narrow = callbacks.compile_callback("narrowphase", failing_narrowphase)
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="capsule" size=".05 .1" euler="30 0 0"/>'
        '<geom type="ellipsoid" size=".1 .2 .3" pos=".1 .02 .05"/></worldbody></mujoco>'
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    table, n = structs.collision_table()
    ours = nativecache._CTYPES["narrowphase"](narrow.address)
    theirs = nativecache._CTYPES["narrowphase"](table[CAP * n + ELL])
    got, want = np.zeros(64), np.zeros(64)
    assert ours(model._address, data._address, got.ctypes.data, 0, 1, 0.0) == 1
    assert theirs(model._address, data._address, want.ctypes.data, 0, 1, 0.0) == 1
    np.testing.assert_array_equal(got[:10], want[:10])
