"""ellipsim changes only the datas it is attached to: every other data, of the same model or another,
gets MuJoCo's own result to the bit, in both modes, also from several threads at once."""

import ctypes
import threading

import mujoco
import numpy as np
import pytest
from test_capsule import capsule_pile_xml

import ellipsim.mujoco as em
from ellipsim.app import scenes
from ellipsim.mujoco import publish

ELL = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)

STEPS = 400


def pile(seed):
    return mujoco.MjModel.from_xml_string(scenes.pile_xml(30, seed=seed))


def capsule_pile(seed):
    """A pile of capsules and ellipsoids (test_capsule.py): capsule x ellipsoid pairs, which the narrow
    phase handles too."""
    return mujoco.MjModel.from_xml_string(capsule_pile_xml(30, seed=seed))


def plain_run(model, steps=STEPS):
    """qpos per step of plain MuJoCo from the initial state: the reference."""
    data = mujoco.MjData(model)
    out = np.empty((steps, model.nq))
    for i in range(steps):
        mujoco.mj_step(model, data)
        out[i] = data.qpos
    return out


@pytest.mark.parametrize("mode", em.MODES)
@pytest.mark.parametrize("make", [pile, capsule_pile])
def test_other_data_of_the_same_model_is_plain_mujoco(mode, make):
    model = make(1)
    if make is capsule_pile:
        assert (model.geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE).sum() == 15
    reference = plain_run(model)
    mine, other = mujoco.MjData(model), mujoco.MjData(model)
    got = np.empty_like(reference)
    with em.attach(model, mine, mode=mode) as att:
        for i in range(STEPS):
            mujoco.mj_step(model, mine)  # interleaved: the attached data steps between the other's steps
            mujoco.mj_step(model, other)
            got[i] = other.qpos
    np.testing.assert_array_equal(got, reference)
    counts = att.counters
    assert (counts["contacts"] if mode == "narrowphase" else counts["discarded"]) > 100  # ellipsim did work on `mine`


@pytest.mark.parametrize("mode", em.MODES)
def test_other_models_are_plain_mujoco(mode):
    m1, m2, m3 = pile(1), pile(2), mujoco.MjModel.from_xml_string(scenes.scene_xml(2, layout="pile", seed=3))
    refs = [plain_run(m) for m in (m2, m3)]
    d1, d2, d3 = (mujoco.MjData(m) for m in (m1, m2, m3))
    got = [np.empty_like(r) for r in refs]
    with em.attach(m1, d1, mode=mode):
        for i in range(STEPS):
            for m, d in ((m1, d1), (m2, d2), (m3, d3)):
                mujoco.mj_step(m, d)
            got[0][i], got[1][i] = d2.qpos, d3.qpos
    for g, r in zip(got, refs):
        np.testing.assert_array_equal(g, r)


def test_geom_distance_of_a_data_not_attached_is_mujocos_own_function():
    """mj_geomDistance calls the table's function with margin = distmax, except that it takes a
    distance-only GJK path when the entry is MuJoCo's own mjc_Convex (engine_support.c: `func ==
    mjc_Convex`).  With ellipsim's function installed, a data that is not attached gets mjc_Convex
    itself, to the bit: MuJoCo's answer, not ellipsim's (the distance-only path is out of reach
    while the table holds another function; the two MuJoCo paths agree to its ccd_tolerance)."""
    model = pile(4)
    data, mine = mujoco.MjData(model), mujoco.MjData(model)
    for _ in range(300):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, mine)
    ell = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    pairs = [(int(a), int(b)) for a in ell[:12] for b in ell[:12] if a < b]
    table, n = publish.collision_table()
    convex = ctypes.CFUNCTYPE(
        ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
    )(table[ELL * n + ELL])
    con = np.zeros(64 * 64)  # room for mjMAXCONPAIR mjContact structs
    distmax = 0.2

    def mujoco_convex(a, b):
        k = convex(model._address, data._address, con.ctypes.data, a, b, distmax)
        assert k <= 1  # one contact per ellipsoid pair; its first field is dist
        return con[0] if k else distmax

    fromto = np.zeros(6)
    expected = [mujoco_convex(a, b) for a, b in pairs]
    with em.attach(model, mine, mode="narrowphase"):
        during = [mujoco.mj_geomDistance(model, data, a, b, distmax, fromto) for a, b in pairs]
        with em.attach(model, data, mode="narrowphase"):
            ours = [mujoco.mj_geomDistance(model, data, a, b, distmax, fromto) for a, b in pairs]
    assert sum(d < 0 for d in expected) >= 3  # penetrating pairs, where the methods differ most
    assert during == expected
    assert max(abs(x - y) for x, y in zip(ours, expected)) > 1e-9  # attached: ellipsim's answer


def test_threads_stepping_attached_and_plain_datas_at_once():
    """Eight Python threads, each with its own data: half attached (narrowphase or filter), half not.
    The plain ones match plain MuJoCo to the bit; the attached ones match the same mode run alone."""
    model = pile(5)
    steps = 200
    reference = plain_run(model, steps)

    def alone(mode):
        data = mujoco.MjData(model)
        out = np.empty((steps, model.nq))
        with em.attach(model, data, mode=mode):
            for i in range(steps):
                mujoco.mj_step(model, data)
                out[i] = data.qpos
        return out

    expected = {"narrowphase": alone("narrowphase"), "filter": alone("filter"), None: reference}
    modes = ["narrowphase", None, "filter", None, "narrowphase", None, "filter", None]
    results, errors = [None] * len(modes), []
    start = threading.Barrier(len(modes))

    def work(k):
        try:
            data = mujoco.MjData(model)
            out = np.empty((steps, model.nq))
            start.wait()
            if modes[k] is None:
                for i in range(steps):
                    mujoco.mj_step(model, data)
                    out[i] = data.qpos
            else:
                with em.attach(model, data, mode=modes[k]):
                    for i in range(steps):
                        mujoco.mj_step(model, data)
                        out[i] = data.qpos
            results[k] = out
        except Exception as exc:  # reported below with the thread's index
            errors.append((k, exc))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(modes))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for k, mode in enumerate(modes):
        np.testing.assert_array_equal(results[k], expected[mode], err_msg=f"thread {k}, mode {mode}")
    np.testing.assert_array_equal(expected["filter"], reference)  # the filter never changes a trajectory
