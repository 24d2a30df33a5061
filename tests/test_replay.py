"""The animation check: a motion played on a model (ellipsim replay), against a pair-by-pair
reference, and the motion files it reads."""

import json
import pathlib
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

from ellipsim import Ellipsoids, Relation, classify, signed_distance
from ellipsim.app import record
from ellipsim.app import replay as rp
from ellipsim.core.pairs.shape_distance import shape_distance
from ellipsim.mujoco.geoms import PairRules
from ellipsim.mujoco.judge import judged, judged_geoms

ZOO = pathlib.Path(__file__).parent / "models" / "zoo.xml"
FPS = 24.0


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(ZOO))


def hug_motion(model, frames=30):
    """From keyframe "rest" to "hug" and half-way back, the ball rolling along x: (frames, nq)."""
    s = np.concatenate([np.linspace(0, 1, frames - frames // 3), np.linspace(1, 0.5, frames // 3)])[:, None]
    q = (1 - s) * model.key_qpos[0] + s * model.key_qpos[1]
    q[:, 14] += np.linspace(0, 0.5, frames)  # the ball's x
    return q


def reference(model, motion):
    """Per frame, every allowed pair of geoms ellipsim judges (an ellipsoid with an ellipsoid, sphere,
    capsule, box or cylinder) decided one by one, with its depth: {frame: {(g1, g2): (relation, depth)}}
    for touching (1) and in-contact (2: the signed distance below the margin, 0 in the zoo) pairs, and
    ncon per frame.  Ellipsoid pairs by classify; the others by their proven distance (shape_distance)."""
    data = mujoco.MjData(model)
    ids = judged_geoms(model)
    rules = PairRules(model, ids)
    assert (model.geom_margin[ids] == 0).all()
    out, ncon = {}, []
    for f, q in enumerate(motion):
        data.qpos[:] = q
        mujoco.mj_fwdPosition(model, data)
        ncon.append(data.ncon)
        for i in range(len(ids)):
            for j in range(i + 1, len(ids)):
                g1, g2 = int(ids[i]), int(ids[j])
                if not rules.allowed([i], [j])[0] or not judged(model, [g1], [g2])[0]:
                    continue
                rel, depth = _one_pair(model, data, g1, g2)
                if rel:
                    out.setdefault(f, {})[(g1, g2)] = (rel, depth)
    return out, ncon


def _one_pair(model, data, g1, g2):
    """(relation 0 apart / 1 touching / 2 in contact, depth or None) of one pair at data's state."""
    types = [int(model.geom_type[g]) for g in (g1, g2)]
    shape = {int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule", int(mujoco.mjtGeom.mjGEOM_BOX): "box"}
    shape[int(mujoco.mjtGeom.mjGEOM_CYLINDER)] = "cylinder"

    def ellipsoid(g):
        r = model.geom_size[g] if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID else [model.geom_size[g, 0]] * 3
        return Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), r)

    if not set(types) & set(shape):
        a, b = ellipsoid(g1), ellipsoid(g2)
        rel = int(classify(a, b)[0])
        return rel, (-signed_distance(a, b)[0][0] if rel == Relation.OVERLAPPING else None)
    e, s = (g1, g2) if types[0] == mujoco.mjtGeom.mjGEOM_ELLIPSOID else (g2, g1)
    kind = shape[int(model.geom_type[s])]
    d = shape_distance(ellipsoid(e), kind, data.geom_xpos[s], data.geom_xmat[s].reshape(3, 3), model.geom_size[s])[0][0]
    return (2, max(-d, 0.0)) if d < 0 else (0, None)


@pytest.fixture(scope="module")
def hug(model):
    motion = hug_motion(model)
    return motion, rp.replay(model, motion, fps=FPS)


def test_replay_matches_a_pair_by_pair_reference(model, hug):
    motion, result = hug
    want, ncon = reference(model, motion)
    assert result.frames == len(motion) and result.fps == FPS
    got = {}
    for p in range(len(result.pair_frame)):
        depth = None if result.pair_relation[p] == Relation.TOUCHING else result.pair_depth[p]
        got.setdefault(int(result.pair_frame[p]), {})[tuple(int(g) for g in result.pair_geoms[p])] = (
            int(result.pair_relation[p]),
            depth,
        )
    assert set(got) == set(want) and len(want) >= 10
    for f in want:
        assert got[f].keys() == want[f].keys(), f
        for pair, (rel, depth) in want[f].items():
            assert got[f][pair][0] == rel
            if depth is not None:
                assert got[f][pair][1] == pytest.approx(depth, rel=1e-12, abs=1e-15)
    in_contact = [sum(1 for rel, _ in want.get(f, {}).values() if rel == 2) for f in range(len(motion))]
    assert result.in_contact.tolist() == in_contact
    assert result.touching.sum() == sum(1 for f in want for rel, _ in want[f].values() if rel == 1)
    assert result.mujoco_contacts.tolist() == ncon
    deepest = [max((d for rel, d in want.get(f, {}).values() if rel == 2), default=0.0) for f in range(len(motion))]
    np.testing.assert_allclose(result.deepest, deepest, rtol=1e-12)


def test_body_pairs_say_which_bodies_and_when(model, hug):
    _, result = hug
    pairs = result.body_pairs()
    top = pairs[0]
    assert top["bodies"] == ["torso", "forearm_l"] and top["geoms"] == ["torso", "hand_l"]
    frames = np.flatnonzero(result.in_contact)
    assert (
        top["frames_in_contact"] > 5
        and top["first"] == frames[0]
        and set(top["contact_frames"]) <= set(frames.tolist())
    )
    assert top["deepest"] == pytest.approx(result.deepest.max())
    assert rp.frame_ranges([1, 2, 3, 7, 9, 10]) == "1-3, 7, 9-10"
    assert rp.frame_ranges(range(0, 40, 2), most=3) == "0, 2, 4, ... (17 more)"


def test_replay_records_every_frame(model, tmp_path):
    motion = hug_motion(model, 12)
    path = tmp_path / "hug.rrd"
    with record.Recorder(path) as recorder:
        result = rp.replay(model, motion, fps=FPS, recorder=recorder, name="hug")
    chunks = RrdReader(path).stream().to_chunks()
    rows = {}
    for c in chunks:
        if c.entity_path == "/counts/pairs/ellipsim" and not c.is_static:
            batch = c.to_record_batch()
            for f, t, v in zip(
                batch.column("frame").to_pylist(),
                batch.column("time").cast("int64").to_pylist(),
                batch.column("Scalars:scalars").to_pylist(),
            ):
                rows[f] = (t, v[0])
    assert sorted(rows) == list(range(12))
    assert [rows[f][0] for f in range(12)] == [round(f / FPS * 1e9) for f in range(12)]
    assert [rows[f][1] for f in range(12)] == result.in_contact.astype(float).tolist()


def test_replay_refuses_bad_arguments(model):
    with pytest.raises(ValueError, match=r"motion must have shape \(frames, 19\) \(frames >= 1\), got \(3, 18\)"):
        rp.replay(model, np.zeros((3, 18)))
    with pytest.raises(ValueError, match=r"fps must be a positive finite number, got 0"):
        rp.replay(model, hug_motion(model, 3), fps=0)


# --- motion files ----------------------------------------------------------------------------------


def test_motion_files_npy_and_csv(model, tmp_path):
    motion = hug_motion(model, 5)
    np.save(tmp_path / "m.npy", motion)
    np.testing.assert_array_equal(rp.load_motion(tmp_path / "m.npy", 19), motion)
    header = ",".join(f"q{i}" for i in range(19))
    np.savetxt(tmp_path / "h.csv", motion, delimiter=",", header=header, comments="")
    np.testing.assert_array_equal(rp.load_motion(tmp_path / "h.csv", 19), motion)
    np.savetxt(tmp_path / "n.csv", motion, delimiter=",")
    np.testing.assert_array_equal(rp.load_motion(tmp_path / "n.csv", 19), motion)


@pytest.mark.parametrize(
    "name, content, message",
    [
        (
            "m.npy",
            np.zeros((4, 18)),
            r"has 18 values per frame, expected \(frames, nq\) with nq = 19: the model's qpos holds "
            r"14 \(2 free joints\) \+ 5 \(5 hinges\)",
        ),
        ("m.npy", np.zeros(19), r"must have shape \(frames, nq\) with nq = 19.*, got shape \(19,\)"),
        ("m.npy", np.zeros((0, 19)), r"has no frames"),
        ("m.npy", np.array([[np.nan] * 19]), r"frame 0, qpos\[0\] must be finite, got nan"),
        ("m.npy", np.zeros((2, 19), dtype=bool), r"must hold real numbers, got dtype bool"),
        ("m.npy", np.array([{"a": 1}], dtype=object), r"is not a readable \.npy array"),
        ("m.csv", "1,2,3\n4,5\n", r"line 2: 2 values, the lines before have 3"),
        ("m.csv", "# exported\n\nq0,q1\n1,2\n\n3,4,5\n", r"line 6: 3 values, the lines before have 2"),
        ("m.csv", "q0,q1\n1,2\n3,x\n", r"line 3: expected comma-separated numbers, got '3,x'"),
        ("m.csv", "1,2\n3,inf\n", r"frame 1, qpos\[1\] must be finite, got inf|has 2 values per frame"),
        ("m.txt", "1,2", r"must be a \.npy or \.csv file, got '\.txt'"),
    ],
)
def test_bad_motion_files_are_named(model, tmp_path, name, content, message):
    path = tmp_path / name
    if isinstance(content, str):
        path.write_text(content)
    else:
        np.save(path, content, allow_pickle=True)
    with pytest.raises(rp.MotionError, match=rf"motion '{path}'.*{message}" if "line" not in message else message):
        rp.load_motion(path, 19, layout=rp.qpos_layout(model))


def test_qpos_layout(model):
    assert rp.qpos_layout(model) == "14 (2 free joints) + 5 (5 hinges)"
    empty = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    assert rp.qpos_layout(empty) == "nothing (no joints)"


# --- the command line ------------------------------------------------------------------------------


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.slow
def test_replay_on_the_command_line(model, tmp_path):
    np.save(tmp_path / "hug.npy", hug_motion(model))
    out = tmp_path / "hug.json"
    proc = cli(
        "replay",
        str(ZOO),
        str(tmp_path / "hug.npy"),
        "--fps",
        str(FPS),
        "--json",
        str(out),
        "--record",
        str(tmp_path / "hug.rrd"),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert "zoo: 30 frames of qpos (nq = 19: 14 (2 free joints) + 5 (5 hinges)) at 24 fps" in proc.stdout
    assert "deepest penetration:" in proc.stdout and "bodies torso / forearm_l (geoms torso / hand_l)" in proc.stdout
    assert "torso / forearm_l: in contact in" in proc.stdout and "MuJoCo's contacts on the same frames" in proc.stdout
    assert "ellipsoid-capsule: MuJoCo mean" in proc.stdout  # the forearm, a capsule, judged too
    report = json.loads(out.read_text())
    assert report["frames"] == 30 and report["nq"] == 19 and report["fps"] == FPS
    assert report["frames_in_contact"] == sum(1 for n in report["per_frame"]["in_contact"] if n)
    by_type = report["by_pair_type"]
    assert by_type["ellipsoid-capsule"]["ellipsim_contacts"] > 0
    assert sum(c["mujoco_contacts"] for c in by_type.values()) == report["mujoco_judged_contacts"]
    assert report["body_pairs"][0]["bodies"] == ["torso", "forearm_l"]
    frame = report["body_pairs"][0]["deepest_frame"]
    deepest = max(p["depth"] for p in report["per_frame"]["pairs"][frame] if p["relation"] == "contact")
    assert deepest == report["per_frame"]["deepest"][frame] == report["body_pairs"][0]["deepest"]
    assert (tmp_path / "hug.rrd").stat().st_size > 0


@pytest.mark.parametrize(
    "motion, extra, message",
    [
        (np.zeros((3, 7)), [], "has 7 values per frame, expected (frames, nq) with nq = 19"),
        (None, [], "does not exist or is not a file"),
        (np.zeros((3, 19)), ["--fps", "0"], "--fps: expected a positive finite number, got '0'"),
        (np.zeros((3, 19)), ["--json", "x.txt"], "--json must name a .json file, got 'x.txt'"),
    ],
)
def test_replay_mistakes_are_one_line(tmp_path, motion, extra, message):
    path = tmp_path / "m.npy"
    if motion is not None:
        np.save(path, motion)
    proc = cli("replay", str(ZOO), str(path), *extra, cwd=tmp_path)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert message in lines[0]


def test_replay_of_a_model_without_a_pair_ellipsim_judges(tmp_path):
    xml = tmp_path / "boxes.xml"
    xml.write_text(
        "<mujoco><worldbody><geom type='plane' size='1 1 .1'/><body><freejoint/><geom type='box' size='.1 .1 .1'/>"
        "</body></worldbody></mujoco>"
    )
    np.save(tmp_path / "m.npy", np.array([[0, 0, z, 1, 0, 0, 0] for z in (0.5, 0.05)], dtype=float))
    proc = cli("replay", str(xml), str(tmp_path / "m.npy"))
    assert proc.returncode == 0, proc.stderr
    assert "the model has no pair ellipsim judges" in proc.stdout
    assert "MuJoCo's contacts on the same frames: 4 in all" in proc.stdout  # the box on the plane, second frame
