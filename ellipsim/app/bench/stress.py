"""Section 2: numerical stress: misclassified pairs per hard category (samples.STRESS) and method."""

import os
import time

import numpy as np

from ...core.certified import certify
from ...core.classify import classify
from ...core.perram_wertheim import contact_scale
from ...core.relation import UNDECIDED
from ...core.samples import STRESS, stress_pairs
from .common import FLOAT_METHODS, MujocoPairs, distances_serial, float_runner, pair_runner, say, verdict


def measure(size):
    """{category: {method: misclassified}}, exact's escalation share and time per pair per category."""
    table, exact_info = {}, {}
    methods = [f"{m} {s} {d}" for m, s, d in FLOAT_METHODS] + ["contact_scale", "narrow phase", "MuJoCo (default tol)"]
    for cat in STRESS:
        say(f"stress: {cat} ...")
        a, b = stress_pairs(cat, size["stress"], seed=5)
        n = len(a)
        t0 = time.perf_counter()
        truth = classify(a, b, parallel=False)
        exact_info[cat] = (np.count_nonzero(certify(a, b, n, False) == UNDECIDED) / n, (time.perf_counter() - t0) / n * 1e9, n)
        row = {}
        for m, s, d in FLOAT_METHODS:
            row[f"{m} {s} {d}"] = int(np.count_nonzero(float_runner(a, b, m, s, d)() != truth))
        row["contact_scale"] = int(np.count_nonzero(verdict(contact_scale(a, b) - 1) != truth))
        row["narrow phase"] = int(np.count_nonzero(verdict(pair_runner(distances_serial, a, b, 40)()) != truth))
        row["MuJoCo (default tol)"] = int(np.count_nonzero(verdict(MujocoPairs(a, b).run(1e-6, 35)) != truth))
        table[cat] = row
    return table, exact_info, methods


def write(result, size, out, plt):
    """The section's markdown, and stress.png in `out`."""
    stable, sinfo, smethods = result
    _plot(plt, out, stable, smethods)
    L = [
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
    ]
    return L


def _plot(plt, out, stable, smethods):
    cats = list(stable)
    grid = np.array([[stable[c][m] for m in smethods] for c in cats], dtype=float)
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
