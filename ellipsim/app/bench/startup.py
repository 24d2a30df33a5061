"""Section 6: start-up, from `import ellipsim` to the end of the first mj_step that runs the narrow
phase, each run in a fresh interpreter, and the README's commands run twice on a fresh install.

The geometry and the MuJoCo callbacks are compiled ahead of time (the _ellipsim extension, built by `pip
install`): nothing compiles at run time, so a first run should cost what a second does (issue 46: the
first run of any README command within 1.2x of the second).  Configurations: ellipsim in each mode, and
MuJoCo alone (the same process without ellipsim: interpreter, numpy and MuJoCo), for scale, interleaved
round by round.  The box this runs on may be loaded by other work: medians, and the CPU time of the child
process beside the wall time.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from .common import say

# Two overlapping ellipsoids: the first mj_step calls the narrow phase (the child checks).
_XML = """<mujoco><worldbody>
<body><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>
<body pos=".15 0 0"><freejoint/><geom type="ellipsoid" size=".1 .2 .3"/></body>
</worldbody></mujoco>"""

_CHILD = r"""
import json, resource, sys, time
t_start = time.perf_counter()
import mujoco
model = mujoco.MjModel.from_xml_string(sys.argv[1])
data = mujoco.MjData(model)
mode = sys.argv[2]
cpu0, t0 = time.process_time(), time.perf_counter()
if mode != "none":
    import ellipsim
    with ellipsim.mujoco.attach(model, data, mode=mode) as att:
        t_attach = time.perf_counter()
        mujoco.mj_step(model, data)
    key = "calls" if mode == "narrowphase" else "seen"
    assert att.counters[key] == 1, att.counters
else:
    t_attach = time.perf_counter()
    mujoco.mj_step(model, data)
t1 = time.perf_counter()
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"part": t1 - t0, "part_cpu": time.process_time() - cpu0, "attach": t_attach - t0,
                  "before": t0 - t_start, "cpu": usage.ru_utime + usage.ru_stime,
                  "core": any(m.startswith("ellipsim.core") for m in sys.modules)}))
"""

#: rounds of the interleaved fresh-process runs
_ROUNDS = {"quick": 2, "full": 10}
MODES = ("filter", "narrowphase")


def _child(mode):
    """One fresh interpreter: the child's report plus "wall", the whole process's wall time."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _CHILD, _XML, mode], capture_output=True, text=True, timeout=900)
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise RuntimeError(f"start-up child ({mode}) failed: {proc.stderr.strip()}")
    return dict(json.loads(proc.stdout), wall=wall)


#: The README's commands as a new user runs them (short settings at the quick size), each in a
#: fresh process: first, then again.
def _readme_commands(tmp, quick):
    from .. import scenes

    model = os.path.join(tmp, "figure.xml")
    with open(model, "w") as f:
        f.write(scenes.scene_xml(2))
    import mujoco

    m = mujoco.MjModel.from_xml_path(model)
    rng = np.random.default_rng(0)
    frames = 60 if quick else 300
    motion = np.repeat(m.qpos0[None], frames, 0) + 0.05 * rng.standard_normal((frames, m.nq)) * (np.arange(m.nq) >= 7)
    np.save(os.path.join(tmp, "walk.npy"), motion)
    short = ["--steps", "300"] if quick else []
    commands = {
        "run handshake --record": ["run", "handshake", *short, "--record", os.path.join(tmp, "handshake.rrd")],
        "run replay --record": ["run", "replay", *short, "--record", os.path.join(tmp, "dance.rrd")],
        "compare pile --json": ["compare", "pile", *(["--steps", "100"] if quick else []), "--json", os.path.join(tmp, "p.json")],
        "replay MODEL MOTION --json --record": [
            "replay", model, os.path.join(tmp, "walk.npy"), "--json", os.path.join(tmp, "w.json"),
            "--record", os.path.join(tmp, "w.rrd"),
        ],
        "demo": ["demo"],
    }  # fmt: skip
    return commands


def first_runs(size):
    """{command: (first run s, median of the later runs s)}: each README command run `startup_runs` times (5;
    3 at the quick size) in fresh processes, one after the other: the first against the rest (nothing of
    ellipsim's is cached between them; a single pair of runs differs by up to 15% on this VM)."""
    quick = bool(size.get("quick"))
    # --quick: the README's first command only; a custom size says how many (startup_first_runs)
    count = size.get("startup_first_runs", 1 if quick else None)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith("ELLIPSIM_")}
        for name, argv in list(_readme_commands(tmp, quick).items())[:count]:
            env_k = env
            times = []
            for _ in range(size.get("startup_runs", 3 if quick else 5)):
                say(f"start-up: runs of `ellipsim {name}` in fresh processes ...")
                t0 = time.perf_counter()
                proc = subprocess.run(
                    [sys.executable, "-m", "ellipsim", *argv], env=env_k, capture_output=True, text=True, timeout=1800
                )
                times.append(time.perf_counter() - t0)
                if proc.returncode:
                    raise RuntimeError(f"`ellipsim {name}` failed: {proc.stderr.strip()[-500:]}")
            out[name] = (times[0], float(np.median(times[1:])))
    return out


def measure(size):
    """{(configuration, mode): [child reports]} (see _child), and "first runs": first_runs(size)."""
    rounds = size.get("startup_rounds", _ROUNDS["quick" if size.get("quick") else "full"])
    modes = size.get("startup_modes", MODES)
    runs = {}
    say(f"start-up: ellipsim and MuJoCo alone, {rounds} interleaved rounds ...")
    for _ in range(rounds):
        for mode in modes:
            runs.setdefault(("ellipsim", mode), []).append(_child(mode))
        runs.setdefault(("MuJoCo alone", "none"), []).append(_child("none"))
    runs["first runs"] = first_runs(size)
    return runs


def write(result, size, out, plt):
    """The section's markdown (no plot)."""
    L = [
        "## 6. Start-up",
        "",
        "A fresh interpreter per run: import mujoco, build two overlapping ellipsoids, then `import ellipsim`, "
        "`attach`, one mj_step that calls ellipsim's callback.  *ellipsim part*: from `import ellipsim` to the end "
        "of that step; *process*: the whole "
        "child, interpreter start-up included.  Medians (minimum in brackets); CPU seconds are the child's own, "
        "less sensitive than wall time to other work on the machine.",
        "",
        "| configuration | mode | runs | ellipsim part s | its CPU s | import + attach s | process wall s "
        "| process CPU s | core's Python layer loaded |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    firsts = result.pop("first runs", {})
    for (config, mode), reports in result.items():
        col = {k: np.array([r[k] for r in reports]) for k in ("part", "part_cpu", "attach", "wall", "cpu")}
        med = {k: float(np.median(v)) for k, v in col.items()}
        core = "/".join(sorted({"yes" if r["core"] else "no" for r in reports}))
        L.append(
            f"| {config} | {mode} | {len(reports)} | **{med['part']:.3f}** ({col['part'].min():.3f}) | {med['part_cpu']:.3f} "
            f"| {med['attach']:.3f} | {med['wall']:.2f} ({col['wall'].min():.2f}) | {med['cpu']:.2f} | {core} |"
        )
    L += [
        "",
        "The README's commands on a fresh install: each run several times in fresh processes, one after the other "
        "(nothing compiles at run time; the issue's goal: the first within 1.2x of the others, here their median).",
        "",
        "| command | first run s | later runs s, median | first / later |",
        "|---|---:|---:|---:|",
    ]
    for name, (first, second) in firsts.items():
        L.append(f"| `ellipsim {name}` | {first:.2f} | {second:.2f} | **{first / second:.2f}** |")
    return L + [""]
