"""`ellipsim fix` and fix.fix_motion: corrected motions proven apart, clean motions untouched, limits kept,
pairs that cannot be freed reported, one-line errors.

The checks are independent of fix.py's own loop: every frame's candidate pairs are found again (MuJoCo's
rules, bounding spheres grown by the clearance) and their distances recomputed by the proven signed
distance."""

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import ellipsim as es
from ellipsim.app import scenes
from ellipsim.app.cli import main
from ellipsim.app.cli.fix import side_by_side
from ellipsim.app.fix import fix_motion
from ellipsim.mujoco.geoms import ellipsoid_geoms, frame_pairs


def cli(*args):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True)


#: B slides on a joint limited to [0, 0.01] m, A fixed: the two overlap whatever the slide does
HELD = """<mujoco><worldbody>
  <body name="a"><geom name="ga" type="ellipsoid" size="0.3 0.2 0.1"/></body>
  <body name="b" pos="0.2 0 0"><joint name="slide" type="slide" axis="1 0 0" range="0 0.01"/>
    <geom name="gb" type="ellipsoid" size="0.3 0.2 0.1"/></body>
</worldbody></mujoco>"""


def _facing(spacing=0.5):
    return mujoco.MjModel.from_xml_string(scenes.scene_xml(2, layout="facing", spacing=spacing))


def _reaching_motion(model, frames=40, seed=0, amplitude=0.8):
    """From the rest pose to a random pose of every hinge (the free roots stay): limbs cross."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, frames)[:, None]
    hinge = np.zeros(model.nq, dtype=bool)
    for j in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE):
        hinge[model.jnt_qposadr[j]] = True
    target = model.qpos0 + hinge * rng.normal(size=model.nq) * amplitude
    return model.qpos0[None] * (1 - t) + target[None] * t


def closest(model, motion, clearance):
    """(F,) the smallest proven distance over each frame's candidate pairs (grown by the clearance)."""
    ids, radii, rules = ellipsoid_geoms(model)
    data = mujoco.MjData(model)
    out = np.full(len(motion), np.inf)
    for f, q in enumerate(motion):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        pairs = ids[frame_pairs(data.geom_xpos[ids][None], radii + clearance, rules)[:, 1:]]
        if not len(pairs):
            continue
        size = model.geom_size.copy()
        sphere = model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE
        size[sphere] = size[sphere, :1]
        body = lambda g: es.Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(-1, 3, 3), size[g])
        dist, _, _, status = es.signed_distance(body(pairs[:, 0]), body(pairs[:, 1]))
        assert (status == es.DistanceStatus.GLOBAL).all()
        out[f] = dist.min()
    return out


@pytest.mark.parametrize("metric", ["mass", "identity"])
def test_fixed_motion_keeps_the_clearance_and_the_limits(metric):
    model = _facing()
    motion = _reaching_motion(model)
    clearance = 0.005
    before = closest(model, motion, clearance)
    assert (before < 0).sum() >= 10  # the motion makes limbs intersect
    result = fix_motion(model, motion, clearance=clearance, metric=metric, smooth=3)
    after = closest(model, result.motion, clearance)
    assert after.min() >= clearance, after.min()
    assert result.unfreed == [] and (result.after_min >= clearance).all()
    limited = np.flatnonzero(model.jnt_limited.astype(bool) & (model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE))
    q = result.motion[:, model.jnt_qposadr[limited]]
    assert (q >= model.jnt_range[limited, 0]).all() and (q <= model.jnt_range[limited, 1]).all()
    for j in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE):
        quat = result.motion[:, model.jnt_qposadr[j] + 3 : model.jnt_qposadr[j] + 7]
        np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
    # frames with no pair closer than the clearance within `smooth` frames keep their qpos bit for bit
    near = np.convolve(result.before_violations > 0, np.ones(7), mode="same") > 0
    assert (result.motion[~near] == motion[~near]).all()
    assert result.changed[result.before_violations > 0].all()
    assert (result.change[result.changed] > 0).all() and (result.change[~result.changed] == 0).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_limbs_reaching_through_each_other_stay_apart_between_frames(seed):
    """Two figures reaching far (1.5 rad per hinge) through each other for most of 60 frames: the corrected
    motion has no overlapping frame and no contact between frames, checked again by replay (exact classify
    of every frame, time_of_impact between frames).  Frames projected each on its own left 13 and 10 contacts
    between frames here (the limb pushed out to one side, then to the other as the motion goes deeper)."""
    from ellipsim.app import replay as rp

    model = _facing(0.4)
    motion = _reaching_motion(model, frames=60, seed=seed, amplitude=1.5)
    result = fix_motion(model, motion)
    assert (result.before_violations > 0).sum() >= 50
    check = rp.replay(model, result.motion, between=True)
    assert (check.in_contact == 0).all() and len(check.between_events()) == 0
    assert result.between == [] and result.unfreed == []
    report = json.loads(json.dumps(result.report()))  # (the --json report of a motion that needed fixing)
    assert report["frames_changed"] == int(result.changed.sum()) and report["touching_between_frames"] == []
    assert isinstance(result.seconds, float) and result.seconds > 0


def test_a_clean_motion_comes_back_bit_for_bit(tmp_path):
    model = _facing(spacing=2.0)
    motion = _reaching_motion(model, frames=20, amplitude=0.05)
    assert closest(model, motion, 0.0).min() > 0
    result = fix_motion(model, motion)
    assert result.motion.tobytes() == motion.tobytes() and not result.changed.any()
    xml, npy, out = tmp_path / "m.xml", tmp_path / "m.npy", tmp_path / "fixed.npy"
    xml.write_text(scenes.scene_xml(2, layout="facing", spacing=2.0))
    np.save(npy, motion)
    assert main(["fix", str(xml), str(npy), "--out", str(out)]) == 0
    assert np.load(out).tobytes() == motion.tobytes()


def test_a_pair_that_cannot_be_freed_is_reported(tmp_path, capsys):
    """B slides on a joint limited to [0, 0.01] m inside A: no change within the limits frees them."""
    xml = HELD
    model = mujoco.MjModel.from_xml_string(xml)
    motion = np.zeros((5, 1))
    result = fix_motion(model, motion, smooth=0)
    assert len(result.unfreed) == 5
    assert {(g1, g2) for _, g1, g2, _, _ in result.unfreed} == {(0, 1)}
    assert all(d < 0 for _, _, _, d, _ in result.unfreed)
    assert {why for *_, why in result.unfreed} == {"joint slide at its upper limit 0.01"}
    report = result.report()
    assert [x["reason"] for x in report["not_freed"]] == ["joint slide at its upper limit 0.01"] * 5
    assert "frame 0: ga x gb at " in "\n".join(result.summary()) and "at its upper limit 0.01" in "\n".join(
        result.summary()
    )
    assert (result.motion[:, 0] == 0.01).all()  # pushed to the end of its range, no further
    (tmp_path / "m.xml").write_text(xml)
    np.save(tmp_path / "m.npy", motion)
    assert main(["fix", str(tmp_path / "m.xml"), str(tmp_path / "m.npy"), "--smooth", "0"]) == 1
    out = capsys.readouterr().out
    assert "not freed: 5 pair-frames" in out and "frame 0: ga x gb" in out


def test_the_recording_model_sets_the_fixed_copy_beside_the_original(tmp_path):
    path = tmp_path / "m.xml"
    path.write_text(scenes.scene_xml(2, layout="facing", spacing=0.5))
    model = mujoco.MjModel.from_xml_path(str(path))
    motion = _reaching_motion(model, frames=10)
    both, joined, offset = side_by_side(str(path), motion, motion)
    axis = int(np.flatnonzero(offset)[0])
    assert axis in (0, 1) and offset[axis] > 0
    assert both.nq == 2 * model.nq and joined.shape == (10, 2 * model.nq)
    data = mujoco.MjData(both)
    body_of = both.geom_bodyid
    copy = np.array(
        [(mujoco.mj_id2name(both, mujoco.mjtObj.mjOBJ_BODY, b) or "").startswith("fixed/") for b in body_of]
    )
    assert copy.sum() == model.ngeom - 1  # every geom but the world's floor
    for q in joined:
        data.qpos[:] = q
        mujoco.mj_kinematics(both, data)
        y_original = data.geom_xpos[~copy & (body_of > 0), axis] + both.geom_rbound[~copy & (body_of > 0)]
        y_copy = data.geom_xpos[copy, axis] - both.geom_rbound[copy]
        assert y_copy.min() > y_original.max()


def test_the_recording_labels_the_original_and_the_fixed_copy(tmp_path, capsys):
    """`fix --record`: a label above each copy, "original" at the model's own place, "fixed" one offset
    beside it, over the bodies' box; the legend says which is which."""
    from tests.test_record import Recording

    path = tmp_path / "m.xml"
    path.write_text(scenes.scene_xml(2, layout="facing", spacing=0.5))
    model = mujoco.MjModel.from_xml_path(str(path))
    np.save(tmp_path / "m.npy", _reaching_motion(model, frames=12))
    out = tmp_path / "fix.rrd"
    main(["fix", str(path), str(tmp_path / "m.npy"), "--record", str(out)])
    rec = Recording(out)
    (labels,) = rec.static("/world/copy_labels", "Points3D:labels")
    (positions,) = rec.static("/world/copy_labels", "Points3D:positions")
    assert labels == ["original", "fixed"]
    apart = np.subtract(positions[1], positions[0])
    text = rec.static("/legend", "TextDocument:text")[-1][0]
    assert "labelled *original*" in text and "labelled *fixed*" in text
    said = float(text.split("beside it, ")[1].split(" m along")[0])  # the offset the legend states
    assert np.count_nonzero(apart) == 1 and apart.max() == pytest.approx(said, abs=0.006)
    _, _, xpos = rec.temporal("/world/contacts", "Points3D:positions")
    assert positions[0][2] > max((p[2] for row in xpos for p in row), default=0.0)  # above the bodies


@pytest.mark.parametrize(
    "args, message",
    [
        (["--clearance", "-1"], "argument --clearance: must be a number of metres >= 0, got '-1'"),
        (["--clearance", "x"], "argument --clearance: must be a number of metres >= 0, got 'x'"),
        (["--out", "fixed.csv"], "--out must name a .npy file, got 'fixed.csv'"),
        (["--smooth", "-2"], "--smooth: expected a non-negative integer, got -2"),
    ],
)
def test_bad_arguments_are_one_line(tmp_path, args, message):
    path = tmp_path / "m.xml"
    path.write_text(scenes.scene_xml(1))
    model = mujoco.MjModel.from_xml_path(str(path))
    np.save(tmp_path / "m.npy", np.repeat(model.qpos0[None], 3, 0))
    proc = cli("fix", str(path), str(tmp_path / "m.npy"), *args)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert message in proc.stderr.strip().splitlines()[-1]


def test_a_motion_of_the_wrong_shape_is_one_line(tmp_path):
    path = tmp_path / "m.xml"
    path.write_text(scenes.scene_xml(1))
    np.save(tmp_path / "m.npy", np.zeros((3, 5)))
    proc = cli("fix", str(path), str(tmp_path / "m.npy"))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "m.npy" in proc.stderr


def test_fix_motion_checks_its_arguments():
    model = _facing()
    motion = _reaching_motion(model, frames=3)
    with pytest.raises(ValueError, match="clearance must be a finite number >= 0"):
        fix_motion(model, motion, clearance=-0.1)
    with pytest.raises(ValueError, match="metric must be one of"):
        fix_motion(model, motion, metric="euclid")
    with pytest.raises(ValueError, match="smooth must be an integer >= 0"):
        fix_motion(model, motion, smooth=1.5)
    with pytest.raises(ValueError, match=r"motion must have shape \(frames, 70\)"):
        fix_motion(model, motion[:, :5])


#: A world body and a mocap body (qpos does not move it) overlapping: no joint between them
MOCAP = """<mujoco><worldbody>
  <body name="a"><geom name="ga" type="ellipsoid" size="0.3 0.2 0.1"/></body>
  <body name="m" mocap="true" pos="0.2 0 0"><geom name="gm" type="ellipsoid" size="0.3 0.2 0.1"/></body>
  <body name="c" pos="3 0 0"><joint type="hinge" axis="0 0 1"/><geom name="gc" type="ellipsoid" size="0.3 0.2 0.1"/></body>
</worldbody></mujoco>"""


def test_a_pair_no_joint_moves_says_so(tmp_path, capsys):
    model = mujoco.MjModel.from_xml_string(MOCAP)
    result = fix_motion(model, np.zeros((2, model.nq)), smooth=0)
    why = "no joint moves either geom relative to the other (no joint on the tree path between their bodies)"
    assert [(f, g1, g2, r) for f, g1, g2, _, r in result.unfreed] == [(0, 0, 1, why), (1, 0, 1, why)]
    (tmp_path / "m.xml").write_text(MOCAP)
    np.save(tmp_path / "m.npy", np.zeros((2, model.nq)))
    report = tmp_path / "r.json"
    assert main(["fix", str(tmp_path / "m.xml"), str(tmp_path / "m.npy"), "--json", str(report)]) == 1
    out = capsys.readouterr().out
    assert f"frame 0: ga x gm at -0.1871 m: {why}" in out
    assert [x["reason"] for x in __import__("json").loads(report.read_text())["not_freed"]] == [why, why]


def test_a_frame_the_solver_cannot_move_is_still_reported():
    """The slide already at the end of its range: nothing changes, and the pair is listed, not called apart."""
    xml = HELD
    model = mujoco.MjModel.from_xml_string(xml)
    result = fix_motion(model, np.full((3, 1), 0.01), smooth=0)
    assert len(result.unfreed) == 3 and (result.after_min < 0).all()


@pytest.mark.parametrize("frames", [1, 2, 3])
def test_motions_shorter_than_the_smoothing_window(frames):
    model = _facing()
    result = fix_motion(model, _reaching_motion(model, frames=frames, amplitude=0.8), smooth=4)
    assert result.motion.shape == (frames, model.nq) and result.unfreed == []


def test_side_by_side_takes_a_model_with_keyframes_and_several_roots(tmp_path):
    """The copy's keyframes were attached once per root body and clashed ("repeated name 'fixed/hug'"):
    the recording's model has none (it does not need them)."""
    path = tmp_path / "keyed.xml"
    path.write_text(
        "<mujoco><worldbody>"
        '<body name="a"><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>'
        '<body name="b" pos="1 0 0"><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>'
        '</worldbody><keyframe><key name="hug" qpos="0 0 0 1 0 0 0 1 0 0 1 0 0 0"/></keyframe></mujoco>'
    )
    motion = np.tile(mujoco.MjModel.from_xml_path(str(path)).key_qpos[0], (3, 1))
    both, joined, offset = side_by_side(str(path), motion, motion)
    assert both.nkey == 0 and joined.shape == (3, 28) and offset.max() > 0
