"""The stepping loop (stepping.FrameLoop) that simulate.run, replay.replay and sweep's mode pass share:
every frame and every contact between frames reaches the caller and the recorder, in order, whatever
the chunking; and run and replay, through it, see the same frames of the same poses."""

import mujoco
import numpy as np
import pytest
from test_between_frames import FPS, PLATE_XML

from ellipsim.app import capture, scenario, simulate
from ellipsim.app import replay as rp
from ellipsim.app.stepping import FrameLoop

# The plate and pellet of tests/test_between_frames.py (its keyframe unused: poses are set per frame):
# the pellet passes through the plate between frames 1 and 2 and again between frames 4 and 5,
# touching it at no frame.
HEIGHTS = [0.5, 0.26, -0.24, -0.5, -0.26, 0.24, 0.5, 0.01, 0.3]


class Calls:
    """A stand-in for record.Recorder that notes what it is sent."""

    def __init__(self):
        self.geometry, self.frames, self.events = None, [], []

    def begin(self, geometry):
        self.geometry = geometry

    def write(self, frames):
        self.frames.append(frames.frame.copy())

    def write_events(self, frame, time, until, point, label, text):
        self.events += [(int(f), lab) for f, lab in zip(frame, label)]


def play(model, every, background):
    """FrameLoop over HEIGHTS (a pose a step): (chunks' frame numbers and times, loop, Calls)."""
    data = mujoco.MjData(model)
    seen, calls = [], Calls()

    def pose(k):
        data.qpos[:] = [0, 0, 0, 1, 0, 0, 0, 0, 0, HEIGHTS[k], 1, 0, 0, 0]
        data.time = k / FPS
        mujoco.mj_fwdPosition(model, data)

    loop = FrameLoop(model, recorder=calls, title="plate", on_chunk=seen.append, between=True, background=background)
    loop.run(data, len(HEIGHTS), pose, every=every)
    frames = np.concatenate([c.frames.frame for c in seen])
    times = np.concatenate([c.frames.times for c in seen])
    return frames, times, loop, calls


@pytest.mark.parametrize("background", [False, True])
@pytest.mark.parametrize("capacity", [1024, 3, 1])
def test_every_frame_and_contact_between_frames_reaches_the_caller_and_the_recorder(capacity, background, monkeypatch):
    monkeypatch.setattr(capture, "MAX_CHUNK_FRAMES", capacity)
    monkeypatch.setattr(capture, "BETWEEN_STRIDE", 2)
    model = mujoco.MjModel.from_xml_string(PLATE_XML)
    frames, times, loop, calls = play(model, 1, background)
    assert frames.tolist() == list(range(len(HEIGHTS)))
    np.testing.assert_array_equal(times, np.arange(len(HEIGHTS)) / FPS)
    assert np.concatenate(calls.frames).tolist() == frames.tolist()  # each chunk once, in order
    assert calls.geometry.name == "plate" and calls.geometry.geom_names == ["plate", "pellet"]
    events = loop.events()
    assert events.frame.tolist() == [1, 4]
    assert calls.events == [(1, "plate / pellet"), (4, "plate / pellet")]
    assert loop.seconds >= 0 and loop.analysis_seconds > 0 and loop.record_seconds >= 0
    assert loop.buffer._worker is None  # closed


def test_a_frame_every_k_steps_from_the_first():
    model = mujoco.MjModel.from_xml_string(PLATE_XML)
    frames, times, loop, calls = play(model, 4, False)
    assert frames.tolist() == [0, 1, 2] and np.allclose(times, [0.0, 0.4, 0.8])
    assert loop.events().frame.tolist() == [0, 1]  # 0.5 -> -0.26 -> 0.3: through the plate between both
    assert calls.events == [(0, "plate / pellet"), (1, "plate / pellet")]


def test_run_and_replay_see_the_same_frames_of_the_same_poses():
    """A kinematic scenario run (40 poses by mj_forward, contacts between frames inline) against its
    poses replayed (mj_fwdPosition, contacts between frames in the background): equal per-frame
    counts and events; times agree to rounding (k * timestep against k / fps)."""
    table, path = scenario.source_table("replay")
    s = scenario.from_table({**table, "timestep": 0.1}, path)  # coarse frames: limbs pass through each other
    steps = s.steps
    run = simulate.run(s, between=True)
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    motion = np.empty((steps, model.nq))
    for k in range(steps):
        data.qpos[control.qadr] = control(k * s.timestep)
        motion[k] = data.qpos
    played = rp.replay(model, motion, fps=1 / s.timestep, between=True)
    fr = run.frames
    np.testing.assert_array_equal(played.in_contact, fr.ellipsim_counts)
    np.testing.assert_array_equal(played.touching, fr.touching_counts)
    np.testing.assert_array_equal(played.mujoco_contacts, fr.contact_counts)
    np.testing.assert_array_equal(played.mujoco_pairs, fr.builtin_counts)
    assert fr.ellipsim_counts.sum() > 0 and len(run.between) > 5
    replayed = played.between_events()
    assert [(d["frame"], d["geoms"], d["status"]) for d in replayed] == [
        (d["frame"], d["geoms"], d["status"]) for d in run.between
    ]
    for a, b in zip(replayed, run.between):
        assert a["t_begin"] == pytest.approx(b["t_begin"], abs=1e-9) and a["t_end"] == pytest.approx(
            b["t_end"], abs=1e-9
        )


def test_events_are_none_when_not_looked_for():
    model = mujoco.MjModel.from_xml_string(PLATE_XML)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    loop = FrameLoop(model)
    loop.run(data, 3, lambda k: None)
    assert loop.events() is None and loop.buffer.between is None
