"""`ellipsim bench`: run time against error for every method, numerical stress, scaling, thesis Table 1.

    ellipsim bench [--quick] [--out DIR]

Writes DIR/report.md and PNG plots (matplotlib, Agg; the 'bench' extra).  Every number compared
in a table is measured in the same run.  Sections:

1. Time vs error: every classify method and set-up (exact; sturm and descartes x cofactor and
   rearranged x float64 and float32), contact_scale, the narrow phase at several Newton caps,
   MuJoCo's mj_geomDistance at ccd_tolerance 1e-2 ... 1e-10 and a few ccd_iterations, and coal's
   GJK/EPA when the 'peers' extra is installed.  Error: misclassification rate against the exact
   relation, and distance error against a 40-digit reference (mpmath).
2. Numerical stress: samples.STRESS categories, misclassifications per method and for MuJoCo.
3. Scaling: ns/pair against batch size; mj_step against the number of figures for builtin,
   filter and narrowphase; the kinematic replay against the number of figures.
4. The thesis's Table 1 re-run: 5000 colliding and 5000 separated generic pairs, the four
   set-up x root-test combinations, next to the thesis's SGI Onyx (195 MHz R10000) timings.
"""

import contextlib
import ctypes
import datetime
import math
import os
import platform
import sys
import time

import mujoco
import numba
import numpy as np

from . import figures, mjstruct, plugin, scenario
from ._jit import jit
from .certified import UNDECIDED, certify
from .classify import _classify_float_serial, classify
from .contact import contact_scale
from .ellipsoids import Ellipsoids
from .frame import load
from .narrowphase import a_frame, bisector_seed, newton, pair_signed_distance, sigma
from .tolerances import NEWTON_MAX_ITER
from .samples import STRESS, generic_pairs, near_contact_pairs, stress_pairs

SIZES = {
    "quick": dict(generic=100_000, near=20_000, mujoco=4_000, stress=600, reference=40, batch_max=100_000,
                  figures=(1, 4, 16), replay_figures=(1, 4, 16), rounds=5, steps=100, coal=1_000),
    "full": dict(generic=1_000_000, near=100_000, mujoco=20_000, stress=5_000, reference=200, batch_max=1_000_000,
                 figures=(1, 4, 16, 64), replay_figures=(1, 4, 16, 64), rounds=15, steps=200, coal=5_000),
}  # fmt: skip
FLOAT_METHODS = [(m, s, d) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor") for d in ("float64", "float32")]
NEWTON_STEPS = (1, 2, 3, 4, 6)  # one run from the bisector seed, capped
MUJOCO_SETTINGS = [(1e-2, 35), (1e-4, 35), (1e-6, 35), (1e-8, 35), (1e-10, 35), (1e-6, 5), (1e-6, 10), (1e-10, 1000)]
# The thesis's Table 1 (5.1.2): average microseconds per pair on an SGI Onyx, 195 MHz R10000.
THESIS_TABLE1 = {
    ("cofactor", "sturm"): (23.3385, 22.3892), ("cofactor", "descartes"): (19.7987, 20.9842),
    ("rearranged", "sturm"): (22.1682, 20.0594), ("rearranged", "descartes"): (18.6665, 16.557),
}  # (without collision, with collision)  # fmt: skip


def _plt():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError("ellipsim bench needs matplotlib and mpmath: pip install 'ellipsim[bench]'") from None
    return plt


def _say(text):
    print(text, file=sys.stderr, flush=True)


def _median_time(fn, rounds):
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _interleaved(fns, rounds, *, self_timed=False):
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


def _relative(times, name, ref):
    """Median over rounds of times[name] / times[ref] (both from one _interleaved call)."""
    return float(np.median(times[name] / times[ref]))


# --- the methods on a batch of pairs -------------------------------------------------------------


def _float_runner(a, b, method, setup, dtype):
    arrays = [np.ascontiguousarray(x, dtype=dtype) for x in (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)]
    out = np.empty(max(len(a), len(b)), dtype=np.int8)

    def run():
        _classify_float_serial(*arrays, setup == "cofactor", method == "sturm", out)
        return out

    return run


@jit
def _distances_serial(Ca, Ra, ra, Cb, Rb, rb, max_iter, out):
    for i in range(out.shape[0]):
        out[i] = pair_signed_distance(load(Ca, Ra, ra, i), load(Cb, Rb, rb, i), max_iter)[1]


@jit
def _newton_runs(Ca, Ra, ra, Cb, Rb, rb, max_iter, out):
    """sigma after one Newton run of at most max_iter steps from the bisector seed: the narrow
    phase's first run alone, without its restart, multistart or certificate."""
    for i in range(out.shape[0]):
        A, B = load(Ca, Ra, ra, i), load(Cb, Rb, rb, i)
        e, a2, M, U = a_frame(A, B)
        rb_ = B[2]
        rb2 = (rb_[0] * rb_[0], rb_[1] * rb_[1], rb_[2] * rb_[2])
        scale = max(A[2][0], A[2][1], A[2][2], rb_[0], rb_[1], rb_[2])
        n = newton(bisector_seed(e, a2, U, rb2), e, a2, M, scale, -math.inf, max_iter)[0]
        out[i] = sigma(n, e, a2, M)


def _pair_runner(kernel, a, b, max_iter):
    """A function filling and returning one float per pair with kernel(pairs..., max_iter, out)."""
    out = np.empty(len(a))

    def run():
        kernel(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, max_iter, out)
        return out

    return run


def _narrow_runner(a, b, cap):
    return _pair_runner(_distances_serial, a, b, cap)


def _verdict(dist):
    """Relation codes from signed distances: > 0 separated, == 0 touching, < 0 overlapping."""
    return np.where(dist > 0, 0, np.where(dist < 0, 2, 1)).astype(np.int8)


class MujocoPairs:
    """MuJoCo's mj_geomDistance on given pairs: static world geoms whose poses are then set to the
    pairs' exact float64 values, called through ctypes in a compiled loop."""

    _FN = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_int64, ctypes.c_int64, ctypes.c_int, ctypes.c_int, ctypes.c_double, ctypes.c_int64)

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
        self.pairs = np.column_stack([np.arange(n), np.arange(n) + n]).astype(np.int64)
        self.distmax = 10.0 * float(max(a.radii.max(), b.radii.max()) + np.abs(b.centers - a.centers).max())
        fn = self._FN(ctypes.cast(mjstruct.mujoco_library().mj_geomDistance, ctypes.c_void_p).value)

        @numba.njit
        def loop(m, d, pairs, distmax, out):
            for k in range(pairs.shape[0]):
                out[k] = fn(m, d, pairs[k, 0], pairs[k, 1], distmax, 0)

        self._loop = loop

    def run(self, tolerance, iterations):
        self.model.opt.ccd_tolerance, self.model.opt.ccd_iterations = tolerance, iterations
        out = np.empty(len(self.pairs))
        self._loop(self.model._address, self.data._address, self.pairs, self.distmax, out)
        return out


def _coal():
    try:
        import coal
    except ImportError:
        return None
    return coal


def _coal_distances(coal, a, b):
    """coal's signed distance (GJK/EPA) through its Python binding, one call per pair."""
    out = np.empty(len(a))
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    req.enable_signed_distance = True
    for k in range(len(a)):
        ea, eb = coal.Ellipsoid(*a.radii[k]), coal.Ellipsoid(*b.radii[k])
        ta, tb = coal.Transform3s(a.rotations[k], a.centers[k]), coal.Transform3s(b.rotations[k], b.centers[k])
        res.clear()
        out[k] = coal.distance(ea, ta, eb, tb, req, res)
    return out


# --- the 40-digit distance reference -----------------------------------------------------------------


def reference_distances(a, b, seeds):
    """Signed distances to ~30 digits: sigma(n) polished by Newton in mpmath from each seed normal
    (k, 3) per pair (the best local maximum among them is kept)."""
    import mpmath

    mpmath.mp.dps = 40
    out = np.empty(len(a))
    for k in range(len(a)):
        d = b.centers[k] - a.centers[k]
        Ma = a.rotations[k] * a.radii[k] ** 2 @ a.rotations[k].T
        Mb = b.rotations[k] * b.radii[k] ** 2 @ b.rotations[k].T
        out[k] = max(float(polish_sigma(d, Ma, Mb, s[k])) for s in seeds if np.all(np.isfinite(s[k])))
    return out


def polish_sigma(d, Ma, Mb, n0, iterations=40):
    """sigma(n) = n.d - sqrt(n'Ma n) - sqrt(n'Mb n) at the local maximum nearest the unit normal n0,
    by Newton in the tangent plane in the current mpmath precision (d, Ma, Mb, n0 are float arrays;
    Ma = R diag(r^2) R' is the support-function matrix of an ellipsoid, Eberly GTCG 10.5.2)."""
    import mpmath as mp

    d = [mp.mpf(float(x)) for x in d]
    Ma, Mb = mp.matrix(np.asarray(Ma).tolist()), mp.matrix(np.asarray(Mb).tolist())
    n0 = mp.matrix([mp.mpf(float(x)) for x in n0])
    n0 /= mp.norm(n0)
    t1 = mp.matrix([0, n0[2], -n0[1]]) if abs(n0[0]) < 0.6 else mp.matrix([-n0[2], 0, n0[0]])
    t1 /= mp.norm(t1)
    t2 = mp.matrix([n0[1] * t1[2] - n0[2] * t1[1], n0[2] * t1[0] - n0[0] * t1[2], n0[0] * t1[1] - n0[1] * t1[0]])

    def f(u, v):
        n = n0 + u * t1 + v * t2
        n /= mp.norm(n)
        return sum(n[i] * d[i] for i in range(3)) - mp.sqrt((n.T * Ma * n)[0]) - mp.sqrt((n.T * Mb * n)[0])

    u = v = mp.mpf(0)
    for _ in range(iterations):
        gu, gv = mp.diff(lambda x: f(x, v), u), mp.diff(lambda y: f(u, y), v)
        huu, hvv = mp.diff(lambda x: f(x, v), u, 2), mp.diff(lambda y: f(u, y), v, 2)
        huv = mp.diff(lambda x: mp.diff(lambda y: f(x, y), v), u)
        det = huu * hvv - huv**2
        if det == 0:
            break
        du, dv = -(hvv * gu - huv * gv) / det, -(huu * gv - huv * gu) / det
        u, v = u + du, v + dv
        if abs(du) + abs(dv) < mp.mpf(10) ** (10 - mp.mp.dps):
            break
    return f(u, v)


# --- 1. time against error ----------------------------------------------------------------------------


PLAIN = "descartes rearranged float64"
NARROW = "narrow phase (certified)"


def pareto(size):
    """Rows (name, family, ns/pair, time / reference in the same rounds, misclassification rate,
    median and max distance error / r_min): classification methods (reference: PLAIN), then
    signed-distance methods (reference: NARROW)."""
    _say("time vs error: pairs and exact relations ...")
    a, b = near_contact_pairs(size["near"], seed=11)
    truth = classify(a, b)
    n = len(truth)
    fns, wrong = {"exact (certified)": lambda: classify(a, b, parallel=False)}, {"exact (certified)": 0.0}
    family = {"exact (certified)": "ellipsim classify"}
    for m, s, d in FLOAT_METHODS:
        name = f"{m} {s} {d}"
        fns[name] = _float_runner(a, b, m, s, d)
        wrong[name], family[name] = np.count_nonzero(fns[name]() != truth) / n, "thesis tests"
    cs_name = "contact_scale > 1 (2 threads)"
    fns[cs_name] = lambda: contact_scale(a, b)  # the parallel kernel
    wrong[cs_name], family[cs_name] = np.count_nonzero(_verdict(contact_scale(a, b) - 1) != truth) / n, "ellipsim contact_scale"
    _say(f"time vs error: timing {len(fns)} classifiers in {size['rounds']} interleaved rounds ...")
    times = _interleaved(fns, size["rounds"])
    rows = [(k, family[k], np.median(times[k]) / n * 1e9, _relative(times, k, PLAIN), wrong[k], None, None) for k in fns]
    # distances: a subset with a 40-digit reference
    m_a, m_b = a[: size["mujoco"]], b[: size["mujoco"]]
    m_truth = truth[: size["mujoco"]]
    nm, ref_n = len(m_a), size["reference"]
    mj = MujocoPairs(m_a, m_b)
    tight = mj.run(1e-12, 1000)
    _say(f"time vs error: 40-digit reference for {ref_n} pairs ...")
    seeds = [_normals(m_a[:ref_n], m_b[:ref_n])]
    ref = reference_distances(m_a[:ref_n], m_b[:ref_n], seeds)
    rmin = np.minimum(m_a.radii[:ref_n].min(1), m_b.radii[:ref_n].min(1))
    fns = {NARROW: _narrow_runner(m_a, m_b, NEWTON_MAX_ITER)}
    family = {NARROW: "ellipsim narrow phase"}
    for k in NEWTON_STEPS:
        name = f"one Newton run, {k} step{'s' if k > 1 else ''}"
        fns[name], family[name] = _pair_runner(_newton_runs, m_a, m_b, k), "ellipsim narrow phase"
    for tol, it in MUJOCO_SETTINGS:
        name = f"MuJoCo tol {tol:g}, {it} it"
        fns[name], family[name] = (lambda tol=tol, it=it: mj.run(tol, it)), "MuJoCo mj_geomDistance"
    dists = {k: fn().copy() for k, fn in fns.items()}
    rounds = max(3, size["rounds"] // 2)
    _say(f"time vs error: timing {len(fns)} distance methods in {rounds} interleaved rounds ...")
    times = _interleaved(fns, rounds)
    for k in fns:
        e = np.abs(dists[k][:ref_n] - ref) / rmin
        rows.append((k, family[k], np.median(times[k]) / nm * 1e9, _relative(times, k, NARROW),
                     np.count_nonzero(_verdict(dists[k]) != m_truth) / nm, np.median(e), e.max()))  # fmt: skip
    coal = _coal()
    if coal is not None:
        _say("time vs error: coal ...")
        k = size["coal"]
        t0 = time.perf_counter()
        dist = _coal_distances(coal, m_a[:k], m_b[:k])
        seconds = time.perf_counter() - t0
        t0 = time.perf_counter()
        fns[NARROW]()
        narrow_seconds = (time.perf_counter() - t0) * k / nm
        e = np.abs(dist[:ref_n] - ref) / rmin if k >= ref_n else np.array([np.nan])
        rows.append(("coal GJK/EPA (Python calls)", "coal", seconds / k * 1e9, seconds / narrow_seconds,
                     np.count_nonzero(_verdict(dist) != m_truth[:k]) / k, np.median(e), e.max()))  # fmt: skip
    notes = {
        "pairs": n, "mujoco_pairs": nm, "reference": ref_n, "coal": coal is not None,
        "full_vs_ref": float((np.abs(dists[NARROW][:ref_n] - ref) / rmin).max()),
        "tight_vs_ref": float((np.abs(tight[:ref_n] - ref) / rmin).max()),
    }  # fmt: skip
    return rows, notes


def _normals(a, b):
    """ellipsim's converged normals as seeds for the reference polish."""
    out = np.empty((len(a), 3))
    for k in range(len(a)):
        _, _, normal, _, _ = pair_signed_distance(load(a.centers, a.rotations, a.radii, k), load(b.centers, b.rotations, b.radii, k))
        out[k] = normal
    return out


# --- 2. numerical stress -----------------------------------------------------------------------------


def stress(size):
    """{category: {method: misclassified}}, exact's escalation share and time per pair per category."""
    table, exact_info = {}, {}
    methods = [f"{m} {s} {d}" for m, s, d in FLOAT_METHODS] + ["contact_scale", "narrow phase", "MuJoCo (default tol)"]
    for cat in STRESS:
        _say(f"stress: {cat} ...")
        a, b = stress_pairs(cat, size["stress"], seed=5)
        n = len(a)
        t0 = time.perf_counter()
        truth = classify(a, b, parallel=False)
        exact_info[cat] = (np.count_nonzero(certify(a, b, n, False) == UNDECIDED) / n, (time.perf_counter() - t0) / n * 1e9, n)
        row = {}
        for m, s, d in FLOAT_METHODS:
            row[f"{m} {s} {d}"] = int(np.count_nonzero(_float_runner(a, b, m, s, d)() != truth))
        row["contact_scale"] = int(np.count_nonzero(_verdict(contact_scale(a, b) - 1) != truth))
        row["narrow phase"] = int(np.count_nonzero(_verdict(_narrow_runner(a, b, 40)()) != truth))
        row["MuJoCo (default tol)"] = int(np.count_nonzero(_verdict(MujocoPairs(a, b).run(1e-6, 35)) != truth))
        table[cat] = row
    return table, exact_info, methods


# --- 3. scaling -----------------------------------------------------------------------------------------


def timed_steps(model, data, steps, mode):
    """(seconds, attachment) of `steps` mj_step calls from data's state, ellipsim attached in `mode`
    ("builtin": not attached, attachment None).  Only the steps are timed; the attachment is inside
    a `with` block, so a step that raises leaves MuJoCo's callback and collision table restored."""
    attachment = None if mode == "builtin" else plugin.attach(model, data, mode=mode)
    with attachment or contextlib.nullcontext():
        t0 = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        seconds = time.perf_counter() - t0
    return seconds, attachment


def _step_segment(model, data, state, steps, mode):
    """A function returning the seconds of `steps` mj_step calls from `state`, ellipsim attached in `mode`."""

    def run():
        mujoco.mj_setState(model, data, state, STEP_STATE)
        return timed_steps(model, data, steps, mode)[0]

    return run


STEP_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
STEP_MODES = ("builtin", "filter", "narrowphase")


def scaling(size):
    """Batch rows (pairs, exact 1 thread, exact 2 threads, plain descartes: ns/pair), mj_step rows
    (figures, µs/step per mode, speed-up builtin/mode per mode), replay rows."""
    _say("scaling: batch sizes ...")
    a, b = generic_pairs(size["batch_max"], seed=3)
    batches = [int(x) for x in 10.0 ** np.arange(0, int(math.log10(size["batch_max"])) + 1)]
    batch_rows = []
    for n in batches:
        x, y = a[:n], b[:n]
        fns = {
            "serial": lambda: classify(x, y, parallel=False),
            "parallel": lambda: classify(x, y, parallel=True),
            "plain": _float_runner(x, y, "descartes", "rearranged", "float64"),
        }
        for fn in fns.values():
            fn()  # compile and warm
        t = _interleaved(fns, max(3, min(size["rounds"], 200_000 // n)))
        batch_rows.append((n, *(np.median(t[k]) / n * 1e9 for k in fns)))
    step_rows = []
    for nf in size["figures"]:
        _say(f"scaling: mj_step with {nf} figures, {size['rounds']} interleaved rounds ...")
        model = mujoco.MjModel.from_xml_string(figures.scene_xml(nf, layout="pile", seed=1))
        data = mujoco.MjData(model)
        for _ in range(1000):  # settle into a heap: contacts, not free fall
            mujoco.mj_step(model, data)
        state = np.empty(mujoco.mj_stateSize(model, STEP_STATE))
        mujoco.mj_getState(model, data, state, STEP_STATE)
        fns = {mode: _step_segment(model, data, state, size["steps"], mode) for mode in STEP_MODES}
        for fn in fns.values():
            fn()  # compile the callbacks
        t = _interleaved(fns, size["rounds"], self_timed=True)
        step_rows.append((nf, *(np.median(t[m]) / size["steps"] * 1e6 for m in STEP_MODES),
                          *(_relative(t, "builtin", m) for m in STEP_MODES[1:])))  # fmt: skip
    replay_rows = []
    base = scenario.load("replay")
    for nf in size["replay_figures"]:
        _say(f"scaling: kinematic replay with {nf} figures ...")
        # figure i starts `stagger` s late; shrink it so that every figure dances within the routine
        stagger = min(base.control["stagger"], base.duration / nf)
        s = scenario.Scenario(**{**base.__dict__, "scene": {**base.scene, "figures": nf},
                                 "control": {**base.control, "stagger": stagger}})  # fmt: skip
        scenario.run(s, steps=5)  # compile and warm
        t0 = time.perf_counter()
        run = scenario.run(s)
        total = time.perf_counter() - t0
        replay_rows.append((nf, run.steps, total / run.steps * 1e3, run.seconds / run.steps * 1e3,
                            int(run.frames.ellipsim_counts.sum())))  # fmt: skip
    return batch_rows, step_rows, replay_rows


# --- 4. the thesis's Table 1 -------------------------------------------------------------------------


def table1(size):
    _say("thesis Table 1 ...")
    a, b = generic_pairs(10_000, seed=4)
    truth = classify(a, b)
    sep, col = np.flatnonzero(truth == 0), np.flatnonzero(truth != 0)
    rows = []
    for setup in ("cofactor", "rearranged"):
        for test in ("sturm", "descartes"):
            ours = []
            for idx in (sep, col):
                run = _float_runner(a[idx], b[idx], test, setup, "float64")
                ours.append(_median_time(run, size["rounds"]) / len(idx) * 1e9)
            thesis = THESIS_TABLE1[(setup, test)]
            rows.append((setup, test, thesis[0], ours[0], thesis[1], ours[1]))
    return rows, (len(sep), len(col))


# --- report ---------------------------------------------------------------------------------------


def _fmt_rate(x):
    return "0" if x == 0 else f"{x:.2e}"


def _fmt_err(x):
    return "-" if x is None else f"{x:.1e}"


def run(out_dir, *, quick=False):
    """Run the suite and write out_dir/report.md and PNG plots; returns the report's path."""
    plt = _plt()
    __import__("mpmath")
    os.makedirs(out_dir, exist_ok=True)
    size = SIZES["quick" if quick else "full"]
    t_start = time.perf_counter()
    prows, pnotes = pareto(size)
    stable, sinfo, smethods = stress(size)
    batch_rows, step_rows, replay_rows = scaling(size)
    t1rows, t1n = table1(size)
    _plots(plt, out_dir, prows, stable, smethods, batch_rows, step_rows, replay_rows, t1rows)
    seconds = time.perf_counter() - t_start
    text = _report(quick, size, seconds, prows, pnotes, stable, sinfo, smethods, batch_rows, step_rows, replay_rows, t1rows, t1n)
    path = os.path.join(out_dir, "report.md")
    with open(path, "w") as f:
        f.write(text)
    return path, seconds


def publish(text, path=None):
    """Print a benchmark's markdown report and, given a path, write it there too."""
    print(text)
    if path:
        with open(path, "w") as f:
            f.write(text)


def machine_description():
    """CPU model, cores and the versions that decide the timings, for a report's first lines."""
    cpu = platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numba {numba.__version__}, mujoco {mujoco.__version__}"


def _report(quick, size, seconds, prows, pnotes, stable, sinfo, smethods, batch_rows, step_rows, replay_rows, t1rows, t1n):
    L = [
        f"# ellipsim bench{' --quick' if quick else ''}",
        "",
        f"{datetime.date.today()}, {machine_description()}; {seconds:.0f} s.",
        "",
        "## 1. Time against error",
        "",
        f"{pnotes['pairs']} random pairs with |contact_scale - 1| < 0.1 (where no shortcut decides); distances on the "
        f"first {pnotes['mujoco_pairs']}, their error against a 40-digit mpmath reference on the first {pnotes['reference']} "
        "(in units of the smaller ellipsoid's shortest semi-axis).  Single-threaded unless noted; MuJoCo is called "
        "through ctypes in a compiled loop" + ("; coal through its Python binding (per-call overhead included)." if pnotes["coal"] else
        "; coal is not installed (pip install 'ellipsim[peers]' adds it)."),
        "",
        "![time against error](pareto.png)",
        "",
        f"### Classification ({pnotes['pairs']} pairs; time relative to {PLAIN}, median of per-round ratios)",
        "",
        "| method | ns/pair | × plain | misclassified |",
        "|---|---:|---:|---:|",
    ]
    for name, _, ns, rel, wrong, med, mx in prows:
        if med is None:
            L.append(f"| {name} | {ns:.0f} | {rel:.2f} | {_fmt_rate(wrong)} |")
    L += [
        "",
        f"### Signed distance ({pnotes['mujoco_pairs']} pairs; time relative to the {NARROW})",
        "",
        "'one Newton run, k steps' is the narrow phase's first run alone, capped, with no certificate, restart or "
        "multistart: what a fixed-iteration Newton would buy.",
        "",
        "| method | ns/pair | × narrow phase | misclassified | distance error, median | distance error, max |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, _, ns, rel, wrong, med, mx in prows:
        if med is not None:
            L.append(f"| {name} | {ns:.0f} | {rel:.2f} | {_fmt_rate(wrong)} | {_fmt_err(med)} | {_fmt_err(mx)} |")
    L += [
        "",
        f"The converged narrow phase is within {pnotes['full_vs_ref']:.1e} of the reference; MuJoCo at ccd_tolerance "
        f"1e-12 within {pnotes['tight_vs_ref']:.1e}.",
        "",
        "## 2. Numerical stress",
        "",
        f"Misclassified pairs out of {size['stress']} per category (samples.stress_pairs); exact's share escalated to "
        "rational arithmetic and its time per pair.  MuJoCo: the sign of mj_geomDistance at ccd_tolerance 1e-6.",
        "",
        "![misclassification per category](stress.png)",
        "",
        "| category | exact: escalated | exact: µs/pair | " + " | ".join(smethods) + " |",
        "|---|---:|---:|" + "---:|" * len(smethods),
    ]
    for cat, row in stable.items():
        share, ns, _ = sinfo[cat]
        L.append(f"| {cat} | {share:.0%} | {ns / 1e3:.2f} | " + " | ".join(str(row[m]) for m in smethods) + " |")
    L += [
        "",
        "exact misclassified 0 pairs in every category (it defines the truth; tests/test_classify.py checks it against "
        "an independent rational reference).",
        "",
        "## 3. Scaling",
        "",
        "![scaling](scaling.png)",
        "",
        "Batches of generic pairs; the three functions timed in the same interleaved rounds.  Below ~10 pairs a "
        "call's Python overhead (input checks) dominates: batch your pairs.",
        "",
        "| pairs per call | exact, ns/pair | exact, 2 threads | plain descartes, ns/pair |",
        "|---:|---:|---:|---:|",
    ]
    L += [f"| {n} | {s:.0f} | {p:.0f} | {q:.0f} |" for n, s, p, q in batch_rows]
    L += [
        "",
        f"mj_step on heaps of figures dropped onto each other, settled for 1000 steps; {size['steps']} steps from that "
        f"state per segment, the three modes interleaved over {size['rounds']} rounds; speed-up = median per-round "
        "builtin time / mode time.",
        "",
        "| figures (heap) | builtin µs/step | filter µs/step | narrowphase µs/step | filter speed-up | narrowphase speed-up |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    L += [f"| {nf} | {b:.0f} | {f:.0f} | {n:.0f} | {sf:.2f} | {sn:.2f} |" for nf, b, f, n, sf, sn in step_rows]
    L += [
        "",
        "The kinematic replay scenario with more figures in a line (all dancing: the stagger is at most the routine's "
        "length / figures).  Per frame: keyframe poses, mj_forward (MuJoCo's kinematics and its own collision, kept "
        "for comparison), then ellipsim's broad phase and one batched exact classify of all frames.",
        "",
        "| figures (kinematic replay) | frames | ms/frame, total | of which mj_forward loop | overlapping pairs, all frames |",
        "|---:|---:|---:|---:|---:|",
    ]
    L += [f"| {nf} | {k} | {ms:.2f} | {fw:.2f} | {c} |" for nf, k, ms, fw, c in replay_rows]
    L += [
        "",
        "## 4. The thesis's Table 1, re-run",
        "",
        f"{t1n[0]} separated and {t1n[1]} colliding generic pairs (thesis 5.1.1), float64, single-threaded; the thesis's "
        "averages were measured on an SGI Onyx (195 MHz R10000).",
        "",
        "![Table 1](table1.png)",
        "",
        "| set-up | root test | thesis µs, separated | ours ns, separated | speed-up | thesis µs, colliding | ours ns, colliding | speed-up |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for setup, test, ts, os_, tc, oc in t1rows:
        L.append(f"| {setup} | {test} | {ts:.2f} | {os_:.0f} | {ts * 1e3 / os_:.0f}x | {tc:.2f} | {oc:.0f} | {tc * 1e3 / oc:.0f}x |")
    L += ["", f"Run time {seconds:.0f} s."]
    return "\n".join(L) + "\n"


def _plots(plt, out, prows, stable, smethods, batch_rows, step_rows, replay_rows, t1rows):
    colours = {"ellipsim classify": "C3", "thesis tests": "C0", "ellipsim contact_scale": "C5",
               "ellipsim narrow phase": "C2", "MuJoCo mj_geomDistance": "C1", "coal": "C4"}  # fmt: skip
    fig = plt.figure(figsize=(15, 8), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, height_ratios=[5, 1.2])
    ax1, ax2, key = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, :])
    floor = 1e-7
    # points carry numbers (listed below the plots); labels of points at the same height alternate in height
    placed = {}
    for k, (name, family, ns, rel, wrong, med, mx) in enumerate(prows, 1):
        for ax, y in ((ax1, max(wrong, floor)), (ax2, None if mx is None else max(mx, 1e-17))):
            if y is None:
                continue
            ax.scatter(ns, y, color=colours[family], s=30)
            j = placed.setdefault((id(ax), y), 0)
            placed[(id(ax), y)] += 1
            ax.annotate(str(k), (ns, y), fontsize=7, xytext=(2, 3 + 8 * (j % 4)), textcoords="offset points")
    for family, c in colours.items():
        ax1.scatter([], [], color=c, label=family)
    ax1.set(xscale="log", yscale="log", xlabel="time per pair [ns]", ylabel=f"misclassified share (0 drawn at {floor:g})",
            title="classification: time against error")  # fmt: skip
    ax1.legend(fontsize=7)
    ax2.set(xscale="log", yscale="log", xlabel="time per pair [ns]", ylabel="max |distance error| / shortest semi-axis",
            title="signed distance: time against error")  # fmt: skip
    names = [f"{k}: {row[0]}" for k, row in enumerate(prows, 1)]
    cols = 4
    per = -(-len(names) // cols)
    key.axis("off")
    key.text(0, 1, "\n".join("    ".join(f"{x:<40}" for x in names[i::per]) for i in range(per)),
             fontsize=7.5, family="monospace", va="top", transform=key.transAxes)  # fmt: skip
    fig.savefig(os.path.join(out, "pareto.png"), dpi=110)
    plt.close(fig)

    cats = list(stable)
    grid = np.array([[stable[c][m] for m in smethods] for c in cats], dtype=float)
    n = max(1, max(sum(stable[c].values()) for c in cats))
    fig, ax = plt.subplots(figsize=(12, 6.5), constrained_layout=True)
    im = ax.imshow(np.log10(grid + 1), cmap="Reds", aspect="auto")
    for i in range(len(cats)):
        for j in range(len(smethods)):
            if grid[i, j]:
                dark = np.log10(grid[i, j] + 1) > 0.6 * np.log10(grid.max() + 1)
                ax.text(j, i, f"{int(grid[i, j])}", ha="center", va="center", fontsize=6, color="white" if dark else "black")
    ax.set_xticks(range(len(smethods)), smethods, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(range(len(cats)), cats, fontsize=7)
    ax.set_title("misclassified pairs per stress category (exact: 0 everywhere)")
    fig.colorbar(im, ax=ax, label="log10(misclassified + 1)")
    fig.savefig(os.path.join(out, "stress.png"), dpi=110)
    plt.close(fig)

    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(15, 4.5), constrained_layout=True)
    b = np.array(batch_rows, dtype=float)
    a1.plot(b[:, 0], b[:, 1], "o-", label="exact, 1 thread")
    a1.plot(b[:, 0], b[:, 2], "o-", label="exact, 2 threads")
    a1.plot(b[:, 0], b[:, 3], "o--", label="plain descartes, 1 thread")
    a1.set(xscale="log", yscale="log", xlabel="pairs per call", ylabel="time per pair [ns]", title="classify: batch size")
    a1.legend(fontsize=8)
    s = np.array(step_rows, dtype=float)
    for k, mode in enumerate(STEP_MODES[1:]):
        a2.plot(s[:, 0], s[:, 4 + k], "o-", label=mode, color=f"C{k + 1}")
    a2.axhline(1.0, color="grey", lw=0.8, label="builtin")
    a2.set(xscale="log", xlabel="figures in a heap", ylabel="mj_step speed-up over builtin", title="mj_step: speed-up against figures")
    a2.legend(fontsize=8)
    r = np.array(replay_rows, dtype=float)
    a3.plot(r[:, 0], r[:, 2], "o-", label="total")
    a3.plot(r[:, 0], r[:, 3], "o--", label="of which mj_forward loop")
    a3.legend(fontsize=8)
    a3.set(xscale="log", yscale="log", xlabel="figures", ylabel="time per frame [ms]", title="kinematic replay")
    fig.savefig(os.path.join(out, "scaling.png"), dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    labels = [f"{s}\n{t}" for s, t, *_ in t1rows]
    x = np.arange(len(labels))
    ax.bar(x - 0.3, [r[2] * 1e3 for r in t1rows], 0.2, label="thesis, separated")
    ax.bar(x - 0.1, [r[4] * 1e3 for r in t1rows], 0.2, label="thesis, colliding")
    ax.bar(x + 0.1, [r[3] for r in t1rows], 0.2, label="ellipsim, separated")
    ax.bar(x + 0.3, [r[5] for r in t1rows], 0.2, label="ellipsim, colliding")
    ax.set_xticks(x, labels)
    ax.set(yscale="log", ylabel="time per pair [ns]", title="thesis Table 1: SGI Onyx 195 MHz vs this machine")
    ax.legend(fontsize=8)
    fig.savefig(os.path.join(out, "table1.png"), dpi=110)
    plt.close(fig)
