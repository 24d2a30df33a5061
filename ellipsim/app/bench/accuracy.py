"""Section 1: time against error for every method, on pairs near contact.

Classification: exact classify, the thesis's Sturm and Descartes tests on both set-ups in float64
and float32, contact_scale.  Signed distance: the narrow phase, its first Newton run capped at k
steps, MuJoCo's mj_geomDistance at several ccd_tolerance / ccd_iterations, and coal's GJK/EPA when
the 'peers' extra is installed.  Error: misclassification rate against the exact relation, and
distance error against a 40-digit reference (reference.py).
"""

import os
import time

import numpy as np

from ...core.exact.classify import classify
from ...core.exact.contact_scale import contact_scale
from ...core.samples import near_contact_pairs
from ...core.tolerances import NEWTON_MAX_ITER
from .common import (
    FLOAT_METHODS,
    MujocoPairs,
    distances_serial,
    float_runner,
    fmt_err,
    fmt_rate,
    interleaved,
    newton_runs,
    pair_runner,
    relative,
    say,
    verdict,
)
from .reference import normals, reference_distances

NEWTON_STEPS = (1, 2, 3, 4, 6)  # one run from the bisector seed, capped
MUJOCO_SETTINGS = [(1e-2, 35), (1e-4, 35), (1e-6, 35), (1e-8, 35), (1e-10, 35), (1e-6, 5), (1e-6, 10), (1e-10, 1000)]


PLAIN = "descartes rearranged float64"
NARROW = "narrow phase signed distance"


def measure(size):
    """Rows (name, family, ns/pair, time / reference in the same rounds, misclassification rate,
    median and max distance error / r_min): classification methods (reference: PLAIN), then
    signed-distance methods (reference: NARROW)."""
    say("time vs error: pairs and exact relations ...")
    a, b = near_contact_pairs(size["near"], seed=11)
    truth = classify(a, b)
    n = len(truth)
    fns, wrong = {"exact": lambda: classify(a, b, parallel=False)}, {"exact": 0.0}
    family = {"exact": "ellipsim classify"}
    for m, s, d in FLOAT_METHODS:
        name = f"{m} {s} {d}"
        fns[name] = float_runner(a, b, m, s, d)
        wrong[name], family[name] = np.count_nonzero(fns[name]() != truth) / n, "thesis tests"
    cs_name = "contact_scale > 1 (2 threads)"
    fns[cs_name] = lambda: contact_scale(a, b)  # the parallel kernel
    wrong[cs_name], family[cs_name] = (
        np.count_nonzero(verdict(contact_scale(a, b) - 1) != truth) / n,
        "ellipsim contact_scale",
    )
    say(f"time vs error: timing {len(fns)} classifiers in {size['rounds']} interleaved rounds ...")
    times = interleaved(fns, size["rounds"])
    rows = [(k, family[k], np.median(times[k]) / n * 1e9, relative(times, k, PLAIN), wrong[k], None, None) for k in fns]
    # distances: a subset with a 40-digit reference
    m_a, m_b = a[: size["mujoco"]], b[: size["mujoco"]]
    m_truth = truth[: size["mujoco"]]
    nm, ref_n = len(m_a), size["reference"]
    mj = MujocoPairs(m_a, m_b)
    tight = mj.run(1e-12, 1000)
    say(f"time vs error: 40-digit reference for {ref_n} pairs ...")
    seeds = [normals(m_a[:ref_n], m_b[:ref_n])]
    ref = reference_distances(m_a[:ref_n], m_b[:ref_n], seeds)
    rmin = np.minimum(m_a.radii[:ref_n].min(1), m_b.radii[:ref_n].min(1))
    fns = {NARROW: pair_runner(distances_serial, m_a, m_b, NEWTON_MAX_ITER)}
    family = {NARROW: "ellipsim narrow phase"}
    for k in NEWTON_STEPS:
        name = f"one Newton run, {k} step{'s' if k > 1 else ''}"
        fns[name], family[name] = pair_runner(newton_runs, m_a, m_b, k), "ellipsim narrow phase"
    for tol, it in MUJOCO_SETTINGS:
        name = f"MuJoCo tol {tol:g}, {it} it"
        fns[name], family[name] = (lambda tol=tol, it=it: mj.run(tol, it)), "MuJoCo mj_geomDistance"
    dists = {k: fn().copy() for k, fn in fns.items()}
    rounds = max(3, size["rounds"] // 2)
    say(f"time vs error: timing {len(fns)} distance methods in {rounds} interleaved rounds ...")
    times = interleaved(fns, rounds)
    for k in fns:
        e = np.abs(dists[k][:ref_n] - ref) / rmin
        rows.append(
            (
                k,
                family[k],
                np.median(times[k]) / nm * 1e9,
                relative(times, k, NARROW),
                np.count_nonzero(verdict(dists[k]) != m_truth) / nm,
                np.median(e),
                e.max(),
            )
        )
    coal = _coal()
    if coal is not None:
        say("time vs error: coal ...")
        k = size["coal"]
        t0 = time.perf_counter()
        dist = _coal_distances(coal, m_a[:k], m_b[:k])
        seconds = time.perf_counter() - t0
        t0 = time.perf_counter()
        fns[NARROW]()
        narrow_seconds = (time.perf_counter() - t0) * k / nm
        e = np.abs(dist[:ref_n] - ref) / rmin if k >= ref_n else np.array([np.nan])
        rows.append(
            (
                "coal GJK/EPA (Python calls)",
                "coal",
                seconds / k * 1e9,
                seconds / narrow_seconds,
                np.count_nonzero(verdict(dist) != m_truth[:k]) / k,
                np.median(e),
                e.max(),
            )
        )
    notes = {
        "pairs": n,
        "mujoco_pairs": nm,
        "reference": ref_n,
        "coal": coal is not None,
        "full_vs_ref": float((np.abs(dists[NARROW][:ref_n] - ref) / rmin).max()),
        "tight_vs_ref": float((np.abs(tight[:ref_n] - ref) / rmin).max()),
    }
    return rows, notes


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


def write(result, size, out, plt):
    """The section's markdown, and pareto.png in `out`."""
    prows, pnotes = result
    _plot(plt, out, prows)
    L = [
        "## 1. Time against error",
        "",
        f"{pnotes['pairs']} random pairs with |contact_scale - 1| < 0.1 (where no shortcut decides); distances on the "
        f"first {pnotes['mujoco_pairs']}, their error against a 40-digit mpmath reference on the first {pnotes['reference']} "
        "(in units of the smaller ellipsoid's shortest semi-axis).  Single-threaded unless noted; MuJoCo is called "
        "through ctypes in a compiled loop"
        + (
            "; coal through its Python binding (per-call overhead included)."
            if pnotes["coal"]
            else "; coal is not installed (pip install 'ellipsim[peers]' adds it)."
        ),
        "",
        "![time against error](pareto.png)",
        "",
        f"### Classification ({pnotes['pairs']} pairs; time relative to {PLAIN}, median of per-round ratios)",
        "",
        "| method | ns/pair | × plain | misclassified |",
        "|---|---:|---:|---:|",
    ]
    for name, _, ns, rel, wrong, med, _mx in prows:
        if med is None:
            L.append(f"| {name} | {ns:.0f} | {rel:.2f} | {fmt_rate(wrong)} |")
    L += [
        "",
        f"### Signed distance ({pnotes['mujoco_pairs']} pairs; time relative to the {NARROW})",
        "",
        "'one Newton run, k steps' is the narrow phase's first run alone, capped, with no proof, restart or "
        "multistart: what a fixed-iteration Newton would buy.",
        "",
        "| method | ns/pair | × narrow phase | misclassified | distance error, median | distance error, max |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, _, ns, rel, wrong, med, mx in prows:
        if med is not None:
            L.append(f"| {name} | {ns:.0f} | {rel:.2f} | {fmt_rate(wrong)} | {fmt_err(med)} | {fmt_err(mx)} |")
    L += [
        "",
        f"The converged narrow phase is within {pnotes['full_vs_ref']:.1e} of the reference; MuJoCo at ccd_tolerance "
        f"1e-12 within {pnotes['tight_vs_ref']:.1e}.",
        "",
    ]
    return L


def _plot(plt, out, prows):
    colours = {
        "ellipsim classify": "C3",
        "thesis tests": "C0",
        "ellipsim contact_scale": "C5",
        "ellipsim narrow phase": "C2",
        "MuJoCo mj_geomDistance": "C1",
        "coal": "C4",
    }
    fig = plt.figure(figsize=(15, 8), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, height_ratios=[5, 1.2])
    ax1, ax2, key = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, :])
    floor = 1e-7
    # points carry numbers (listed below the plots); labels of points at the same height alternate in height
    placed = {}
    for k, (_name, family, ns, _rel, wrong, _med, mx) in enumerate(prows, 1):
        for ax, y in ((ax1, max(wrong, floor)), (ax2, None if mx is None else max(mx, 1e-17))):
            if y is None:
                continue
            ax.scatter(ns, y, color=colours[family], s=30)
            j = placed.setdefault((id(ax), y), 0)
            placed[(id(ax), y)] += 1
            ax.annotate(str(k), (ns, y), fontsize=7, xytext=(2, 3 + 8 * (j % 4)), textcoords="offset points")
    for family, c in colours.items():
        ax1.scatter([], [], color=c, label=family)
    ax1.set(
        xscale="log",
        yscale="log",
        xlabel="time per pair [ns]",
        ylabel=f"misclassified share (0 drawn at {floor:g})",
        title="classification: time against error",
    )
    ax1.legend(fontsize=7)
    ax2.set(
        xscale="log",
        yscale="log",
        xlabel="time per pair [ns]",
        ylabel="max |distance error| / shortest semi-axis",
        title="signed distance: time against error",
    )
    names = [f"{k}: {row[0]}" for k, row in enumerate(prows, 1)]
    cols = 4
    per = -(-len(names) // cols)
    key.axis("off")
    key.text(
        0,
        1,
        "\n".join("    ".join(f"{x:<40}" for x in names[i::per]) for i in range(per)),
        fontsize=7.5,
        family="monospace",
        va="top",
        transform=key.transAxes,
    )
    fig.savefig(os.path.join(out, "pareto.png"), dpi=110)
    plt.close(fig)

    fig.savefig(os.path.join(out, "pareto.png"), dpi=110)
    plt.close(fig)
