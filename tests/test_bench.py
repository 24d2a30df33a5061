"""The benchmark suite's building blocks, and one quick run of `ellipsim bench`."""

import os
import sys

import numpy as np
import pytest

from ellipsim import Relation, classify, signed_distance
from ellipsim.app.bench import common as bench
from ellipsim.app.bench.inside_mujoco import TWIN_SWAPPED
from ellipsim.app.cli import main
from ellipsim.core.samples import STRESS, stress_pairs


@pytest.mark.parametrize("category", STRESS)
def test_stress_categories_are_what_they_say(category):
    a, b = stress_pairs(category, 60, seed=2)
    rel = classify(a, b)
    counts = np.bincount(rel, minlength=3)
    if category == "exactly tangent":
        assert counts[Relation.TOUCHING] == 60
    elif category in ("spheres", "coaxial spheroids"):
        assert counts.tolist() == [20, 20, 20]  # touching, 2^-40 apart, 2^-40 overlapping
    elif category == "identical and contained":
        assert counts[Relation.OVERLAPPING] == 60
    else:  # alternately just separated and just overlapping
        np.testing.assert_array_equal(rel, np.where(np.arange(60) % 2 == 0, 0, 2))


def test_stress_bad_category():
    with pytest.raises(ValueError, match="category must be one of"):
        stress_pairs("wobbly", 10)


def test_mujoco_pairs_measure_the_same_geometry():
    """MuJoCo's mj_geomDistance on the pairs' exact poses agrees with the narrow phase to its tolerance."""
    a, b = stress_pairs("near-tangent 1e-1", 40, seed=3)
    mj = bench.MujocoPairs(a, b)
    ours = signed_distance(a, b)[0]
    np.testing.assert_allclose(mj.run(1e-12, 1000), ours, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_quick_bench_writes_report_and_plots(tmp_path, monkeypatch):
    small = dict(
        bench.SIZES["quick"],
        generic=2_000,
        near=1_000,
        mujoco=300,
        stress=30,
        reference=4,
        batch_max=1_000,
        figures=(1, 2),
        replay_figures=(1, 2),
        rounds=1,
        steps=10,
        coal=20,
        scenes=("1 figure",),
        step_rounds=1,
        compare_steps=2,
        deep_pairs=3,
        long_seconds=0.05,
        mesh_pairs=6,
        mesh_calls=60,
        terrain_steps=3,
    )
    monkeypatch.setitem(bench.SIZES, "quick", small)
    from ellipsim.app.bench import on_warp

    monkeypatch.setitem(
        on_warp.WARP_SIZES, "quick", dict(warp_pairs=12, warp_cost_worlds=200, warp_worlds=2, warp_settle=20)
    )
    assert main(["bench", "--quick", "--out", str(tmp_path)]) == 0
    report = (tmp_path / "report.md").read_text()
    for section in (
        "1. Time against error",
        "2. Numerical stress",
        "3. Scaling",
        "4. The thesis's Table 1",
        "5. Inside MuJoCo",
        "9. ellipsim on MuJoCo Warp",
        "| capsule x ellipsoid | 100 m away | deep (-0.3) | ellipsim on Warp |",
        "| ellipsoid x box |",
        "Height field x ellipsoid (2 worlds of 8 ellipsoids",
        "Convex mesh x ellipsoid (2 worlds of 8 ellipsoids",
        "## 11. Other pair types, run after run",
        "## 14. Meshes and height fields",
        "| ellipsoid x mesh of 500 points | deep |",
        "| ellipsoid x height field, 30 x 30 | deep |",
        "| ellipsoid x height field, the terrain scene's | resting |",
        "mj_step on the terrain scenario's scene",
    ):
        assert section in report
    for png in ("pareto.png", "stress.png", "scaling.png", "table1.png", "mujoco.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "| exact |" in report and "MuJoCo tol 1e-06, 35 it" in report
    # each reference is timed against itself in the same rounds
    assert "| descartes rearranged float64 |" in report.split("### Signed distance")[0]
    narrow = next(line for line in report.splitlines() if line.startswith("| narrow phase signed distance |"))
    assert narrow.split("|")[3].strip() == "1.00"
    assert "| one Newton run, 6 steps |" in report and "| 1 figure |" in report
    assert (
        "Where mj_step's time goes" in report
        and "| 4 figures in a heap: capsule twin | capsule twin, plain MuJoCo |" in report
    )
    assert "| 1 figure | 0 | nan |" in report  # no ellipsim call: no cost per call
    assert "| 1 figure | 0.00 | 0.00 |" in report  # one figure: no ellipsoid pair crosses another
    calls = report.split("Calls into MuJoCo's collision functions per step")[1].split("\n")[0]
    assert calls.startswith(" in plain MuJoCo") and "4 figures in a heap" in calls and "capsule twin" in calls
    same = report.split("| from the settled state of |")[1].split("\n\n")[0]
    assert "| the ellipsoids' |" in same and "| the twin's |" in same
    assert f"| 4 figures in a heap: capsule twin | {TWIN_SWAPPED[0]} |" in report


@pytest.mark.slow
def test_bench_only_runs_the_sections_named(tmp_path, monkeypatch):
    small = dict(bench.SIZES["quick"], stress=10)
    monkeypatch.setitem(bench.SIZES, "quick", small)
    monkeypatch.setattr("ellipsim.app.bench.stress.STRESS", ("spheres",))
    assert main(["bench", "--quick", "--only", "stress", "--out", str(tmp_path)]) == 0
    report = (tmp_path / "report.md").read_text()
    assert report.startswith("# ellipsim bench --quick --only stress") and "| spheres |" in report
    assert "1. Time against error" not in report and not (tmp_path / "pareto.png").exists()


def test_bench_out_must_be_a_directory(tmp_path, capsys):
    path = tmp_path / "file.txt"
    path.write_text("x")
    assert main(["bench", "--quick", "--out", str(path)]) == 2
    assert "exists and is not a directory" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "nope" / "report.md")


def test_speculative_section_judges_mujoco_by_the_proven_time_of_impact():
    """Section 8: without speculative contacts MuJoCo makes no contact for a pair apart at t = 0 (every
    impact within the step is missed); with them it catches most; the report says so in its table."""
    from ellipsim.app.bench import speculative

    r = speculative.measure(dict(speculative=40))
    off, on = r["rows"]["MuJoCo, speculative off"], r["rows"]["MuJoCo, speculative on"]
    assert r["impacts"] >= 10
    assert off["missed"] == r["impacts"] and off["false"] == 0
    assert on["missed"] < off["missed"] // 2
    text = "\n".join(speculative.write(r, None, None, None))
    assert "| MuJoCo, speculative on |" in text and "| ellipsim time_of_impact |" in text


def _small_pile():
    from ellipsim.app import scenes

    return bench.settled(scenes.pile_xml(6, seed=3, bin_half_width=0.2), 150)


def test_mujoco_timers_run_inside_and_restore_the_previous_clock():
    import mujoco

    from ellipsim.app.bench import inside_mujoco

    def clock():
        return 0.0

    model, data, state = _small_pile()
    previous = mujoco.get_mjcb_time()
    mujoco.set_mjcb_time(clock)
    try:
        with inside_mujoco.mujoco_timers():
            t = inside_mujoco.breakdown({m: (model, data, state, m) for m in ("builtin", "narrowphase")}, 5, 1)
        assert mujoco.get_mjcb_time() is clock
    finally:
        mujoco.set_mjcb_time(previous)
    for mode in ("builtin", "narrowphase"):
        row = t[mode]
        assert row["narrow"] > 0 and row["broad"] > 0 and row["contacts"] > 0
        assert row["step"] >= row["broad"] + row["narrow"] + row["constraint"]


def test_in_situ_noop_slots_are_restored_and_calls_counted():
    import mujoco

    from ellipsim.app.bench import inside_mujoco
    from ellipsim.mujoco import publish
    from ellipsim.mujoco.context import PAIR_TYPES
    from ellipsim.native import ext

    table, n = publish.collision_table()
    before = [table[row.type1 * n + row.type2] for row in PAIR_TYPES]
    for address in (inside_mujoco._noop_address(), ext.bench.DISCARD):
        with inside_mujoco._installed(address):
            assert all(table[row.type1 * n + row.type2] == address for row in PAIR_TYPES)
        assert [table[row.type1 * n + row.type2] for row in PAIR_TYPES] == before
    model, data, state = _small_pile()
    ns, calls, noop, own = inside_mujoco.in_situ(model, data, state, 5, 1)
    assert calls > 0 and np.isfinite(ns) and np.isfinite(own) and noop >= 0
    assert [table[row.type1 * n + row.type2] for row in PAIR_TYPES] == before
    assert mujoco.get_mjcb_time() is None or mujoco.get_mjcb_time() is not inside_mujoco._clock


def test_narrow_calls_counts_every_call_and_restores_the_table():
    """On the small pile, the calls counted per step are at least its contacts per step (each contact
    comes from one call, several per call at most for MuJoCo's multi-contact pairs: not among ellipsoids),
    the stepping is MuJoCo's own (the same state after the same steps as without counting), and every
    slot holds its function again after."""
    import mujoco

    from ellipsim.app.bench import inside_mujoco
    from ellipsim.mujoco import publish

    table, n = publish.collision_table()
    before = list(table)
    model, data, state = _small_pile()
    calls = inside_mujoco.narrow_calls(model, data, state, 5)
    counted = data.qpos.copy()
    assert list(table) == before
    mujoco.mj_setState(model, data, state, bench.STEP_STATE)
    for _ in range(5):
        mujoco.mj_step(model, data)
    np.testing.assert_array_equal(data.qpos, counted)
    assert calls >= data.ncon > 0


def test_twin_same_state_pairs_each_state_with_both_models():
    """Each row compares the two models from one settled state: the ellipsoids' own row with the twin
    run from the ellipsoids' state, the twin's own row with the ellipsoids run from the twin's."""
    from ellipsim.app.bench import inside_mujoco as im

    timers = {
        im.TWIN_OWN[0]: {"narrow": 100.0},
        im.TWIN_OWN[1]: {"narrow": 60.0},
        im.TWIN_SWAPPED[0]: {"narrow": 80.0},
        im.TWIN_SWAPPED[1]: {"narrow": 70.0},
    }
    calls = dict(zip(timers, (740.0, 580.0, 600.0, 650.0), strict=True))
    got = im._twin_same_state(("heap", 0.0, 0.0, 1.0, timers, calls))
    assert got["the ellipsoids'"] == (100.0, 70.0, 100.0 / 70.0, 740.0, 650.0)
    assert got["the twin's"] == (80.0, 60.0, 80.0 / 60.0, 600.0, 580.0)


def test_pair_spread_reports_median_lowest_highest_and_slower_runs():
    from ellipsim.app.bench import pair_spread

    runs = [{"cylinder": {"deep": (100.0, mujoco, 0, 400)}} for mujoco in (96.0, 103.0, 110.0)]
    lines = pair_spread.write(runs, {}, None, None)
    row = next(line for line in lines if line.startswith("| ellipsoid x cylinder | deep |"))
    assert row == "| ellipsoid x cylinder | deep | 100 | 103 | 1.03x | 0.96x | 1.10x | 1 of 3 |"


def test_deepest_crossing_reads_ellipsoid_pairs_only():
    """Two round ellipsoids (r = 0.1) 0.15 apart cross 0.05 deep; the deeper sphere in the floor is not
    an ellipsoid pair; with no stepping the segment's depth is the start's."""
    import mujoco

    from ellipsim.app.bench import inside_mujoco

    xml = """<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
      <body pos="0 0 0.3"><freejoint/><geom type="ellipsoid" size="0.1 0.1 0.1"/></body>
      <body pos="0.15 0 0.3"><freejoint/><geom type="ellipsoid" size="0.1 0.1 0.1"/></body>
      <body pos="1 0 0"><freejoint/><geom type="sphere" size="0.1"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, bench.STEP_STATE))
    mujoco.mj_getState(model, data, state, bench.STEP_STATE)
    start, segment = inside_mujoco.deepest_crossing(model, data, state, 0)
    assert abs(start - 0.05) < 2e-4 and segment == start  # MuJoCo's EPA at its default tolerance: 4e-5 off
    assert -data.contact.dist[: data.ncon].min() > 0.09  # the sphere's 0.1 in the floor, left out
    start2, segment2 = inside_mujoco.deepest_crossing(model, data, state, 3)
    assert start2 == start and segment2 >= start


def test_pile_xml_thickness_draws_thin_third_semi_axes():
    import mujoco

    from ellipsim.app import scenes

    model = mujoco.MjModel.from_xml_string(scenes.pile_xml(12, seed=1, radii=(0.03, 0.08), thickness=(0.002, 0.006)))
    ell = model.geom_size[model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID]
    assert len(ell) == 12
    assert np.all((ell[:, 2] >= 0.002) & (ell[:, 2] <= 0.006)) and np.all(ell[:, :2] >= 0.03)
    for bad in ((0.0, 0.01), (0.01, 0.002), (0.01, 0.2), 0.01):
        with pytest.raises(ValueError, match="thickness"):
            scenes.pile_xml(3, thickness=bad)


def test_baseline_must_be_an_interpreter_with_ellipsim(tmp_path, capsys):
    assert (
        main(["bench", "--quick", "--only", "baseline", "--baseline", str(tmp_path / "nope"), "--out", str(tmp_path)])
        == 2
    )
    err = capsys.readouterr().err
    assert (
        err.startswith("ellipsim: error: --baseline: ") and "is not an executable file" in err and err.count("\n") == 1
    )
    assert main(["bench", "--quick", "--only", "baseline", "--baseline", "/bin/true", "--out", str(tmp_path)]) == 2
    assert "/bin/true cannot import ellipsim: it printed no version" in capsys.readouterr().err
    assert not (tmp_path / "report.md").exists()


def test_baseline_section_without_a_baseline_says_so(tmp_path, monkeypatch):
    from ellipsim.app.bench import baseline

    monkeypatch.delenv(baseline.ENV, raising=False)
    result = baseline.measure(dict(bench.SIZES["quick"], baseline=None))
    lines = baseline.write(result, bench.SIZES["quick"], str(tmp_path), None)
    assert any(line.startswith("Not run: no baseline interpreter given (--baseline PYTHON") for line in lines)


@pytest.mark.slow
def test_baseline_section_measures_every_public_function_on_both_sides(tmp_path, monkeypatch):
    """This interpreter against itself: a row per public batch function, pair type and mj_step scene and mode."""
    from ellipsim.app.bench import baseline

    small = dict(bench.SIZES["quick"], baseline_pairs=40, baseline_steps=2, baseline_rounds=2, baseline_repeats=1)
    monkeypatch.setitem(bench.SIZES, "quick", small)
    monkeypatch.setattr(baseline, "STEP_SCENES", ("pile of 40 ellipsoids",))
    monkeypatch.setitem(baseline.SCENES, "pile of 40 ellipsoids", (baseline.SCENES["pile of 40 ellipsoids"][0], 5))
    assert main(["bench", "--quick", "--only", "baseline", "--baseline", sys.executable, "--out", str(tmp_path)]) == 0
    report = (tmp_path / "report.md").read_text()
    assert "## 13. This build against a baseline install" in report and "each side in 2 fresh processes" in report
    rows = [line for line in report.splitlines() if line.startswith("| ") and "ns/pair" in line or "µs/step" in line]
    names = {row.split(" | ")[0][2:] for row in rows}
    for fn in ("classify method=exact", "classify_pairs", "characteristic_polynomial", "contact_scale", "contains"):
        assert fn in names, fn
    for kind in ("capsule", "box", "cylinder"):
        assert {f"shape_distance {kind}", f"shape_distance {kind} derivatives=True"} <= names
    assert {"signed_distance (near contact)", "signed_distance derivatives=True", "time_of_impact"} <= names
    assert {f"mj_step pile of 40 ellipsoids, {mode}" for mode in ("builtin", "filter", "narrowphase")} <= names
    assert "Slower than the baseline in every round: " in report


def test_mesh_section_places_its_categories_and_both_sides_make_the_same_contacts():
    """meshes.py: the mesh poses are at their category's distance (through the kernel), and on penetrating and
    deep poses both functions make a contact on every pair; on the height field both make the same number."""
    import mujoco
    import numpy as np

    import ellipsim
    from ellipsim.app.bench import meshes
    from ellipsim.mujoco import publish
    from ellipsim.mujoco.hull import mesh_hull

    rng = np.random.default_rng(3)
    points = rng.normal(size=(40, 3)) * 0.1
    table, n = publish.collision_table()
    convex = table[int(mujoco.mjtGeom.mjGEOM_ELLIPSOID) * n + int(mujoco.mjtGeom.mjGEOM_MESH)]
    size = {"mesh_calls": 20}
    for category in meshes.CATEGORIES:
        model, data, pairs = meshes.mesh_poses(points, category, 10, rng)
        e, m = pairs[:, 0], pairs[:, 1]
        E = ellipsim.Ellipsoids(data.geom_xpos[e], data.geom_xmat[e].reshape(-1, 3, 3), model.geom_size[e])
        d = np.array([
            ellipsim.shape_distance(E[i : i + 1], "mesh", data.geom_xpos[m[i]], data.geom_xmat[m[i]].reshape(3, 3),
                                    mesh_hull(model, int(model.geom_dataid[m[i]])))[0][0]
            for i in range(10)
        ])  # fmt: skip
        if category == "separated":
            assert (d > 5e-7).all()
        elif category == "touching":
            assert (np.abs(d) < 1e-12).all()
        else:
            assert (d < 0).all()
            _, _, made, theirs, fallbacks = meshes._time(model, data, pairs, convex, size, rounds=1)
            assert made == theirs == 10 and fallbacks == 0
    field = table[int(mujoco.mjtGeom.mjGEOM_HFIELD) * n + int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)]
    for category, (model, data, pairs) in meshes.field_poses(10, rng).items():
        _, _, made, theirs, _ = meshes._time(model, data, pairs, field, size, rounds=1)
        assert made == theirs and (made > 0) == (category != "apart"), category
