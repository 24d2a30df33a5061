"""ellipsim's narrow phase against MuJoCo's GJK/EPA: time per pair, mj_step, accuracy, long runs.

    python bench/bench_narrowphase.py [--rounds 30] [--out bench/results/narrowphase.md]

1. Cost per pair: both mjfCollision functions (ellipsim's cfunc and MuJoCo's original from
   mjCOLLISIONFUNC) called in a compiled loop over the ellipsoid pairs MuJoCo's broad phase produced
   at a settled state, split by the exact relation (touching or overlapping / separated).
2. mj_step, plain and with attach(mode="narrowphase"), in paired segments from one settled state.
3. Contacts on the same states: plugin.compare_narrowphase against MuJoCo at its default
   ccd_tolerance (1e-6) and at 1e-10.
4. Global optimum: random deep penetrations of elongated ellipsoids, ellipsim against the best of
   300 gradient-ascent starts.
5. Long runs: 10 s of simulated time plain and with the narrow phase; kinetic energy, deepest
   penetration, bodies leaving the scene.
"""

import argparse
import contextlib
import datetime
import os
import sys
import time

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from bench_plugin import _NARROW_FN, _loop_narrow  # noqa: E402

from ellipsim import Ellipsoids, classify, figures, mjstruct, plugin, signed_distance  # noqa: E402
from ellipsim.bench import machine_description, publish, timed_steps  # noqa: E402
from ellipsim.narrowphase import MULTISTART  # noqa: E402

SCENES = {
    "pile of 40 ellipsoids": (lambda: figures.pile_xml(40, seed=1), 1500),
    "pile of 100 ellipsoids": (lambda: figures.pile_xml(100, seed=1), 1500),
    "4 figures in a heap": (lambda: figures.scene_xml(4, layout="pile", seed=1), 1000),
    "16 figures in a heap": (lambda: figures.scene_xml(16, layout="pile", seed=1), 1000),
}
SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
ELL = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)


def settle(make, steps):
    model = mujoco.MjModel.from_xml_string(make())
    data = mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    state = np.empty(mujoco.mj_stateSize(model, SPEC))
    mujoco.mj_getState(model, data, state, SPEC)
    return model, data, state


def per_pair(model, data, reps=100):
    """ns per call of ellipsim's and MuJoCo's function on the touching and the separated pairs."""
    table, n = mjstruct.collision_table()
    theirs = _loop_narrow(_NARROW_FN(table[ELL * n + ELL]))
    ours = _loop_narrow(_NARROW_FN(plugin.narrowphase_function().address))
    pairs = plugin.candidate_pairs(model, data)
    pairs = np.ascontiguousarray(pairs[(model.geom_type[pairs] == ELL).all(axis=1)])
    geoms = lambda g: Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(-1, 3, 3), model.geom_size[g])  # noqa: E731
    touching = classify(geoms(pairs[:, 0]), geoms(pairs[:, 1])) != 0
    margins = model.geom_margin[pairs].sum(axis=1) + model.geom_gap[pairs].sum(axis=1)
    con = np.zeros(640)
    out = {}
    for name, sel in (("touching", touching), ("separated", ~touching)):
        p, mg = np.ascontiguousarray(pairs[sel]), np.ascontiguousarray(margins[sel])
        if len(p) == 0:
            out[name] = (np.nan, np.nan, 0)
            continue
        best = [np.inf, np.inf]
        for fn, k in ((ours, 0), (theirs, 1)):
            fn(model._address, data._address, con.ctypes.data, p[:1], mg[:1], 1)
            for _ in range(5):
                t0 = time.perf_counter()
                fn(model._address, data._address, con.ctypes.data, p, mg, reps)
                best[k] = min(best[k], time.perf_counter() - t0)
        out[name] = (best[0] / (len(p) * reps) * 1e9, best[1] / (len(p) * reps) * 1e9, len(p))
    return out


def paired_steps(model, data, state, rounds, steps=100):
    """Median plain and narrowphase seconds per step, and the median per-round speed-up."""
    plain, ours = [], []
    for r in range(rounds):
        for narrow in (r % 2 == 0, r % 2 == 1):
            mujoco.mj_setState(model, data, state, SPEC)
            seconds, _ = timed_steps(model, data, steps, "narrowphase" if narrow else "builtin")
            (ours if narrow else plain).append(seconds)
    plain, ours = np.array(plain), np.array(ours)
    speedup = plain / ours
    return np.median(plain) / steps, np.median(ours) / steps, np.median(speedup), np.percentile(speedup, [25, 75])


def contacts(model, data, state, nstep=30):
    mujoco.mj_setState(model, data, state, SPEC)
    default = plugin.compare_narrowphase(model, data, nstep)
    saved = model.opt.ccd_tolerance, model.opt.ccd_iterations
    model.opt.ccd_tolerance, model.opt.ccd_iterations = 1e-10, 500
    mujoco.mj_setState(model, data, state, SPEC)
    tight = plugin.compare_narrowphase(model, data, nstep)
    model.opt.ccd_tolerance, model.opt.ccd_iterations = saved
    return default, tight


def global_optimum(n_pairs, seed=0):
    """Random deep crossings of elongated ellipsoids: how often ellipsim's maximum falls short of the
    best of 300 projected-gradient starts (float), and how often it needed the multi-start."""
    rng = np.random.default_rng(seed)
    i = np.arange(300) + 0.5
    phi, th = np.arccos(1 - 2 * i / 300), np.pi * (1 + 5**0.5) * i
    starts = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1)
    misses = multistart = tested = 0
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
        multistart += status[0] == MULTISTART
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
    return tested, multistart, misses, worst


def long_run(make, seconds):
    """Plain and narrowphase runs of `seconds` simulated time from the same start."""
    rows = {}
    for mode in ("plain", "narrowphase"):
        model = mujoco.MjModel.from_xml_string(make())
        data = mujoco.MjData(model)
        steps = int(seconds / model.opt.timestep)
        att = plugin.attach(model, data, mode="narrowphase") if mode == "narrowphase" else None
        energy, depth = [], 0.0
        with att or contextlib.nullcontext():
            t0 = time.perf_counter()
            for k in range(steps):
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
        last = np.array(energy[-int(len(energy) * 0.1):])
        rows[mode] = dict(
            kinetic_max=max(energy), kinetic_last=float(last.mean()), depth=depth, out=out,
            badqacc=int(data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number), wall=wall,
            fallbacks=att.counters["fallbacks"] if att else 0,
        )  # fmt: skip
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=30, help="paired mj_step segments per scene")
    p.add_argument("--pairs", type=int, default=2000, help="random deep pairs for the global-optimum check")
    p.add_argument("--seconds", type=float, default=10.0, help="simulated seconds of the long runs")
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    t_start = time.perf_counter()
    plugin.narrowphase_function()
    lines = [
        "# ellipsim's narrow phase against MuJoCo's GJK/EPA",
        "",
        f"`python bench/bench_narrowphase.py --rounds {args.rounds} --pairs {args.pairs} --seconds {args.seconds:g}`, "
        f"{datetime.date.today()}, {machine_description()}.",
        "",
        "## Time per pair and per step",
        "",
        "Both mjfCollision functions called in a compiled loop over the ellipsoid pairs of a settled state "
        "(in brackets: how many); mj_step in paired segments of 100 steps from that state, median speed-up "
        "plain / narrowphase with its interquartile range.",
        "",
        "| scene | ellipsim ns/touching pair | MuJoCo ns/touching pair | ellipsim ns/separated pair "
        "| MuJoCo ns/separated pair | plain µs/step | narrowphase µs/step | mj_step speed-up |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    comparisons, scenes = {}, {}
    for name, (make, settle_steps) in SCENES.items():
        print(f"{name} ...", file=sys.stderr, flush=True)
        model, data, state = settle(make, settle_steps)
        mujoco.mj_setState(model, data, state, SPEC)
        mujoco.mj_forward(model, data)
        pp = per_pair(model, data)
        t_plain, t_ours, speed, (q1, q3) = paired_steps(model, data, state, args.rounds)
        scenes[name] = (pp, speed)
        lines.append(
            f"| {name} | {pp['touching'][0]:.0f} ({pp['touching'][2]}) | {pp['touching'][1]:.0f} "
            f"| {pp['separated'][0]:.0f} ({pp['separated'][2]}) | {pp['separated'][1]:.0f} "
            f"| {t_plain * 1e6:.0f} | {t_ours * 1e6:.0f} | **{speed:.2f}x** ({q1:.2f}-{q3:.2f}) |"
        )
        comparisons[name] = contacts(model, data, state)
    lines += [
        "",
        "## Contacts on the same states",
        "",
        "`plugin.compare_narrowphase` over 30 steps from the settled state.  Bounds (issue 4): same pairs in "
        "contact except |dist| < 2e-6, |Δdist| <= 2e-6, normal angle <= 1e-3 rad, position <= 1e-3 m.  "
        "A difference beyond them is refereed: sigma at each side's normal (the signed distance is the "
        "maximum of sigma), ellipsim's certificate, and for deep penetrations MuJoCo at ccd_tolerance 1e-11.",
        "",
        "| scene | MuJoCo ccd_tolerance | contacts compared | max Δdist | max angle rad | max Δpos "
        "| beyond bounds | ellipsim right | MuJoCo right | undetermined |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, (default, tight) in comparisons.items():
        for label, c in (("1e-6 (default)", default), ("1e-10", tight)):
            right = [d.right for d in c.differences]
            lines.append(
                f"| {name} | {label} | {c.matched} | {c.max_ddist:.1e} | {c.max_angle:.1e} | {c.max_dpos:.1e} "
                f"| {len(c.differences)} | {right.count('ellipsim')} | {right.count('mujoco')} "
                f"| {right.count('undetermined')} |"
            )
    print("global optimum ...", file=sys.stderr, flush=True)
    tested, multistart, misses, worst = global_optimum(args.pairs)
    lines += [
        "",
        "At the default tolerance the largest angles (up to radians) are contacts within ~1e-7 of touching, "
        "where EPA returns an arbitrary normal: sigma along it implies a depth of centimetres.",
        "",
        "## Global optimum on deep crossings",
        "",
        f"{tested} random penetrating pairs of elongated ellipsoids (long semi-axis 0.15-0.4, others 0.02-0.06, "
        f"centres within ~7 cm): {multistart} needed the multi-start (depth beyond the rolling-radius "
        f"certificate); ellipsim's maximum fell short of the best of 300 gradient-ascent starts by more than "
        f"1e-9 r_min in **{misses}** (largest shortfall {max(worst, 0.0):.1e}).",
        "",
        "## Long runs",
        "",
        f"{args.seconds:g} s of simulated time from the initial drop, plain and with the narrow phase (trajectories "
        "differ: the contacts differ by MuJoCo's tolerance).",
        "",
        "| scene | mode | max kinetic J | mean kinetic J, last 10% | deepest penetration m | bodies out "
        "| bad-acceleration warnings | fallbacks | wall s |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name in ("pile of 40 ellipsoids", "16 figures in a heap"):
        print(f"long run {name} ...", file=sys.stderr, flush=True)
        for mode, r in long_run(SCENES[name][0], args.seconds).items():
            lines.append(
                f"| {name} | {mode} | {r['kinetic_max']:.3g} | {r['kinetic_last']:.3g} | {r['depth']:.2g} "
                f"| {r['out']} | {r['badqacc']} | {r['fallbacks']} | {r['wall']:.1f} |"
            )
    touching = [pp["touching"][0] for pp, _ in scenes.values()]
    speeds = {k: s for k, (_, s) in scenes.items()}
    lines += [
        "",
        "## Targets (issue 4)",
        "",
        f"- <= 0.4 µs per penetrating pair: {min(touching):.0f}-{max(touching):.0f} ns "
        f"({'met' if max(touching) <= 400 else 'not met'}).",
        f"- mj_step >= 1.15x faster on a pile of >= 40 ellipsoids and on 16 figures in a heap: "
        f"{speeds['pile of 40 ellipsoids']:.2f}x, {speeds['16 figures in a heap']:.2f}x "
        f"({'met' if min(speeds['pile of 40 ellipsoids'], speeds['16 figures in a heap']) >= 1.15 else 'not met'}).",
        "",
        f"Run time {time.perf_counter() - t_start:.0f} s.",
    ]
    text = "\n".join(lines) + "\n"
    publish(text, args.out)


if __name__ == "__main__":
    main()
