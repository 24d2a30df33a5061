"""Section 2: numerical stress: misclassified pairs per hard category (samples.STRESS) and method."""

import os
import time

import numpy as np
from scipy.spatial.transform import Rotation

from ...core.distance.ellipsoid_pair import GLOBAL, signed_distance
from ...core.ellipsoids import Ellipsoids
from ...core.exact.certified_filter import certify
from ...core.exact.classify import classify
from ...core.exact.contact_scale import contact_scale
from ...core.pairs.shape_distance import shape_distance
from ...core.relation import UNDECIDED
from ...core.samples import STRESS, stress_pairs
from .common import FLOAT_METHODS, MujocoPairs, distances_serial, float_runner, pair_runner, say, verdict

FALLBACKS = "narrow phase: UNPROVEN"


def measure(size):
    """{category: {method: misclassified}}, exact's escalation share and time per pair per category."""
    table, exact_info = {}, {}
    methods = [f"{m} {s} {d}" for m, s, d in FLOAT_METHODS] + ["contact_scale", "narrow phase", "MuJoCo (default tol)"]
    methods.append(FALLBACKS)
    for cat in STRESS:
        say(f"stress: {cat} ...")
        a, b = stress_pairs(cat, size["stress"], seed=5)
        n = len(a)
        t0 = time.perf_counter()
        truth = classify(a, b, parallel=False)
        exact_info[cat] = (
            np.count_nonzero(certify(a, b, n, False) == UNDECIDED) / n,
            (time.perf_counter() - t0) / n * 1e9,
            n,
        )
        row = {}
        for m, s, d in FLOAT_METHODS:
            row[f"{m} {s} {d}"] = int(np.count_nonzero(float_runner(a, b, m, s, d)() != truth))
        row["contact_scale"] = int(np.count_nonzero(verdict(contact_scale(a, b) - 1) != truth))
        row["narrow phase"] = int(np.count_nonzero(verdict(pair_runner(distances_serial, a, b, 40)()) != truth))
        _, _, _, status = signed_distance(a, b, parallel=False)
        row[FALLBACKS] = int(np.count_nonzero(status != GLOBAL))
        row["MuJoCo (default tol)"] = int(np.count_nonzero(verdict(MujocoPairs(a, b).run(1e-6, 35)) != truth))
        table[cat] = row
    return table, exact_info, methods, symmetric_fallbacks(size["stress"] // 10)


def write(result, size, out, plt):
    """The section's markdown, and stress.png in `out`."""
    stable, sinfo, smethods, sym = result
    _plot(plt, out, stable, [m for m in smethods if m != FALLBACKS])
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
        "an independent rational reference).  'narrow phase: UNPROVEN' counts the pairs whose signed distance is not "
        "proven global (inside MuJoCo: a fallback to MuJoCo's function).",
        "",
        "Symmetric limbs, where maxima form circles or nearly do (the narrow phase's fallbacks, UNPROVEN / pairs):",
        "",
        "| category | pairs | UNPROVEN | deep (signed distance < 0) |",
        "|---|---:|---:|---:|",
    ]
    for name, (pairs, unproven, deep) in sym.items():
        L.append(f"| {name} | {pairs} | {unproven} | {deep} |")
    L.append("")
    return L


def _spheroids(rng, n):
    aspect, s = rng.uniform(1.15, 8.0, n), rng.uniform(0.05, 0.3, n)
    prolate = rng.random(n) < 0.5
    return np.where(prolate[:, None], np.stack([aspect * s, s, s], 1), np.stack([s, aspect * s, aspect * s], 1))


def symmetric_fallbacks(n):
    """{category: (pairs, UNPROVEN, deep)}: spheroids with parallel axes (equal rotations, or turned about
    the common axis), nearly parallel (tilted by 1e-12 to 0.1 rad), each also on float32 poses, spheroids only
    nearly (a cross-section off a circle by 1e-12 to 1e-5) on a common axis, and a cylinder on a spheroid's axis
    (exactly or tilted by up to 1e-2 rad); centres on the axis, near it or anywhere, deep to touching."""
    rng = np.random.default_rng(18)
    out = {}
    for name in ("parallel spheroids", "nearly parallel spheroids"):
        ra, rb = _spheroids(rng, n), _spheroids(rng, n)
        R = Rotation.random(n, random_state=rng).as_matrix()
        turn = Rotation.from_rotvec(np.stack([rng.uniform(0, 2 * np.pi, n), np.zeros(n), np.zeros(n)], 1)).as_matrix()
        Rb = np.where((np.arange(n) % 2 == 0)[:, None, None], R, R @ turn)
        if name != "parallel spheroids":
            axis = rng.normal(size=(n, 3))
            axis *= (10.0 ** rng.uniform(-12, -1, n) / np.linalg.norm(axis, axis=1))[:, None]
            Rb = Rotation.from_rotvec(axis).as_matrix() @ Rb
        u = np.where((np.arange(n) % 3 == 0)[:, None], R[:, :, 0], rng.normal(size=(n, 3)))
        u /= np.linalg.norm(u, axis=1)[:, None]
        c = u * (rng.uniform(0.0, 1.1, n) * (ra.max(1) + rb.max(1)))[:, None]
        dist, _, _, status = signed_distance(Ellipsoids(np.zeros((n, 3)), R, ra), Ellipsoids(c, Rb, rb), parallel=False)
        out[name] = (n, int(np.count_nonzero(status != GLOBAL)), int(np.count_nonzero(dist < 0)))
        # the same pairs as MuJoCo Warp holds them: float32 poses (rotations orthonormal only to ~6e-8, so the
        # spheroids are spheroids only to that: the maxima a nearly flat ring on the axis)
        f32 = [np.asarray(x, np.float32).astype(float) for x in (R, ra, c, Rb, rb)]
        dist, _, _, status = signed_distance(
            Ellipsoids(np.zeros((n, 3)), f32[0], f32[1]), Ellipsoids(f32[2], f32[3], f32[4]), parallel=False
        )
        out[f"{name}, float32 poses"] = (n, int(np.count_nonzero(status != GLOBAL)), int(np.count_nonzero(dist < 0)))
    rE = _spheroids(rng, n)
    RE, cK, RK, sK = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3, 3)), np.zeros((n, 3))
    for i in range(n):
        RE[i] = R = Rotation.random(random_state=rng).as_matrix()
        k = int(np.argmax(np.abs(rE[i] - np.median(rE[i]))))  # the axis of revolution
        tilt = rng.choice([0.0, 1e-12, 1e-8, 1e-4, 1e-2])
        axis = rng.normal(size=3)
        Rk = R @ Rotation.from_rotvec(axis / np.linalg.norm(axis) * tilt).as_matrix()
        RK[i] = Rk[:, [(k + 1) % 3, (k + 2) % 3, k]]  # the cylinder's axis (its z) along E's axis k
        r, L = rng.uniform(0.02, 0.3), rng.uniform(0.01, 0.3)
        cK[i], sK[i, :2] = R[:, k] * rng.uniform(0.0, 1.05) * (rE[i, k] + L), (r, L)
    dist, _, _, status = shape_distance(Ellipsoids(np.zeros((n, 3)), RE, rE), "cylinder", cK, RK, sK, parallel=False)
    out["cylinder on a spheroid's axis"] = (n, int(np.count_nonzero(status != GLOBAL)), int(np.count_nonzero(dist < 0)))
    # spheroids only nearly: B's cross-section off a circle by 1e-12 to 1e-5 of its size, on A's axis
    near = np.random.default_rng(19)  # its own draws: the other categories' pairs stay as they were
    ra, rb = _spheroids(near, n), _spheroids(near, n)
    off = 10.0 ** near.uniform(-12, -5, n)
    rb[:, 1] *= 1.0 + off  # (the axis of revolution is 0: the cross-section is (1, 2))
    R = Rotation.random(n, random_state=near).as_matrix()
    c = R[:, :, 0] * (near.uniform(-1.1, 1.1, n) * (ra.max(1) + rb.max(1)))[:, None]
    dist, _, _, status = signed_distance(Ellipsoids(np.zeros((n, 3)), R, ra), Ellipsoids(c, R, rb), parallel=False)
    out["nearly spheroidal on a common axis"] = (
        n,
        int(np.count_nonzero(status != GLOBAL)),
        int(np.count_nonzero(dist < 0)),
    )
    return out


def _plot(plt, out, stable, smethods):
    cats = list(stable)
    grid = np.array([[stable[c][m] for m in smethods] for c in cats], dtype=float)
    fig, ax = plt.subplots(figsize=(12, 6.5), constrained_layout=True)
    im = ax.imshow(np.log10(grid + 1), cmap="Reds", aspect="auto")
    for i in range(len(cats)):
        for j in range(len(smethods)):
            if grid[i, j]:
                dark = np.log10(grid[i, j] + 1) > 0.6 * np.log10(grid.max() + 1)
                ax.text(
                    j, i, f"{int(grid[i, j])}", ha="center", va="center", fontsize=6, color="white" if dark else "black"
                )
    ax.set_xticks(range(len(smethods)), smethods, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(range(len(cats)), cats, fontsize=7)
    ax.set_title("misclassified pairs per stress category (exact: 0 everywhere)")
    fig.colorbar(im, ax=ax, label="log10(misclassified + 1)")
    fig.savefig(os.path.join(out, "stress.png"), dpi=110)
    plt.close(fig)
