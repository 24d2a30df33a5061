"""What every section of the suite shares: sizes, interleaved timing, runners, MuJoCo's distance.

Timing rule of the suite: methods compared in a table are timed in the same interleaved rounds, and
ratios are medians of per-round ratios (this VM's speed drifts by up to 1.5x within seconds, so
sequential timings lie).
"""

import contextlib
import ctypes
import os
import platform
import sys
import time

import mujoco
import numpy as np

from ...mujoco import publish
from ...mujoco.attachment import attach
from ...native import ext

SIZES = {
    "quick": dict(
        quick=True,  # (a section may add sizes of its own per --quick: on_warp, startup)
        generic=100_000,
        near=10_000,
        mujoco=2_000,
        stress=300,
        reference=20,
        batch_max=100_000,
        figures=(1, 4, 16),
        replay_figures=(1, 4, 16),
        rounds=5,
        steps=100,
        coal=500,
        scenes=("pile of 40 ellipsoids", "4 figures in a heap"),
        step_rounds=8,
        compare_steps=10,
        deep_pairs=60,
        pair_types=100,
        pair_type_calls=4_000,
        pair_repeats=2,
        mesh_pairs=40,
        mesh_calls=2_000,
        terrain_steps=100,
        long_seconds=1.0,
        motion=500,
        motion_samples=(2, 4, 8, 16, 32, 64, 128, 256, 512, 1024),
        motion_contains=10_000,
        speculative=60,
        baseline_pairs=2_000,
        baseline_steps=50,
        baseline_rounds=2,
        baseline_repeats=3,
    ),
    "full": dict(
        generic=1_000_000,
        near=100_000,
        mujoco=20_000,
        stress=5_000,
        reference=200,
        batch_max=1_000_000,
        figures=(1, 4, 16, 64),
        replay_figures=(1, 4, 16, 64),
        rounds=15,
        steps=200,
        coal=5_000,
        scenes=None,
        step_rounds=30,
        compare_steps=30,
        deep_pairs=2_000,
        pair_types=400,
        pair_type_calls=20_000,
        pair_repeats=10,
        mesh_pairs=200,
        mesh_calls=20_000,
        terrain_steps=500,
        long_seconds=10.0,
        motion=4_000,
        motion_samples=(2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096),
        motion_contains=200_000,
        speculative=400,
        baseline_pairs=20_000,
        baseline_steps=200,
        baseline_rounds=5,
        baseline_repeats=5,
    ),
}
FLOAT_METHODS = [
    (m, s, d) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor") for d in ("float64", "float32")
]


def plt():
    """matplotlib.pyplot on the Agg backend; ImportError naming the extra when it is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
    except ImportError:
        raise ImportError("ellipsim bench needs matplotlib and mpmath: pip install '.[bench]'") from None
    return pyplot


def say(text):
    """Progress of the suite, on stderr."""
    print(text, file=sys.stderr, flush=True)


def median_time(fn, rounds):
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def interleaved(fns, rounds, *, self_timed=False):
    """{name: seconds per round (rounds,)} timing every fn of `fns` once per round, in an order rotated
    each round: this VM drifts by up to 1.5x over seconds, so methods compared must share the rounds.
    self_timed: each fn returns its own seconds (to keep set-up out of the timed region)."""
    names = list(fns)
    times = {k: [] for k in names}
    for r in range(rounds):
        k = r % len(names)
        for name in names[k:] + names[:k]:
            t0 = time.perf_counter()
            result = fns[name]()
            times[name].append(result if self_timed else time.perf_counter() - t0)
    return {k: np.array(v) for k, v in times.items()}


def relative(times, name, ref):
    """Median over rounds of times[name] / times[ref] (both from one `interleaved` call)."""
    return float(np.median(times[name] / times[ref]))


def machine_description():
    """CPU model, cores and the versions that decide the timings, for a report's first lines."""
    cpu = platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, mujoco {mujoco.__version__}"


def fmt_rate(x):
    return "0" if x == 0 else f"{x:.2e}"


def fmt_err(x):
    return "-" if x is None else f"{x:.1e}"


# --- the methods on a batch of pairs -------------------------------------------------------------


def float_runner(a, b, method, setup, dtype):
    """A function running a thesis test (uncertified) on the pairs, single-threaded."""
    arrays = [
        np.ascontiguousarray(x, dtype=dtype) for x in (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    ]
    out = np.empty(max(len(a), len(b)), dtype=np.int8)

    def run():
        ext.classify_float(*arrays, setup == "cofactor", method == "sturm", out, 0, len(out))
        return out

    return run


def distances_serial(Ca, Ra, ra, Cb, Rb, rb, max_iter, out):
    """The narrow phase's signed distance of each pair, one thread, no input checks (a compiled loop:
    the time is the function's own, not Python's)."""
    ext.testing.distances_serial(Ca, Ra, ra, Cb, Rb, rb, max_iter, out)


def newton_runs(Ca, Ra, ra, Cb, Rb, rb, max_iter, out):
    """sigma after one Newton run of at most max_iter steps from the bisector seed: the narrow
    phase's first run alone, without its restart, multistart or proof (a compiled loop)."""
    ext.testing.newton_runs(Ca, Ra, ra, Cb, Rb, rb, max_iter, out)


def pair_runner(kernel, a, b, max_iter):
    """A function filling and returning one float per pair with kernel(pairs..., max_iter, out)."""
    out = np.empty(len(a))

    def run():
        kernel(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, max_iter, out)
        return out

    return run


def verdict(dist):
    """Relation codes from signed distances: > 0 separated, == 0 touching, < 0 overlapping."""
    return np.where(dist > 0, 0, np.where(dist < 0, 2, 1)).astype(np.int8)


class MujocoPairs:
    """MuJoCo's mj_geomDistance on given pairs: static world geoms whose poses are then set to the
    pairs' exact float64 values, called through its address in a compiled loop (ext.bench.geom_distance_loop)."""

    def __init__(self, a, b):
        n = len(a)
        geoms = []
        for e in (a, b):
            for c, r in zip(e.centers.tolist(), e.radii.tolist()):
                pos, size = " ".join(map(repr, c)), " ".join(map(repr, r))
                geoms.append(f'<geom type="ellipsoid" contype="0" conaffinity="0" pos="{pos}" size="{size}"/>')
        self.model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{''.join(geoms)}</worldbody></mujoco>")
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        self.data.geom_xpos[:n], self.data.geom_xpos[n:] = a.centers, b.centers
        self.data.geom_xmat[:n], self.data.geom_xmat[n:] = a.rotations.reshape(n, 9), b.rotations.reshape(n, 9)
        self.pairs = np.column_stack([np.arange(n), np.arange(n) + n]).astype(np.int32)
        self.distmax = 10.0 * float(max(a.radii.max(), b.radii.max()) + np.abs(b.centers - a.centers).max())
        self._fn = ctypes.cast(publish.mujoco_library().mj_geomDistance, ctypes.c_void_p).value

    def run(self, tolerance, iterations):
        self.model.opt.ccd_tolerance, self.model.opt.ccd_iterations = tolerance, iterations
        out = np.empty(len(self.pairs))
        ext.bench.geom_distance_loop(self._fn, self.model._address, self.data._address, self.pairs, self.distmax, out)
        return out


# --- mj_step --------------------------------------------------------------------------------------

STEP_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
STEP_MODES = ("builtin", "filter", "narrowphase")


def timed_steps(model, data, steps, mode):
    """(seconds, attachment) of `steps` mj_step calls from data's state, ellipsim attached in `mode`
    ("builtin": not attached, attachment None).  Only the steps are timed; the attachment is inside
    a `with` block, so a step that raises leaves MuJoCo's callback and collision table restored."""
    attachment = None if mode == "builtin" else attach(model, data, mode=mode)
    with attachment or contextlib.nullcontext():
        t0 = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        seconds = time.perf_counter() - t0
    return seconds, attachment


def step_segment(model, data, state, steps, mode):
    """A function returning the seconds of `steps` mj_step calls from `state`, ellipsim attached in `mode`."""

    def run():
        mujoco.mj_setState(model, data, state, STEP_STATE)
        return timed_steps(model, data, steps, mode)[0]

    return run


def settled(xml, steps):
    """(model, data, state) of a scene after `steps` plain mj_step calls from its initial state."""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    state = np.empty(mujoco.mj_stateSize(model, STEP_STATE))
    mujoco.mj_getState(model, data, state, STEP_STATE)
    return model, data, state
