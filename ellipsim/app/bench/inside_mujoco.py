"""Section 5: ellipsim inside mj_step: speed per mode, cost per pair, contacts against MuJoCo's own.

1. mj_step on settled scenes (piles of free ellipsoids in a bin, heaps of oval-limb figures):
   builtin, filter and narrowphase timed in the same interleaved rounds from one state.
2. Cost per pair: the compiled callbacks and MuJoCo's own table function (GJK/EPA) called in a
   compiled loop over the ellipsoid pairs MuJoCo's broad phase produced at the settled state, split
   by the exact relation.
3. Contacts on the same states: mujoco.compare_narrowphase at MuJoCo's default ccd_tolerance and at
   1e-10.
4. Deep crossings of elongated ellipsoids: the narrow phase's maximum against the best of 300
   gradient-ascent starts.
4b. Other pair types: ellipsoid x capsule, box, cylinder per call against MuJoCo's (pair_types.py).
5. Long runs: plain and narrowphase from the same drop; kinetic energy, depth, bodies leaving.
6. Where mj_step's time goes: MuJoCo's own timers (mjcb_time set) per mode and for the capsule twin
   (each model also from the other's settled state), and the cost of an ellipsim call inside mj_step
   (its narrow phase against a no-op function in the same table slots, on the same states).
"""

import contextlib
import ctypes
import math
import os
import time
from importlib import resources

import mujoco
import numpy as np

from ...core.distance.ellipsoid_pair import UNPROVEN, signed_distance
from ...core.ellipsoids import Ellipsoids
from ...core.exact.classify import classify
from ...mujoco import publish
from ...mujoco.attachment import attach
from ...mujoco.compare import compare_narrowphase
from ...mujoco.context import PAIR_TYPES
from ...mujoco.geoms import candidate_pairs
from ...native import ext
from .. import scenes
from . import pair_types
from .common import STEP_MODES, STEP_STATE, interleaved, relative, say, settled, step_segment, timed_steps

SCENES = {
    "pile of 40 ellipsoids": (lambda: scenes.pile_xml(40, seed=1), 1500),
    "pile of 100 ellipsoids": (lambda: scenes.pile_xml(100, seed=1), 1500),
    "1 figure": (lambda: scenes.scene_xml(1, layout="pile", seed=1), 1000),
    "4 figures in a heap": (lambda: scenes.scene_xml(4, layout="pile", seed=1), 1000),
    "16 figures in a heap": (lambda: scenes.scene_xml(16, layout="pile", seed=1), 1000),
    "64 figures in a heap": (lambda: scenes.scene_xml(64, layout="pile", seed=1), 1000),
}
SCENES["pile of 60 leaves"] = (lambda: scenes.pile_xml(60, seed=1, radii=(0.03, 0.08), thickness=(0.002, 0.006)), 1500)
SCENES["MuJoCo's collision_convex/perf/mixed.xml"] = (
    lambda: resources.files(__package__).joinpath("mixed.xml").read_text(),
    1000,
)
#: 300 two-leaf bodies (600 ellipsoids 25 x 10 x 1 mm) falling 3 m through air: they land at ~1000 steps,
#: crossing each other up to 10 times their thickness deep, and settle by ~1250
SCENES["MuJoCo's replicate/leaves.xml, landing"] = (
    lambda: resources.files(__package__).joinpath("leaves.xml").read_text(),
    1000,
)
COMPARED = ("pile of 40 ellipsoids", "pile of 100 ellipsoids", "4 figures in a heap", "16 figures in a heap")
LONG_RUNS = ("pile of 40 ellipsoids", "16 figures in a heap")
ELL = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)

_NARROW_FN = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_int64, ctypes.c_int64, ctypes.c_int64, ctypes.c_int, ctypes.c_int, ctypes.c_double
)


def _filter_loop(address):
    """loop(m, d, pairs, reps): the filter at `address` over the pairs, reps times, in a compiled loop
    (ext.bench.filter_loop): the time is the callback's own, not Python's."""
    return lambda m, d, pairs, reps: ext.bench.filter_loop(address, m, d, pairs, reps)


def _narrow_loop(address):
    """loop(m, d, con, pairs, margins, reps): the mjfCollision at `address` over the pairs, reps times, in a
    compiled loop (ext.bench.collision_loop)."""
    return lambda m, d, con, pairs, margins, reps: ext.bench.collision_loop(address, m, d, con, pairs, margins, reps)


def per_pair(model, data, reps=100):
    """ns per call at data's state over the ellipsoid-ellipsoid candidate pairs, split by the exact
    relation: {"touching"|"separated": (ellipsim narrowphase, MuJoCo GJK/EPA, filter, pairs)}."""
    table, n = publish.collision_table()
    theirs = _narrow_loop(table[ELL * n + ELL])
    ours = _narrow_loop(ext.mujoco.NARROWPHASE)
    filt = _filter_loop(ext.mujoco.FILTER)
    pairs = candidate_pairs(model, data)
    pairs = np.ascontiguousarray(pairs[(model.geom_type[pairs] == ELL).all(axis=1)].astype(np.int32))
    geoms = lambda g: Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(-1, 3, 3), model.geom_size[g])  # noqa: E731
    touching = classify(geoms(pairs[:, 0]), geoms(pairs[:, 1])) != 0 if len(pairs) else np.zeros(0, bool)
    margins = model.geom_margin[pairs].sum(axis=1) + model.geom_gap[pairs].sum(axis=1)
    con = np.zeros(640)
    # The callbacks answer as MuJoCo for a data not attached in their mode: time each on a data that is.
    filtered = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, STEP_STATE))
    mujoco.mj_getState(model, data, state, STEP_STATE)
    mujoco.mj_setState(model, filtered, state, STEP_STATE)
    mujoco.mj_forward(model, filtered)
    with attach(model, data, mode="narrowphase"), attach(model, filtered, mode="filter"):
        return _per_pair_rounds(
            ours, theirs, filt, model._address, data._address, filtered._address, con, pairs, margins, touching, reps
        )


def _per_pair_rounds(ours, theirs, filt, m, d, df, con, pairs, margins, touching, reps):
    out = {}
    for name, sel in (("touching", touching), ("separated", ~touching)):
        p, mg = np.ascontiguousarray(pairs[sel]), np.ascontiguousarray(margins[sel])
        if len(p) == 0:
            out[name] = (np.nan, np.nan, np.nan, 0)
            continue
        runs = {
            "ellipsim": lambda: ours(m, d, con.ctypes.data, p, mg, reps),
            "mujoco": lambda: theirs(m, d, con.ctypes.data, p, mg, reps),
            "filter": lambda: filt(m, df, p, reps),
        }
        for fn in runs.values():
            fn()
        t = interleaved(runs, 5)
        out[name] = (*(np.min(t[k]) / (len(p) * reps) * 1e9 for k in runs), len(p))
    return out


def steps(model, data, state, size):
    """Per mode: median µs/step and (median, q1, q3) of the per-round speed-up over builtin, plus the
    counters per step of the last filter and narrowphase segments."""
    fns = {mode: step_segment(model, data, state, size["steps"], mode) for mode in STEP_MODES}
    for fn in fns.values():
        fn()  # compile the callbacks, warm the caches
    t = interleaved(fns, size["step_rounds"], self_timed=True)
    us = {mode: float(np.median(t[mode])) / size["steps"] * 1e6 for mode in STEP_MODES}
    speed = {}
    for mode in STEP_MODES[1:]:
        ratio = t["builtin"] / t[mode]
        speed[mode] = (relative(t, "builtin", mode), *np.percentile(ratio, [25, 75]))
    counters = {}
    for mode in STEP_MODES[1:]:
        mujoco.mj_setState(model, data, state, STEP_STATE)
        _, att = timed_steps(model, data, size["steps"], mode)
        counters[mode] = {k: v / size["steps"] for k, v in att.counters.items()}
    return us, speed, counters


def _deepest(model, data):
    """The deepest ellipsoid-ellipsoid crossing among data's contacts (-dist, m; 0 if none crosses)."""
    n = data.ncon
    ell = (model.geom_type[data.contact.geom[:n]] == ELL).all(axis=1) if n else np.zeros(0, bool)
    return max(0.0, -float(data.contact.dist[:n][ell].min())) if ell.any() else 0.0


def deepest_crossing(model, data, state, steps):
    """The deepest ellipsoid-ellipsoid crossing plain MuJoCo's contacts report (m): in `state`, and over
    `steps` plain mj_step calls from it (the builtin segment the speed-ups time)."""
    mujoco.mj_setState(model, data, state, STEP_STATE)
    mujoco.mj_forward(model, data)
    start = deepest = _deepest(model, data)
    for _ in range(steps):
        mujoco.mj_step(model, data)
        deepest = max(deepest, _deepest(model, data))
    return start, deepest


def contacts(model, data, state, nstep):
    """compare_narrowphase at MuJoCo's default ccd_tolerance and at 1e-10 (500 iterations)."""
    mujoco.mj_setState(model, data, state, STEP_STATE)
    default = compare_narrowphase(model, data, nstep)
    saved = model.opt.ccd_tolerance, model.opt.ccd_iterations
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-10, 500
    mujoco.mj_setState(model, data, state, STEP_STATE)
    tight = compare_narrowphase(model, data, nstep)
    model.opt.ccd_tolerance, model.opt.ccd_iterations = saved
    return default, tight


def deep_crossings(n_pairs, seed=0):
    """Random deep crossings of elongated ellipsoids: how often ellipsim's maximum falls short of the
    best of 300 projected-gradient starts (float), and how often its proof ran out of budget."""
    rng = np.random.default_rng(seed)
    i = np.arange(300) + 0.5
    phi, th = np.arccos(1 - 2 * i / 300), np.pi * (1 + 5**0.5) * i
    starts = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1)
    misses = unproven = tested = 0
    worst = 0.0
    while tested < n_pairs:
        ra, rb = rng.uniform(0.02, 0.06, 3), rng.uniform(0.02, 0.06, 3)
        ra[0], rb[0] = rng.uniform(0.15, 0.4), rng.uniform(0.15, 0.4)
        a = Ellipsoids.from_quaternions([0, 0, 0], rng.normal(size=4), ra)
        b = Ellipsoids.from_quaternions(rng.normal(size=3) * 0.04, rng.normal(size=4), rb)
        dist, _, _, status = signed_distance(a, b)
        if dist[0] >= 0:
            continue
        tested += 1
        unproven += status[0] == UNPROVEN
        d = b.centers[0] - a.centers[0]
        Ma, Mb = a.rotations[0] * ra**2 @ a.rotations[0].T, b.rotations[0] * rb**2 @ b.rotations[0].T
        n = starts.copy()
        step = 0.2 / np.sqrt(np.linalg.eigvalsh(Ma + Mb).max())
        for _ in range(600):
            ga, gb = n @ Ma, n @ Mb
            g = d - ga / np.sqrt(np.sum(n * ga, 1))[:, None] - gb / np.sqrt(np.sum(n * gb, 1))[:, None]
            n = n + step * (g - np.sum(g * n, 1)[:, None] * n)
            n /= np.linalg.norm(n, axis=1)[:, None]
        best = (n @ d - np.sqrt(np.sum(n * (n @ Ma), 1)) - np.sqrt(np.sum(n * (n @ Mb), 1))).max()
        short = best - dist[0]
        worst = max(worst, short)
        misses += short > 1e-9 * min(ra.min(), rb.min())
    return tested, unproven, misses, worst


def long_run(xml, seconds):
    """Plain and narrowphase runs of `seconds` simulated time from the same start."""
    rows = {}
    for mode in ("builtin", "narrowphase"):
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        nstep = int(seconds / model.opt.timestep)
        att = attach(model, data, mode="narrowphase") if mode == "narrowphase" else None
        energy, depth = [], 0.0
        with att or contextlib.nullcontext():
            t0 = time.perf_counter()
            for k in range(nstep):
                mujoco.mj_step(model, data)
                if k % 10 == 0:
                    mujoco.mj_energyPos(model, data)
                    mujoco.mj_energyVel(model, data)
                    energy.append(data.energy[1])
                    if data.ncon:
                        depth = max(depth, -data.contact.dist[: data.ncon].min())
            wall = time.perf_counter() - t0
        pos = data.xpos[1:]
        out = int(np.count_nonzero((np.abs(pos[:, :2]) > 5).any(axis=1) | (pos[:, 2] < -0.05)))
        last = np.array(energy[-max(1, int(len(energy) * 0.1)) :])
        rows[mode] = dict(
            kinetic_max=max(energy),
            kinetic_last=float(last.mean()),
            depth=depth,
            out=out,
            badqacc=int(data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number),
            wall=wall,
            fallbacks=att.counters["fallbacks"] if att else 0,
        )
    return rows


#: MuJoCo's timers of the breakdown, in mj_step's order (the rest of a step: kinematics, inertia,
#: velocity, actuation, integration)
TIMERS = {
    "step": mujoco.mjtTimer.mjTIMER_STEP,
    "broad": mujoco.mjtTimer.mjTIMER_COL_BROAD,
    "narrow": mujoco.mjtTimer.mjTIMER_COL_NARROW,
    "constraint": mujoco.mjtTimer.mjTIMER_CONSTRAINT,
}


def _clock():
    return time.perf_counter() * 1e6  # µs, as data.timer reads


@contextlib.contextmanager
def mujoco_timers():
    """MuJoCo's timers running for the block (mjcb_time: a clock in µs; ~32 calls per step, ~0.2 µs
    each, so the breakdown is timed apart from the speed-ups), the previous timer callback restored."""
    previous = mujoco.get_mjcb_time()
    mujoco.set_mjcb_time(_clock)
    try:
        yield
    finally:
        mujoco.set_mjcb_time(previous)


def _reset_timers(data):
    for k in range(int(mujoco.mjtTimer.mjNTIMER)):
        data.timer[k].duration = 0.0
        data.timer[k].number = 0


def _timed_segment(model, data, state, steps, mode):
    """{timer: µs per step} and contacts per step over `steps` mj_step calls from `state` (timers on)."""
    mujoco.mj_setState(model, data, state, STEP_STATE)
    contacts = 0
    with attach(model, data, mode=mode) if mode != "builtin" else contextlib.nullcontext():
        _reset_timers(data)
        for _ in range(steps):
            mujoco.mj_step(model, data)
            contacts += data.ncon
    out = {name: data.timer[int(k)].duration / steps for name, k in TIMERS.items()}
    out["contacts"] = contacts / steps
    return out


def breakdown(runs, steps, rounds):
    """{name: {timer: median µs per step, "contacts": per step}} of runs = {name: (model, data, state,
    mode)}, every run once per round in rotated order (as common.interleaved)."""
    names = list(runs)
    got = {name: [] for name in names}
    with mujoco_timers():
        for r in range(rounds):
            k = r % len(names)
            for name in names[k:] + names[:k]:
                got[name].append(_timed_segment(*runs[name][:3], steps, runs[name][3]))
    return {name: {key: float(np.median([g[key] for g in rows])) for key in rows[0]} for name, rows in got.items()}


def _noop_address():
    """A compiled narrow-phase function that makes no contact (ext.bench.NOOP)."""
    return ext.bench.NOOP


@contextlib.contextmanager
def _installed(address):
    """The function at `address` in every collision-table slot ellipsim's narrow phase takes (context.PAIR_TYPES):
    the no-op (_noop_address), or ellipsim's narrow phase with its contact dropped (ext.bench.DISCARD)."""
    table, ntypes = publish.collision_table()
    slots = [row.type1 * ntypes + row.type2 for row in PAIR_TYPES]
    saved = [table[k] for k in slots]
    for k in slots:
        table[k] = address
    try:
        yield
    finally:
        for k, v in zip(slots, saved, strict=True):
            table[k] = v


def in_situ(model, data, state, steps, rounds):
    """ns per ellipsim call inside mj_step: the states of a narrowphase segment from `state`, then per
    round each state in order set and mj_forward run twice, ellipsim attached and with the no-op in its
    slots, then with ellipsim's narrow phase dropping its contact (ext.bench.DISCARD); (narrow phase with
    ellipsim - with the no-op) / ellipsim's calls, median of the rounds.  Returns (ns per call, calls per step,
    no-op narrow phase µs per step, ns per call with the contact dropped: ellipsim's own work, without MuJoCo's
    on the contacts it returns)."""
    size = mujoco.mj_stateSize(model, STEP_STATE)
    states = np.empty((steps, size))
    mujoco.mj_setState(model, data, state, STEP_STATE)
    with attach(model, data, mode="narrowphase"):
        for i in range(steps):
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, states[i], STEP_STATE)
    k = int(mujoco.mjtTimer.mjTIMER_COL_NARROW)

    def narrow():
        total = 0.0
        for s in states:
            mujoco.mj_setState(model, data, s, STEP_STATE)
            data.timer[k].duration = 0.0
            mujoco.mj_forward(model, data)
            total += data.timer[k].duration
        return total / steps

    per_call, own, calls, noop = [], [], 0.0, []
    with mujoco_timers():
        for _ in range(rounds):
            with attach(model, data, mode="narrowphase") as att:
                ours = narrow()
                calls = att.counters["calls"] / steps
                with _installed(ext.bench.DISCARD):
                    dropped = narrow()
            with _installed(_noop_address()):
                none = narrow()
            noop.append(none)
            per_call.append((ours - none) / calls * 1e3 if calls else math.nan)
            own.append((dropped - none) / calls * 1e3 if calls else math.nan)
    return float(np.median(per_call)), calls, float(np.median(noop)), float(np.median(own))


def narrow_calls(model, data, state, steps):
    """Calls per step into MuJoCo's collision functions (every filled slot of mjCOLLISIONFUNC, whatever
    the pair type) over `steps` plain mj_step calls from `state`: each slot wrapped by a counting Python
    function that calls the one it replaces, restored after (a count: the wrapper's time is not measured)."""
    table, ntypes = publish.collision_table()
    calls, keep, saved = [0], [], {}

    def counting(original):
        def counted(m, d, con, g1, g2, margin):
            calls[0] += 1
            return original(m, d, con, g1, g2, margin)

        return _NARROW_FN(counted)

    try:
        for k in range(ntypes * ntypes):
            if table[k]:
                saved[k] = table[k]
                keep.append(counting(_NARROW_FN(table[k])))
                table[k] = ctypes.cast(keep[-1], ctypes.c_void_p).value
        mujoco.mj_setState(model, data, state, STEP_STATE)
        for _ in range(steps):
            mujoco.mj_step(model, data)
    finally:
        for k, v in saved.items():
            table[k] = v
    return calls[0] / steps


def timer_rounds(size):
    """Rounds of the timer breakdown and of in_situ (a quarter of the speed-ups' rounds, at least 3)."""
    return max(3, size["step_rounds"] // 4)


#: the twin's timer rows: each model from its own settled state, then from the other's (TWIN_SWAPPED)
TWIN_OWN = ("ellipsoids, narrowphase", "capsule twin, plain MuJoCo")
TWIN_SWAPPED = (
    "ellipsoids, narrowphase, from the twin's settled state",
    "capsule twin, plain MuJoCo, from the ellipsoids' settled state",
)


def capsule_twin(name, size):
    """A figure heap with ellipsoid limbs in narrowphase mode against its capsule twin (scenes.
    capsule_twin_xml) in plain MuJoCo, each settled from the same drop: (ellipsoid µs/step, capsule
    µs/step, median per-round ratio ellipsoid / capsule, breakdown, {run: narrow_calls in plain MuJoCo}).
    The breakdown and the calls also run each model from the other's settled state (TWIN_SWAPPED: the
    twin changes only geom types and masses, so the states fit both), which parts the narrow phases'
    difference into the heaps' states and the cost of the same contacts."""
    xml = SCENES[name][0]()
    ell = settled(xml, SCENES[name][1])
    cap = settled(scenes.capsule_twin_xml(xml), SCENES[name][1])
    if ell[2].shape != cap[2].shape:
        raise RuntimeError(f"{name}: the capsule twin's state does not fit the ellipsoid model's")
    fns = {
        "ellipsoids": step_segment(*ell, size["steps"], "narrowphase"),
        "capsules": step_segment(*cap, size["steps"], "builtin"),
    }
    for fn in fns.values():
        fn()
    t = interleaved(fns, size["step_rounds"], self_timed=True)
    us = {k: float(np.median(v)) / size["steps"] * 1e6 for k, v in t.items()}
    runs = {
        TWIN_OWN[0]: (*ell, "narrowphase"),
        TWIN_OWN[1]: (*cap, "builtin"),
        TWIN_SWAPPED[0]: (*ell[:2], cap[2], "narrowphase"),
        TWIN_SWAPPED[1]: (*cap[:2], ell[2], "builtin"),
    }
    timers = breakdown(runs, size["steps"], timer_rounds(size))
    calls = {k: narrow_calls(*run[:3], size["steps"]) for k, run in runs.items()}
    return us["ellipsoids"], us["capsules"], relative(t, "ellipsoids", "capsules"), timers, calls


def measure(size):
    names = size["scenes"] or tuple(SCENES)
    rows, compared, longs, timers, situ, depths = {}, {}, {}, {}, {}, {}
    for name in names:
        make, settle_steps = SCENES[name]
        say(f"inside MuJoCo: {name}: settle, mj_step in {size['step_rounds']} interleaved rounds ...")
        model, data, state = settled(make(), settle_steps)
        mujoco.mj_setState(model, data, state, STEP_STATE)
        mujoco.mj_forward(model, data)
        pp = per_pair(model, data)
        rows[name] = (model.ngeom, pp, *steps(model, data, state, size))
        depths[name] = deepest_crossing(model, data, state, size["steps"])
        say(f"inside MuJoCo: {name}: MuJoCo's timers per mode, ellipsim's calls in situ ...")
        timers[name] = breakdown(
            {mode: (model, data, state, mode) for mode in STEP_MODES}, size["steps"], timer_rounds(size)
        )
        situ[name] = in_situ(model, data, state, size["steps"], timer_rounds(size))
        if name in COMPARED:
            say(f"inside MuJoCo: {name}: contacts against MuJoCo's ...")
            compared[name] = contacts(model, data, state, size["compare_steps"])
    heap = "16 figures in a heap" if "16 figures in a heap" in names else "4 figures in a heap"
    say(f"inside MuJoCo: {heap} against its capsule twin ...")
    twin = (heap, *capsule_twin(heap, size))
    say("inside MuJoCo: deep crossings ...")
    deep = deep_crossings(size["deep_pairs"])
    say("inside MuJoCo: other pair types ...")
    types = pair_types.measure(size)
    for name in LONG_RUNS:
        if name in names:
            say(f"inside MuJoCo: long runs of {name} ...")
            longs[name] = long_run(SCENES[name][0](), size["long_seconds"])
    return rows, compared, deep, longs, twin, types, timers, situ, depths


def write(result, size, out, plt):
    """The section's markdown, and mujoco.png in `out`."""
    rows, compared, deep, longs, twin, types, timers, situ, depths = result
    _plot(plt, out, rows)
    L = [
        "## 5. Inside MuJoCo",
        "",
        "![inside MuJoCo](mujoco.png)",
        "",
        f"Each scene settled with plain MuJoCo; then {size['steps']} steps from that state per segment, builtin, "
        f"filter and narrowphase interleaved over {size['step_rounds']} rounds.  Speed-up = median per-round builtin "
        "time / mode time (interquartile range in brackets).",
        "",
        "| scene | geoms | builtin µs/step | filter µs/step | narrowphase µs/step | filter speed-up | narrowphase speed-up "
        "| candidate pairs/step | discarded/step | fallbacks/step |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, (ngeom, _pp, us, speed, counters) in rows.items():
        f, n = speed["filter"], speed["narrowphase"]
        L.append(
            f"| {name} | {ngeom} | {us['builtin']:.0f} | {us['filter']:.0f} | {us['narrowphase']:.0f} "
            f"| {f[0]:.2f} ({f[1]:.2f}-{f[2]:.2f}) | **{n[0]:.2f}** ({n[1]:.2f}-{n[2]:.2f}) "
            f"| {counters['filter']['seen']:.0f} | {counters['filter']['discarded']:.0f} | {counters['narrowphase']['fallbacks']:.2g} |"
        )
    L += [
        "",
        f"Deepest ellipsoid-ellipsoid crossing in plain MuJoCo (-dist of its own contacts): in the settled state the "
        f"segments start from, and over a builtin segment's {size['steps']} steps.",
        "",
        "| scene | deepest crossing at the start, mm | deepest within the segment, mm |",
        "|---|---:|---:|",
        *(f"| {name} | {a * 1e3:.2f} | {b * 1e3:.2f} |" for name, (a, b) in depths.items()),
    ]
    L += _write_timers(timers, situ, rows, twin, size)
    L += [
        "",
        "Cost per call: each function in a compiled loop over the ellipsoid-ellipsoid candidate pairs of the settled "
        "state (in brackets: how many), split by the exact relation; minimum of 5 interleaved rounds.",
        "",
        "| scene | ellipsim ns/touching pair | MuJoCo ns/touching pair | ellipsim ns/separated pair "
        "| MuJoCo ns/separated pair | filter ns/pair |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, (_ngeom, pp, *_rest) in rows.items():
        t, s = pp["touching"], pp["separated"]
        L.append(f"| {name} | {t[0]:.0f} ({t[3]}) | {t[1]:.0f} | {s[0]:.0f} ({s[3]}) | {s[1]:.0f} | {s[2]:.0f} |")
    touching = [pp["touching"][0] for _, pp, *_r in rows.values() if pp["touching"][3]]
    separated = [pp["separated"][0] for _, pp, *_r in rows.values() if pp["separated"][3]]
    L += [
        "",
        "Goals of issue 13, inside mj_step (per-pair rows: the largest over the scenes above):",
        "",
        "| goal | measured | met |",
        "|---|---:|---|",
        *(
            f"| <= {goal} ns per {kind} pair | {max(v):.0f} ns | {'yes' if max(v) <= goal else 'no'} |"
            for goal, kind, v in ((200, "penetrating (touching)", touching), (50, "separated", separated))
            if v
        ),
        f"| {twin[0]}, narrowphase, within 1.05x of its capsule twin in plain MuJoCo | {twin[1]:.0f} / {twin[2]:.0f} "
        f"µs/step: {twin[3]:.2f}x | {'yes' if twin[3] <= 1.05 else 'no'} |",
        f"| {twin[0]}, narrow phase inside mj_step within 1.2x of the capsule twin's (MuJoCo's timers) "
        f"| {_twin_narrow(twin)[0]:.0f} / {_twin_narrow(twin)[1]:.0f} µs/step: {_twin_narrow(twin)[2]:.2f}x "
        f"| {'yes' if _twin_narrow(twin)[2] <= 1.2 else 'no'} |",
        *(
            f"| {name} (box walls, or MuJoCo's mixed convex shapes) faster than builtin | narrowphase speed-up "
            f"{rows[name][3]['narrowphase'][0]:.2f} | {'yes' if rows[name][3]['narrowphase'][0] > 1 else 'no'} |"
            for name in rows
            if name.startswith("pile") or "mixed" in name
        ),
    ]
    L += [
        "",
        f"Contacts on the same states (`mujoco.compare_narrowphase` over {size['compare_steps']} steps from the settled "
        "state).  Bounds: same pairs in contact except |dist| < 2e-6, |Δdist| <= 2e-6, normal angle <= 1e-3 rad, "
        "position <= 1e-3 m.  A difference beyond them is refereed: sigma at each side's normal (the signed distance "
        "is the maximum of sigma), whether ellipsim's maximum is proven global, and for deep penetrations MuJoCo at "
        "ccd_tolerance 1e-11.",
        "",
        "| scene | MuJoCo ccd_tolerance | contacts compared | max Δdist | max angle rad | max Δpos "
        "| beyond bounds | ellipsim right | MuJoCo right | undetermined |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, (default, tight) in compared.items():
        for label, c in (("1e-6 (default)", default), ("1e-10", tight)):
            right = [d.right for d in c.differences]
            L.append(
                f"| {name} | {label} | {c.matched} | {c.max_ddist:.1e} | {c.max_angle:.1e} | {c.max_dpos:.1e} "
                f"| {len(c.differences)} | {right.count('ellipsim')} | {right.count('mujoco')} | {right.count('undetermined')} |"
            )
    tested, unproven, misses, worst = deep
    L += [
        "",
        f"Deep crossings: {tested} random penetrating pairs of elongated ellipsoids (long semi-axis 0.15-0.4, others "
        f"0.02-0.06, centres within ~7 cm): the proof of the global maximum ran out of budget on {unproven}; ellipsim's "
        f"maximum fell short of the best of 300 gradient-ascent starts by more than 1e-9 r_min in **{misses}** "
        f"(largest shortfall {max(worst, 0.0):.1e}).",
        *pair_types.write(types),
        "",
    ]
    if longs:
        L += [
            f"Long runs: {size['long_seconds']:g} s of simulated time from the initial drop, plain and with the narrow "
            "phase (trajectories differ: the contacts differ by MuJoCo's tolerance).",
            "",
            "| scene | mode | max kinetic J | mean kinetic J, last 10% | deepest penetration m | bodies out "
            "| bad-acceleration warnings | fallbacks | wall s |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for name, modes in longs.items():
            for mode, r in modes.items():
                L.append(
                    f"| {name} | {mode} | {r['kinetic_max']:.3g} | {r['kinetic_last']:.3g} | {r['depth']:.2g} "
                    f"| {r['out']} | {r['badqacc']} | {r['fallbacks']} | {r['wall']:.1f} |"
                )
        L.append("")
    return L


def _twin_narrow(twin):
    """(ellipsoids' narrow µs/step, the capsule twin's, their ratio) from the twin's timers."""
    t = twin[4]
    ours, theirs = t[TWIN_OWN[0]]["narrow"], t[TWIN_OWN[1]]["narrow"]
    return ours, theirs, ours / theirs


def _twin_same_state(twin):
    """{whose settled state: (ellipsoids' narrow µs/step, the twin's, their ratio, the ellipsoid model's
    calls/step, the twin's)} from the same states (capsule_twin)."""
    t, calls = twin[4], twin[5]
    pairs = {"the ellipsoids'": (TWIN_OWN[0], TWIN_SWAPPED[1]), "the twin's": (TWIN_SWAPPED[0], TWIN_OWN[1])}
    out = {}
    for state, (a, b) in pairs.items():
        ours, theirs = t[a]["narrow"], t[b]["narrow"]
        out[state] = (ours, theirs, ours / theirs, calls[a], calls[b])
    return out


def _write_timers(timers, situ, rows, twin, size):
    """The timer breakdown and the in-situ cost per call (markdown lines)."""
    rounds = timer_rounds(size)
    L = [
        "",
        f"Where mj_step's time goes: MuJoCo's own timers (`mjcb_time` set to a µs clock), µs per step, median of "
        f"{rounds} interleaved rounds of {size['steps']} steps from the settled state (timed apart from the speed-ups "
        "above: the clock is called ~32 times a step).  Other: kinematics, inertia, making the constraints, velocity, "
        "actuation, integration.",
        "",
        "| scene | mode | mj_step | broad phase | narrow phase | constraint solver | other | contacts/step |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    named = dict(timers)
    named[f"{twin[0]}: capsule twin"] = twin[4]
    for name, modes in named.items():
        for mode, t in modes.items():
            other = t["step"] - t["broad"] - t["narrow"] - t["constraint"]
            L.append(
                f"| {name} | {mode} | {t['step']:.0f} | {t['broad']:.0f} | {t['narrow']:.0f} | {t['constraint']:.0f} "
                f"| {other:.0f} | {t['contacts']:.0f} |"
            )
    L += [
        "",
        f"Calls into MuJoCo's collision functions per step in plain MuJoCo (every pair type, {size['steps']} steps "
        f"from the settled state): {twin[0]} {twin[5][TWIN_OWN[0]]:.0f}, its capsule twin {twin[5][TWIN_OWN[1]]:.0f}.",
        "",
        f"The same comparison from the same state (each model's {size['steps']} steps from the ellipsoids' and from "
        "the twin's settled state, the rows above): what the narrow phases' ratio owes to the heaps settling "
        "differently, and what to the cost of the same contacts.",
        "",
        "| from the settled state of | ellipsim's narrow phase µs/step | the twin's µs/step | ratio "
        "| calls/step, ellipsoid model | calls/step, twin |",
        "|---|---:|---:|---:|---:|---:|",
        *(
            f"| {state} | {a:.0f} | {b:.0f} | {r:.2f}x | {ca:.0f} | {cb:.0f} |"
            for state, (a, b, r, ca, cb) in _twin_same_state(twin).items()
        ),
    ]
    L += [
        "",
        "ellipsim's calls inside mj_step: the states of a narrowphase segment, each set and run through mj_forward with "
        "ellipsim attached and with a no-op function (no contact) in the same collision-table slots; in-situ cost = "
        "(narrow phase with ellipsim - with the no-op) / ellipsim's calls, median of "
        f"{rounds} rounds; it includes MuJoCo's own work on each contact ellipsim makes (the no-op makes none).  "
        "Contact dropped: the same calls returning no contact, ellipsim's own cost in mj_step (the kernels from the "
        "previous step's warm start, the glue, the caches MuJoCo leaves).  The compiled loop's cost (table below, "
        "ellipsoid pairs only, warm-started at the same state) weighted by its touching and separated pairs, for "
        "comparison.",
        "",
        "| scene | ellipsim calls/step | in-situ ns/call | contact dropped, ns/call | compiled loop ns/call "
        "| narrow phase with the no-op µs/step |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, (ns, calls, noop, own) in situ.items():
        t, s = rows[name][1]["touching"], rows[name][1]["separated"]
        npairs = t[3] + s[3]
        loop = (np.nan_to_num(t[0]) * t[3] + np.nan_to_num(s[0]) * s[3]) / npairs if npairs else np.nan
        L.append(f"| {name} | {calls:.0f} | {ns:.0f} | {own:.0f} | {loop:.0f} | {noop:.0f} |")
    return L


def _plot(plt, out, rows):
    names = list(rows)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 4.5), constrained_layout=True)
    x = np.arange(len(names))
    for k, mode in enumerate(STEP_MODES[1:]):
        med = np.array([rows[n][3][mode][0] for n in names])
        err = np.array([[med[i] - rows[n][3][mode][1], rows[n][3][mode][2] - med[i]] for i, n in enumerate(names)]).T
        a1.bar(x + (k - 0.5) * 0.35, med, 0.35, yerr=err, label=mode, color=f"C{k + 1}")
    a1.axhline(1.0, color="grey", lw=0.8)
    a1.set_xticks(x, names, rotation=20, ha="right", fontsize=8)
    a1.set(ylabel="mj_step speed-up over builtin", title="mj_step: speed-up per scene (IQR)")
    a1.legend(fontsize=8)
    shown = []
    for k, (label, j, kind) in enumerate(
        (
            ("ellipsim, touching", 0, "touching"),
            ("MuJoCo, touching", 1, "touching"),
            ("ellipsim, separated", 0, "separated"),
            ("MuJoCo, separated", 1, "separated"),
        )
    ):
        ns = [rows[n][1][kind][j] for n in names]  # nan where a scene has no such pair
        shown += ns
        a2.bar(x + (k - 1.5) * 0.2, ns, 0.2, label=label, color=f"C{k}")
    a2.set_xticks(x, names, rotation=20, ha="right", fontsize=8)
    a2.set(ylabel="ns per call", title="cost per ellipsoid pair")
    if np.nanmax(np.asarray(shown + [0.0])) > 0:
        a2.set_yscale("log")
    a2.legend(fontsize=8)
    fig.savefig(os.path.join(out, "mujoco.png"), dpi=110)
    plt.close(fig)
