"""Section 7: moving ellipsoids: time_of_impact against checking sampled instants with the exact
classify, per motion set; how many samples a sampling checker needs to find the same contacts; contains.

The sampling checker is what continuous collision detection replaces: the exact classify (certified
filter, rationals when unsure) at N uniform instants t_k = k / (N - 1) of the same motion (the float
poses time_of_impact classifies), stopping at the first instant that is not separated.
"""

import os
import time

import numpy as np
from scipy.spatial.transform import Rotation

from ...core.ellipsoids import Ellipsoids
from ...core.exact.classify import classify
from ...core.exact.contact_scale import contact_scale
from ...core.exact.containment import UNDECIDED as CONTAIN_UNDECIDED
from ...core.exact.containment import certify_containment, contains
from ...core.motion.time_of_impact import UNRESOLVED, _check, float_poses, time_of_impact
from ...core.relation import SEPARATED, UNDECIDED
from ...core.samples import random_ellipsoids
from ...native import ext
from .common import interleaved, relative, say


def _cpu(fn):
    """fn as a self-timed function for `interleaved`: this thread's CPU seconds (the VM is shared: wall
    time counts the other jobs' turns)."""

    def run():
        t0 = time.thread_time()
        fn()
        return time.thread_time() - t0

    return run


# --- motion sets -----------------------------------------------------------------------------------


def _turned(rng, x, max_angle, max_move):
    """x moved by up to max_move and turned about a random axis by up to max_angle radians."""
    n = len(x)
    rv = rng.normal(size=(n, 3))
    rv *= (rng.uniform(0, max_angle, n) / np.linalg.norm(rv, axis=1))[:, None]
    dc = rng.normal(size=(n, 3))
    dc *= (rng.uniform(0, max_move, n) / np.linalg.norm(dc, axis=1))[:, None]
    R1 = (Rotation.from_matrix(x.rotations) * Rotation.from_rotvec(rv)).as_matrix()
    return Ellipsoids(x.centers + dc, R1, x.radii)


def broadphase_set(rng, n):
    """Large random motions (semi-axes 0.1-1, centres anywhere in a box of half-width 1.5, turns up to
    3 rad) whose swept bounding spheres meet: what a broad phase over one long step hands on."""
    parts, total = [], 0
    while total < n:
        a0, b0 = random_ellipsoids(rng, 4 * n, box=1.5), random_ellipsoids(rng, 4 * n, box=1.5)
        a1, b1 = _turned(rng, a0, 3.0, 0.0), _turned(rng, b0, 3.0, 0.0)
        a1 = Ellipsoids(rng.uniform(-1.5, 1.5, (4 * n, 3)), a1.rotations, a1.radii)
        b1 = Ellipsoids(rng.uniform(-1.5, 1.5, (4 * n, 3)), b1.rotations, b1.radii)
        d0 = b0.centers - a0.centers
        v = (b1.centers - b0.centers) - (a1.centers - a0.centers)
        t = np.clip(-(d0 * v).sum(1) / np.maximum((v * v).sum(1), 1e-300), 0, 1)
        near = np.linalg.norm(d0 + t[:, None] * v, axis=1) <= a0.radii.max(1) + b0.radii.max(1)
        keep = np.flatnonzero(near)
        parts.append((a0[keep], a1[keep], b0[keep], b1[keep]))
        total += len(keep)
    return tuple(Ellipsoids.concatenate([p[k] for p in parts])[:n] for k in range(4))


def smallstep_set(rng, n):
    """A simulation step: pairs near contact at t = 0 (|contact_scale - 1| < 0.1), each body moving by
    up to 0.05 and turning by up to 0.1 rad."""
    parts, total = [], 0
    while total < n:
        a0, b0 = random_ellipsoids(rng, 8 * n), random_ellipsoids(rng, 8 * n)
        keep = np.flatnonzero(np.abs(contact_scale(a0, b0) - 1) < 0.1)
        a0, b0 = a0[keep], b0[keep]
        parts.append((a0, _turned(rng, a0, 0.1, 0.05), b0, _turned(rng, b0, 0.1, 0.05)))
        total += len(keep)
    return tuple(Ellipsoids.concatenate([p[k] for p in parts])[:n] for k in range(4))


def tunnel_set(rng, n):
    """Thin plates (1 x 1 x 0.002) sweeping along their normal at speed 6 through small balls (radius
    0.005) near the origin: contacts about 1e-3 long, between most samples of a sampling checker."""
    R = Rotation.random(n, random_state=rng).as_matrix()
    normal = R[:, :, 2]
    plate = np.tile([1.0, 1.0, 0.002], (n, 1))
    b = Ellipsoids(
        rng.uniform(-0.3, 0.3, (n, 3)), Rotation.random(n, random_state=rng).as_matrix(), np.full((n, 3), 0.005)
    )
    return Ellipsoids(-3 * normal, R, plate), Ellipsoids(3 * normal, R, plate), b, b


SETS = {"broadphase": broadphase_set, "smallstep": smallstep_set, "tunnel": tunnel_set}
SET_NOTES = {
    "broadphase": "large random motions whose swept bounding spheres meet (turns up to 3 rad)",
    "smallstep": "near contact at t = 0, moving by <= 0.05 and turning by <= 0.1 rad (a simulation step)",
    "tunnel": "thin plates crossing small balls at speed 6 (contacts ~1e-3 long)",
}

# --- the sampling checker -------------------------------------------------------------------------


def first_hits(a0, a1, b0, b1, N):
    """(n,) index of the first of N uniform instants at which the pair is not separated (N if none):
    the exact classify on time_of_impact's float poses, rationals where the float filter is unsure.

    The scan is compiled (ext.first_hits, one thread): per pair the certified filter on the float pose at
    each instant k / (N - 1) until one is not proven separated; an instant the filter cannot decide ends
    that scan, and the pair is finished here with the exact relation from that instant on."""
    arrays, n = _check(a0, a1, b0, b1)
    out = np.empty(n, dtype=np.int64)
    undecided = np.empty((n, 2), dtype=np.int64)
    count = ext.first_hits(*arrays, N, out, undecided)
    rel = np.empty(1, dtype=np.int8)
    for i, k in undecided[:count]:
        out[i] = N
        for kk in range(k, N):
            ca, Ra, ra, cb, Rb, rb = float_poses(arrays, [i], [kk / (N - 1)])
            rel[0] = UNDECIDED
            ext.resolve(ca, Ra, ra, cb, Rb, rb, rel, 0, 1)  # the exact relation (integer arithmetic)
            if rel[0] != SEPARATED:
                out[i] = kk
                break
    return out


def all_poses(a0, a1, b0, b1, N):
    """The float poses of every pair at N uniform instants, as two Ellipsoids batches (pair-major)."""
    arrays, n = _check(a0, a1, b0, b1)
    idx = np.repeat(np.arange(n), N)
    ts = np.tile(np.arange(N) / (N - 1), n)
    ca, Ra, ra, cb, Rb, rb = float_poses(arrays, idx, ts)
    return Ellipsoids(ca, Ra, ra), Ellipsoids(cb, Rb, rb)


# --- the section ---------------------------------------------------------------------------------------


def measure(size):
    """Per set: times (toi, 64-sample first hit, classify of 64 given poses), counts, the sampling curve;
    and contains: ns/pair and the share left to rationals."""
    rng = np.random.default_rng(2026)
    n, rounds = size["motion"], size["rounds"]
    rows, curves = {}, {}
    for name, build in SETS.items():
        say(f"motion: {name} ...")
        a0, a1, b0, b1 = build(rng, n)
        time_of_impact(a0[:4], a1[:4], b0[:4], b1[:4], parallel=False)  # compile and warm
        first_hits(a0[:4], a1[:4], b0[:4], b1[:4], 64)
        pa, pb = all_poses(a0, a1, b0, b1, 64)
        results = {}

        def toi():
            results["toi"] = time_of_impact(a0, a1, b0, b1, parallel=False, return_status=True)

        def sampled():
            results["hits"] = first_hits(a0, a1, b0, b1, 64)

        fns = {"toi": toi, "sampled": sampled, "given": lambda: classify(pa, pb, parallel=False)}
        times = interleaved({k: _cpu(f) for k, f in fns.items()}, rounds, self_timed=True)
        toi_, status = results["toi"]
        contacts = np.isfinite(toi_)
        rows[name] = dict(
            pairs=n,
            toi=np.median(times["toi"]) / n * 1e9,
            sampled=np.median(times["sampled"]) / n * 1e9,
            given=np.median(times["given"]) / n * 1e9,
            ratio=relative(times, "sampled", "toi"),
            ratio_given=relative(times, "given", "toi"),
            contacts=int(contacts.sum()),
            found64=int(np.count_nonzero(contacts & (results["hits"] < 64))),
            unresolved=int(np.count_nonzero(status == UNRESOLVED)),
        )
        curve = []
        for N in size["motion_samples"]:
            hits = {}
            run = _cpu(lambda: hits.__setitem__("h", first_hits(a0, a1, b0, b1, N)))  # noqa: B023 (called at once)
            t = interleaved({"hits": run}, 3 if N <= 512 else 1, self_timed=True)["hits"]
            h = hits["h"]
            found = contacts & (h < N)
            err = np.abs(h[found] / (N - 1.0) - toi_[found])
            worst = float(err.max()) if len(err) else float("nan")  # |t_N - toi| over the contacts found
            curve.append((N, float(np.median(t)) / n * 1e9, found.sum() / max(contacts.sum(), 1), worst))
        curves[name] = curve
    say("motion: contains ...")
    m = size["motion_contains"]
    a = random_ellipsoids(rng, m, radii=(0.5, 2.0))
    rb = a.radii.min(1)[:, None] * rng.uniform(0.1, 1.0, (m, 3))
    cb = a.centers + np.einsum("nij,nj->ni", a.rotations, a.radii * rng.uniform(-0.6, 0.6, (m, 3)))
    b = Ellipsoids(cb, Rotation.random(m, random_state=rng).as_matrix(), rb)
    contains(a[:4], b[:4], parallel=False)
    fns = {"contains": lambda: contains(a, b, parallel=False), "classify": lambda: classify(a, b, parallel=False)}
    t = interleaved({k: _cpu(f) for k, f in fns.items()}, rounds, self_timed=True)
    inside = contains(a, b, parallel=False)
    escalated = np.count_nonzero(certify_containment(a, b, m, False) == CONTAIN_UNDECIDED)
    k = 20
    t_same = _cpu(lambda: contains(a[:k], a[:k], parallel=False))() / k
    # internally tangent, exactly (dyadic, axis-aligned): B's x-extreme touches A's and B curves more there
    big = Ellipsoids(np.zeros((k, 3)), np.tile(np.eye(3), (k, 1, 1)), np.tile([1.0, 0.75, 0.5], (k, 1)))
    tangent = Ellipsoids(np.tile([0.5, 0.0, 0.0], (k, 1)), big.rotations, np.tile([0.5, 0.375, 0.25], (k, 1)))
    t_tangent = _cpu(lambda: contains(big, tangent, parallel=False))() / k
    cont = dict(
        pairs=m,
        ns=np.median(t["contains"]) / m * 1e9,
        ratio=relative(t, "contains", "classify"),
        inside=float(inside.mean()),
        escalated=int(escalated),
        same_frame_us=t_same * 1e6,
        tangent_ms=t_tangent * 1e3,
    )
    return rows, curves, dict(cont, same_frame_batch=k)


def write(result, size, out, plt):
    """The section's markdown, and motion.png in `out`."""
    rows, curves, cont = result
    _plot(plt, out, rows, curves)
    L = [
        "## 7. Moving ellipsoids: time of impact and containment",
        "",
        "time_of_impact against a sampling checker: the exact classify at N uniform instants of the same motion "
        "(time_of_impact's float poses), stopping at the first instant not separated.  Single-threaded, timed in "
        "the same interleaved rounds as thread CPU time (the VM is shared); ratios are medians of per-round ratios "
        "(> 1: time_of_impact is cheaper).  "
        "'64 given poses' classifies all 64 pre-built poses of every pair (pose cost excluded, no early stop).",
        "",
        "| set | pairs | time_of_impact ns/pair | 64 samples ns/pair | ratio | 64 given poses ns/pair | ratio | contacts | "
        "found by 64 samples | unresolved |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, r in rows.items():
        L.append(
            f"| {name} | {r['pairs']} | {r['toi']:.0f} | {r['sampled']:.0f} | {r['ratio']:.2f}x | {r['given']:.0f} | "
            f"{r['ratio_given']:.2f}x | {r['contacts']} | {r['found64']} | {r['unresolved']} |"
        )
    L += ["", "Sets: " + "; ".join(f"{k}: {v}" for k, v in SET_NOTES.items()) + ".", ""]
    L += ["![time against samples](motion.png)", ""]
    L += [
        "| set | samples a checker needs to find every contact time_of_impact finds | its ns/pair | its worst "
        "\\|t_N - toi\\| | time_of_impact ns/pair |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, curve in curves.items():
        need = next((c for c in curve if c[2] == 1.0), None)
        if need is None:
            L.append(f"| {name} | > {curve[-1][0]} | - | - | {rows[name]['toi']:.0f} |")
        else:
            L.append(f"| {name} | {need[0]} | {need[1]:.0f} | {need[3]:.1e} | {rows[name]['toi']:.0f} |")
    L += [
        "",
        f"contains on {cont['pairs']} pairs (B centred inside A, {cont['inside']:.0%} inside): {cont['ns']:.0f} ns/pair, "
        f"{cont['ratio']:.1f}x the time of classify on the same pairs; {cont['escalated']} left to rationals.  "
        f"Same frame (identical pairs): {cont['same_frame_us']:.1f} us/pair through the exact shortcut (a call of "
        f"{cont['same_frame_batch']} pairs); internally tangent pairs need rationals: {cont['tangent_ms']:.2f} ms/pair.",
        "",
    ]
    return L


def _plot(plt, out, rows, curves):
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    for name, curve in curves.items():
        N = [c[0] for c in curve]
        (line,) = ax.plot(N, [c[1] for c in curve], "o-", label=f"{name}: N samples")
        ax.axhline(rows[name]["toi"], color=line.get_color(), ls="--", label=f"{name}: time_of_impact")
        need = next((c for c in curve if c[2] == 1.0), None)
        if need:
            ax.plot([need[0]], [need[1]], "*", ms=14, color=line.get_color())
        bx.plot(N, [c[2] for c in curve], "o-", color=line.get_color(), label=name)
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="samples N",
        ylabel="ns per pair (1 thread)",
        title="time against samples (star: all of time_of_impact's contacts found)",
    )
    ax.legend(fontsize=7)
    bx.set(xscale="log", xlabel="samples N", ylabel="share of time_of_impact's contacts found", ylim=(0, 1.02))
    bx.legend(fontsize=8)
    fig.savefig(os.path.join(out, "motion.png"), dpi=110)
    plt.close(fig)
