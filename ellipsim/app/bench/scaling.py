"""Section 3: scaling with batch size (classify) and with the number of figures (kinematic replay)."""

import math
import os
import time

import mujoco
import numpy as np

from ...core.distance.ellipsoid_pair import signed_distance
from ...core.ellipsoids import Ellipsoids
from ...core.exact.classify import classify, classify_pairs
from ...core.motion import time_of_impact as toi
from ...core.samples import generic_pairs
from ...core.tolerances import NEWTON_MAX_ITER
from ...mujoco.geoms import ellipsoid_geoms, frame_pairs
from ...native import ext
from .. import scenario, simulate
from .common import float_runner, interleaved, relative, say


def measure(size):
    """Batch rows (pairs, exact 1 thread, exact 2 threads, plain descartes: ns/pair) and replay rows
    (figures, frames, ms/frame total, ms/frame in the mj_forward loop, overlapping pairs)."""
    say("scaling: batch sizes ...")
    a, b = generic_pairs(size["batch_max"], seed=3)
    batches = [int(x) for x in 10.0 ** np.arange(0, int(math.log10(size["batch_max"])) + 1)]
    batch_rows = []
    for n in batches:
        x, y = a[:n], b[:n]
        fns = {
            "serial": lambda: classify(x, y, parallel=False),
            "parallel": lambda: classify(x, y, parallel=True),
            "plain": float_runner(x, y, "descartes", "rearranged", "float64"),
        }
        for fn in fns.values():
            fn()  # compile and warm
        t = interleaved(fns, max(3, min(size["rounds"], 200_000 // n)))
        batch_rows.append((n, *(np.median(t[k]) / n * 1e9 for k in fns)))
    replay_rows = []
    base = scenario.load("replay")
    for nf in size["replay_figures"]:
        say(f"scaling: kinematic replay with {nf} figures ...")
        # figure i starts `stagger` s late; shrink it so that every figure dances within the routine
        stagger = min(base.control["stagger"], base.duration / nf)
        s = scenario.Scenario(
            **{**base.__dict__, "scene": {**base.scene, "figures": nf}, "control": {**base.control, "stagger": stagger}}
        )
        simulate.run(s, steps=5)  # compile and warm
        t0 = time.perf_counter()
        run = simulate.run(s)
        total = time.perf_counter() - t0
        replay_rows.append(
            (
                nf,
                run.steps,
                total / run.steps * 1e3,
                run.seconds / run.steps * 1e3,
                int(run.frames.ellipsim_counts.sum()),
            )
        )
    nf = size["replay_figures"][-1]
    say(f"scaling: {nf} figures, ellipsim's frames against mj_kinematics + mj_collision ...")
    goal = (nf, *kinematic_goal(_replay_scenario(base, nf), size["rounds"]))
    say("scaling: one pair per call ...")
    return batch_rows, replay_rows, goal, one_pair_calls(size["rounds"])


#: Calls per timed round of one_pair_calls (a round times a loop: one call is near the timer's resolution).
ONE_PAIR_CALLS = 2_000


def one_pair_calls(rounds):
    """{function: (kernel µs, public call µs)} for one generic pair per call: classify, signed_distance
    and time_of_impact from Python with pre-built Ellipsoids, against their batch kernel called
    directly on the pair with its outputs allocated and its checks done beforehand (the compiled
    module's dispatch of the arrays included: what any call from Python pays).  Minimum over
    interleaved rounds."""
    a, b = generic_pairs(2, seed=3)
    x, y = a[:1], b[:1]
    x1 = Ellipsoids(x.centers + 0.3, x.rotations, x.radii)
    y1 = Ellipsoids(y.centers - 0.3, y.rotations, y.radii)
    arrays = (x.centers, x.rotations, x.radii, y.centers, y.rotations, y.radii)
    code = np.empty(1, dtype=np.int8)
    dist, normal, pos, status = np.empty(1), np.empty((1, 3)), np.empty((1, 3)), np.empty(1, dtype=np.int8)
    motion, _ = toi._check(x, x1, y, y1)
    oracle = (
        np.zeros((1, toi.TOI_MAX_ORACLE)),
        np.zeros((1, toi.TOI_MAX_ORACLE), dtype=np.int8),
        np.zeros(1, np.int64),
    )
    t, st, t_exact, steps, idx = np.empty(1), np.empty(1, np.int8), np.empty(1), np.empty(1, np.int64), np.arange(1)
    one = {
        "classify": (lambda: ext.certify(*arrays, code, 0, 1), lambda: classify(x, y)),
        "signed_distance": (
            lambda: ext.signed_distances(*arrays, NEWTON_MAX_ITER, dist, normal, pos, status, 0, 1),
            lambda: signed_distance(x, y),
        ),
        "time_of_impact": (
            lambda: ext.toi(*motion, idx, *oracle, t, st, t_exact, steps, 0, 1),
            lambda: toi.time_of_impact(x, x1, y, y1),
        ),
    }

    def looped(fn):
        def run():
            for _ in range(ONE_PAIR_CALLS):
                fn()

        return run

    fns = {f"{name} {k}": looped(f) for name, pair in one.items() for k, f in zip(("kernel", "call"), pair)}
    for fn in fns.values():
        fn()  # compile and warm
    t = interleaved(fns, max(5, rounds))
    best = {k: float(np.min(v)) / ONE_PAIR_CALLS * 1e6 for k, v in t.items()}
    return {name: (best[f"{name} kernel"], best[f"{name} call"]) for name in one}


def _replay_scenario(base, nf):
    """The replay scenario with nf figures in a line, all dancing within the routine."""
    stagger = min(base.control["stagger"], base.duration / nf)
    return scenario.Scenario(
        **{**base.__dict__, "scene": {**base.scene, "figures": nf}, "control": {**base.control, "stagger": stagger}}
    )


def kinematic_goal(s, rounds):
    """Issue 13's replay goal on scenario s's frames: per frame, MuJoCo's check (mj_kinematics +
    mj_collision) against ellipsim's (mj_kinematics, the poses copied out, then one broad phase and
    one exact classify_pairs of all frames' candidate pairs), in interleaved rounds.  (frames, MuJoCo
    ms/frame, ellipsim ms/frame, median per-round ratio ellipsim / MuJoCo, ellipsim's candidate pairs)."""
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    steps = int(round(s.duration / s.timestep))
    poses = np.array([control(k * s.timestep) for k in range(steps)])
    ids, radii, rules = ellipsoid_geoms(model)
    centers, rotations = np.empty((steps, len(ids), 3)), np.empty((steps, len(ids), 3, 3))
    found = []

    def mujoco_check():
        for k in range(steps):
            data.qpos[control.qadr] = poses[k]
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)

    def ellipsim_check():
        for k in range(steps):
            data.qpos[control.qadr] = poses[k]
            mujoco.mj_kinematics(model, data)
            centers[k] = data.geom_xpos[ids]
            rotations[k] = data.geom_xmat[ids].reshape(-1, 3, 3)
        pairs = frame_pairs(centers, radii, rules)
        g = len(ids)
        every = Ellipsoids(
            centers.reshape(-1, 3), rotations.reshape(-1, 3, 3), np.tile(radii, (steps, 1))
        )  # validated once
        rel = classify_pairs(every, pairs[:, 0] * g + pairs[:, 1], pairs[:, 0] * g + pairs[:, 2])
        found[:] = [len(pairs), int(np.count_nonzero(rel))]

    fns = {"mujoco": mujoco_check, "ellipsim": ellipsim_check}
    for fn in fns.values():
        fn()
    t = interleaved(fns, max(3, rounds // 3))
    return (
        steps,
        np.median(t["mujoco"]) / steps * 1e3,
        np.median(t["ellipsim"]) / steps * 1e3,
        relative(t, "ellipsim", "mujoco"),
        *found,
    )


def write(result, size, out, plt):
    """The section's markdown, and scaling.png in `out`."""
    batch_rows, replay_rows, goal, one_pair = result
    _plot(plt, out, batch_rows, replay_rows)
    L = [
        "## 3. Scaling",
        "",
        "![scaling](scaling.png)",
        "",
        "Batches of generic pairs; the three functions timed in the same interleaved rounds.  Below ~10 pairs a "
        "call's Python overhead (input checks, the compiled module's dispatch) dominates: batch your pairs.",
        "",
        "| pairs per call | exact, ns/pair | exact, 2 threads | plain descartes, ns/pair |",
        "|---:|---:|---:|---:|",
    ]
    L += [f"| {n} | {s:.0f} | {p:.0f} | {q:.0f} |" for n, s, p, q in batch_rows]
    L += [
        "",
        "One generic pair per call from Python, pre-built Ellipsoids: each public function against its batch kernel "
        "called directly on the pair (outputs allocated and checks done beforehand; the compiled module's dispatch "
        f"of the arrays included), loops of {ONE_PAIR_CALLS} calls in interleaved rounds, the fastest round.  "
        "Issue 20's goal: a call within 1.5 µs of its kernel.",
        "",
        "| one pair per call | kernel, µs | public call, µs | overhead, µs | goal: <= 1.5 |",
        "|---|---:|---:|---:|---|",
    ]
    L += [
        f"| {name} | {k:.2f} | {c:.2f} | {c - k:.2f} | {'met' if c - k <= 1.5 else 'not met'} |"
        for name, (k, c) in one_pair.items()
    ]
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
    nf, frames, ms_mj, ms_el, ratio, pairs, contacts = goal
    L += [
        "",
        f"Issue 13's replay goal, {nf} figures, {frames} frames: ellipsim's check of every frame (mj_kinematics, the "
        "ellipsoid poses copied out and validated as one batch, one sweep-and-prune over all frames, one exact classify_pairs of all their "
        f"candidate pairs: {pairs} pairs, {contacts} touching or overlapping) against MuJoCo's (mj_kinematics + "
        "mj_collision per frame), interleaved rounds; classify_pairs runs on 2 threads from 10^4 pairs.",
        "",
        "| MuJoCo ms/frame | ellipsim ms/frame | ellipsim / MuJoCo | goal: <= 0.5 |",
        "|---:|---:|---:|---|",
        f"| {ms_mj:.3f} | {ms_el:.3f} | {ratio:.2f} | {'met' if ratio <= 0.5 else 'not met'} |",
        "",
    ]
    return L


def _plot(plt, out, batch_rows, replay_rows):
    fig, (a1, a3) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    b = np.array(batch_rows, dtype=float)
    a1.plot(b[:, 0], b[:, 1], "o-", label="exact, 1 thread")
    a1.plot(b[:, 0], b[:, 2], "o-", label="exact, 2 threads")
    a1.plot(b[:, 0], b[:, 3], "o--", label="plain descartes, 1 thread")
    a1.set(
        xscale="log", yscale="log", xlabel="pairs per call", ylabel="time per pair [ns]", title="classify: batch size"
    )
    a1.legend(fontsize=8)
    r = np.array(replay_rows, dtype=float)
    a3.plot(r[:, 0], r[:, 2], "o-", label="total")
    a3.plot(r[:, 0], r[:, 3], "o--", label="of which mj_forward loop")
    a3.legend(fontsize=8)
    a3.set(xscale="log", yscale="log", xlabel="figures", ylabel="time per frame [ms]", title="kinematic replay")
    fig.savefig(os.path.join(out, "scaling.png"), dpi=110)
    plt.close(fig)
