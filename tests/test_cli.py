import errno
import io
import json
import os
import pathlib
import re
import signal
import subprocess
import sys
import time
import types

import mujoco
import numpy as np
import pytest
import trimesh

import ellipsim
from ellipsim import classify, contact_scale, shipped
from ellipsim.app import fit as fitting
from ellipsim.app import mjcf, scenario
from ellipsim.app import replay as rp
from ellipsim.app import sweep as sw
from ellipsim.app.cli import Progress, common, main
from ellipsim.app.cli import scenarios as scenarios_command
from ellipsim.core.samples import generic_pairs, near_contact_pairs


def ctrl_c_default():
    """SIGINT back to its default before exec, so the child installs Python's KeyboardInterrupt handler
    even when pytest itself runs as a background job (which ignores SIGINT)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True, cwd=cwd)


def one_line_error(proc):
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1
    return lines[0]


def test_demo_prints_the_table(capsys):
    assert main(["demo", "--pairs", "2000", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "2000 random ellipsoid pairs" in out
    exact_row = next(line for line in out.splitlines() if line.strip().startswith("exact "))
    sep, touch, over, wrong = (int(x) for x in exact_row.split()[1:5])
    assert (sep, touch + over, wrong) == (1000, 1000, 0)


@pytest.mark.parametrize(
    "args, message",
    [
        (["demo", "--pairs", "0"], "--pairs: expected a positive integer, got 0"),
        (["demo", "--pairs", "many"], "--pairs: expected a positive integer, got 'many'"),
        (["demo", "--pairs", "1.5"], "--pairs: expected a positive integer, got '1.5'"),
        (["demo", "--seed", "-1"], "--seed: expected a non-negative integer, got -1"),
        (["demo", "--pairs", "1e9"], "--pairs 1000000000 needs 1e+03 GB, more than the"),
        (
            ["run", "crowd", "--steps", "1e15"],
            "--steps 1000000000000000: 1000000000000000 steps (125000000000000 recorded frames of counts) needs 5e+06 GB",
        ),
        (
            ["compare", "crowd", "--steps", "1e15"],
            "--steps 1000000000000000: 1000000000000000 steps of pair counts needs 4e+07 GB",
        ),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        ([], "the following arguments are required: command"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(args, message):
    assert message in one_line_error(cli(*args))


@pytest.mark.parametrize(
    "error, shown",
    [
        (scenario.ScenarioError("s.toml: missing key 'duration'"), "s.toml: missing key 'duration'"),
        (mjcf.ModelError("m.xml: no keyframe named 'up'"), "m.xml: no keyframe named 'up'"),
        (rp.MotionError("motion 'w.csv' has no frames"), "motion 'w.csv' has no frames"),
        (sw.SweepError("seeds must be a positive integer, got 0"), "--seeds must be a positive integer, got 0"),
    ],
)
def test_every_domain_error_is_a_user_error_reported_in_one_line(monkeypatch, capsys, error, shown):
    """The CLI catches errors.UserError alone: a domain error that is not one would end in a traceback."""

    def fail(args):
        raise error

    monkeypatch.setattr(scenarios_command, "list_scenarios", fail)
    assert main(["list"]) == 2
    assert capsys.readouterr().err == f"ellipsim: error: {shown}\n"


def test_counts_take_float_notation_of_whole_numbers():
    assert common.count("1e3") == 1000 and common.count("2_000") == 2000 and common.count("0", allow_zero=True) == 0


def test_version():
    proc = cli("--version")
    assert proc.returncode == 0 and proc.stdout.strip() == f"ellipsim {ellipsim.__version__}"


def test_view_refuses_a_file_that_is_not_a_recording(tmp_path):
    fake = tmp_path / "notes.rrd"
    fake.write_text("hello")
    assert f"'{fake}' is not a rerun recording" in one_line_error(cli("view", str(fake)))


def test_hints_name_the_extra_to_install_from_a_checkout(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "replay", "--steps", "2", "--plot", str(tmp_path / "p.png")]) == 2
    root = os.path.dirname(os.path.dirname(os.path.abspath(ellipsim.__file__)))
    assert (
        capsys.readouterr().err.strip() == f"ellipsim: error: plots need matplotlib: pip install '.[plot]' (in {root})"
    )
    monkeypatch.setattr(shipped, "source_checkout", lambda: None)  # an installed copy
    assert common.install_hint("plot") == "pip install 'ellipsim[plot]'"


def test_sample_sets():
    a, b = generic_pairs(1000, seed=5)
    rel = classify(a, b)
    assert len(a) == 1000 and np.count_nonzero(rel == 0) == 500
    a, b = near_contact_pairs(300, band=0.05, seed=5)
    assert len(a) == 300 and np.all(np.abs(contact_scale(a, b) - 1) < 0.05)


def test_show_must_not_be_negative():
    proc = subprocess.run(
        [sys.executable, "-m", "ellipsim", "compare", "replay", "--show", "-1"], capture_output=True, text=True
    )
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--show: expected a non-negative integer, got -1" in lines[0]


def test_compare_quotes_the_bands_it_judges_by(capsys):
    """The near-tangent band and the normal_off angle are the library's constants, quoted as such, and the
    JSON states the angle."""
    from ellipsim.core.tolerances import NEAR_TANGENT
    from ellipsim.mujoco.judge import NORMAL_OFF_DEG

    assert main(["compare", "pile", "--steps", "850", "--show", "0"]) == 0  # near-tangent pairs from step 825
    out = capsys.readouterr().out
    assert f"within {NEAR_TANGENT:g} m of the margin" in out and f"beyond {NORMAL_OFF_DEG:g} deg of the exact" in out


def test_compare_json_is_compact_in_a_folder_made_for_it(tmp_path, capsys):
    """A per-step array is one line, not a number a line; the folders of --json are made."""
    out = tmp_path / "reports" / "june" / "replay.json"
    assert main(["compare", "replay", "--steps", "300", "--json", str(out)]) == 0
    text = out.read_text()
    report = json.loads(text)
    assert report["steps"] == 300 and len(report["per_step"]["both"]) == 300
    lines = text.splitlines()
    # the header and per-step arrays, about 11 lines per pair type, one per disagreement
    budget = 35 + 11 * len(report["by_pair_type"])
    assert len(lines) <= budget + len(report["disagreements"]) + len(report["passed_through"] or []), text[:2000]
    both = next(line for line in lines if line.lstrip().startswith('"both"'))
    assert json.loads(both.split(": ", 1)[1].rstrip(",")) == report["per_step"]["both"]


def _disagreement(step):
    from ellipsim.mujoco.validate import Disagreement

    return Disagreement(
        step=step,
        geom1=0,
        geom2=1,
        names=("a", "b"),
        mujoco_contact=True,
        mujoco_dist=-1e-3,
        relation="separated",
        contact_scale=1.01,
        geom_distance=0.01,
        right="ellipsim",
        reason="r",
        kind="mujoco_extra",
        pair_type="ellipsoid-ellipsoid",
    )


@pytest.mark.parametrize(
    "show, more",
    [(2, "    ... and 2 more (--show N, or --json)"), (4, None), (0, "    ... and 4 more (--show N, or --json)")],
)
def test_compare_says_how_many_disagreements_it_does_not_show(show, more):
    from ellipsim.app.comparison import Comparison

    counts = np.array([[0, 3, 4, 0]])
    ds = [_disagreement(k) for k in range(4)]
    by_type = np.zeros((1, 5, 4), dtype=np.int64)
    by_type[0, 0] = counts[0]
    validation = types.SimpleNamespace(counts=counts, by_type=by_type, contacts_disabled=False, disagreements=ds)
    c = Comparison("s", 1, validation, counts[:, 2], counts[:, 0], {"mujoco_extra": ds}, None, None)
    lines = c.summary(show)
    shown = [line for line in lines if line.startswith("    step ")]
    assert [line.split(":")[0] for line in shown] == [f"    step {k}" for k in range(min(show, 4))]
    assert [line for line in lines if "more" in line] == ([more] if more else [])


CONTACTS_OFF = """<mujoco><option><flag contact="disable"/></option><worldbody>
  <body><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>
  <body pos="0.05 0 0"><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>
</worldbody></mujoco>"""


def test_a_model_without_contacts_says_so(tmp_path, capsys):
    """dm_control's fish disables contacts: say so, not `agreement 0/0 (0.0000%)`."""
    from ellipsim.mujoco.validate import contacts_disabled

    path = tmp_path / "off.xml"
    path.write_text(CONTACTS_OFF)
    assert contacts_disabled(mujoco.MjModel.from_xml_string(CONTACTS_OFF))
    assert not contacts_disabled(mujoco.MjModel.from_xml_string(CONTACTS_OFF.replace('contact="disable"', "")))
    assert main(["compare", str(path), "--steps", "5"]) == 0
    out = capsys.readouterr().out
    assert 'no candidate pairs in 5 steps: the model disables contacts (<option><flag contact="disable"/>)' in out
    assert "0/0" not in out and "agreement" not in out
    assert main(["run", str(path), "--steps", "5"]) == 0
    out = capsys.readouterr().out
    assert "contacts per step (all geoms): mean 0.0, max 0; none: the model disables contacts" in out


def test_narrow_phase_counts_add_up(capsys):
    """pairs = certified apart + measured beyond the margin + contacts + fallbacks, all shown."""
    assert main(["run", "pile", "--steps", "300", "--mode", "narrowphase"]) == 0
    line = next(line for line in capsys.readouterr().out.splitlines() if "narrow phase:" in line)
    found = re.fullmatch(
        r"  narrow phase: (\d+) pairs = (\d+) certified apart \+ (\d+) measured beyond the margin \+ (\d+) "
        r"contacts \+ (\d+) fallbacks to MuJoCo",
        line,
    )
    assert found, line
    total, *parts = (int(x) for x in found.groups())
    assert total == sum(parts) and parts[1] > 0 and parts[2] > 0  # the pile has pairs of each kind


def _unwritable(*args, **kwargs):
    raise PermissionError(errno.EACCES, "Permission denied")


@pytest.mark.parametrize(
    "args, patch",
    [
        (
            ["compare", "replay", "--steps", "5", "--json", "{dir}/c.json"],
            ("ellipsim.app.cli.common.open", _unwritable),
        ),
        (
            ["compare", "replay", "--steps", "5", "--plot", "{dir}/c.png"],
            ("matplotlib.figure.Figure.savefig", _unwritable),
        ),
        (["run", "replay", "--steps", "5", "--record", "{dir}/c.rrd"], ("ellipsim.app.record.os.replace", _unwritable)),
    ],
)
def test_output_that_cannot_be_written_is_one_line(tmp_path, monkeypatch, capsys, args, patch):
    """A write that fails after the run (full disk, permissions changed meanwhile): one line, status 2."""
    if "--plot" in args:
        pytest.importorskip("matplotlib")
    target, fake = patch
    monkeypatch.setattr(target, fake, raising=False)
    args = [a.format(dir=tmp_path) for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()  # the progress bar's lines, then the error
    assert err[-1] == f"ellipsim: error: {args[-2]}: cannot write {args[-1]!r}: Permission denied"
    assert not any("error" in line or "Traceback" in line for line in err[:-1])
    assert os.listdir(tmp_path) == []  # no partial file left behind


@pytest.mark.parametrize(
    "sig, status, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_interrupted_recording_keeps_its_frames(tmp_path, sig, status, word):
    """Ctrl-C or SIGTERM during `run --record`: the frames so far are a complete recording that
    rerun reads, in a folder made for it, and the one line says at which step and how many frames."""
    from test_record import Recording

    from ellipsim.app import scenario, simulate

    out = tmp_path / "runs" / "crowd.rrd"  # runs/ is made: parents of an output are made if missing
    out.parent.parent.joinpath("crowd.rrd").write_bytes(b"")  # a neighbour the recording must not touch
    proc = subprocess.Popen(
        [sys.executable, "-m", "ellipsim", "run", "crowd", "--steps", "200000", "--record", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=ctrl_c_default,  # a shell's background job ignores SIGINT, and the child would inherit it
    )
    try:
        line = proc.stderr.readline()  # the progress bar's first line: stepping has begun
        assert "crowd [" in line, line
        time.sleep(0.5)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == status, err
    last = err.strip().splitlines()[-1]
    found = re.fullmatch(rf"ellipsim: {word} at step (\d+)/200000; recording of (\d+) frames kept in (.+)", last)
    assert found and "Traceback" not in err, err
    steps, frames = int(found[1]), int(found[2])
    assert found[3] == str(out) and 0 < steps < 200000
    every = simulate.record_every(scenario.load("crowd"))
    assert frames == -(-steps // every)  # a frame at every `every`-th step from step 0
    got, _, counts = Recording(str(out)).temporal("/counts/pairs/builtin", "Scalars:scalars")
    assert got == list(range(frames)) and len(counts) == frames
    assert sorted(os.listdir(out.parent)) == ["crowd.rrd"]  # no partial file beside it
    assert out.parent.parent.joinpath("crowd.rrd").read_bytes() == b""


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_shows_a_rate_only_once_it_means_something(monkeypatch):
    clock = iter([0.0, 0.1, 0.5, 1.5, 2.0, 2.6, 3.0])
    monkeypatch.setattr(time, "perf_counter", lambda: next(clock))
    stream = Terminal()
    bar = Progress("x", 100, stream=stream)
    for done in (1, 5, 20, 30, 60, 70):
        bar(done)
    lines = stream.getvalue().split("\r")[1:]  # redrawn in place
    assert len(lines) == 6 and bar.done == 70
    assert not any("/s" in line or "left" in line for line in lines[:3])  # compile and warm-up: no rate
    assert lines[-1].endswith("70/100 steps, 33/s, 1 s left")  # (70 - 20) / (3.0 - 1.5) s from the anchor


def test_progress_without_a_terminal_prints_by_time_not_by_tenths(monkeypatch):
    """In a log (no terminal) a line at the start, then one per Progress.INTERVAL seconds with the
    time elapsed and left, and the last: not ten lines minutes apart, nor one per call."""
    clock = iter([0.0, 0.5, 5.0, 10.0, 15.4, 16.0, 20.0, 30.0, 31.5, 40.0])
    monkeypatch.setattr(time, "perf_counter", lambda: next(clock))
    stream = io.StringIO()
    bar = Progress("x", 1000, stream=stream)
    assert Progress.INTERVAL == 15.0
    for done in (1, 100, 200, 300, 320, 400, 600, 610, 1000):
        bar(done)
    lines = stream.getvalue().splitlines()
    assert [line.split("] ")[1].split(",")[0] for line in lines] == [
        "  0.1% 1/1000 steps in 0 s",  # the first call: stepping has begun
        " 32.0% 320/1000 steps in 16 s",  # 15.5 s after the first line
        " 61.0% 610/1000 steps in 32 s",
        "100.0% 1000/1000 steps in 40 s",  # the end, whenever it comes
    ]
    assert lines[1].endswith("320/1000 steps in 16 s, 20/s, 34 s left")  # (320 - 100) / (16 - 5) s from the anchor


# --- fit -------------------------------------------------------------------------------------------


def test_fit_prints_short_numbers_and_writes_mjcf_that_encloses_the_meshes(tmp_path, capsys):
    arm = trimesh.creation.capsule(height=0.3, radius=0.05)
    arm.apply_transform(trimesh.transformations.rotation_matrix(0.4, [1, 2, 3], [0.1, 0.0, 0.2]))
    arm.apply_translation([0.1, -0.05, 0.9])
    arm.export(tmp_path / "arm.stl")
    box = trimesh.creation.box([0.2, 0.1, 0.05])
    box.apply_translation([1e-15, 0.3, 0.0])  # a centre with 1e-15 noise: printed as 0
    box.export(tmp_path / "foot.obj")
    out = tmp_path / "model" / "limbs.xml"  # model/ is made
    assert (
        main(["fit", str(tmp_path / "arm.stl"), str(tmp_path / "foot.obj"), "--method", "mvee", "--out", str(out)]) == 0
    )
    text = capsys.readouterr().out
    rows = [line.split() for line in text.splitlines() if line.split()[:1] in (["arm"], ["foot"])]
    assert [r[0] for r in rows] == ["arm", "foot"]
    for row in rows:
        numbers = row[1:11]
        assert all(len(re.sub(r"[-.]|^0+", "", n).lstrip("0")) <= 6 for n in numbers), (
            numbers
        )  # <= 6 significant digits
    assert rows[1][1:4] == ["0", "0.3", "0"]
    model = mujoco.MjModel.from_xml_path(str(out))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for name, mesh in (("arm", tmp_path / "arm.stl"), ("foot", tmp_path / "foot.obj")):
        g = model.geom(name).id
        vertices = fitting.mesh_vertices(str(mesh))
        local = (vertices - data.geom_xpos[g]) @ data.geom_xmat[g].reshape(3, 3) / model.geom_size[g]
        level = np.einsum("ij,ij->i", local, local)
        assert (
            level.max() <= 1 + 1e-6 and level.max() > 0.9
        )  # every vertex inside (MuJoCo's float32-free numbers), tight


def test_fit_mistakes_are_one_line(tmp_path):
    assert "mesh file" in one_line_error(cli("fit", str(tmp_path / "none.stl")))
    assert "--out must name a .xml file" in one_line_error(cli("fit", str(tmp_path / "none.stl"), "--out", "x.txt"))


def test_bench_sections_are_the_suites_and_the_cli_starts_without_it(tmp_path, capsys):
    from ellipsim.app import bench
    from ellipsim.app.cli import bench as bench_cli

    assert list(bench_cli.SECTIONS) == list(bench.SECTIONS)  # --help lists the suite's sections, in its order
    with pytest.raises(SystemExit) as stopped:
        main(["bench", "--only", "stress", "nosuch", "--out", str(tmp_path / "b")])
    assert stopped.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("ellipsim bench: error: argument --only: invalid choice: 'nosuch'") and err.count("\n") == 0
    assert all(repr(name) in err for name in bench.SECTIONS)
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    shown = capsys.readouterr().out
    assert all(f"  {name:<12} {what}" in shown for name, what in bench_cli.SECTIONS.items())
    assert not (tmp_path / "b").exists()
    code = "import sys\nfrom ellipsim.app import cli\ncli.parser()\nprint('ellipsim.app.bench' in sys.modules)\n"
    assert (
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
        == "False"
    )


def test_record_flags_draw_labels_and_the_models_colours(tmp_path):
    from ellipsim.app import record, scenario, simulate
    from tests.test_record import Recording, packed

    out = tmp_path / "hs.rrd"
    assert main(["run", "handshake", "--steps", "20", "--record", str(out), "--labels", "--colors", "mjcf"]) == 0
    rec = Recording(out)
    entity = next(e for e in rec.entities() if e.endswith("/geoms/ellipsoids"))
    assert rec.static(entity, "Ellipsoids3D:show_labels") == [[True]]
    model, _ = simulate.build(scenario.load("handshake"))
    (labels,) = rec.static(entity, "Ellipsoids3D:labels")
    _, _, colors = rec.temporal(entity, "Ellipsoids3D:colors")
    mjcf = [packed(record.rgba8(model.geom_rgba[model.geom(name).id])) for name in labels]
    assert colors[0] == mjcf  # frame 0, every geom free: the model's own colours
    default = tmp_path / "plain.rrd"
    assert main(["run", "handshake", "--steps", "20", "--record", str(default)]) == 0
    plain = Recording(default)
    assert plain.static(entity, "Ellipsoids3D:show_labels") == [[False]]
    assert plain.temporal(entity, "Ellipsoids3D:colors")[2][0] != mjcf  # a hue per figure instead


@pytest.mark.parametrize("command", [["run"], ["compare", "--steps", "3"], ["run", "--engine", "warp", "--steps", "2"]])
def test_a_model_mujoco_refuses_is_one_line_naming_the_file_as_typed(tmp_path, command):
    """No header before the error (it is printed once the model is built), and the file as the user typed
    it, as ellipsim's own errors show it (not MuJoCo's absolute path)."""
    (tmp_path / "bad.xml").write_text('<mujoco><worldbody><geom type="sphere" size="-1"/></worldbody></mujoco>')
    line = one_line_error(cli(command[0], "bad.xml", *command[1:], cwd=tmp_path))
    assert line.startswith("ellipsim: error: bad.xml: MuJoCo ") and str(tmp_path) not in line, line


def test_an_mjcf_models_own_colours_textures_and_tendons_are_drawn(tmp_path):
    """A model's own colours by default (a material's, a texture's mean times it), and its spatial tendons a
    path each frame: the weight hangs on its rope (the path from the anchor to the hook, 0.55 m and what a soft
    limit gives)."""
    from ellipsim.app import capture, record
    from tests.test_record import Recording, packed

    path = pathlib.Path(__file__).parent / "models" / "weight.xml"
    model = mujoco.MjModel.from_xml_path(str(path))
    out = tmp_path / "w.rrd"
    assert main(["run", str(path), "--steps", "400", "--record", str(out)]) == 0
    rec = Recording(out)
    rgba = lambda name: packed(record.rgba8(model.geom_rgba[model.geom(name).id]))  # noqa: E731
    _, _, colors = rec.temporal("/world/model/weight/geoms/ellipsoids", "Ellipsoids3D:colors")
    assert colors[0] == [rgba("weight")]  # hanging free: the model's green
    _, _, colors = rec.temporal("/world/model/balloon/geoms/ellipsoids", "Ellipsoids3D:colors")
    assert colors[0] == [packed(record.rgba8(model.mat_rgba[model.material("red").id]))]  # its material's
    assert rec.static("/world/model/box/geoms/boxes", "Boxes3D:colors") == [[rgba("crate")]]
    floor = model.mat_rgba[model.material("grid").id].copy()
    floor[:3] *= capture.texture_colors(model)[model.material("grid").id]
    assert rec.static("/world/model/geoms/floor", "Mesh3D:albedo_factor")[-1] == [packed(record.rgba8(floor))]
    assert 0.1 < floor[:3].mean() < 0.5  # the checker's blues, not white
    frames, _, strips = rec.temporal("/world/tendons", "LineStrips3D:strips")
    assert len(frames) == 50 and all(len(s) == 1 and len(s[0]) == 2 for s in strips)  # one rope, two points
    anchor = model.site("anchor").pos
    for a, b in (s[0] for s in strips):
        np.testing.assert_allclose(a, anchor, atol=1e-6)
        # the weight below, held (MuJoCo's limit is soft: under the weight it gives a few millimetres)
        assert np.linalg.norm(np.subtract(b, a)) <= 0.56 and b[2] < a[2]
    _, _, colors = rec.temporal("/world/tendons", "LineStrips3D:colors")
    assert colors[0] == [packed(record.rgba8(model.tendon_rgba[0]))]
    hued = tmp_path / "hued.rrd"  # the hue per figure stays an option
    assert main(["run", str(path), "--steps", "20", "--record", str(hued), "--colors", "figure"]) == 0
    _, _, colors = Recording(hued).temporal("/world/model/weight/geoms/ellipsoids", "Ellipsoids3D:colors")
    assert colors[0] != [rgba("weight")]
