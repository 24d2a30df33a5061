"""The C++ narrow phase (ellipsim/native/mujoco/narrowphase.hpp, issue 46), installed by ellipsim.mujoco.attach.

Each scene runs twice from fresh datas and must give the same counters and bit-identical trajectories and
contacts: mixed piles of every pair type, with margins and gaps, speculative contacts, explicit `<pair>` elements,
cold (no warm-start table); the warm-start table across mj_resetData and mj_setState (each rerun the first
run's, the warm start acting), two datas attached at once (each as if alone) and a data not attached beside them
(MuJoCo alone), MuJoCo's threads (rollouts on 1 and 3 threads alike, a thread pool), a fast ellipsoid stopped
by a thin plate under speculative contacts, and the fallback to MuJoCo's function for an unproven pair.
Called for a data not attached, the C++ function is MuJoCo's original for every pair type.
"""

import ctypes

import mujoco
import mujoco.rollout as rollout
import numpy as np
import pytest
from test_cylinder import cylinder_pile_xml
from test_explicit_pairs import column_xml
from test_reproducible import _unprovable_pair

import ellipsim.mujoco as em
import ellipsim.native as native
from ellipsim.app import scenes
from ellipsim.app.bench.validation import mixed_pile_xml
from ellipsim.mujoco import context, publish

ext = native.ext
NARROW_T = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double
)
FULL = mujoco.mjtState.mjSTATE_INTEGRATION


def both(procedure):
    """procedure() run twice (fresh models and datas inside): (first, second) results."""
    return procedure(), procedure()


def snapshot(data):
    """Everything a step leaves that the narrow phase decides: state and every contact field it sets."""
    c = data.contact[: data.ncon]
    return [data.qpos.copy(), data.qvel.copy(), c.dist.copy(), c.pos.copy(), c.frame.copy(), c.geom.copy()]


def steps(model, data, n):
    """The snapshots of n steps."""
    out = []
    for _ in range(n):
        mujoco.mj_step(model, data)
        out += snapshot(data)
    return out


def assert_identical(got, want):
    """Two lists of float or int arrays equal to the bit."""
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.dtype == w.dtype
        np.testing.assert_array_equal(g.view(np.uint8), w.view(np.uint8))


def attached_run(xml, n, warm_start=True):
    """(snapshots, counters) of a fresh data of xml stepped n steps, attached in mode narrowphase."""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    with em.attach(model, data, mode="narrowphase", warm_start=warm_start) as att:
        assert att.installed
        out = steps(model, data, n)
    return out, att.counters


def mixed_pile(seed, variant):
    xml = mixed_pile_xml(seed=seed)
    if variant == "margins":  # every geom (the per-geom 2 mm margins of the pile stay)
        xml = xml.replace("<worldbody>", '<default><geom margin="0.003" gap="0.001"/></default><worldbody>', 1)
    if variant == "speculative":
        xml = xml.replace(
            '<option timestep="0.002"/>', '<option timestep="0.002"><flag speculative="enable"/></option>'
        )
    if variant == "override":  # opt.o_margin for every pair
        xml = xml.replace(
            '<option timestep="0.002"/>',
            '<option timestep="0.002" o_margin="0.004"><flag override="enable"/></option>',
        )
    return xml


def test_compiled_against_the_running_mujoco():
    assert ext.mujoco.MUJOCO_VERSION == mujoco.mj_version()
    assert ext.mujoco.NARROWPHASE not in (0, ext.mujoco.FILTER)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("variant", ["plain", "margins", "speculative", "override"])
def test_mixed_piles(seed, variant):
    xml = mixed_pile(seed, variant)
    (want, wc), (got, gc) = both(lambda: attached_run(xml, 400))
    assert gc == wc and wc["contacts"] > 100 and wc["separated"] > 100
    if variant in ("margins", "override"):
        assert wc["apart"] > 0  # contacts measured apart beyond the margin
    assert_identical(got, want)


@pytest.mark.parametrize("margin", [0.0, 0.01])
def test_cylinder_piles(margin):
    """Ellipsoids and cylinders (test_cylinder's pile): deep rim contacts, the rim's branch and bound."""
    xml = cylinder_pile_xml(margin=margin)
    (want, wc), (got, gc) = both(lambda: attached_run(xml, 400))
    assert gc == wc and wc["contacts"] > 500
    assert_identical(got, want)


def test_mixed_pile_cold():
    """warm_start=False: no table (mask 0), every pair from the bisector seed."""
    xml = mixed_pile(2, "margins")
    (want, wc), (got, gc) = both(lambda: attached_run(xml, 300, warm_start=False))
    assert gc == wc and wc["contacts"] > 100
    assert_identical(got, want)


@pytest.mark.parametrize("n_dynamic, override", [(0, None), (4, (0, 3))])
def test_explicit_pairs(n_dynamic, override):
    """`<pair>` elements: their own margin and gap reach the narrow phase, their geoms never the filter."""
    xml = column_xml(n_dynamic=n_dynamic, override=override)
    (want, wc), (got, gc) = both(lambda: attached_run(xml, 500))
    assert gc == wc and wc["contacts"] > 100
    assert_identical(got, want)


def test_speculative_fast_ellipsoid():
    """A 0.05 m ellipsoid at 50 m/s at a thin ellipsoid plate, speculative contacts on (issue 18)."""
    xml = """<mujoco><option timestep="0.002" gravity="0 0 0"><flag speculative="enable"/></option>
      <worldbody><geom type="ellipsoid" size=".3 .3 .004" pos=".5 0 0" euler="0 90 0"/>
        <body pos="0 0 0"><freejoint/><geom type="ellipsoid" size=".05 .04 .03"/></body>
      </worldbody><keyframe><key qvel="50 0 0 0 0 0"/></keyframe></mujoco>"""

    def run():
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        with em.attach(model, data, mode="narrowphase") as att:
            out = steps(model, data, 40)
        return out, att.counters

    (want, wc), (got, gc) = both(run)
    assert gc == wc and wc["calls"] > 0
    assert_identical(got, want)
    assert want[-6][0] < 0.58  # stopped at the plate, as in plain MuJoCo


def test_reset_and_set_state_rerun():
    """The warm-start table's epochs: a pile stepped, reset, stepped again, set back (time goes back) and
    forward (time jumps ahead) to a saved state: each rerun the first run's, and the same bits from a fresh data."""
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(30, seed=5))

    def run():
        data = mujoco.MjData(model)
        state = np.empty(mujoco.mj_stateSize(model, FULL))
        with em.attach(model, data, mode="narrowphase") as att:
            first = steps(model, data, 200)
            mujoco.mj_resetData(model, data)
            again = steps(model, data, 100)
            mujoco.mj_getState(model, data, state, FULL)
            after = steps(model, data, 100)
            mujoco.mj_setState(model, data, state, FULL)  # back by 100 steps
            back = steps(model, data, 50)
            mujoco.mj_resetData(model, data)
            steps(model, data, 20)
            mujoco.mj_setState(model, data, state, FULL)  # ahead by 80 steps
            ahead = steps(model, data, 50)
        return first, again + after, back, ahead, att.counters

    want, got = both(run)
    assert got[-1] == want[-1] and want[-1]["contacts"] > 1000
    for g, w in zip(got[:-1], want[:-1]):
        assert_identical(g, w)
    first, rerun, back, ahead, _ = got
    assert_identical(rerun, first)  # after a reset: a fresh data's trajectory
    assert_identical(ahead, back)  # from one state, each a new epoch: a fresh data set to it
    assert not all(np.array_equal(g, w) for g, w in zip(back, first[6 * 100 : 6 * 150]))  # warm start acts


def test_two_datas_attached_at_once_and_one_not():
    """Two datas of one model attached together, stepped in turn from different velocities, each with its own
    table and counters (each as if attached alone); a third, not attached, steps as MuJoCo alone (MuJoCo's original
    functions)."""
    model = mujoco.MjModel.from_xml_string(mixed_pile(3, "margins"))
    plain = mujoco.MjData(model)
    alone = steps(model, plain, 200)

    def run():
        d1, d2, other = mujoco.MjData(model), mujoco.MjData(model), mujoco.MjData(model)
        d2.qvel[:] = np.random.default_rng(0).normal(0, 0.3, model.nv)
        out1, out2, out3 = [], [], []
        with em.attach(model, d1, mode="narrowphase") as a1, em.attach(model, d2, mode="narrowphase") as a2:
            for _ in range(200):
                out1 += steps(model, d1, 1)
                out2 += steps(model, d2, 1)
                out3 += steps(model, other, 1)
        return out1, out2, out3, a1.counters, a2.counters

    want, got = both(run)
    assert got[3:] == want[3:] and want[3] != want[4] and want[4]["contacts"] > 100
    for g, w in zip(got[:3], want[:3]):
        assert_identical(g, w)
    assert_identical(got[2], alone)
    for k, qvel in ((0, None), (1, np.random.default_rng(0).normal(0, 0.3, model.nv))):
        d = mujoco.MjData(model)
        if qvel is not None:
            d.qvel[:] = qvel
        with em.attach(model, d, mode="narrowphase") as att:
            assert_identical(got[k], steps(model, d, 200))
        assert att.counters == got[3 + k]


def test_rollouts_on_threads():
    """mujoco.rollout on attached datas (one per thread), from 6 initial states: on 3 threads as on 1, twice."""
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(20, seed=7))
    base = mujoco.MjData(model)
    s0 = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, base, s0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    states = np.tile(s0, (6, 1))
    states[:, 1 + model.nq : 1 + model.nq + model.nv] = np.random.default_rng(0).normal(0, 0.5, (6, model.nv))

    def run(nthread):
        datas = [mujoco.MjData(model) for _ in range(nthread)]
        atts = [em.attach(model, d, mode="narrowphase") for d in datas]
        for a in atts:
            a.__enter__()
        try:
            state, sensor = rollout.rollout(model, datas, states, nstep=120)
        finally:
            for a in atts:
                a.__exit__(None, None, None)
        return state, sum(a.counters["contacts"] for a in atts)

    (want, wn), (got, gn) = run(1), run(3)
    assert gn == wn > 0
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    again, an = run(3)
    assert an == wn
    np.testing.assert_array_equal(again.view(np.int64), want.view(np.int64))


def test_mujocos_thread_pool():
    """One data's narrow phase on MuJoCo's thread pool (mju_threadpool: several threads call the table for
    one data).  Cold, so that no two threads share a table set: the same bits twice."""
    xml = scenes.pile_xml(40, seed=2)

    def run():
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        mujoco.mju_threadpool(data, 2)
        with em.attach(model, data, mode="narrowphase", warm_start=False) as att:
            out = steps(model, data, 300)
        return out, att.counters

    (want, wc), (got, gc) = both(run)
    assert gc == wc and wc["contacts"] > 1000
    assert_identical(got, want)


def test_unproven_pair_falls_back():
    """A pair the branch and bound cannot prove: MuJoCo's function runs (a fallback), and the contact
    carries the better of its normal and ellipsim's; the same bits twice."""
    a, b = _unprovable_pair()
    from scipy.spatial.transform import Rotation as Rot

    def body(e):
        f = lambda v: " ".join(repr(float(x)) for x in v)
        q = Rot.from_matrix(e.rotations[0]).as_quat(scalar_first=True)
        return (
            f'<body pos="{f(e.centers[0])}" quat="{f(q)}"><freejoint/><inertial pos="0 0 0" mass="1" '
            f'diaginertia="1 1 1"/><geom type="ellipsoid" size="{f(e.radii[0])}"/></body>'
        )

    xml = f"<mujoco><worldbody>{body(a)}{body(b)}</worldbody></mujoco>"

    def run():
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        with em.attach(model, data, mode="narrowphase") as att:
            mujoco.mj_forward(model, data)
        return snapshot(data), att.counters

    (want, wc), (got, gc) = both(run)
    assert gc == wc and wc["fallbacks"] == 1 and len(want[2]) == 1
    assert_identical(got, want)


def test_unattached_call_is_mujocos_function():
    """Called directly for a data not attached, the C++ function answers with MuJoCo's original for each row
    of context.PAIR_TYPES (through the context's fallback words)."""
    publish.fill_context()
    model = mujoco.MjModel.from_xml_string(mixed_pile_xml(seed=0))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ours = NARROW_T(ext.mujoco.NARROWPHASE)
    table, n = publish.collision_table()
    tried = 0
    for row in context.PAIR_TYPES:
        g1 = int(np.flatnonzero(model.geom_type == row.type1)[0])
        g2 = int(np.flatnonzero(model.geom_type == row.type2)[-1])
        theirs = NARROW_T(table[row.type1 * n + row.type2])
        for margin in (0.0, 10.0):  # apart, and in contact within a large margin
            # room for mjMAXCONPAIR mjPreContacts (10 doubles each): a height field's call fills up to 50
            got, want = np.zeros(50 * 10), np.zeros(50 * 10)
            r1 = ours(model._address, data._address, got.ctypes.data, g1, g2, margin)
            r2 = theirs(model._address, data._address, want.ctypes.data, g1, g2, margin)
            assert r1 == r2
            np.testing.assert_array_equal(got, want)
            tried += r1
    assert tried >= len(context.PAIR_TYPES)
