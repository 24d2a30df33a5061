"""Section 13 (baseline): this build against another install of ellipsim, side by side in one run (issue 46: the
C++ core against the numba build of 93d004e, "nothing slower").

`ellipsim bench --only baseline --baseline PYTHON`: PYTHON is the interpreter of the other install (a venv with
`pip install` of the commit to compare).  The inputs are made here once and saved; each side measures them in its
own fresh process (baseline_child.py: every public batch function per pair, serial, and mj_step per scene and
mode), the two sides alternating, size["baseline_rounds"] processes each.  Speed-up = baseline time / this
build's, per round; the table gives its median and its range over the rounds, since this VM's speed drifts.
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
from scipy.spatial.transform import Rotation

from ...core.rotations import quaternions_to_rotations
from ...core.samples import generic_pairs, near_contact_pairs, random_ellipsoids
from .common import say
from .inside_mujoco import SCENES

CHILD = pathlib.Path(__file__).with_name("baseline_child.py")
#: glibc's malloc maps a large block (the outputs of a batch call) afresh, page faults and all, until the process
#: has freed one of its size, when it raises its threshold: a process's history then decides (the numba build's
#: LLVM raised it at import, this build's import does not).  Both sides' processes run with the threshold fixed
#: at 32 MiB and its trim threshold at 256 MiB (freed heap kept, not returned and faulted in again), so that the
#: comparison is of the builds, not of that history (the measuring processes only).
MALLOC_ENV = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(256 << 20)}
#: the scenes timed per mj_step (inside_mujoco.SCENES) and the plain steps that settle each first
STEP_SCENES = ("pile of 40 ellipsoids", "4 figures in a heap", "MuJoCo's collision_convex/perf/mixed.xml")
ENV = "ELLIPSIM_BASELINE_PYTHON"


def _shapes(rng, ellipsoids, kind):
    """One `kind` geom per ellipsoid near it (MuJoCo's sizes: capsule and cylinder radius, half length; box half
    sizes), its centre 0.3-1.3 times the sum of the bodies' largest sizes from the ellipsoid's: deep, touching
    and separated pairs."""
    n = len(ellipsoids)
    sizes = rng.uniform(0.05, 0.5, (n, 3))
    if kind != "box":
        sizes[:, 2] = 0.0
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    reach = ellipsoids.radii.max(axis=1) + sizes.max(axis=1)
    centers = ellipsoids.centers + d * (reach * rng.uniform(0.3, 1.3, n))[:, None]
    q = rng.normal(size=(n, 4))
    return centers, quaternions_to_rotations(q / np.linalg.norm(q, axis=1)[:, None]), sizes


def _moved(rng, e, step):
    """e after a rigid motion: a translation of about `step` and a turn of about 1 rad."""
    turn = Rotation.from_rotvec(rng.normal(size=(len(e), 3)) * 0.6)
    return type(e)(e.centers + rng.normal(size=(len(e), 3)) * step, turn.as_matrix() @ e.rotations, e.radii)


def inputs(size, path):
    """Write the inputs both sides measure (npz at `path`)."""
    rng = np.random.default_rng(13)
    n = size["baseline_pairs"]
    a, b = generic_pairs(n, seed=13)
    na, nb = near_contact_pairs(max(n // 10, 10), seed=13)
    e = random_ellipsoids(rng, max(n // 10, 10), radii=(0.05, 0.5))
    t0, u0 = generic_pairs(max(n // 20, 10), seed=14)
    t1, u1 = _moved(rng, t0, 0.3), _moved(rng, u0, 0.3)
    z = {"steps": size["baseline_steps"], "settle": max(SCENES[s][1] for s in STEP_SCENES)}
    for name, x in dict(a=a, b=b, na=na, nb=nb, e=e, t0=t0, t1=t1, u0=u0, u1=u1).items():
        z[f"{name}_c"], z[f"{name}_R"], z[f"{name}_r"] = x.centers, x.rotations, x.radii
    for kind in ("capsule", "box", "cylinder"):
        z[f"{kind}_c"], z[f"{kind}_R"], z[f"{kind}_s"] = _shapes(rng, e, kind)
    z["scene_names"] = np.array(STEP_SCENES)
    z["scene_xmls"] = np.array([SCENES[s][0]() for s in STEP_SCENES])
    np.savez(path, **z)


def child(python, path, repeats):
    """One measuring process of `python` (-I: it imports its own install, never this checkout)."""
    proc = subprocess.run(
        [python, "-I", "-c", CHILD.read_text(), str(path), str(repeats)],
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
        env=dict(os.environ, **MALLOC_ENV),
    )
    if proc.returncode:
        tail = proc.stderr.strip().splitlines()[-1:] or ["no output"]
        raise RuntimeError(f"the measuring process of {python} failed: {tail[0]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def check_baseline(python):
    """None when `python` runs and imports an ellipsim, else the reason (one line)."""
    if not (os.path.isfile(python) and os.access(python, os.X_OK)):
        return f"{python!r} is not an executable file"
    proc = subprocess.run(
        [python, "-I", "-c", "import ellipsim; print(ellipsim.__version__)"],
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
    )
    if proc.returncode or not proc.stdout.strip():
        why = (proc.stderr.strip().splitlines() or ["it printed no version"])[-1]
        return f"{python} cannot import ellipsim: {why}"
    return None


def measure(size):
    """{"skipped": reason} without a baseline, else {"this": [per round], "baseline": [per round]}."""
    python = size.get("baseline") or os.environ.get(ENV)
    if not python:
        return {"skipped": f"no baseline interpreter given (--baseline PYTHON or ${ENV})"}
    reason = check_baseline(python)
    if reason:
        raise ValueError(f"baseline: {reason}")
    runs = {"this": [], "baseline": []}
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "inputs.npz"
        say("baseline: making the inputs ...")
        inputs(size, path)
        for k in range(size["baseline_rounds"]):
            order = ("this", "baseline") if k % 2 == 0 else ("baseline", "this")
            for side in order:
                say(f"baseline: round {k + 1} of {size['baseline_rounds']}, {side} ...")
                runs[side].append(child(sys.executable if side == "this" else python, path, size["baseline_repeats"]))
    return dict(runs, python=python)


def write(result, size, out, plt):
    """Markdown lines: per item, both sides' median time and the speed-up's median, lowest and highest."""
    L = ["## 13. This build against a baseline install", ""]
    if "skipped" in result:
        return L + [f"Not run: {result['skipped']}.", ""]
    this, base = result["this"], result["baseline"]
    L += [
        f"This build ({this[0]['file']}) against {result['python']} (ellipsim {base[0]['version']} at "
        f"{base[0]['file']}), on the same inputs, each side in {len(this)} fresh processes alternating with the "
        "other's.  Per pair: every public batch function with parallel=False (the fastest of "
        f"{size['baseline_repeats']} calls), except the all-cores row; per step: mj_step from the same settled "
        "state, its fastest repeat.  Speed-up = baseline / this build, per round.  Both sides run with glibc's mmap "
        "and trim thresholds fixed (32 and 256 MiB): otherwise a fresh process maps each large output array "
        "anew, page faults included, until it has freed one (a cost of the process's history, not of either build).",
        "",
        "| item | this build | baseline | speed-up, median | lowest | highest |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    slower = []
    for item in this[0]:
        if item in ("version", "file"):
            continue
        ours = np.array([r[item] for r in this])
        theirs = np.array([r[item] for r in base])
        speed = theirs / ours
        unit = "µs/step" if item.startswith("mj_step") else "ns/pair"
        scale = 1e6 if unit == "µs/step" else 1e9
        L.append(
            f"| {item} | {np.median(ours) * scale:.{1 if unit == 'µs/step' else 0}f} {unit} "
            f"| {np.median(theirs) * scale:.{1 if unit == 'µs/step' else 0}f} {unit} | {np.median(speed):.2f}x "
            f"| {speed.min():.2f}x | {speed.max():.2f}x |"
        )
        if speed.max() < 1.0:
            slower.append(f"{item} ({np.median(speed):.2f}x)")
    L += [
        "",
        "The builtin rows run MuJoCo alone, the same code on both sides: their spread is this run's noise.  "
        f"Slower than the baseline in every round: {', '.join(slower) if slower else 'none'}.",
        "",
    ]
    return L
