"""A user's own MJCF model, run as a scenario: loading (includes and assets relative to the file),
keyframes, held controls, controls by actuator name, and the errors of models that do not fit.

tests/models/zoo.xml has a geom of every type, an <include> of its assets (a mesh file, an inline
height field, a material), five actuators and two keyframes; see its header.
"""

import json
import pathlib
import shutil
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from ellipsim.app import mjcf, scenario, simulate
from ellipsim.app.cli import main

MODELS = pathlib.Path(__file__).parent / "models"
ZOO = MODELS / "zoo.xml"


@pytest.fixture
def models(tmp_path):
    """A copy of tests/models in a temporary folder, to write variants of zoo.xml next to its assets."""
    target = tmp_path / "models"
    shutil.copytree(MODELS, target)
    return target


def variant(models, name, old, new):
    """zoo.xml with `old` replaced by `new`, written beside it as `name`."""
    text = (models / "zoo.xml").read_text()
    assert old in text
    path = models / name
    path.write_text(text.replace(old, new, 1))
    return path


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True, cwd=cwd)


def one_line_error(proc):
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    return lines[-1]


# --- loading ---------------------------------------------------------------------------------------


def test_a_model_path_is_a_scenario(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # includes and the mesh file resolve relative to zoo.xml, not here
    s = scenario.load(str(ZOO))
    assert (s.name, s.timestep, s.mode, s.kinematic) == ("zoo", 0.004, "narrowphase", False)
    assert s.scene == {"kind": "mjcf", "path": str(ZOO), "key": None, "ctrl": "hold"}
    assert s.steps == round(scenario.MJCF_DURATION / 0.004)
    model, data = simulate.build(s)
    assert model.ngeom == 13 and model.nmesh == 1 and model.nhfield == 1 and model.nq == 19
    assert set(mjcf.geom_counts(model)) == {
        "plane",
        "hfield",
        "sphere",
        "capsule",
        "ellipsoid",
        "cylinder",
        "box",
        "mesh",
    }


def test_keyframes_by_name_and_index():
    model = mjcf.load_model(ZOO)
    assert [mjcf.keyframe(model, k) for k in (None, "rest", "hug", 1, "1", "-1", -3)] == [None, 0, 1, 1, 1, 2, 0]
    with pytest.raises(mjcf.ModelError, match=r"model: no keyframe named 'stand'; it has 3: rest, hug, wave"):
        mjcf.keyframe(model, "stand")
    with pytest.raises(mjcf.ModelError, match=r"keyframe index 3 is out of range; it has 3: rest, hug, wave"):
        mjcf.keyframe(model, 3)


def test_held_controls():
    """hold: each position servo's target is its joint's angle, the motor 0; zero; the keyframe's."""
    model = mjcf.load_model(ZOO)
    data = mujoco.MjData(model)
    ctrl = mjcf.start(model, data, 1, "hold")
    hinges = [model.joint(n).qposadr[0] for n in ("shoulder_l", "elbow_l", "shoulder_r", "elbow_r")]
    np.testing.assert_allclose(ctrl[:4], data.qpos[hinges], atol=1e-15)
    assert ctrl[1] == pytest.approx(-1.6) and ctrl[4] == 0.0
    np.testing.assert_array_equal(data.ctrl, ctrl)
    np.testing.assert_array_equal(mjcf.start(model, data, 1, "zero"), np.zeros(5))
    np.testing.assert_array_equal(mjcf.start(model, data, 1, "keyframe"), model.key_ctrl[1])
    with pytest.raises(mjcf.ModelError, match=r"ctrl 'keyframe' takes the controls of a keyframe: choose one with key"):
        mjcf.start(model, data, None, "keyframe")
    with pytest.raises(mjcf.ModelError, match=r"ctrl must be one of \('hold', 'zero', 'keyframe'\), got 'grip'"):
        mjcf.start(model, data, None, "grip")


@pytest.mark.parametrize("ctrl, target", [("hold", -1.2), ("zero", 0.0)])
def test_hold_keeps_the_keyframe_pose(ctrl, target):
    """From keyframe "wave" (right arm raised 1.2 rad, touching nothing) the servos hold the arm up
    while the figure drops onto the floor; with zero controls it falls to 0.  Within 0.15 rad: the
    kp = 40 servo sags under the arm's ~3 N m of gravity by ~0.08 rad, and rings after the landing."""
    s = scenario.with_model_options(scenario.load(str(ZOO)), key="wave", ctrl=ctrl)
    run = simulate.run(s, steps=300)
    assert run.steps == 300 and run.frames.contact_counts.max() > 0  # it lands on the floor
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    for _ in range(300):
        data.ctrl[:] = control(data.time)
        mujoco.mj_step(model, data)
    shoulder = data.qpos[model.joint("shoulder_r").qposadr[0]]
    assert abs(shoulder - target) < 0.15, shoulder


def test_controls_drive_actuators_by_name(tmp_path):
    """A TOML scenario of the model (path relative to the TOML) with keyframes naming actuators:
    the left elbow goes to -60 degrees, the others stay where `hold` holds them."""
    (tmp_path / "sub").mkdir()
    toml = tmp_path / "sub" / "wave.toml"
    toml.write_text(f"""
duration = 0.8
[scene]
kind = "mjcf"
path = "{ZOO}"
key = "rest"
[control]
kind = "keyframes"
keys = [{{ t = 0.0, joints = {{}} }}, {{ t = 0.4, joints = {{ elbow_l = -60 }} }}]
""")
    s = scenario.load(str(toml))
    assert s.timestep == 0.004 and s.scene["key"] == "rest"
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    np.testing.assert_allclose(control(0.8), [0, np.radians(-60), 0, 0, 0], atol=1e-15)
    relative = tmp_path / "sub" / "rel.toml"
    shutil.copytree(MODELS, tmp_path / "models")
    relative.write_text(toml.read_text().replace(str(ZOO), "../models/zoo.xml"))
    assert scenario.load(str(relative)).scene["path"] == str(tmp_path / "models" / "zoo.xml")


@pytest.mark.parametrize(
    "control, message",
    [
        (
            'kind = "sway"',
            r"\[control\] control 'sway' moves the figure's joints \(.*waist_bend.*\); none of the model's 5 actuators",
        ),
        (
            'kind = "keyframes"\nkeys = [{t = 0}, {t = 1, joints = {wrist = 3}}]',
            r"\[control\] keys\[1\]\.joints names 'wrist', which no actuator drives; the model's actuators are elbow_l, elbow_r, hip",
        ),
    ],
)
def test_controls_that_do_not_fit_the_model(tmp_path, control, message):
    toml = tmp_path / "m.toml"
    toml.write_text(f'duration = 0.1\n[scene]\nkind = "mjcf"\npath = "{ZOO}"\n[control]\n{control}\n')
    s = scenario.load(str(toml))
    with pytest.raises(scenario.ScenarioError, match=rf"m\.toml: {message}"):
        simulate.run(s, steps=2)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            'duration = 1\nkinematic = true\n[scene]\nkind = "mjcf"\npath = "{zoo}"\n[control]\nkind = "keyframes"\nkeys = [{{t = 0}}, {{t = 1}}]\n',
            r"key 'kinematic' must be false for an mjcf scene \(to pose a model frame by frame: ellipsim replay MODEL MOTION\)",
        ),
        ('duration = 1\n[scene]\nkind = "mjcf"\n[control]\n', r"missing key 'scene\.path'"),
        (
            'duration = 1\n[scene]\nkind = "mjcf"\npath = "nope.xml"\n[control]\n',
            r"\[scene\] path: model '.*nope\.xml' does not exist",
        ),
        (
            'duration = 1\n[scene]\nkind = "mjcf"\npath = "{zoo}"\nfigures = 3\n[control]\n',
            r"unknown key 'scene\.figures' \(known here: kind, path, key, ctrl\)",
        ),
        (
            'duration = 1\n[scene]\nkind = "mjcf"\npath = "{zoo}"\nctrl = "grip"\n[control]\n',
            r"key 'scene\.ctrl' must be one of",
        ),
    ],
)
def test_mjcf_scene_tables_are_checked(tmp_path, text, message):
    toml = tmp_path / "m.toml"
    toml.write_text(text.format(zoo=ZOO))
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.load(str(toml))


def test_model_errors_are_one_line(models):
    broken = variant(models, "broken.xml", "<worldbody>", "<worldbody><bodyy/>")
    with pytest.raises(
        scenario.ScenarioError,
        match=r"broken\.xml: MuJoCo cannot read this model: .*unrecognized element; Element 'bodyy'",
    ) as info:
        scenario.load(str(broken))
    assert str(info.value).count("broken.xml") == 1  # the path once, not again as "the model '...'"
    missing = variant(models, "missing.xml", 'file="zoo_assets.xml"', 'file="gone.xml"')
    with pytest.raises(scenario.ScenarioError, match=r"Error opening file 'gone\.xml'; Element 'include'") as info:
        scenario.load(str(missing))
    assert "\n" not in str(info.value)
    bad_size = variant(models, "bad_size.xml", 'size="0.12 0.16 0.28"', 'size="0 0.16 0.28"')
    s = scenario.load(str(bad_size))  # parses; MuJoCo refuses it when compiling
    with pytest.raises(
        scenario.ScenarioError, match=r"bad_size\.xml: MuJoCo cannot load this model: Error: size 0 must be positive"
    ):
        simulate.build(s)
    with pytest.raises(scenario.ScenarioError, match=r"model '.*nothere\.xml' does not exist or is not a file"):
        scenario.load(str(models / "nothere.xml"))


def test_mujoco_out_of_memory_is_a_clear_error(models, monkeypatch):
    monkeypatch.chdir(models)  # MuJoCo logs its warnings to MUJOCO_LOG.TXT in the working directory
    small = variant(models, "small.xml", '<option timestep="0.004"/>', '<option timestep="0.004"/><size memory="2K"/>')
    s = scenario.load(str(small))
    with pytest.raises(
        scenario.ScenarioError,
        match=r"small\.xml MuJoCo stopped at step \d+: mj_stackAlloc: out of memory.*increase <size memory",
    ):
        simulate.run(s, steps=200)
    huge = variant(models, "huge.xml", '<option timestep="0.004"/>', '<option timestep="0.004"/><size memory="100T"/>')
    with pytest.raises(
        scenario.ScenarioError, match=r"huge\.xml: MuJoCo could not allocate the model's memory .*<size memory"
    ):
        simulate.build(scenario.load(str(huge)))


def test_too_many_figures_for_memory_is_refused_before_building(tmp_path):
    toml = tmp_path / "many.toml"
    toml.write_text("duration = 0.01\ntimestep = 0.002\n[scene]\nfigures = 100000\n[control]\n")
    s = scenario.load(str(toml))
    with pytest.raises(
        scenario.ScenarioError,
        match=r"many\.toml: \[scene\] figures = 100000 needs 9\.1e\+03 GB of MuJoCo arena "
        r"\(its broad phase takes 4 bytes per pair of the model's 1500001 bodies\), "
        r"more than the .* available: at most \d+ figures here",
    ):
        simulate.build(s)


# --- the command line ------------------------------------------------------------------------------


@pytest.mark.slow
def test_run_and_compare_a_model_from_the_command_line(tmp_path):
    proc = cli("run", str(ZOO), "--steps", "150", "--key", "hug", "--ctrl", "keyframe", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "zoo: MJCF model" in proc.stdout and "from its keyframe 'hug', actuators: keyframe" in proc.stdout
    assert "150 steps of 0.004 s" in proc.stdout and "narrow phase:" in proc.stdout
    report = tmp_path / "zoo.json"
    proc = cli("compare", str(ZOO), "--steps", "100", "--key", "1", "--json", str(report), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(report.read_text())
    assert {
        "scenario",
        "engine",
        "steps",
        "pairs",
        "agreement",
        "mujoco_contacts",
        "ellipsim_contacts",
        "mujoco_extra",
        "mujoco_missed",
        "near_tangent",
        "normal_off",
        "undetermined",
        "no_candidates",
        "normal_off_deg",
        "by_pair_type",
        "per_step",
        "disagreements",
        "passed_through",
        "contacts_disabled",
    } == set(got)
    assert got["passed_through"] is None or isinstance(got["passed_through"], list)  # None: not looked for
    assert got["scenario"] == "zoo" and got["steps"] == 100 and got["ellipsim_contacts"] > 0
    assert got["mujoco_extra"] == 0 and got["mujoco_missed"] == 0
    # the hug: the left hand (a sphere) and forearm (a capsule) in the torso (an ellipsoid), both judged
    by_type = got["by_pair_type"]
    assert (
        by_type["ellipsoid-sphere"]["ellipsim_contacts"] > 0 and by_type["ellipsoid-capsule"]["ellipsim_contacts"] > 0
    )


@pytest.mark.parametrize(
    "args, message",
    [
        (["run", str(ZOO), "--key", "stand"], "no keyframe named 'stand'; it has 3: rest, hug, wave"),
        (
            ["run", str(ZOO), "--ctrl", "keyframe"],
            "ctrl 'keyframe' takes the controls of a keyframe: choose one with key (--key)",
        ),
        (["run", "pile", "--key", "1"], "--key applies to MJCF models; scenario 'pile' builds a figures scene"),
        (["run", "nothere.xml"], "model 'nothere.xml' does not exist or is not a file"),
        (["compare", str(ZOO), "--key", "9"], "keyframe index 9 is out of range"),
    ],
)
def test_model_mistakes_on_the_command_line(args, message):
    assert message in one_line_error(cli(*args))


def test_main_runs_a_model(capsys):
    assert main(["run", str(ZOO), "--steps", "20", "--mode", "filter"]) == 0
    out = capsys.readouterr().out
    assert "20 steps of 0.004 s" in out and "filter:" in out and "contacts per step (all geoms)" in out
