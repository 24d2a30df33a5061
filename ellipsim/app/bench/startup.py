"""Section 6: start-up, from `import ellipsim` to the end of the first mj_step that runs the narrow
phase, each run in a fresh interpreter (issue 10, part 4: <= 0.3 s once compiled, <= 4 s on a fresh
install).

Configurations (ellipsim's cache is ELLIPSIM_CACHE_DIR, the shipped objects ELLIPSIM_PREBUILT_DIR):

- cold: empty ellipsim cache, no prebuilt callbacks, no shipped kernels, empty numba cache: the compile
  of a platform without shipped objects;
- prebuilt: empty ellipsim cache, the shipped CPU-generic objects: a fresh install;
- warm: the cache the cold runs wrote;
- MuJoCo alone: the same process without ellipsim (interpreter, numpy and MuJoCo), for scale.

Warm, prebuilt and MuJoCo-alone runs are interleaved round by round.  The box this runs on may be
loaded by other work: medians, and the CPU time of the child process beside the wall time.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from ...core import cache_root, kernel_cache
from ...mujoco import nativecache
from .common import SIZES, say

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
    from ellipsim.mujoco import nativecache
    origin = nativecache.function(mode).origin
else:
    t_attach = time.perf_counter()
    mujoco.mj_step(model, data)
    origin = "-"
t1 = time.perf_counter()
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"part": t1 - t0, "part_cpu": time.process_time() - cpu0, "attach": t_attach - t0,
                  "before": t0 - t_start, "cpu": usage.ru_utime + usage.ru_stime, "origin": origin,
                  "numba": "numba" in sys.modules}))
"""

#: runs per configuration: (cold runs per mode, warm / prebuilt / MuJoCo-alone rounds, the modes
#: compiled cold and then loaded warm, the modes loaded prebuilt).  --quick compiles only the filter
#: (the narrow phase's cold compile takes minutes: the full run measures it)
_RUNS = {
    "quick": (1, 2, ("filter",), ("filter", "narrowphase")),
    "full": (3, 10, ("narrowphase", "filter"), ("narrowphase", "filter")),
}


def _child(mode, cache, prebuilt, numba_cache=None):
    """One fresh interpreter: the child's report plus "wall", the whole process's wall time."""
    env = dict(os.environ, **{cache_root.CACHE_ENV: str(cache), nativecache.PREBUILT_ENV: str(prebuilt)})
    if numba_cache is not None:  # a cold start: nor numba's cache nor the shipped kernels
        env["NUMBA_CACHE_DIR"] = str(numba_cache)
        env[kernel_cache.SHIPPED_ENV] = str(prebuilt)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, _XML, mode], env=env, capture_output=True, text=True, timeout=900
    )
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise RuntimeError(f"start-up child ({mode}) failed: {proc.stderr.strip()}")
    return dict(json.loads(proc.stdout), wall=wall, notice=nativecache.NOTICE_PREFIX in proc.stderr)


#: The README's commands as a new user runs them (short settings at the quick size), each in a
#: fresh process: first on empty caches (a fresh install: the shipped kernels and callbacks), then again.
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
    """{command: (first run s, second run s, the first's stderr said it compiles)}: each README command
    twice in fresh processes on one fresh set of caches."""
    quick = size == SIZES["quick"]
    # --quick: the README's first command only; a custom size says how many (startup_first_runs)
    count = size.get("startup_first_runs", 1 if quick else None)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "ELLIPSIM_"))}
        for name, argv in list(_readme_commands(tmp, quick).items())[:count]:
            env_k = dict(env, ELLIPSIM_CACHE_DIR=os.path.join(tmp, f"cache-{len(out)}"))
            times, notices = [], []
            for _ in range(2):
                say(f"start-up: first and second run of `ellipsim {name}` ...")
                t0 = time.perf_counter()
                proc = subprocess.run(
                    [sys.executable, "-m", "ellipsim", *argv], env=env_k, capture_output=True, text=True, timeout=1800
                )
                times.append(time.perf_counter() - t0)
                if proc.returncode:
                    raise RuntimeError(f"`ellipsim {name}` failed: {proc.stderr.strip()[-500:]}")
                notices.append("compiling" in proc.stderr)
            out[name] = (times[0], times[1], notices[0])
    return out


def measure(size):
    """{(configuration, mode): [child reports]} (see _child), and "first runs": first_runs(size)."""
    n_cold, rounds, modes, prebuilt_modes = _RUNS["quick" if size == SIZES["quick"] else "full"]
    n_cold, rounds, modes = (
        size.get("startup_cold", n_cold),
        size.get("startup_rounds", rounds),
        size.get("startup_modes", modes),
    )
    prebuilt_modes = size.get("startup_modes", prebuilt_modes)
    runs = {}
    with tempfile.TemporaryDirectory() as tmp:
        cache, nothing = os.path.join(tmp, "cache"), os.path.join(tmp, "no-prebuilt")
        os.makedirs(nothing)
        for mode in modes:
            for k in range(n_cold):
                say(f"start-up: cold {mode} {k + 1}/{n_cold} (compiles) ...")
                fresh = os.path.join(tmp, f"cold-{mode}-{k}")
                # the last cold run writes into `cache`, the warm runs' cache
                target = cache if k == n_cold - 1 else os.path.join(fresh, "cache")
                runs.setdefault(("cold", mode), []).append(_child(mode, target, nothing, os.path.join(fresh, "numba")))
            if n_cold == 0:  # fill the warm cache all the same
                _child(mode, cache, nothing, os.path.join(tmp, f"numba-{mode}"))
        say(f"start-up: warm, prebuilt and MuJoCo alone, {rounds} interleaved rounds ...")
        shipped = nativecache.prebuilt_dir()
        for k in range(rounds):
            for mode in modes:
                runs.setdefault(("warm", mode), []).append(_child(mode, cache, nothing))
            for mode in prebuilt_modes:
                runs.setdefault(("prebuilt", mode), []).append(_child(mode, os.path.join(tmp, f"empty-{k}"), shipped))
            runs.setdefault(("MuJoCo alone", "none"), []).append(_child("none", cache, nothing))
    runs["first runs"] = first_runs(size)
    return runs


def write(result, size, out, plt):
    """The section's markdown (no plot)."""
    L = [
        "## 6. Start-up",
        "",
        "A fresh interpreter per run: import mujoco, build two overlapping ellipsoids, then `import ellipsim`, "
        "`attach`, one mj_step that calls ellipsim's callback.  *ellipsim part*: from `import ellipsim` to the end "
        "of that step (the issue's goal: <= 0.3 s once compiled, <= 4 s on a fresh install); *process*: the whole "
        "child, interpreter start-up included.  Medians (minimum in brackets); CPU seconds are the child's own, "
        "less sensitive than wall time to other work on the machine.",
        "",
        "| configuration | mode | runs | ellipsim part s | its CPU s | import + attach s | process wall s "
        "| process CPU s | callback from | numba imported | notice |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|---|---|",
    ]
    firsts = result.pop("first runs", {})
    for (config, mode), reports in result.items():
        col = {k: np.array([r[k] for r in reports]) for k in ("part", "part_cpu", "attach", "wall", "cpu")}
        med = {k: float(np.median(v)) for k, v in col.items()}
        origins = "/".join(sorted({r["origin"] for r in reports}))
        numba = "/".join(sorted({"yes" if r["numba"] else "no" for r in reports}))
        notice = "/".join(sorted({"yes" if r["notice"] else "no" for r in reports}))
        L.append(
            f"| {config} | {mode} | {len(reports)} | **{med['part']:.3f}** ({col['part'].min():.3f}) | {med['part_cpu']:.3f} "
            f"| {med['attach']:.3f} | {med['wall']:.2f} ({col['wall'].min():.2f}) | {med['cpu']:.2f} | {origins} | {numba} "
            f"| {notice} |"
        )
    L += [
        "",
        "The README's commands on a fresh install: each run twice in fresh processes on one fresh set of caches "
        "(the first loads the shipped kernels and callbacks; the issue's goal: the first within 1.5x of the second).",
        "",
        "| command | first run s | second run s | first / second | first run compiled |",
        "|---|---:|---:|---:|---|",
    ]
    for name, (first, second, compiled) in firsts.items():
        L.append(
            f"| `ellipsim {name}` | {first:.2f} | {second:.2f} | **{first / second:.2f}** | {'yes' if compiled else 'no'} |"
        )
    L += [
        "",
        "Regenerate the shipped objects after changing a kernel: `python -m ellipsim.app.prebuild` (the callbacks, "
        "then every numba kernel of the README's commands and public functions).",
        "",
    ]
    return L
