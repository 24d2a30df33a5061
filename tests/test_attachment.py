"""The contact pre-filter against plain MuJoCo: same trajectories, real discards, clean attach/detach."""

import ctypes

import mujoco
import mujoco.rollout
import numpy as np
import pytest

import ellipsim.mujoco as plugin
from ellipsim.mujoco import attachment as attach_module
from ellipsim.native import ext

PILE = """<mujoco><option timestep="0.002"/><worldbody>
  <geom type="plane" size="2 2 .1"/>
  <geom type="box" size=".5 .02 .3" pos="0 .55 .3"/><geom type="box" size=".5 .02 .3" pos="0 -.55 .3"/>
  <geom type="box" size=".02 .5 .3" pos=".55 0 .3"/><geom type="box" size=".02 .5 .3" pos="-.55 0 .3"/>
  {bodies}
</worldbody></mujoco>"""


def pile_xml(n=40, geom_extra=""):
    bodies = "".join(
        f'<body pos="{0.25 * (i % 4) - 0.375} {0.25 * ((i // 4) % 4) - 0.375} {0.2 + 0.25 * (i // 16)}" '
        f'euler="{i * 17} {i * 29} {i * 7}"><freejoint/>'
        f'<geom type="ellipsoid" size="{0.05 + 0.01 * (i % 5)} {0.07 + 0.01 * (i % 3)} 0.11" {geom_extra}/></body>'
        for i in range(n)
    )
    return PILE.format(bodies=bodies)


def chain_xml(n=10):
    """An articulated chain of ellipsoids, coiled so that non-adjacent links meet as it falls."""
    body = ""
    for i in reversed(range(n)):
        axis = "0 1 0" if i % 2 else "1 0 1"
        inner = body
        body = (
            f'<body pos="{0.0 if i == 0 else 0.16} 0 0" euler="0 {10 * (i % 2)} {0 if i == 0 else 38}">'
            + ("<freejoint/>" if i == 0 else f'<joint type="hinge" axis="{axis}" range="-120 120" damping=".01"/>')
            + f'<geom type="ellipsoid" size=".09 .04 .03" pos=".08 0 0"/>{inner}</body>'
        )
    return f"""<mujoco><compiler angle="degree"/><option timestep="0.002"/><worldbody>
      <geom type="plane" size="3 3 .1"/><body pos="0 0 .5" euler="0 20 40">{body[body.index(">") + 1 :]}
    </worldbody></mujoco>"""


MIXED = """<mujoco><option timestep="0.002"/><worldbody>
  <geom type="plane" size="2 2 .1"/>
  <body pos="0 0 .3"><freejoint/><geom type="ellipsoid" size=".1 .07 .05" margin=".01" gap=".004"/></body>
  <body pos=".05 .02 .5"><freejoint/><geom type="sphere" size=".06"/></body>
  <body pos="-.04 0 .7"><freejoint/><geom type="box" size=".05 .04 .03"/></body>
  <body pos=".02 -.03 .9"><freejoint/><geom type="capsule" size=".03 .06"/></body>
  <body pos="0 .04 1.1"><freejoint/><geom type="cylinder" size=".04 .05"/></body>
  <body pos=".03 0 1.3"><freejoint/><geom type="ellipsoid" size=".05 .09 .06" contype="2" conaffinity="2"/></body>
  <body pos="-.02 .01 1.5"><freejoint/><geom type="ellipsoid" size=".08 .05 .05" contype="1" conaffinity="2"/></body>
  <body pos=".01 .02 1.7"><freejoint/><geom type="sphere" size=".05" contype="4" conaffinity="4"/></body>
</worldbody></mujoco>"""


def simulate(model, steps, attached=False):
    """qpos per step and ncon per step, from the model's initial state."""
    data = mujoco.MjData(model)
    qpos, ncon = np.empty((steps, model.nq)), np.empty(steps, dtype=int)
    att = plugin.attach(model, data) if attached else None
    with att if attached else _nothing():
        for i in range(steps):
            mujoco.mj_step(model, data)
            qpos[i], ncon[i] = data.qpos, data.ncon
    return qpos, ncon, att


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def assert_bit_identical(model, steps):
    q0, n0, _ = simulate(model, steps)
    q1, n1, att = simulate(model, steps, attached=True)
    np.testing.assert_array_equal(n1, n0)
    np.testing.assert_array_equal(q1, q0)  # exact equality, every step
    return att.counters, n0


def test_pile_is_bit_identical_and_pairs_are_discarded():
    counters, ncon = assert_bit_identical(mujoco.MjModel.from_xml_string(pile_xml()), 800)
    assert ncon.max() > 20  # a real pile with many contacts
    assert counters["discarded"] > 1000 and counters["passed"] > 1000
    assert counters["seen"] == counters["discarded"] + counters["passed"]


def test_articulated_chain_is_bit_identical():
    model = mujoco.MjModel.from_xml_string(chain_xml())
    counters, ncon = assert_bit_identical(model, 1000)
    assert ncon.max() >= 3 and counters["discarded"] > 0


@pytest.mark.parametrize("extra", ['margin="0.02"', 'margin="0.01" gap="0.005"', 'gap="0.03"'])
def test_margin_and_gap_lose_no_contact(extra):
    counters, _ = assert_bit_identical(mujoco.MjModel.from_xml_string(pile_xml(24, extra)), 500)
    assert counters["discarded"] > 0


def test_global_margin_override_loses_no_contact():
    model = mujoco.MjModel.from_xml_string(pile_xml(24))
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_OVERRIDE
    model.opt.o_margin = 0.03
    counters, _ = assert_bit_identical(model, 500)
    assert counters["discarded"] > 0


def test_other_geom_types_and_bitmasks_pass_through_unchanged():
    model = mujoco.MjModel.from_xml_string(MIXED)
    counters, ncon = assert_bit_identical(model, 800)
    assert ncon.max() >= 5


def call_filter(model, data, g1, g2):
    fn = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int)(ext.mujoco.FILTER)
    return fn(model._address, data._address, g1, g2)


def test_callback_decisions_pair_by_pair():
    xml = """<mujoco><worldbody>
      <geom name="e1" type="ellipsoid" size=".1 .2 .3"/>
      <geom name="e2" type="ellipsoid" size=".1 .2 .3" pos="2 0 0"/>
      <geom name="box" type="box" size=".1 .1 .1" pos="0 3 0"/>
      <geom name="s1" type="sphere" size=".1" pos="0 0 3"/>
      <geom name="s2" type="sphere" size=".1" pos="0 0 -3"/>
      <geom name="e3" type="ellipsoid" size=".1 .2 .3" pos=".15 0 0"/>
      <geom name="off" type="ellipsoid" size=".1 .2 .3" pos="5 5 5" contype="2" conaffinity="2"/>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    g = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, i): i for i in range(m.ngeom)}
    with plugin.attach(m, d, mode="filter") as att:
        assert call_filter(m, d, g["e1"], g["e2"]) == 1  # proven separated
        assert call_filter(m, d, g["e1"], g["e3"]) == 0  # overlapping: MuJoCo must see it
        assert call_filter(m, d, g["e1"], g["s1"]) == 1  # sphere-ellipsoid, separated
        assert call_filter(m, d, g["e1"], g["box"]) == 0  # not ours: passes untouched
        assert call_filter(m, d, g["s1"], g["s2"]) == 0  # sphere-sphere: MuJoCo's own
        assert call_filter(m, d, g["e1"], g["off"]) == 1  # contype/conaffinity mismatch
        assert call_filter(m, d, g["box"], g["off"]) == 1  # ... for any geom types
    assert att.counters == {"seen": 3, "discarded": 2, "passed": 1}
    other = mujoco.MjData(m)  # not attached: MuJoCo's bitmask test only, nothing discarded or counted
    mujoco.mj_forward(m, other)
    assert call_filter(m, other, g["e1"], g["e2"]) == 0 and call_filter(m, other, g["e1"], g["off"]) == 1


def test_attach_detach_restores_mujoco_state():
    model = mujoco.MjModel.from_xml_string(pile_xml(8))
    d1, d2 = mujoco.MjData(model), mujoco.MjData(model)
    assert mujoco.get_mjcb_contactfilter() is None
    with plugin.attach(model, d1) as a1:
        assert a1.installed and mujoco.get_mjcb_contactfilter() is not None
        with plugin.attach(model, d2):
            pass
        assert mujoco.get_mjcb_contactfilter() is not None  # still needed by d1
    assert mujoco.get_mjcb_contactfilter() is None
    with pytest.raises(RuntimeError, match="boom"):
        with plugin.attach(model, d1):
            raise RuntimeError("boom")
    assert mujoco.get_mjcb_contactfilter() is None and not attach_module._state["attached"]


def test_scene_without_ellipsoid_pairs_installs_nothing():
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="1 1 .1"/><body pos="0 0 1"><freejoint/>'
        '<geom type="ellipsoid" size=".1 .1 .2"/></body><body pos="0 0 2"><freejoint/><geom type="box" size=".1 .1 .1"/></body>'
        "</worldbody></mujoco>"
    )
    with plugin.attach(model, mujoco.MjData(model)) as att:
        assert not att.installed and mujoco.get_mjcb_contactfilter() is None


def test_misuse_is_a_clear_error():
    model = mujoco.MjModel.from_xml_string(pile_xml(4))
    other = mujoco.MjModel.from_xml_string(pile_xml(5))
    data = mujoco.MjData(model)
    with pytest.raises(ValueError, match="data belongs to another model"):
        plugin.attach(model, mujoco.MjData(other))
    with pytest.raises(ValueError, match="mode must be one of"):
        plugin.attach(model, data, mode="gjk")
    with pytest.raises(ValueError, match="model must be a mujoco.MjModel, got str"):
        plugin.attach("model.xml", data)
    with plugin.attach(model, data):
        with pytest.raises(ValueError, match="already attached"):
            with plugin.attach(model, data):
                pass
    mujoco.set_mjcb_contactfilter(lambda m, d, g1, g2: 0)
    try:
        with pytest.raises(ValueError, match="already installed"):
            with plugin.attach(model, data):
                pass
    finally:
        mujoco.set_mjcb_contactfilter(None)


def test_two_models_attached_at_once():
    m1 = mujoco.MjModel.from_xml_string(pile_xml(20))
    m2 = mujoco.MjModel.from_xml_string(chain_xml())
    plain = [simulate(m, 400)[0] for m in (m1, m2)]
    d1, d2 = mujoco.MjData(m1), mujoco.MjData(m2)
    q1, q2 = np.empty_like(plain[0]), np.empty_like(plain[1])
    with plugin.attach(m1, d1) as a1, plugin.attach(m2, d2) as a2:
        for i in range(400):  # interleaved
            mujoco.mj_step(m1, d1)
            mujoco.mj_step(m2, d2)
            q1[i], q2[i] = d1.qpos, d2.qpos
    np.testing.assert_array_equal(q1, plain[0])
    np.testing.assert_array_equal(q2, plain[1])
    assert a1.counters["discarded"] > 0 and a2.counters["seen"] > 0


def test_threaded_rollout_is_bit_identical():
    model = mujoco.MjModel.from_xml_string(pile_xml(16))
    datas = [mujoco.MjData(model) for _ in range(2)]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, datas[0], state0, spec)
    states = np.tile(state0, (4, 1))
    states[:, 1 + 2] += [0.0, 0.01, 0.02, 0.03]  # 4 rollouts over 2 threads, first body raised a little
    plain, _ = mujoco.rollout.rollout(model, datas, states, nstep=300)
    with plugin.attach(model, datas[0]) as a0, plugin.attach(model, datas[1]):
        filtered, _ = mujoco.rollout.rollout(model, datas, states, nstep=300)
    np.testing.assert_array_equal(filtered, plain)
    assert a0.counters["discarded"] > 0


def test_validation_counts_and_explains():
    model = mujoco.MjModel.from_xml_string(pile_xml(24))
    v = plugin.validate(model, mujoco.MjData(model), 300)
    totals = v.totals()
    assert v.counts.shape == (300, 4) and totals["both"] > 100 and totals["neither"] > 100
    # Every disagreement is a near-tangent pair: MuJoCo's tolerance, not a real miss.
    for dis in v.disagreements:
        assert dis.right == "ellipsim" and abs(dis.geom_distance) < 1e-5 and abs(dis.contact_scale - 1) < 1e-4


def test_validation_catches_a_contact_within_mujocos_tolerance():
    """Ellipsoids 1e-8 apart: the exact test says separated; MuJoCo (ccd_tolerance 1e-6) may not."""
    gap = 1e-8
    xml = f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>
      <body pos="{0.25 + gap} 0 0"><freejoint/><geom type="ellipsoid" size=".15 .1 .2"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    v = plugin.validate(model, mujoco.MjData(model), 1)
    assert v.counts[0, 0] == 0 and v.counts[0, 3] == 0  # ellipsim never calls it a contact
    if v.counts[0, 2]:  # MuJoCo did: the report says who is right
        (dis,) = v.disagreements
        assert dis.mujoco_contact and dis.relation == "separated" and dis.right == "ellipsim"
    with pytest.raises(ValueError, match="nstep must be a positive integer, got 0"):
        plugin.validate(model, mujoco.MjData(model), 0)
