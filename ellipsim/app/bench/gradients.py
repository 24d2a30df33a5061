"""Section 10: exact derivatives and `ellipsim fix`.

Derivatives: signed_distance with derivatives=True (d dist, d normal, d pos with respect to both poses and
semi-axes) against the distance alone on the same random pairs, shape_distance the same for an ellipsoid
against a capsule, box or cylinder, and time_of_impact with the derivatives of
its first contact against time_of_impact alone on approaching, turning pairs; single-threaded, this
thread's CPU time, interleaved rounds, medians of per-round ratios.

fix: fix.fix_motion on the replay scenario's dance (4 figures, 200 frames) and on the same routine danced by
64 figures in a line (a generated 64-figure motion), clearance 0 and 5 mm, mass metric, smooth 4:
frames per second, the change (sum over frames of sqrt(d' M d)), pairs closer than the clearance before,
pair-frames not freed, and the corrected motion checked again (every frame's closest pair, proven; contacts
between frames by time_of_impact, replay.replay).
"""

import time

import numpy as np

from ...core.distance.ellipsoid_pair import signed_distance
from ...core.ellipsoids import Ellipsoids
from ...core.motion.time_of_impact import time_of_impact
from ...core.pairs.shape_distance import shape_distance
from ...core.samples import generic_pairs
from .common import interleaved, relative, say


def _cpu(fn):
    def run():
        t0 = time.thread_time()
        fn()
        return time.thread_time() - t0

    return run


def approaching(rng, n):
    """n pairs approaching head on while turning (A near the origin, B 2 m along x crossing back)."""
    from scipy.spatial.transform import Rotation

    def body(centers):
        q = rng.normal(size=(n, 4))
        return Ellipsoids.from_quaternions(centers, q, rng.uniform(0.1, 0.5, (n, 3)))

    def moved(E, step, turn):
        R = Rotation.from_rotvec(rng.normal(size=(n, 3)) * turn).as_matrix() @ E.rotations
        return Ellipsoids(E.centers + step, R, E.radii)

    a0 = body(rng.uniform(-0.2, 0.2, (n, 3)))
    b0 = body(a0.centers + [2.0, 0.0, 0.0])
    return (
        a0,
        moved(a0, rng.normal(size=(n, 3)) * 0.3, 0.8),
        b0,
        moved(b0, rng.normal(size=(n, 3)) * 0.3 - [2, 0, 0], 0.8),
    )


def dance(figures):
    """(model, motion (200, nq)): the replay scenario's key-framed dance danced by `figures` figures."""
    from .. import scenario, simulate

    path = scenario.resolve("replay")
    table = scenario.read_table(path)
    table["scene"]["figures"] = figures
    s = scenario.from_table(table, path)
    model, data = simulate.build(s)
    control = simulate.controller(model, data, s)
    motion = np.repeat(data.qpos[None], s.steps, 0)
    for k in range(s.steps):
        motion[k, control.qadr] = control(k * s.timestep)
    return model, motion


def measure(size):
    from .. import replay as rp
    from ..fix import fix_motion

    rng = np.random.default_rng(2026)
    n, rounds = size["motion"] * 5, size["rounds"]
    a, b = generic_pairs(n, seed=5)
    m = max(200, size["motion"] // 2)
    a0, a1, b0, b1 = approaching(rng, m)
    shapes = {}
    for kind in ("capsule", "box", "cylinder"):  # the random pairs' b as the other body: about half crossing
        sizes = b.radii.copy()
        if kind != "box":
            sizes[:, 2] = 0.0
        shapes[kind] = (kind, b.centers, b.rotations, sizes)
    cases = [
        (
            f"shape_distance, {kind}",
            n,
            lambda k=k: shape_distance(a, *k, parallel=False),
            lambda k=k: shape_distance(a, *k, parallel=False, derivatives=True),
            lambda out: int(((out[-1].status <= 1) | (out[-1].status == 4)).sum()),
        )
        for kind, k in shapes.items()
    ]
    rows = []
    for what, pairs, base, deriv, defined in (
        (
            "signed_distance",
            n,
            lambda: signed_distance(a, b, parallel=False),
            lambda: signed_distance(a, b, parallel=False, derivatives=True),
            lambda out: int((out[-1].status <= 1).sum()),
        ),
        (
            "time_of_impact",
            m,
            lambda: time_of_impact(a0, a1, b0, b1, parallel=False),
            lambda: time_of_impact(a0, a1, b0, b1, parallel=False, derivatives=True),
            lambda out: int((out[-1].status == 0).sum()),
        ),
        *cases,
    ):
        say(f"gradients: {what} with and without derivatives ...")
        out = deriv()  # (compiled and warm)
        t = interleaved({"alone": _cpu(base), "derivatives": _cpu(deriv)}, rounds, self_timed=True)
        rows.append(
            dict(
                what=what,
                pairs=pairs,
                base=float(np.median(t["alone"])) / pairs * 1e9,
                with_=float(np.median(t["derivatives"])) / pairs * 1e9,
                ratio=relative(t, "derivatives", "alone"),
                defined=defined(out),
            )
        )
    fixes = []
    for figures in (4, 64) if size["rounds"] > 5 else (4, 16):
        model, motion = dance(figures)
        for clearance in (0.0, 0.005):
            say(f"gradients: fix, {figures} figures, clearance {clearance:g} m ...")
            t0 = time.perf_counter()
            result = fix_motion(model, motion, clearance=clearance)
            seconds = time.perf_counter() - t0
            check = rp.replay(model, result.motion, between=True)
            fixes.append(
                dict(
                    figures=figures,
                    frames=len(motion),
                    nq=model.nq,
                    clearance=clearance,
                    fps=len(motion) / seconds,
                    changed=int(result.changed.sum()),
                    change=float(result.change.sum()),
                    largest=float(result.change.max()),
                    before=int(result.before_violations.sum()),
                    unfreed=len(result.unfreed),
                    closest=float(result.after_min[np.isfinite(result.after_min)].min()),
                    overlapping=int((check.in_contact > 0).sum()),
                    between_before=len(rp.replay(model, motion, between=True).between_events()),
                    between=len(check.between_events()),
                )
            )
    return rows, fixes


def write(result, size, out, plt):
    rows, fixes = result
    L = [
        "## 10. Exact derivatives and `ellipsim fix`",
        "",
        "Derivatives (core/distance/derivatives.py, core/motion/impact_derivatives.py): the same pairs with and "
        "without them, single-threaded, this thread's CPU time in interleaved rounds, ratio the median of "
        "per-round ratios.  signed_distance: random pairs (half overlapping); d dist, d normal and d pos with "
        "respect to both centres, rotations and semi-axes (18 columns).  time_of_impact: pairs approaching while "
        "turning; d t* / d (both poses of both bodies) (24 columns), where the first contact is transversal.  "
        "shape_distance (core/pairs/derivatives.py): the same random pairs with the second ellipsoid's pose and "
        "semi-axes as a capsule's, box's or cylinder's (MuJoCo's geom_size); derivatives defined: SMOOTH, BRANCH "
        "or ONE_SIDED.",
        "",
        "| function | pairs | ns/pair alone | ns/pair with derivatives | ratio | derivatives defined |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        L.append(
            f"| {r['what']} | {r['pairs']} | {r['base']:.0f} | {r['with_']:.0f} | {r['ratio']:.2f}x | {r['defined']} |"
        )
    L += [
        "",
        "`ellipsim fix` (app/fix.py) on the replay scenario's dance, danced by 4 figures and by 64 in a line "
        "(200 frames each): mass metric, smooth 4.  Change: sum over frames of sqrt(d' M(q) d) of the correction "
        "(kg^1/2 m).  After: every frame's closest candidate pair, proven, and contacts between frames "
        "(time_of_impact on the interpolated motion) of the corrected motion.",
        "",
        "| figures | nq | clearance m | frames/s | frames changed | change (largest frame) | pair-frames closer before | "
        "not freed | closest after m | frames overlapping after | contacts between frames before / after |",
        "|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---|",
    ]
    for f in fixes:
        L.append(
            f"| {f['figures']} | {f['nq']} | {f['clearance']:g} | {f['fps']:.0f} | {f['changed']} of {f['frames']} | "
            f"{f['change']:.3g} ({f['largest']:.3g}) | {f['before']} | {f['unfreed']} | {f['closest']:.3g} | "
            f"{f['overlapping']} | {f['between_before']} / {f['between']} |"
        )
    L.append("")
    return L
