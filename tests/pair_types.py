"""What the capsule, box and cylinder tests check alike inside MuJoCo: agreement with MuJoCo run
tight on a pile, bit-identical plain datas, the table entry installed and restored.  Each takes the pair's geom types (t1 <= t2, MuJoCo's
table order)."""

import math

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation as Rot

import ellipsim.mujoco as em
from ellipsim.core.rotations import quaternions_to_rotations
from ellipsim.core.tolerances import ANGLE_TOL, DIST_TOL, NEAR_TANGENT, POS_TOL
from ellipsim.mujoco import publish
from ellipsim.native import ext


def random_rotations(rng, m):
    q = rng.normal(size=(m, 4))
    return quaternions_to_rotations(q / np.linalg.norm(q, axis=1)[:, None])


def contacts_of(model, data, t1, t2):
    """{(g1, g2): (dist, normal, pos, includemargin)} of the contacts between geom types t1 and t2."""
    out = {}
    for c in data.contact[: data.ncon]:
        if model.geom_type[c.geom1] == t1 and model.geom_type[c.geom2] == t2:
            out[(int(c.geom1), int(c.geom2))] = (c.dist, c.frame[:3].copy(), c.pos.copy(), c.includemargin)
    return out


def pile_agrees_with_tight_mujoco(xml, t1, t2, steps=500):
    """Every 4th step's (t1, t2) contacts of the attached data against MuJoCo's mjc_Convex run tight
    (ccd_tolerance 1e-10, 1000 iterations) at the same state: within the issue's 2e-6 m, 1e-3 rad,
    1e-3 m (tolerances.py); near-tangent pairs (|dist| < 2e-6) may exist on one side only.  Returns
    (contacts compared, the attachment's counters)."""
    model = mujoco.MjModel.from_xml_string(xml)
    tight = mujoco.MjModel.from_xml_string(xml)
    tight.opt.ccd_tolerance, tight.opt.ccd_iterations = 1e-10, 1000
    data, check = mujoco.MjData(model), mujoco.MjData(tight)
    compared = 0
    with em.attach(model, data, mode="narrowphase") as att:
        for step in range(steps):
            qpos, qvel = data.qpos.copy(), data.qvel.copy()
            mujoco.mj_step(model, data)  # data.contact: the contacts at qpos
            if step % 4:
                continue
            check.qpos[:], check.qvel[:] = qpos, qvel
            mujoco.mj_forward(tight, check)  # not attached: MuJoCo's own function
            ours, theirs = contacts_of(model, data, t1, t2), contacts_of(tight, check, t1, t2)
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
    return compared, att.counters


def unattached_is_plain_mujoco(xml, steps=300):
    """While another data of the same model is attached in mode narrowphase, a data not attached
    steps bit for bit as MuJoCo alone does; returns the attached data's counters."""
    model = mujoco.MjModel.from_xml_string(xml)
    alone, other, attached = mujoco.MjData(model), mujoco.MjData(model), mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, alone)
    with em.attach(model, attached, mode="narrowphase") as att:
        for _ in range(steps):
            mujoco.mj_step(model, other)
            mujoco.mj_step(model, attached)
    np.testing.assert_array_equal(other.qpos, alone.qpos)
    np.testing.assert_array_equal(other.qvel, alone.qvel)
    return att.counters


def entry_installed_and_restored(xml, t1, t2):
    """The narrow phase sits in the (t1, t2) entry of MuJoCo's table while a data is attached, and
    MuJoCo's function is back after."""
    model = mujoco.MjModel.from_xml_string(xml)
    table, n = publish.collision_table()
    before = table[t1 * n + t2]
    with em.attach(model, mujoco.MjData(model), mode="narrowphase") as att:
        assert att.installed and table[t1 * n + t2] == ext.mujoco.NARROWPHASE
    assert table[t1 * n + t2] == before


# --- the kernels' poses and their check against the dense reference ------------------------------


def pair_row(kernel, E, K, columns):
    """The row of an ext.testing pose kernel (arguments Ce, Re, re, Ck, Rk, sk, out, lo, hi; `columns` wide)
    on one pair: E and K each (centre (3,), rotation row-major (9,), sizes (3,))."""
    shapes = ((1, 3), (1, 3, 3), (1, 3))
    args = [np.array(x, dtype=float).reshape(shape) for body in (E, K) for x, shape in zip(body, shapes)]
    out = np.empty((1, columns))
    kernel(*args, out, 0, 1)
    return out[0]


def kernel_result(kernel, E, K):
    """ext.testing's capsule_ellipsoid, box_ellipsoid or cylinder_ellipsoid on one pair (E, K as pair_row's):
    (status, dist, normal, pos, ub), normal and pos 3-tuples."""
    r = pair_row(kernel, E, K, 9).tolist()
    return int(r[0]), r[1], tuple(r[2:5]), tuple(r[5:8]), r[8]


def far_poses(rng, rE, sK):
    """Pose dict (cE, RE, rE, cK, RK, sK) of m pairs with random rotations, E's centre in [-1, 1]^3
    and K's far from it in a random direction."""
    m = len(rE)
    RE, RK = random_rotations(rng, m), random_rotations(rng, m)
    cE = rng.uniform(-1, 1, (m, 3))
    d = rng.normal(size=(m, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    cK = cE + d * (2 * (np.linalg.norm(rE, axis=1) + np.linalg.norm(sK, axis=1)) + 0.1)[:, None]
    return dict(cE=cE, RE=RE, rE=rE, cK=cK, RK=RK, sK=sK)


def place_gaps(P, cat, kernel, small, rng):
    """Categories 0 (separated: gap log-uniform in [1e-6, 0.1] m), 1 (touching: gap 0 or +-1e-9) and
    2 (shallow: pushed in by up to half of `small`): K translated along the kernel's normal of the far
    pose (the distance of convex bodies shrinks by exactly the translation while they stay apart; the
    reference measures the result, nothing assumes it).  kernel(P, i) -> (status, dist, normal, ...)."""
    m = len(cat)
    gap = np.where(cat == 0, 10 ** rng.uniform(-6, -1, m), 0.0)
    gap = np.where(cat == 1, rng.choice([0.0, 1e-9, -1e-9], m), gap)
    gap = np.where(cat == 2, -rng.uniform(1e-6, 0.5, m) * small, gap)
    for i in np.flatnonzero(cat <= 2):
        _, dist, normal, _, _ = kernel(P, i)
        P["cK"][i] = P["cK"][i] - np.array(normal) * (dist - gap[i])


def check_against_reference(P, cat, names, out, normals, ref, ref_sigma, s_min, statuses, certified_status):
    """The kernel's value within 1e-12 of s_min of the dense reference in every category, on either
    side; statuses among `statuses`; the certificate (ub) above the reference and within 1e-12 s_min
    of the value where certified; the value equal to the reference's sigma at the kernel's normal.
    out: (status, dist, ub) rows."""
    status, dist, ub = out[:, 0], out[:, 1], out[:, 2]
    scale = np.linalg.norm(P["cK"] - P["cE"], axis=1) + np.maximum(P["rE"].max(1), P["sK"].max(1))
    slack = 64 * 2.0**-53 * scale  # the rounding allowance of sigma (tolerances.PAIR_SIGMA_SLACK_ULPS)
    below = (ref - dist) / s_min  # ours below the reference: a missed maximum
    above = (dist - ref) / s_min  # ours above it: the reference's polish stopped short, or ours is wrong
    for k, name in enumerate(names):
        sel = cat == k
        assert below[sel].max() <= 1e-12, f"{name}: {below[sel].max():.3g} s_min below the reference"
        assert above[sel].max() <= 1e-12, f"{name}: {above[sel].max():.3g} s_min above the reference"
    assert set(np.unique(status)) <= set(statuses)
    certified = status == certified_status
    assert np.all(ref[certified] <= ub[certified] + slack[certified])  # the certificate holds
    assert np.all(ub[certified] - dist[certified] <= 1e-12 * s_min[certified] + slack[certified])
    at_ours = ref_sigma(P, normals[:, None, :])[:, 0]  # our dist is sigma at our normal, independently
    np.testing.assert_allclose(at_ours, dist, rtol=0, atol=1e-14 * scale.max())


def coaxial_poses(seed, m=200):
    """A spheroid E (prolate or oblate, aspect 1.15-6, a random rotation) and a cylinder or capsule
    (sizes as MuJoCo's geom_size) whose axis is E's, exactly or tilted by 1e-12 to 1e-2 rad, centred on
    the axis or a hair off it, deep to touching: sigma is (nearly) constant along the rim or the side
    circle facing E (limbs of one straight chain)."""
    rng = np.random.default_rng(seed)
    rE, cK, RK, sK = np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 3, 3)), np.zeros((m, 3))
    RE = Rot.random(m, random_state=rng).as_matrix()
    for i in range(m):
        s, aspect = rng.uniform(0.05, 0.3), rng.uniform(1.15, 6.0)
        rE[i] = (s, s, s * aspect) if i % 2 else (s * aspect, s * aspect, s)
        tilt = [0.0, 1e-12, 1e-8, 1e-4, 1e-2][i % 5]
        axis = rng.normal(size=3)
        RK[i] = RE[i] @ Rot.from_rotvec(axis / np.linalg.norm(axis) * tilt).as_matrix()
        sK[i, 0], sK[i, 1] = rng.uniform(0.02, 0.4), rng.uniform(0.01, 0.4)
        off = rng.normal(size=3) * tilt if i % 3 == 0 else np.zeros(3)
        cK[i] = RE[i] @ (np.array([0.0, 0.0, rng.uniform(0.0, 1.05) * (rE[i, 2] + sK[i, 1])]) + off)
    return dict(cE=np.zeros((m, 3)), RE=RE, rE=rE, cK=cK, RK=RK, sK=sK)
