"""Recording MuJoCo's candidate pairs: the buffer grows with the candidates, and nothing is lost."""

import mujoco
import numpy as np

from ellipsim.app import scenes
from ellipsim.mujoco.geoms import PairRecorder, candidate_pairs


def test_recorder_grows_its_buffer_and_loses_no_pair():
    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(40, seed=2))
    data = mujoco.MjData(model)
    for _ in range(800):  # settled: many touching pairs
        mujoco.mj_step(model, data)
    full = candidate_pairs(model, data)
    assert len(full) > 40
    recorder = PairRecorder(model, data)
    recorder.capacity = 3  # overflows on the first step
    with recorder:
        again = recorder.forward()
        assert recorder.capacity >= len(full)
        np.testing.assert_array_equal(again, full)
        np.testing.assert_array_equal(recorder.forward(), full)  # the grown buffer is kept
    assert mujoco.get_mjcb_contactfilter() is None
