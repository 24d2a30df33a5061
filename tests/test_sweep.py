"""Sweeps: variants and their validation, rows against a direct run, backends, resume, failures, CLI."""

import csv
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest
from rerun.chunk import RrdReader
from test_cli import ctrl_c_default

from ellipsim.app import scenario, simulate
from ellipsim.app import sweep as sw
from ellipsim.app.cli import main

# One figure flailing in free fall (shipped): its limbs meet within 30 steps, the feet 7.5 cm deep.
TINY = dict(vary={"control.amplitude": [0.8, 1.0]}, seeds=2, steps=40)
PILE = """
description = "a few free ellipsoids"
duration = 0.06
timestep = 0.002
[scene]
kind = "pile"
ellipsoids = 4
[control]
kind = "hold"
"""


def cli(*args, env=None):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True, env=env)


def one_line_error(proc):
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


def deterministic(rows):
    return [{k: v for k, v in r.items() if k not in sw.TIMING} for r in rows]


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_vary_values_are_toml_literals_or_bare_words():
    assert sw.parse_vary("scene.figures=2,4,8") == ("scene.figures", [2, 4, 8])
    assert sw.parse_vary("timestep=0.002,1e-3,.5") == ("timestep", [0.002, 0.001, 0.5])
    assert sw.parse_vary("mode=builtin, narrowphase") == ("mode", ["builtin", "narrowphase"])
    assert sw.parse_vary('scene.floor=true,"true"') == ("scene.floor", [True, "true"])
    assert sw.parse_vary("gravity=[0, 0, -9.81],[0,0,-1.62]") == ("gravity", [[0, 0, -9.81], [0, 0, -1.62]])
    assert sw.parse_vary('description="a, b",c') == ("description", ["a, b", "c"])
    for text, message in (
        ("scene.figures", "expected KEY=V1,V2"),
        ("=2", "expected KEY=V1,V2"),
        ("scene.figures=2,,4", "value 2 is empty"),
        ("scene.figures=", "value 1 is empty"),
    ):
        with pytest.raises(sw.SweepError, match=message):
            sw.parse_vary(text)


def test_variants_are_the_product_with_seeds_innermost_and_ids_name_the_scenario():
    variants = sw.plan("tumble", {"control.amplitude": [0.8, 1.0], "timestep": [0.002, 0.004]}, seeds=2, steps=30)
    assert [(v.values["control.amplitude"], v.values["timestep"], v.values["seed"]) for v in variants] == [
        (a, t, s) for a in (0.8, 1.0) for t in (0.002, 0.004) for s in (0, 1)
    ]
    assert all(v.steps == 30 and v.mode == "narrowphase" and v.record is None for v in variants)
    v = variants[3]  # the seed goes to the scene and to the flailing control
    s = scenario.from_table(v.table, v.path)
    assert (s.scene["seed"], s.control["seed"], s.control["amplitude"], s.timestep) == (1, 1, 0.8, 0.004)
    assert len({v.id for v in variants}) == 8 and all(len(v.id) == 12 for v in variants)
    again = sw.plan("tumble", {"control.amplitude": [0.8, 1.0], "timestep": [0.002, 0.004]}, seeds=2, steps=30)
    assert [v.id for v in again] == [v.id for v in variants]
    # the id is the scenario's, not the spelling's: the shipped amplitude (0.8) set explicitly, or a file
    assert sw.plan("tumble", {"control.amplitude": [0.8]}, steps=30)[0].id == sw.plan("tumble", steps=30)[0].id
    assert sw.plan("tumble", steps=31)[0].id != sw.plan("tumble", steps=30)[0].id
    assert sw.plan(scenario.resolve("tumble"), steps=30)[0].id == sw.plan("tumble", steps=30)[0].id
    # without --steps each variant runs its own duration
    assert [v.steps for v in sw.plan("tumble", {"timestep": [0.002, 0.004]})] == [2000, 1000]


def test_a_model_sweeps_its_timestep_and_mode(tmp_path):
    model = os.path.join(os.path.dirname(__file__), "models", "zoo.xml")
    variants = sw.plan(model, {"timestep": [0.004, 0.002], "mode": ["builtin", "filter"]}, steps=5)
    assert [(v.values["timestep"], v.mode) for v in variants] == [
        (0.004, "builtin"),
        (0.004, "filter"),
        (0.002, "builtin"),
        (0.002, "filter"),
    ]
    rows = sw.sweep(model, {"mode": ["builtin", "filter"]}, steps=5, workers=1)
    assert [r["error"] for r in rows] == [None, None] and rows[0]["pairs"] == rows[1]["pairs"]
    with pytest.raises(sw.SweepError, match="seeds: zoo builds an mjcf scene, which has no seed"):
        sw.plan(model, seeds=2)


@pytest.mark.parametrize(
    "vary, kwargs, message",
    [
        (
            {"scene.figurs": [2]},
            {},
            r"vary scene\.figurs=2: .*tumble\.toml: unknown key 'scene\.figurs' \(did you mean 'scene\.figures'\?",
        ),
        (
            {"scene.figures": [1, "two"]},
            {},
            r"vary scene\.figures=two: .*key 'scene\.figures' must be an int, got 'two'",
        ),
        ({"timestep": [0.002, -1]}, {}, r"vary timestep=-1: .*key 'timestep' must be positive, got -1"),
        (
            {"duration": [0.01], "timestep": [0.002, 0.1]},
            {},
            r"vary duration=0\.01, timestep=0\.1: .*must not exceed the duration",
        ),
        ({"timestep.x": [1]}, {}, r"vary timestep\.x: 'timestep' is 0\.002, not a table"),
        ({"scene[0]": [1]}, {}, r"vary 'scene\[0\]': KEY must be a dotted TOML key"),
        ({"scene.figures": []}, {}, r"vary scene\.figures: no values"),
        ({"scene.figures": 2}, {}, r"vary scene\.figures: expected a list of values, got 2"),
        ({"scene.figures": [2, 2]}, {}, r"vary scene\.figures=2: the value is given twice"),
        (
            {"control.amplitude": [1, 1.0]},
            {},
            r"vary: control\.amplitude=1 and control\.amplitude=1\.0 are the same scenario",
        ),
        ({"mode": ["builtin"]}, {"mode": "filter"}, r"mode: given both as mode and in vary"),
        ({"scene.seed": [1]}, {"seeds": 2}, r"seeds: scene\.seed is also in vary"),
        ({}, {"seeds": 0}, r"seeds must be a positive integer, got 0"),
        ({}, {"steps": 2**60}, r"steps 1152921504606846976 \(the scenario\): .* needs .* more than"),
        ({}, {"mode": "gjk"}, r"mode must be one of"),
    ],
)
def test_every_variant_is_validated_before_any_runs(vary, kwargs, message):
    with pytest.raises(sw.SweepError, match=message):
        sw.plan("tumble", vary, **kwargs)


def test_a_row_is_plain_mujoco_validated_then_the_mode(tmp_path):
    """The comparison columns are simulate.validation's (as `ellipsim compare` counts them), the
    mode's columns those of the scenario's mode; both passes start from the same state."""
    v = sw.plan("tumble", steps=30)[0]
    row = sw.run_variant(v)
    s = scenario.load("tumble")
    validation, _ = simulate.validation(s, 30)
    kinds = [d.kind for d in validation.disagreements]
    c = validation.counts.sum(axis=0)
    assert row["error"] is None and row["mode"] == "narrowphase" and row["steps"] == 30
    assert (row["pairs"], row["mujoco_contacts"], row["ellipsim_contacts"]) == (c.sum(), c[0] + c[2], c[0] + c[3])
    for kind in ("mujoco_extra", "mujoco_missed", "near_tangent", "normal_off"):
        assert row[kind] == kinds.count(kind), kind
    assert row["mujoco_contacts"] > 10 and row["fallbacks"] == 0 and row["mujoco_warnings"] == 0
    # the flailing feet cross: 7.5 cm deep at frame 3 (exact signed distance, checked by hand)
    assert 0.07 < row["deepest_penetration"] < 0.08
    run = simulate.run(s, steps=30)  # the same trajectory as `ellipsim run`: the same frames overlap
    assert run.frames.ellipsim_counts.sum() > 0
    assert row["steps_per_second"] > 0 and row["wall_seconds"] > 0
    builtin = sw.run_variant(sw.plan("tumble", steps=30, mode="builtin")[0])
    assert builtin["fallbacks"] is None and builtin["pairs"] == row["pairs"]  # plain MuJoCo's pass either way


@pytest.mark.slow
def test_local_pool_gives_the_rows_of_one_process_and_a_rerun_resumes(tmp_path):
    out = tmp_path / "sweep"
    alone = sw.sweep("tumble", **TINY, workers=1)
    calls = []
    pooled = sw.sweep("tumble", **TINY, workers=2, out=out, progress=lambda done, total: calls.append((done, total)))
    assert deterministic(pooled) == deterministic(alone)
    assert calls[-1] == (4, 4) and len(calls) == 4
    assert sum(r["mujoco_contacts"] for r in pooled) > 0 and any(r["deepest_penetration"] > 0 for r in pooled)
    text = read_csv(out / sw.RESULTS)
    assert [r["variant"] for r in text] == [r["variant"] for r in pooled]  # sorted into variant order
    assert list(text[0]) == ["variant", "scenario", "control.amplitude", "seed", "mode", *sw._METRICS]
    assert set(sw.COLUMNS) >= set(text[0]) - {"control.amplitude"} and {r["scenario"] for r in text} == {"tumble"}
    assert (out / sw.PLOT).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # a re-run runs nothing and returns the same rows, timings included
    calls.clear()
    assert sw.sweep("tumble", **TINY, workers=2, out=out, progress=lambda *a: calls.append(a)) == pooled and calls == []
    # a crash while the last row was written: that line is cut short, and only that variant runs again
    lines = (out / sw.RESULTS).read_text().splitlines()
    (out / sw.RESULTS).write_text("\n".join(lines[:-1] + [lines[-1][:20]]) + "\n")
    again = sw.sweep("tumble", **TINY, workers=2, out=out, progress=lambda *a: calls.append(a))
    assert calls == [(1, 1)] and deterministic(again) == deterministic(pooled) and again[:3] == pooled[:3]
    # a bigger sweep into the same folder runs only its new variants
    calls.clear()
    more = sw.sweep(
        "tumble",
        vary={"control.amplitude": [0.8, 1.0, 0.6]},
        seeds=2,
        steps=40,
        workers=1,
        out=out,
        progress=lambda *a: calls.append(a),
    )
    assert calls[-1] == (2, 2) and deterministic(more[:4]) == deterministic(pooled)
    assert len(read_csv(out / sw.RESULTS)) == 6


@pytest.mark.slow
def test_a_failing_variant_is_a_row_with_its_error_and_runs_again_on_resume(tmp_path):
    path = tmp_path / "pile.toml"
    path.write_text(PILE)
    out = tmp_path / "out"
    vary = {"scene.bin_half_width": [0.5, 0.05]}  # 0.05 m cannot hold an ellipsoid: refused when the scene is built
    rows = sw.sweep(str(path), vary, workers=1, out=out)  # the CLI below runs it on the pool
    assert rows[0]["error"] is None and rows[0]["pairs"] is not None
    assert rows[1]["error"].startswith("ScenarioError: ") and "bin_half_width must be at least" in rows[1]["error"]
    assert rows[1]["pairs"] is None and rows[1]["wall_seconds"] > 0
    text = read_csv(out / sw.RESULTS)
    assert text[1]["error"] == rows[1]["error"] and text[1]["pairs"] == ""
    calls = []
    again = sw.sweep(str(path), vary, workers=1, out=out, progress=lambda *a: calls.append(a))
    assert calls == [(1, 1)] and again[1]["error"] == rows[1]["error"] and len(read_csv(out / sw.RESULTS)) == 2
    proc = cli("sweep", str(path), "--vary", "scene.bin_half_width=0.5,0.05", "--out", str(out))
    assert proc.returncode == 1 and "1 of 2 variants failed" in proc.stderr and "bin_half_width" in proc.stderr


def _stand_in(v):
    """A variant's function that kills its worker for one variant (as an out-of-memory kill would)."""
    if v.values["x"] == "die":
        os._exit(3)
    time.sleep(0.2)
    return {"variant": v.id, "x": v.values["x"], "error": None}


@pytest.mark.slow
def test_a_worker_that_dies_breaks_only_its_variant():
    todo = [sw.Variant(f"v{k}", {"x": x}, {}, "", 1, "builtin") for k, x in enumerate(["a", "die", "b", "c", "d"])]
    rows = []
    sw._run_local(todo, 2, rows.append, run=_stand_in)
    by_id = {r["variant"]: r for r in rows}
    assert sorted(by_id) == ["v0", "v1", "v2", "v3", "v4"] and len(rows) == 5
    assert by_id["v1"]["error"].startswith("WorkerDied: its worker process died while running it alone")
    assert all(by_id[v]["error"] is None for v in ("v0", "v2", "v3", "v4"))


@pytest.mark.slow
def test_recordings_one_per_variant_named_and_identified_by_it(tmp_path):
    out = tmp_path / "rec"
    proc = cli(
        "sweep",
        "tumble",
        "--vary",
        "control.amplitude=0.8,1.0",
        "--steps",
        "30",
        "--record",
        "--out",
        str(out),
        "--workers",
        "2",
    )
    assert proc.returncode == 0, proc.stderr
    rows = read_csv(out / sw.RESULTS)
    ids = [r["variant"] for r in rows]
    names = [f"tumble_control.amplitude={r['control.amplitude']}_{r['variant']}.rrd" for r in rows]
    assert names == [f"tumble_control.amplitude={a}_{i}.rrd" for a, i in zip(("0.8", "1.0"), ids)]
    assert len(ids) == 2 and sorted(p.name for p in out.glob("*.rrd")) == sorted(names)
    for vid, name in zip(ids, names):
        reader = RrdReader(str(out / name))
        assert [r.recording_id for r in reader.recordings()] == [vid]
        chunks = reader.stream().to_chunks()
        assert any(c.entity_path.endswith("geoms/ellipsoids") for c in chunks)
    assert not list(out.glob(".*part")) and f"view one with: ellipsim view {out / names[0]}" in proc.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["--vary", "scene.figurs=2"], "--vary scene.figurs=2: "),
        (["--vary", "scene.figures=two"], "key 'scene.figures' must be an int, got 'two'"),
        (["--vary", "scene.figures=0"], "--vary scene.figures=0: "),
        (["--vary", "scene.figures"], "--vary 'scene.figures': expected KEY=V1,V2,..."),
        (["--vary", "scene.figures=1", "--vary", "scene.figures=2"], "--vary scene.figures: given twice"),
        (["--vary", "mode=builtin", "--mode", "filter"], "--mode: given both"),
        (["--seeds", "0"], "--seeds: expected a positive integer, got 0"),
        (["--workers", "0"], "--workers: expected a positive integer, got 0"),
        (["--backend", "dask"], "--backend: invalid choice: 'dask'"),
    ],
)
def test_cli_mistakes_are_one_line_before_anything_runs(tmp_path, args, message):
    out = tmp_path / "out"
    line = one_line_error(cli("sweep", "tumble", "--steps", "5", "--out", str(out), *args))
    assert message in line
    assert not out.exists()


def test_cli_names_scenario_output_and_missing_ray(tmp_path, monkeypatch, capsys):
    assert "unknown scenario 'tumbel'" in one_line_error(cli("sweep", "tumbel", "--out", str(tmp_path / "o")))
    (tmp_path / "file").write_text("")
    assert "--out '" in one_line_error(cli("sweep", "tumble", "--out", str(tmp_path / "file")))
    line = one_line_error(cli("sweep", "tumble", "--out", str(tmp_path / "file" / "o")))
    assert f"--out: '{tmp_path / 'file'}' is not a directory" in line
    out = tmp_path / "sweeps" / "o"  # folders made if missing, as --help says (the README's `--out sweeps/pile`)
    assert main(["sweep", "tumble", "--steps", "5", "--out", str(out), "--workers", "1"]) == 0
    assert (out / sw.RESULTS).is_file()
    capsys.readouterr()
    assert main(["sweep", "tumble", "--steps", "5", "--vary", "timestep=0.002", "--out", str(out)]) == 2
    assert "holds the results of another sweep" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    assert main(["sweep", "tumble", "--steps", "5", "--out", str(tmp_path / "r"), "--backend", "ray"]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        err.startswith("ellipsim: error: --backend ray needs Ray: pip install '.[ray]'") and len(err.splitlines()) == 1
    )
    with pytest.raises(ImportError, match=r"backend 'ray' needs Ray: pip install 'ellipsim\[ray\]'"):
        sw.sweep("tumble", steps=5, backend="ray")
    assert not (tmp_path / "r").exists()


def test_without_matplotlib_the_cli_sweeps_and_says_the_plot_needs_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"matplotlib: pip install 'ellipsim\[plot\]'"):
        sw.sweep("tumble", steps=5, out=tmp_path / "api")
    assert main(["sweep", "tumble", "--steps", "5", "--out", str(tmp_path / "o"), "--workers", "1"]) == 0
    assert "no plot: it needs matplotlib" in capsys.readouterr().out
    assert (tmp_path / "o" / sw.RESULTS).exists() and not (tmp_path / "o" / sw.PLOT).exists()


def test_cli_prints_the_table(tmp_path, capsys):
    out = tmp_path / "o"
    assert (
        main(
            [
                "sweep",
                "tumble",
                "--vary",
                "control.amplitude=0.8,1.0",
                "--steps",
                "30",
                "--out",
                str(out),
                "--workers",
                "1",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "2 variants (2 control.amplitude), 30 steps each" in text
    ids = [r["variant"] for r in read_csv(out / sw.RESULTS)]
    head = next(line for line in text.splitlines() if "variant" in line and "missed" in line and "normal_off" in line)
    assert head.split()[:3] == ["variant", "control.amplitude", "steps/s"]
    assert [line.split()[:2] for line in text.splitlines() if line.split()[:1] in ([ids[0]], [ids[1]])] == [
        [ids[0], "0.8"],
        [ids[1], "1.0"],
    ]


def test_batches_deal_variants_round_robin():
    assert sw.batches(list(range(10)), 1) == [[0, 4, 8], [1, 5, 9], [2, 6], [3, 7]]
    assert sw.batches(list(range(3)), 2) == [[0], [1], [2]]
    assert sw.batches([], 2) == []


def test_plot_takes_categories_failures_and_a_lone_variant(tmp_path):
    rows = [
        {
            "mode": m,
            "seed": s,
            "mujoco_contacts": 3 + s,
            "ellipsim_contacts": 3,
            "mujoco_extra": 0,
            "mujoco_missed": s,
            "near_tangent": 0,
            "normal_off": 1,
            "steps_per_second": 1000.0 * (s + 1),
            "deepest_penetration": 0.001,
            "error": None,
        }
        for m in ("builtin", "narrowphase")
        for s in (0, 1)
    ] + [{"mode": "filter", "seed": 0, "error": "ScenarioError: no"}]
    for k in (
        "mujoco_contacts",
        "ellipsim_contacts",
        "mujoco_extra",
        "mujoco_missed",
        "near_tangent",
        "normal_off",
        "steps_per_second",
        "deepest_penetration",
    ):
        rows[-1][k] = None
    path = sw.plot_rows(rows, ["mode", "seed"], str(tmp_path / "a.png"), title="t")
    assert pathlib.Path(path).read_bytes()[:4] == b"\x89PNG"
    lone = [dict(rows[0], seed=None)]
    assert pathlib.Path(sw.plot_rows(lone, [], str(tmp_path / "b.png"))).read_bytes()[:4] == b"\x89PNG"


@pytest.fixture(scope="module")
def ray_local():
    """Ray started in this process on two CPUs, as CI runs it (local_mode is gone from Ray 2.x)."""
    import ray

    os.environ.pop("RAY_ADDRESS", None)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


@pytest.mark.slow
def test_ray_gives_the_rows_of_the_local_pool(tmp_path, ray_local):
    local = sw.sweep("tumble", **TINY, workers=2)
    calls = []
    out = tmp_path / "ray"
    rows = sw.sweep("tumble", **TINY, backend="ray", out=out, record=True, progress=lambda *a: calls.append(a))
    assert deterministic(rows) == deterministic(local) and calls[-1] == (4, 4)
    assert sorted(p.name for p in out.glob("*.rrd")) == sorted(
        sw.recording_name("tumble.toml", {k: r[k] for k in ("control.amplitude", "seed")}, r["variant"]) for r in rows
    )
    assert ray_local.is_initialized()  # a sweep leaves a Ray it did not start running


@pytest.mark.slow
def test_a_ray_worker_that_dies_breaks_only_its_variant(ray_local):
    import ray.cloudpickle

    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray's workers cannot import this file
    try:
        todo = [sw.Variant(f"v{k}", {"x": x}, {}, "", 1, "builtin") for k, x in enumerate(["die", "a", "b", "c", "d"])]
        assert sw.batches(todo, 1)[0] == [todo[0], todo[4]]  # v4 runs after v0 in the same task
        rows = []
        sw._run_ray(todo, 1, rows.append, run=_stand_in)
    finally:
        ray.cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    by_id = {r["variant"]: r for r in rows}
    assert sorted(by_id) == ["v0", "v1", "v2", "v3", "v4"] and len(rows) == 5
    assert by_id["v0"]["error"].startswith("WorkerDied: its Ray worker died while running it")
    assert all(by_id[v]["error"] is None for v in ("v1", "v2", "v3", "v4"))
    assert ray_local.is_initialized()


@pytest.mark.slow
def test_cli_sweep_on_ray_starts_its_own_instance(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    out = tmp_path / "o"
    proc = cli(
        "sweep",
        "tumble",
        "--vary",
        "control.amplitude=0.8,1.0",
        "--steps",
        "30",
        "--out",
        str(out),
        "--backend",
        "ray",
        "--workers",
        "2",
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    assert "running 2 on a local Ray instance" in proc.stdout
    local = sw.sweep("tumble", vary={"control.amplitude": [0.8, 1.0]}, steps=30, workers=1, out=out)
    assert [r["variant"] for r in read_csv(out / sw.RESULTS)] == [r["variant"] for r in local]


@pytest.mark.slow
def test_ctrl_c_stops_the_workers_keeps_the_rows_and_leaves_no_partial_recording(tmp_path):
    out = tmp_path / "o"
    # variants of ~3-10 s each on this VM: interrupted while both workers are recording
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "ellipsim",
            "sweep",
            "pile",
            "--vary",
            "scene.figures=2,3,4,5",
            "--steps",
            "400",
            "--record",
            "--out",
            str(out),
            "--workers",
            "2",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=ctrl_c_default,  # a shell's background job ignores SIGINT, and the child would inherit it
    )
    deadline = time.monotonic() + 120
    while not list(out.glob(".*.rrd.*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(out.glob(".*.rrd.*.part")), "no recording was started"
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "ellipsim: interrupted"
    assert time.monotonic() - t0 < 10  # the workers were stopped, not waited for
    assert not list(out.glob(".*part")) and (out / sw.RESULTS).exists()
    rows = read_csv(out / sw.RESULTS)
    assert all(r["error"] == "" for r in rows) and len(rows) < 4


def test_an_output_that_cannot_be_written_after_all_is_one_line(tmp_path, monkeypatch, capsys):
    def unwritable(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("matplotlib.figure.Figure.savefig", unwritable)
    out = tmp_path / "o"
    assert main(["sweep", "tumble", "--steps", "5", "--out", str(out), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == f"ellipsim: error: --out: cannot write {str(out)!r}: Permission denied"
    assert len(read_csv(out / sw.RESULTS)) == 1  # the rows are kept: a re-run only draws the plot


def test_a_script_whose_workers_cannot_start_is_told_why():
    """Spawned workers re-run the parent's main script: one read from standard input cannot be."""
    code = "from ellipsim.app import sweep as sw\nsw.sweep('tumble', steps=5, seeds=2, workers=2)\n"
    proc = subprocess.run([sys.executable, "-"], input=code, capture_output=True, text=True)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == (
        "RuntimeError: the local backend's worker processes could not start (their error is above); a script read "
        "from standard input cannot start them: run it from a file, or use workers=1"
    )
