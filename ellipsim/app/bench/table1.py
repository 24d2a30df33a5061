"""Section 4: the thesis's Table 1 re-run (5.1.2): the four set-up x root-test combinations on
separated and colliding generic pairs, beside the thesis's SGI Onyx (195 MHz R10000) timings."""

import os

import numpy as np

from ...core.exact.classify import classify
from ...core.samples import generic_pairs
from .common import float_runner, median_time, say

# The thesis's Table 1 (5.1.2): average microseconds per pair on an SGI Onyx, 195 MHz R10000.
THESIS_TABLE1 = {
    ("cofactor", "sturm"): (23.3385, 22.3892), ("cofactor", "descartes"): (19.7987, 20.9842),
    ("rearranged", "sturm"): (22.1682, 20.0594), ("rearranged", "descartes"): (18.6665, 16.557),
}  # (without collision, with collision)  # fmt: skip


def measure(size):
    say("thesis Table 1 ...")
    a, b = generic_pairs(10_000, seed=4)
    truth = classify(a, b)
    sep, col = np.flatnonzero(truth == 0), np.flatnonzero(truth != 0)
    rows = []
    for setup in ("cofactor", "rearranged"):
        for test in ("sturm", "descartes"):
            ours = []
            for idx in (sep, col):
                run = float_runner(a[idx], b[idx], test, setup, "float64")
                ours.append(median_time(run, size["rounds"]) / len(idx) * 1e9)
            thesis = THESIS_TABLE1[(setup, test)]
            rows.append((setup, test, thesis[0], ours[0], thesis[1], ours[1]))
    return rows, (len(sep), len(col))


def write(result, size, out, plt):
    """The section's markdown, and table1.png in `out`."""
    t1rows, t1n = result
    _plot(plt, out, t1rows)
    L = [
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
        L.append(
            f"| {setup} | {test} | {ts:.2f} | {os_:.0f} | {ts * 1e3 / os_:.0f}x | {tc:.2f} | {oc:.0f} | {tc * 1e3 / oc:.0f}x |"
        )
    return L


def _plot(plt, out, t1rows):
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
