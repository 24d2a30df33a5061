"""The narrow phase's warm start (attach(..., warm_start=True), the default): each ellipsoid pair's Newton
run starts from the pair's normal of the previous call on the same data.

The results must satisfy the cold start's contract -- maximum proven global, distance within 1e-12 of
the smaller shortest semi-axis of the exact value -- so warm and cold contacts at the same state differ
by at most twice that (each side within it of the exact value).  They are not bit-identical to cold
ones, but a data's trajectory is its own: the same with or without other datas attached and stepped
in between, from one thread or eight."""

import math
import threading

import mujoco
import numpy as np
import pytest
from distance_stages import pair_signed_distance, pair_signed_distance_from, sigma_lower_bound

import ellipsim.mujoco as em
from ellipsim.app import scenes
from ellipsim.core.distance.ellipsoid_pair import GLOBAL
from ellipsim.mujoco import attachment

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
ELL = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
#: the contract, per side: 1e-12 of the smaller shortest semi-axis (tolerances.BB_TOL_REL); two sides
CONTRACT = 2e-12
#: normals: both sides end a Newton run whose last step was below NEWTON_STEP_TOL = 1e-5 rad, so they
#: sit ~1e-10 rad from the maximiser (quadratic convergence); 1e-8 rad leaves room for flat maxima
NORMAL_TOL = 1e-8


def settled(xml, steps):
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return model, data


BENCH_SCENES = {  # as ellipsim/app/bench/inside_mujoco.py settles them
    "pile of 40 ellipsoids": (lambda: scenes.pile_xml(40, seed=1), 1500),
    "4 figures in a heap": (lambda: scenes.scene_xml(4, layout="pile", seed=1), 1000),
}


def contacts(data):
    """{(g1, g2): (dist, normal (3,), pos (3,))} of data's contacts."""
    c = data.contact
    return {
        (int(g[0]), int(g[1])): (float(c.dist[k]), c.frame[k, :3].copy(), c.pos[k].copy()) for k, g in enumerate(c.geom)
    }


@pytest.mark.parametrize("scene", list(BENCH_SCENES))
def test_warm_contacts_match_cold_ones_within_the_contract(scene):
    """200 warm-started steps; before each, the same state's contacts from a cold attachment on
    another data: same pairs, distances within the contract, normals and positions alike."""
    make, settle = BENCH_SCENES[scene]
    model, data = settled(make(), settle)
    cold = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    rmin = model.geom_size.min(axis=1)
    rmin[model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE] = model.geom_size[
        model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE, 0
    ]
    worst, compared = 0.0, 0
    warm, ref = em.attach(model, data, mode="narrowphase"), em.attach(model, cold, mode="narrowphase", warm_start=False)
    with warm, ref:
        for step in range(200):
            mujoco.mj_getState(model, data, state, FULL)
            mujoco.mj_setState(model, cold, state, FULL)
            mujoco.mj_forward(model, cold)
            mujoco.mj_step(model, data)  # its collision runs at the state `cold` was given
            got, want = contacts(data), contacts(cold)
            assert got.keys() == want.keys(), f"step {step}"
            for pair, (dist, normal, pos) in got.items():
                if model.geom_type[pair[0]] != ELL or model.geom_type[pair[1]] != ELL:
                    continue
                d0, n0, p0 = want[pair]
                bound = CONTRACT * min(rmin[pair[0]], rmin[pair[1]])
                assert abs(dist - d0) <= bound, f"step {step}, pair {pair}: {dist!r} against cold {d0!r}"
                assert np.linalg.norm(normal - n0) <= NORMAL_TOL, f"step {step}, pair {pair}"
                assert np.linalg.norm(pos - p0) <= NORMAL_TOL * model.geom_size[list(pair)].max(), (
                    f"step {step}, pair {pair}"
                )
                worst = max(worst, abs(dist - d0) / bound)
                compared += 1
        table = warm._warm
    assert warm.counters["fallbacks"] == ref.counters["fallbacks"] == 0  # every maximum proven global
    assert warm.counters["contacts"] == ref.counters["contacts"] > 1000
    assert compared > 1000
    # every ellipsoid contact of the last step is stored: key, contact bit, the normal reported to
    # MuJoCo (which normalises it again when it completes the contact frame: to a few ulps), and the
    # one of the step before, where the pair has moved
    normals = table.view(np.float64)
    slot = {int(k) >> 1: i for i, k in enumerate(table[:, 0]) if k}
    moved = 0
    for (g1, g2), (_dist, normal, _pos) in contacts(data).items():
        if model.geom_type[g1] == ELL and model.geom_type[g2] == ELL:
            k = slot[(g1 << 32) | g2]
            assert table[k, 0] & 1 == 1
            np.testing.assert_allclose(normals[k, 1:4], normal, rtol=0, atol=4e-15)
            moved += not np.array_equal(normals[k, 4:7], normal)
            assert np.linalg.norm(normals[k, 4:7] - normal) < 1e-2
    assert moved > 5
    assert not np.any(ref._warm)  # cold: no table


@pytest.mark.parametrize("pool", [0, 2], ids=["one thread", "MuJoCo's thread pool"])
@pytest.mark.parametrize("tiny", [False, True], ids=["table", "two-slot table"])
def test_shared_sets_and_mujoco_threads_stay_within_the_contract(monkeypatch, tiny, pool):
    """With two slots for every pair of a pile, keys share the one set: entries move and are dropped.
    With MuJoCo's thread pool on the data (mju_threadpool: MuJoCo 4.0 then runs one data's narrow
    phase on several threads, checked below), writes to a shared set interleave and a call may read a
    torn entry.  Either way a seed only chooses where Newton starts: contacts stay within the
    contract of cold ones, every maximum proven."""
    if tiny:
        monkeypatch.setattr(attachment, "warm_slots", lambda model: 2)
    model, data = settled(scenes.pile_xml(60, seed=2), 600)
    if pool:
        mujoco.mju_threadpool(data, pool)
    cold = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    rmin = model.geom_size.min(axis=1)
    with (
        em.attach(model, data, mode="narrowphase") as warm,
        em.attach(model, cold, mode="narrowphase", warm_start=False),
    ):
        for step in range(100):
            mujoco.mj_getState(model, data, state, FULL)
            mujoco.mj_setState(model, cold, state, FULL)
            mujoco.mj_forward(model, cold)
            mujoco.mj_step(model, data)
            got, want = contacts(data), contacts(cold)
            assert got.keys() == want.keys()
            for pair, (dist, _, _) in got.items():
                assert abs(dist - want[pair][0]) <= CONTRACT * rmin[list(pair)].min(), f"step {step}, pair {pair}"
        assert warm.counters["fallbacks"] == 0 and warm.counters["contacts"] > 3000
        if tiny:
            assert np.count_nonzero(warm._warm[:, 0]) == 2  # full, hence evicting


def test_mujocos_thread_pool_runs_one_datas_narrow_phase_on_several_threads():
    """What the test above relies on: with mju_threadpool, MuJoCo 4.0 calls the collision table's
    function for one data from more than one thread (here a Python function in the table, wrapping
    MuJoCo's own: it records the calling threads)."""
    import ctypes

    from ellipsim.mujoco import publish

    model, data = settled(scenes.pile_xml(60, seed=2), 300)
    mujoco.mju_threadpool(data, 2)
    table, n = publish.collision_table()
    fn = ctypes.CFUNCTYPE(
        ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
    )
    original, saved = fn(table[ELL * n + ELL]), table[ELL * n + ELL]
    callers = set()

    def recording(m, d, con, g1, g2, margin):
        callers.add(threading.get_ident())
        return original(m, d, con, g1, g2, margin)

    wrapper = fn(recording)
    table[ELL * n + ELL] = ctypes.cast(wrapper, ctypes.c_void_p).value
    try:
        for _ in range(5):
            mujoco.mj_step(model, data)
    finally:
        table[ELL * n + ELL] = saved
    assert len(callers) >= 2


def trajectory(model, data, steps, other=None):
    """qpos per step of `data` stepped attached in narrowphase mode; `other` (model, data): attached
    too and stepped between every two of data's steps."""
    out = np.empty((steps, model.nq))
    with em.attach(model, data, mode="narrowphase"):
        if other is None:
            for i in range(steps):
                mujoco.mj_step(model, data)
                out[i] = data.qpos
            return out
        with em.attach(*other, mode="narrowphase"):
            for i in range(steps):
                mujoco.mj_step(*other)
                mujoco.mj_step(model, data)
                out[i] = data.qpos
    return out


def test_each_data_has_its_own_table():
    """Data A alone, and A while data B of the same model (another state: other normals for the same
    geom pairs) and a data of another model are attached and stepped in between: A's trajectory is
    the same to the bit, and so is B's against B alone."""
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(30, seed=1))
    a0, b0 = mujoco.MjData(model), mujoco.MjData(model)
    for _ in range(300):
        mujoco.mj_step(model, a0)
    for _ in range(450):
        mujoco.mj_step(model, b0)
    state_a, state_b = np.empty(mujoco.mj_stateSize(model, FULL)), np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, a0, state_a, FULL)
    mujoco.mj_getState(model, b0, state_b, FULL)

    def fresh(state):
        d = mujoco.MjData(model)
        mujoco.mj_setState(model, d, state, FULL)
        return d

    alone_a = trajectory(model, fresh(state_a), 200)
    alone_b = trajectory(model, fresh(state_b), 200)
    with_b = trajectory(model, fresh(state_a), 200, other=(model, fresh(state_b)))
    np.testing.assert_array_equal(with_b, alone_a)
    b = fresh(state_b)
    with_a = trajectory(model, b, 200, other=(model, fresh(state_a)))
    np.testing.assert_array_equal(with_a, alone_b)
    other_model = mujoco.MjModel.from_xml_string(scenes.pile_xml(30, seed=7))
    with_other = trajectory(model, fresh(state_a), 200, other=(other_model, mujoco.MjData(other_model)))
    np.testing.assert_array_equal(with_other, alone_a)
    assert not np.array_equal(alone_a[-1], alone_b[-1])


def test_eight_threads_each_match_their_data_alone():
    """Eight Python threads stepping their own data at once, warm and cold starts mixed: each
    trajectory is its run alone, to the bit (no table shared across datas)."""
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(30, seed=5))
    steps = 150

    def run(warm):
        data = mujoco.MjData(model)
        out = np.empty((steps, model.nq))
        with em.attach(model, data, mode="narrowphase", warm_start=warm):
            for i in range(steps):
                mujoco.mj_step(model, data)
                out[i] = data.qpos
        return out

    expected = {True: run(True), False: run(False)}
    warms = [True, True, False, True, True, False, True, True]
    results, errors = [None] * len(warms), []
    start = threading.Barrier(len(warms))

    def work(k):
        try:
            start.wait()
            results[k] = run(warms[k])
        except Exception as exc:  # reported below with the thread's index
            errors.append((k, exc))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(warms))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for k, warm in enumerate(warms):
        np.testing.assert_array_equal(results[k], expected[warm], err_msg=f"thread {k}, warm_start {warm}")
    assert not np.array_equal(expected[True], expected[False])  # warm is not cold to the bit ...
    np.testing.assert_allclose(expected[True][:20], expected[False][:20], rtol=0, atol=1e-9)  # ... but close


def test_warm_start_flag_is_checked():
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(4, seed=1))
    with pytest.raises(ValueError, match="warm_start must be True or False, got 1"):
        em.attach(model, mujoco.MjData(model), mode="narrowphase", warm_start=1)


# --- the seeded kernel and the one-direction bound ------------------------------------------------


def _pairs(n, seed):
    """n random pairs (A, B) as vec3.load tuples: semi-axes 0.02-0.4 (up to 20:1), centres 0.1-1.3 of
    the sum of the largest semi-axes apart: deep crossings (the branch and bound), shallow contacts
    and separated pairs."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        pair = []
        for _ in range(2):
            q = rng.normal(size=4)
            m = np.zeros(9)
            mujoco.mju_quat2Mat(m, q / np.linalg.norm(q))
            pair.append((m, rng.uniform(0.02, 0.4, size=3)))
        (Ra, ra), (Rb, rb) = pair
        u = rng.normal(size=3)
        cb = u / np.linalg.norm(u) * rng.uniform(0.1, 1.3) * (ra.max() + rb.max())
        out.append((((0.0, 0.0, 0.0), tuple(Ra), tuple(ra)), (tuple(cb), tuple(Rb), tuple(rb))))
    return out


def test_any_seed_gives_the_cold_result_within_the_contract():
    """Seeds: the exact normal, a perturbed one, a random one, the opposite, zero, NaN and huge
    vectors (the bisector then): every result is proven and within the contract of the cold one."""
    rng = np.random.default_rng(3)
    pairs = _pairs(300, 11)
    checked = deep = 0
    for i, (A, B) in enumerate(pairs):
        st, dist, normal, pos, _ = pair_signed_distance(A, B)
        assert st == GLOBAL
        rmin = min(min(A[2]), min(B[2]))
        ra, rb = np.array(A[2]), np.array(B[2])
        deep += dist < -(ra.min() ** 2 / ra.max() + rb.min() ** 2 / rb.max())  # beyond the rolling radii
        n = np.array(normal)
        seeds = [
            n,
            n + 1e-3 * rng.normal(size=3),
            rng.normal(size=3),
            -n,
            np.zeros(3),
            np.full(3, np.nan),
            np.full(3, 1e300),
        ]
        for s in seeds:
            st2, d2, n2, p2, _ = pair_signed_distance_from(A, B, tuple(float(x) for x in s))
            assert st2 == GLOBAL
            assert abs(d2 - dist) <= CONTRACT * rmin, (i, s, d2, dist)
            checked += 1
    assert checked == 7 * len(pairs)
    assert deep >= 20


def test_sigma_lower_bound_is_below_the_distance_and_tight_at_the_normal():
    rng = np.random.default_rng(4)
    pairs = _pairs(300, 12)
    for A, B in pairs:
        _, dist, normal, _, _ = pair_signed_distance(A, B)
        scale = np.abs(np.subtract(B[0], A[0])).sum() + max(A[2]) + max(B[2])
        at_normal = sigma_lower_bound(A, B, normal)
        assert at_normal <= dist
        assert dist - at_normal <= 1e-13 * scale  # the allowance is 64 u S, ~7e-15 S
        for _ in range(5):
            assert sigma_lower_bound(A, B, tuple(rng.normal(size=3))) <= dist
    A, B = pairs[0]
    for bad in ((0.0, 0.0, 0.0), (math.nan, 0.0, 0.0), (1e300, 0.0, 0.0)):
        assert sigma_lower_bound(A, B, bad) == -math.inf
