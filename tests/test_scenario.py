"""Scenarios: loading and validation, what each shipped scenario does, the broad phase, the CLI."""

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ellipsim.app import scenario, simulate
from ellipsim.app.control import Controller
from ellipsim.core.broadphase import sweep_and_prune
from ellipsim.mujoco.geoms import ellipsoid_geoms
from ellipsim.app.cli import main

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
    assert {"handshake", "pile", "crowd", "tumble", "replay"} <= set(names)
    for name in names:
        s = scenario.load(name)
        assert s.duration > 0 and s.steps >= 1 and s.mode in scenario.MODES


@pytest.mark.parametrize(
    "text, message",
    [
        ("duration = [", r"s\.toml: not valid TOML"),
        (GOOD.replace('mode = "filter"', 'mode = "gjk"'), r"s\.toml: key 'mode' must be one of \('builtin', 'filter', 'narrowphase'\), got 'gjk'"),
        (GOOD.replace("duration = 0.2", "duration = -1"), r"key 'duration' must be positive, got -1"),
        (GOOD.replace("duration = 0.2", 'duration = "long"'), r"key 'duration' must be a float, got 'long'"),
        (GOOD.replace("figures = 2", "figures = 0"), r"key 'scene.figures' must be positive, got 0"),
        (GOOD.replace('layout = "line"', 'layout = "circle"'), r"key 'scene.layout' must be one of"),
        (GOOD.replace('kind = "sway"', 'kind = "jump"'), r"key 'control.kind' must be one of"),
        (GOOD + "colour = 1\n", r"unknown key 'control.colour'"),
        (GOOD.replace("timestep = 0.002\n", ""), r"missing key 'timestep'"),
        (GOOD.split("[scene]")[0], r"missing table \[scene\]"),
        (GOOD.replace("timestep = 0.002", "timestep = 1.0"), r"key 'timestep' must not exceed the duration"),
    ],
)
def test_malformed_files_name_the_file_and_key(tmp_path, text, message):
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.load(write(tmp_path, text))


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
        (PILE.replace('kind = "hold"', 'kind = "sway"'), r"s\.toml: key 'control\.kind' must be 'hold' for a pile scene .*, got 'sway'"),
        (PILE.replace('kind = "hold"', 'kind = "dance"'), r"key 'control\.kind' must be 'hold' for a pile scene .*, got 'dance'"),
        (PILE.replace('kind = "hold"', 'kind = "keyframes"\nkeys = [{t = 0}, {t = 1}]'), r"key 'control\.kind' must be 'hold' for a pile scene"),
        (PILE.replace("[scene]", "kinematic = true\n[scene]"), r"key 'kinematic' must be false for a pile scene .*, got True"),
        (KEYFRAMES, r"s\.toml: key 'control\.keys\[1\]\.joints' names unknown joint 'nosuch'; the figure's joints are waist_flex, .*elbow_l"),
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
        (GOOD.replace("spacing = 0.8", "spacing = 0.1"), r"s\.toml: \[scene\] spacing must exceed .* for layout 'line'.*, got 0\.1"),
        (GOOD.replace("spacing = 0.8", "drop_height = -1"), r"s\.toml: \[scene\] drop_height must be non-negative, got -1\.0"),
        (PILE.replace("ellipsoids = 6", "ellipsoids = 6\nbin_half_width = 0.05"), r"s\.toml: \[scene\] bin_half_width must be at least .*, got 0\.05"),
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
    tr = simulate.run(scenario.load("handshake")).frames
    h0, h1 = tr.geom_names.index("f0_hand_r"), tr.geom_names.index("f1_hand_r")
    assert tr.state[0, h0] == 0 and tr.state[-1, h0] == 2 and tr.state[-1, h1] == 2
    assert np.linalg.norm(tr.centers[-1, h0] - tr.centers[-1, h1]) < 0.2


@pytest.mark.slow
def test_crowd_neighbours_brush_and_tumble_hits_itself():
    crowd = simulate.run(scenario.load("crowd"), steps=1000).frames
    assert crowd.ellipsim_counts.max() >= 5
    tumble = simulate.run(scenario.load("tumble")).frames
    assert (tumble.geom_figure == 0).all()
    assert tumble.ellipsim_counts.max() >= 1  # one figure alone: every contact is a self-collision


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


def test_ellipsoid_contacts_are_mujocos_in_order():
    """The vectorised read of data.contact: MuJoCo's contacts between two ellipsoids, in MuJoCo's
    order, positions and normals (first row of the frame) as a per-contact loop reads them."""
    model, data = simulate.build(scenario.load("pile"))
    ids, _, _ = ellipsoid_geoms(model)
    keep = np.zeros(model.ngeom, dtype=bool)
    keep[ids] = True
    for _ in range(700):
        mujoco.mj_step(model, data)
    want = [(c.pos.copy(), c.frame[:3].copy()) for c in (data.contact[k] for k in range(data.ncon))
            if keep[c.geom[0]] and keep[c.geom[1]]]  # fmt: skip
    assert 0 < len(want) < data.ncon  # ellipsoid pairs kept, floor contacts left out
    pos, normal = simulate._ellipsoid_contacts(data, keep)
    assert pos.shape == normal.shape == (len(want), 3)
    np.testing.assert_array_equal(pos, [p for p, _ in want])
    np.testing.assert_array_equal(normal, [n for _, n in want])


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
    allowed = rng.random((n, n)) < 0.8
    allowed = allowed & allowed.T
    np.fill_diagonal(allowed, False)
    got = {tuple(p) for p in sweep_and_prune(centers, rho, allowed)}
    d = np.linalg.norm(centers[:, :, None] - centers[:, None, :], axis=-1)
    want = {(f, i, j) for f in range(3) for i in range(n) for j in range(i + 1, n)
            if allowed[i, j] and d[f, i, j] <= rho[i] + rho[j]}  # fmt: skip
    assert got == want


def test_candidate_rules_follow_mujoco():
    """Every contact MuJoCo makes between ellipsoids is an allowed pair; parent-child pairs are not."""
    s = scenario.load("pile")
    model, data = simulate.build(s)
    ids, radii, allowed = ellipsoid_geoms(model)
    for _ in range(800):
        mujoco.mj_step(model, data)
    pos = {g: k for k, g in enumerate(ids)}
    for c in data.contact[: data.ncon]:
        if c.geom[0] in pos and c.geom[1] in pos:
            assert allowed[pos[c.geom[0]], pos[c.geom[1]]]
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in ids]
    assert not allowed[names.index("f0_thigh_l"), names.index("f0_shin_l")]
    assert allowed[names.index("f0_hand_l"), names.index("f0_thigh_l")]


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
    assert {"steps", "builtin_contacts", "ellipsim_overlaps", "missed", "extra"} <= set(report)
    assert report["steps"] == 300 and len(report["per_frame"]["builtin_contacts"]) == 300
    assert report["builtin_contacts"] == sum(report["per_frame"]["builtin_contacts"]) > 0
    assert report["missed"] == 0 and report["extra"] == 0
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
        (["run", "pile", "--record", "/no/such/dir/x.rrd"], "--record: directory '/no/such/dir' does not exist"),
        (["run", "pile", "--record", "out.txt"], "--record must name a .rrd file, got 'out.txt'"),
        (["compare", "pile", "--json", "/no/such/dir/x.json"], "--json: directory '/no/such/dir' does not exist"),
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
    proc = cli("run", write(tmp_path, GOOD.replace('kind = "sway"', 'kind = 5')))
    assert proc.returncode == 2
    assert "s.toml: key 'control.kind' must be a str, got 5" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
