"""Scenarios: loading and validation, what each shipped scenario does, the broad phase, the CLI."""

import json
import pathlib
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ellipsim import Ellipsoids, Relation, classify
from ellipsim.app import capture, scenario, scenes, simulate
from ellipsim.app.cli import main
from ellipsim.app.control import Controller
from ellipsim.core.motion.broad_phase import sweep_and_prune
from ellipsim.mujoco.geoms import candidate_pairs, ellipsoid_geoms, frame_pairs

ZOO = pathlib.Path(__file__).parent / "models" / "zoo.xml"

GOOD = """
description = "test"
duration = 0.2
timestep = 0.002
mode = "filter"
[scene]
kind = "figures"
figures = 2
layout = "line"
spacing = 0.8
[control]
kind = "sway"
"""


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_shipped_scenarios_load():
    names = scenario.available()
    assert {"handshake", "pile", "crowd", "tumble", "replay", "terrain"} <= set(names)
    for name in names:
        s = scenario.load(name)
        assert s.duration > 0 and s.steps >= 1 and s.mode in scenario.MODES


@pytest.mark.parametrize(
    "text, message",
    [
        ("duration = [", r"s\.toml: not valid TOML"),
        (
            GOOD.replace('mode = "filter"', 'mode = "gjk"'),
            r"s\.toml: key 'mode' must be one of \('builtin', 'filter', 'narrowphase'\), got 'gjk'",
        ),
        (GOOD.replace("duration = 0.2", "duration = -1"), r"key 'duration' must be positive, got -1"),
        (GOOD.replace("duration = 0.2", 'duration = "long"'), r"key 'duration' must be a float, got 'long'"),
        (GOOD.replace("figures = 2", "figures = 0"), r"key 'scene.figures' must be positive, got 0"),
        (GOOD.replace('layout = "line"', 'layout = "circle"'), r"key 'scene.layout' must be one of"),
        (GOOD.replace("figures = 2", "figures = 2\nprops = 3"), r"key 'scene.props' must be a non-negative count"),
        (GOOD.replace("figures = 2", "figures = 2\nterrain = 1"), r"key 'scene.terrain' must be a bool"),
        (GOOD.replace('kind = "sway"', 'kind = "jump"'), r"key 'control.kind' must be one of"),
        (GOOD + "colour = 1\n", r"unknown key 'control.colour'"),
        (
            "durration = 3\n" + GOOD,
            r"s\.toml: unknown key 'durration' \(did you mean 'duration'\? known here: description, duration",
        ),
        (GOOD.replace("[scene]", "[scenery]"), r"unknown key 'scenery' \(did you mean 'scene'\?"),
        (GOOD.replace("figures = 2", "figurs = 2"), r"unknown key 'scene.figurs' \(did you mean 'scene.figures'\?"),
        (
            GOOD.replace("duration = 0.2", "duration = 1e300").replace("timestep = 0.002", "timestep = 1e-300"),
            r"key 'duration' is inf steps of 1e-300 s; at most 9\.01e\+15, got 1e\+300",
        ),
        (
            GOOD.replace("duration = 0.2", "duration = 1e10").replace("timestep = 0.002", "timestep = 1e-9"),
            r"key 'duration' is 1e\+19 steps of 1e-09 s; at most 9\.01e\+15, got 10000000000\.0",
        ),
        (GOOD.replace("timestep = 0.002\n", ""), r"missing key 'timestep'"),
        (GOOD.split("[scene]")[0], r"missing table \[scene\]"),
        (GOOD.replace("timestep = 0.002", "timestep = 1.0"), r"key 'timestep' must not exceed the duration"),
    ],
)
def test_malformed_files_name_the_file_and_key(tmp_path, text, message):
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.load(write(tmp_path, text))


@pytest.mark.parametrize(
    "text, missing",
    [
        (
            GOOD.replace("duration = 0.2\n", "").replace("timestep = 0.002\n", "").replace("figures = 2\n", ""),
            "missing key 'duration', key 'timestep' and key 'scene.figures'",
        ),
        (GOOD.split("[scene]")[0], "missing table [scene] and table [control]"),
        (
            'timestep = 0.01\n[scene]\nkind = "pile"\n[control]\nkind = "keyframes"\n',
            "missing key 'duration', key 'scene.ellipsoids' and key 'control.keys'",
        ),
        (GOOD.replace("duration = 0.2\n", ""), "missing key 'duration'"),
    ],
)
def test_every_missing_key_is_named_in_one_message(tmp_path, text, missing):
    """Not one run per missing key: the message lists them all (each named once)."""
    with pytest.raises(scenario.ScenarioError) as info:
        scenario.load(write(tmp_path, text))
    assert str(info.value) == f"{tmp_path / 's.toml'}: {missing}"


PILE = """
duration = 0.02
timestep = 0.002
[scene]
kind = "pile"
ellipsoids = 6
[control]
kind = "hold"
"""

KEYFRAMES = """
duration = 0.2
timestep = 0.02
kinematic = true
[scene]
figures = 1
[control]
kind = "keyframes"
keys = [{ t = 0.0, joints = {} }, { t = 1.0, joints = { elbow_l = 30, nosuch = 10 } }]
"""


@pytest.mark.parametrize(
    "text, message",
    [
        (
            PILE.replace('kind = "hold"', 'kind = "sway"'),
            r"s\.toml: key 'control\.kind' must be 'hold' for a pile scene .*, got 'sway'",
        ),
        (
            PILE.replace('kind = "hold"', 'kind = "dance"'),
            r"key 'control\.kind' must be 'hold' for a pile scene .*, got 'dance'",
        ),
        (
            PILE.replace('kind = "hold"', 'kind = "keyframes"\nkeys = [{t = 0}, {t = 1}]'),
            r"key 'control\.kind' must be 'hold' for a pile scene",
        ),
        (
            PILE.replace("[scene]", "kinematic = true\n[scene]"),
            r"key 'kinematic' must be false for a pile scene .*, got True",
        ),
        (
            KEYFRAMES,
            r"s\.toml: key 'control\.keys\[1\]\.joints' names unknown joint 'nosuch'; the figure's joints are waist_flex, .*elbow_l",
        ),
    ],
)
def test_controls_that_cannot_apply_are_refused(tmp_path, text, message):
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.load(write(tmp_path, text))


def test_pile_scene_holds(tmp_path):
    """A pile of free ellipsoids with the default control runs (no actuators, nothing to drive)."""
    s = scenario.load(write(tmp_path, PILE))
    model, _ = simulate.build(s)
    assert model.nu == 0 and Controller(model, s.control)(0.5).shape == (0,)
    assert simulate.run(s).steps == 10


def test_file_that_is_not_utf8(tmp_path):
    path = tmp_path / "s.toml"
    path.write_bytes(GOOD.replace("test", "caf\xe9").encode("latin-1"))
    with pytest.raises(scenario.ScenarioError, match=r"s\.toml: not UTF-8 text: .*can't decode byte 0xe9"):
        scenario.load(str(path))


@pytest.mark.parametrize(
    "text, message",
    [
        (
            GOOD.replace("spacing = 0.8", "spacing = 0.1"),
            r"s\.toml: \[scene\] spacing must exceed .* for layout 'line'.*, got 0\.1",
        ),
        (
            GOOD.replace("spacing = 0.8", "drop_height = -1"),
            r"s\.toml: \[scene\] drop_height must be non-negative, got -1\.0",
        ),
        (
            PILE.replace("ellipsoids = 6", "ellipsoids = 6\nbin_half_width = 0.05"),
            r"s\.toml: \[scene\] bin_half_width must be at least .*, got 0\.05",
        ),
    ],
)
def test_scenes_the_model_builder_refuses_name_the_file(tmp_path, text, message):
    s = scenario.load(write(tmp_path, text))
    with pytest.raises(scenario.ScenarioError, match=message):
        simulate.build(s)


def test_unknown_scenario_lists_the_available_ones():
    with pytest.raises(scenario.ScenarioError, match=r"unknown scenario 'dance-party'; available: crowd, handshake"):
        scenario.load("dance-party")


@pytest.mark.slow
def test_handshake_hands_meet():
    tr = simulate.run(scenario.load("handshake"), keep=True).kept
    h0, h1 = tr.geom_names.index("f0_hand_r"), tr.geom_names.index("f1_hand_r")
    assert tr.state[0, h0] == 0 and tr.state[-1, h0] == 2 and tr.state[-1, h1] == 2
    assert np.linalg.norm(tr.centers[-1, h0] - tr.centers[-1, h1]) < 0.2


@pytest.mark.slow
def test_crowd_neighbours_brush_and_tumble_hits_itself():
    crowd = simulate.run(scenario.load("crowd"), steps=1000).frames
    assert crowd.ellipsim_counts.max() >= 5
    tumble = simulate.run(scenario.load("tumble"), keep=True)
    assert all(name.startswith("f0_") for name in tumble.kept.geom_names)
    assert tumble.frames.ellipsim_counts.max() >= 1  # one figure alone: every contact is a self-collision


@pytest.mark.slow
def test_pile_and_replay_make_contacts():
    pile = simulate.run(scenario.load("pile"), steps=600)
    assert pile.frames.ellipsim_counts.max() > 10 and pile.counters["contacts"] > 0
    replay = simulate.run(scenario.load("replay"))
    tr = replay.frames
    assert len(tr.times) == replay.steps and replay.counters == {}  # kinematic: every frame kept
    assert tr.ellipsim_counts.max() > 0
    # Without physics MuJoCo's contacts and the exact verdicts agree frame by frame except within
    # MuJoCo's tolerance of touching.
    assert np.abs(tr.builtin_counts - tr.ellipsim_counts).max() <= 1


def test_frame_buffer_reads_every_contact_in_order():
    """The vectorised read of data.contact: all of MuJoCo's contacts, in MuJoCo's order, positions
    and normals (first row of the frame) as a per-contact loop reads them, flagged when on a pair ellipsim
    judges (here two ellipsoids; the floor is a plane); and the verdicts of the frame's pairs."""
    model, data = simulate.build(scenario.load("pile"))
    ids, _, _ = ellipsoid_geoms(model)
    for _ in range(700):
        mujoco.mj_step(model, data)
    contacts = [data.contact[k] for k in range(data.ncon)]
    both = [c.geom[0] in ids and c.geom[1] in ids for c in contacts]
    assert 0 < sum(both) < data.ncon  # ellipsoid pairs and floor contacts
    buffer = capture.FrameBuffer(model, record=True)
    assert not buffer.add(data, data.time)
    chunk = buffer.flush()
    f = chunk.frames
    np.testing.assert_array_equal(f.contact_pos, [c.pos for c in contacts])
    np.testing.assert_array_equal(f.contact_normal, [c.frame[:3] for c in contacts])
    np.testing.assert_array_equal(f.contact_ellipsoids, both)
    assert f.contact_counts.tolist() == [data.ncon] and f.builtin_counts.tolist() == [sum(both)]
    assert f.ellipsim_counts[0] == np.count_nonzero(chunk.contact == capture.CONTACT) > 0
    assert buffer.flush() is None


def test_controller_qpos_addresses():
    replay = scenario.load("replay")
    model, data = simulate.build(replay)
    c = Controller(model, replay.control)
    np.testing.assert_array_equal(c.qadr, [model.jnt_qposadr[model.actuator_trnid[a, 0]] for a in range(model.nu)])
    data.qpos[c.qadr] = c(1.3)
    for a, (_, _, adr) in enumerate(c.joints):
        assert data.qpos[adr] == c(1.3)[a]


def test_controls_stay_in_range_and_reach_their_targets():
    model, _ = simulate.build(scenario.load("handshake"))
    c = Controller(model, scenario.load("handshake").control)
    for t in np.linspace(0, 3, 31):
        u = c(t)
        assert np.all(u >= model.actuator_ctrlrange[:, 0]) and np.all(u <= model.actuator_ctrlrange[:, 1])
    idx = [k for k, (_, j, _) in enumerate(c.joints) if j == "elbow_r"]
    np.testing.assert_allclose(c(10.0)[idx], np.radians(30.0))
    replay = scenario.load("replay")
    model, _ = simulate.build(replay)
    c = Controller(model, replay.control)
    t1, keys = replay.control["keys"][1]
    k = [i for i, (f, j, _) in enumerate(c.joints) if f == 0 and j == "shoulder_abd_l"]
    np.testing.assert_allclose(c(t1)[k], np.radians(keys["shoulder_abd_l"]))


@settings(max_examples=50)
@given(st.integers(1, 40), st.integers(0, 2**32 - 1))
def test_sweep_and_prune_finds_every_overlapping_pair(n, seed):
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-1, 1, (3, n, 3)) * rng.permutation([0.2, 1.0, 5.0])  # the sweep axis varies
    rho = rng.uniform(0.05, 0.4, n)
    pairs = sweep_and_prune(centers, rho)
    got = {tuple(p) for p in pairs}
    d = np.linalg.norm(centers[:, :, None] - centers[:, None, :], axis=-1)
    want = {(f, i, j) for f in range(3) for i in range(n) for j in range(i + 1, n) if d[f, i, j] <= rho[i] + rho[j]}
    assert got == want and len(got) == len(pairs)  # each pair once
    assert np.all(np.diff(pairs[:, 0]) >= 0)  # sorted by frame


def test_candidate_rules_follow_mujoco():
    """Every contact MuJoCo makes between ellipsoids is an allowed pair; parent-child pairs are not."""
    s = scenario.load("pile")
    model, data = simulate.build(s)
    ids, radii, rules = ellipsoid_geoms(model)
    allowed = rules.matrix()
    for _ in range(800):
        mujoco.mj_step(model, data)
    pos = {g: k for k, g in enumerate(ids)}
    for c in data.contact[: data.ncon]:
        if c.geom[0] in pos and c.geom[1] in pos:
            assert allowed[pos[c.geom[0]], pos[c.geom[1]]]
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in ids]
    assert not allowed[names.index("f0_thigh_l"), names.index("f0_shin_l")]
    assert allowed[names.index("f0_hand_l"), names.index("f0_thigh_l")]


def _reference_allowed(model, ids):
    """The (g, g) matrix of MuJoCo's pair rules, written out pair by pair (the slow, obvious way)."""
    out = np.zeros((len(ids), len(ids)), dtype=bool)
    excluded = {tuple(sorted((int(sig >> 16), int(sig & 0xFFFF)))) for sig in model.exclude_signature}
    parent_filter = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    for a, ga in enumerate(ids):
        for b, gb in enumerate(ids):
            ba, bb = model.geom_bodyid[ga], model.geom_bodyid[gb]
            wa, wb = model.body_weldid[ba], model.body_weldid[bb]
            pa, pb = model.body_weldid[model.body_parentid[wa]], model.body_weldid[model.body_parentid[wb]]
            out[a, b] = (
                a != b
                and bool(
                    model.geom_contype[ga] & model.geom_conaffinity[gb]
                    or model.geom_contype[gb] & model.geom_conaffinity[ga]
                )
                and wa != wb
                and not (parent_filter and wa and wb and (wa == pb or pa == wb))
                and tuple(sorted((int(ba), int(bb)))) not in excluded
            )
    return out


@pytest.mark.parametrize("scene", ["crowd", "handshake", "zoo", "no parent filter"])
def test_pair_rules_match_the_rules_pair_by_pair(scene):
    if scene == "zoo":
        model = mujoco.MjModel.from_xml_path(str(ZOO))
    elif scene == "no parent filter":
        model = mujoco.MjModel.from_xml_string(scenes.scene_xml(2, fixed_roots=True))
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    else:
        model, _ = simulate.build(scenario.load(scene))
    ids, _, rules = ellipsoid_geoms(model)
    want = _reference_allowed(model, ids)
    assert want.any() and not want.all()
    np.testing.assert_array_equal(rules.matrix(), want)


def test_pair_rules_take_memory_linear_in_the_geoms():
    """No (g, g) matrix: 500 figures are 7500 geoms, and a matrix of them took minutes to build."""
    model = mujoco.MjModel.from_xml_string(scenes.scene_xml(40, fixed_roots=True, spacing=0.8))
    ids, _, rules = ellipsoid_geoms(model)
    sizes = [v.size for v in vars(rules).values() if isinstance(v, np.ndarray)]
    assert max(sizes) <= max(len(ids), model.nexclude) and model.nexclude == 3 * 40


def test_frame_pairs_are_mujocos_candidates_whose_spheres_meet():
    """At a contact-rich state of a pile of figures, the broad phase over frames finds every pair
    MuJoCo's own broad phase sends to collision whose bounding spheres overlap; the others it finds
    MuJoCo's tighter boxes rule out, and the exact test proves them all separated."""
    model, data = simulate.build(scenario.load("pile"))
    for _ in range(700):
        mujoco.mj_step(model, data)
    ids, radii, rules = ellipsoid_geoms(model)
    mujocos = {tuple(p) for p in candidate_pairs(model, data)}
    centers = data.geom_xpos[ids][None]
    ours = {(int(ids[i]), int(ids[j])) for _, i, j in frame_pairs(centers, radii, rules)}
    rho = radii.max(axis=1)
    index = {g: k for k, g in enumerate(ids)}
    meet = {
        (a, b)
        for a, b in mujocos
        if np.linalg.norm(data.geom_xpos[a] - data.geom_xpos[b]) <= rho[index[a]] + rho[index[b]]
    }
    assert len(meet) > 50 and meet <= ours
    extra = np.array(sorted(ours - mujocos)).reshape(-1, 2)
    assert len(extra) > 0 and rules.allowed([index[a] for a, _ in extra], [index[b] for _, b in extra]).all()

    def batch(g):
        return Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(-1, 3, 3), radii[[index[k] for k in g]])

    assert (classify(batch(extra[:, 0]), batch(extra[:, 1])) == Relation.SEPARATED).all()


# --- command line ----------------------------------------------------------------------------------


def cli(*args):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True)


@pytest.mark.slow
def test_run_prints_a_summary(capsys):
    assert main(["run", "pile", "--steps", "300", "--mode", "filter"]) == 0
    out = capsys.readouterr().out
    assert "steps/s" in out and "filter:" in out and "pairs tested" in out


@pytest.mark.slow
def test_compare_writes_json(tmp_path, capsys):
    path = tmp_path / "c.json"
    assert main(["compare", "crowd", "--steps", "300", "--json", str(path)]) == 0
    report = json.loads(path.read_text())
    counters = {"pairs", "mujoco_contacts", "ellipsim_contacts", "mujoco_extra", "mujoco_missed", "near_tangent"}
    assert {"steps", "normal_off", *counters} <= set(report)
    assert report["steps"] == 300 and len(report["per_step"]["mujoco_contacts"]) == 300
    assert report["mujoco_contacts"] == sum(report["per_step"]["mujoco_contacts"]) > 0
    assert report["mujoco_extra"] == 0 and report["mujoco_missed"] == 0
    by_type = report["by_pair_type"]
    assert list(by_type) == [
        "ellipsoid-ellipsoid",
        "ellipsoid-sphere",
        "ellipsoid-capsule",
        "ellipsoid-box",
        "ellipsoid-cylinder",
        "ellipsoid-mesh",
        "ellipsoid-hfield",
    ]
    for key in counters | {"normal_off", "agreement"}:  # the same counters per type, adding up to the totals
        assert sum(c[key] for c in by_type.values()) == report[key], key
    assert "agreement" in capsys.readouterr().out


@pytest.mark.slow
def test_compare_plot(tmp_path):
    path = tmp_path / "c.png"
    assert main(["compare", "replay", "--steps", "50", "--plot", str(path)]) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, message",
    [
        (["run", "dance-party"], "unknown scenario 'dance-party'; available:"),
        (["run", "pile", "--mode", "gjk"], "invalid choice: 'gjk'"),
        (["run", "pile", "--steps", "0"], "expected a positive integer, got 0"),
        (["run", "pile", "--record", "/dev/null/x.rrd"], "--record: '/dev/null' is not a directory"),
        (["run", "pile", "--record", "out.txt"], "--record must name a .rrd file, got 'out.txt'"),
        (["compare", "pile", "--json", "/dev/null/d/x.json"], "--json: '/dev/null' is not a directory"),
        (["compare", "pile", "--plot", "/dev/null/x.png"], "--plot: '/dev/null' is not a directory"),
        (["fit", "arm.stl", "--out", "/dev/null/x.xml"], "--out: '/dev/null' is not a directory"),
        (["view", "/no/such/file.rrd"], "/no/such/file.rrd"),
    ],
)
def test_user_mistakes_exit_2_with_one_line(args, message):
    proc = cli(*args)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in proc.stderr


@pytest.mark.parametrize("command", ["run", "compare"])
def test_refused_scene_on_the_command_line(tmp_path, command):
    proc = cli(command, write(tmp_path, GOOD.replace("spacing = 0.8", "spacing = 0.1")))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "s.toml: [scene] spacing must exceed" in lines[0] and "got 0.1" in lines[0]


@pytest.mark.parametrize("option, name", [("--json", "d.json"), ("--plot", "d.png"), ("--record", "d.rrd")])
def test_output_that_is_a_directory_is_refused_before_running(tmp_path, option, name):
    (tmp_path / name).mkdir()
    command = "run" if option == "--record" else "compare"
    proc = cli(command, "pile", option, str(tmp_path / name))
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{option}: '{tmp_path / name}' is a directory" in lines[0]


def test_malformed_scenario_file_on_the_command_line(tmp_path):
    proc = cli("run", write(tmp_path, GOOD.replace('kind = "sway"', "kind = 5")))
    assert proc.returncode == 2
    assert (
        "s.toml: key 'control.kind' must be a str, got 5" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    )
