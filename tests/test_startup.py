"""Start-up: the geometry and the MuJoCo callbacks are compiled ahead of time (the _ellipsim extension), so a
fresh interpreter attaches and steps without compiling anything, loads neither numba nor llvmlite, and gets
the same trajectory to the bit as this process.  The bench's start-up section (6) measures first against
second runs."""

import hashlib
import json
import subprocess
import sys

import mujoco
import pytest

import ellipsim.mujoco as em
from ellipsim.app import scenes

STEPS = 150

# A fresh interpreter: attach in the modes given, step, report.  `import ellipsim` first: the
# point is what importing and attaching load.
STEP = r"""
import hashlib, json, sys
import mujoco
import ellipsim
model = mujoco.MjModel.from_xml_path(sys.argv[1])
out = {}
for mode in sys.argv[3:]:
    data = mujoco.MjData(model)
    digest = hashlib.sha256()
    with ellipsim.mujoco.attach(model, data, mode=mode) as att:
        for _ in range(int(sys.argv[2])):
            mujoco.mj_step(model, data)
            digest.update(data.qpos.tobytes() + data.qvel.tobytes())
    out[mode] = {"digest": digest.hexdigest(), "counters": att.counters}
out["core"] = sorted(m for m in sys.modules if m.startswith("ellipsim.core"))
out["scipy"] = "scipy" in sys.modules
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    """(path of a pile's MJCF, {mode: trajectory digest} stepped in this process)."""
    path = tmp_path_factory.mktemp("scene") / "pile.xml"
    path.write_text(scenes.pile_xml(30, seed=2))
    model = mujoco.MjModel.from_xml_path(str(path))
    expected = {}
    for mode in em.MODES:
        data = mujoco.MjData(model)
        digest = hashlib.sha256()
        with em.attach(model, data, mode=mode):
            for _ in range(STEPS):
                mujoco.mj_step(model, data)
                digest.update(data.qpos.tobytes() + data.qvel.tobytes())
        expected[mode] = digest.hexdigest()
    return path, expected


def test_a_fresh_process_attaches_and_steps_with_nothing_compiled(pile):
    """Both modes in a fresh interpreter: this process's trajectories to the bit, counted calls, and no JIT
    compiler, no scipy and none of the core's Python layer imported by `import ellipsim` + attach + mj_step (the
    callbacks are the compiled module's)."""
    path, expected = pile
    proc = subprocess.run(
        [sys.executable, "-c", STEP, str(path), str(STEPS), *em.MODES], capture_output=True, text=True, check=True
    )
    report = json.loads(proc.stdout)
    for mode in em.MODES:
        assert report[mode]["digest"] == expected[mode], mode
    assert report["narrowphase"]["counters"]["calls"] > 0 and report["filter"]["counters"]["seen"] > 0
    assert report["core"] == [] and not report["scipy"]
    assert proc.stderr == ""  # no notice, no warning: nothing to say on a first run


@pytest.mark.slow  # the benchmark suite's start-up section
def test_bench_section_reports_first_and_second_runs():
    from ellipsim.app.bench import startup

    size = {"startup_rounds": 1, "startup_modes": ("filter",), "startup_first_runs": 1, "startup_runs": 2}
    runs = startup.measure(size)
    firsts = runs["first runs"]  # the README's first command, twice in fresh processes
    assert list(firsts) == ["run handshake --record"]
    first, second = firsts["run handshake --record"]
    assert 0 < first and 0 < second
    assert sorted(k for k in runs if k != "first runs") == [("MuJoCo alone", "none"), ("ellipsim", "filter")]
    assert not any(r["core"] for k, rs in runs.items() if k != "first runs" for r in rs)
    for rs in (rs for k, rs in runs.items() if k != "first runs"):
        assert all(0 < r["part"] <= r["wall"] and 0 < r["cpu"] for r in rs)
    lines = startup.write(runs, None, None, None)
    assert lines[0] == "## 6. Start-up"
    assert any(line.startswith("| ellipsim | filter | 1 |") and line.endswith("| no |") for line in lines)
    assert any(line.startswith("| `ellipsim run handshake --record` |") for line in lines)
