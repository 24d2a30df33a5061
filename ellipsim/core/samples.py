"""Reproducible sets of ellipsoid pairs for the demo and the benchmarks.

`generic_pairs` follows the thesis's generic sets (5.1.1): random semi-axes, orientations and
positions, half of the pairs colliding and half separated.  `near_contact_pairs` keeps only pairs
whose Perram-Wertheim scale is within a band around 1, where no shortcut applies.
"""

import math

import numpy as np

from .ellipsoids import Ellipsoids
from .exact.classify import classify
from .exact.contact_scale import contact_scale


def random_ellipsoids(rng, n, *, box=0.75, radii=(0.1, 1.0)):
    """n ellipsoids: centres uniform in [-box, box]^3, uniform random rotations, semi-axes uniform in `radii`."""
    q = rng.normal(size=(n, 4))
    return Ellipsoids.from_quaternions(rng.uniform(-box, box, (n, 3)), q, rng.uniform(*radii, (n, 3)))


def generic_pairs(n, *, seed=0):
    """n pairs, n // 2 overlapping (or touching) and the rest separated, shuffled (thesis 5.1)."""
    rng = np.random.default_rng(seed)
    m = 2 * n + 1000
    a, b = random_ellipsoids(rng, m), random_ellipsoids(rng, m)
    rel = classify(a, b)
    colliding = np.flatnonzero(rel != 0)[: n // 2]
    separated = np.flatnonzero(rel == 0)[: n - len(colliding)]
    idx = rng.permutation(np.concatenate([colliding, separated]))
    return a[idx], b[idx]


def near_contact_pairs(n, *, band=0.1, seed=0):
    """n random pairs with |contact_scale - 1| < band: the pairs that need the full test."""
    if not (
        isinstance(band, (int, float, np.floating, np.integer)) and not isinstance(band, bool) and 0 < band < math.inf
    ):
        raise ValueError(f"band must be a positive finite number, got {band!r}")
    rng = np.random.default_rng(seed)
    keep_a, keep_b, total = [], [], 0
    while total < n:
        a, b = random_ellipsoids(rng, 4 * n), random_ellipsoids(rng, 4 * n)
        idx = np.flatnonzero(np.abs(contact_scale(a, b) - 1.0) < band)
        keep_a.append(a[idx])
        keep_b.append(b[idx])
        total += len(idx)
    return Ellipsoids.concatenate(keep_a)[:n], Ellipsoids.concatenate(keep_b)[:n]


def _move_to_scale(a, b, target):
    """b translated along c_b - c_a so that contact_scale(a, b) is target (n,) (F is quadratic in the offset)."""
    d = b.centers - a.centers
    s = contact_scale(a, b)
    return Ellipsoids(a.centers + d * (target / s)[:, None], b.rotations, b.radii)


def _axis_frames(rng, n):
    """n signed-permutation rotations: exact in floats, so tangencies built on them stay exact."""
    perms = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1], [1, 0, 2], [0, 2, 1], [2, 1, 0]])
    rot = np.zeros((n, 3, 3))
    p = perms[rng.integers(0, 6, n)]
    signs = rng.choice([-1.0, 1.0], (n, 3))
    rot[np.arange(n)[:, None], np.arange(3)[None, :], p] = signs
    return rot


def _dyadic(rng, shape, lo=1, hi=64):
    """Numbers k / 16 with few bits, so their sums are exact."""
    return rng.integers(lo, hi, shape) / 16.0


STRESS = (
    "near-tangent 1e-1",
    "near-tangent 1e-3",
    "near-tangent 1e-6",
    "near-tangent 1e-9",
    "near-tangent 1e-12",
    "near-tangent 1e-15",
    "exactly tangent",
    "spheres",
    "coaxial spheroids",
    "identical and contained",
    "aspect 1e2",
    "aspect 1e3",
    "aspect 1e4",
    "offset 1e3",
    "offset 1e5",
    "offset 1e7",
    "scale 1e-6",
    "scale 1e6",
)


def stress_pairs(category, n, *, seed=0):
    """n pairs of one numerically hard category (STRESS), half just separated and half just overlapping
    where the category has a gap; the thesis methods' weak spots and MuJoCo's tolerance are here.

    near-tangent 1e-k: random pairs moved to contact_scale 1 -+ 10^-k.  exactly tangent: axis-aligned
    dyadic ellipsoids meeting on an axis (touching, exactly).  spheres: dyadic spheres exactly
    touching, or 2^-40 apart or overlapping.  coaxial spheroids: spheroids on a common axis, touching or
    2^-40 off.  identical and contained: the same ellipsoid, a concentric half-size copy, or an
    internally tangent sphere.  aspect 1e{2,3,4}: semi-axis ratio up to that, contact_scale 1 -+ 1e-6.
    offset 1e{3,5,7}: near-tangent (1e-6) pairs translated that far.  scale 1e-6 / 1e6: scaled.
    """
    if category not in STRESS:
        raise ValueError(f"category must be one of {STRESS}, got {category!r}")
    rng = np.random.default_rng(seed)
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    if category.startswith("near-tangent"):
        gap = float(category.split()[1])
        a, b = random_ellipsoids(rng, n), random_ellipsoids(rng, n)
        return a, _move_to_scale(a, b, 1.0 + sign * gap)
    if category == "exactly tangent":
        ra, rb, rot = _dyadic(rng, (n, 3)), _dyadic(rng, (n, 3)), _axis_frames(rng, n)
        axis = rot[:, :, 0]  # the world direction of each pair's first local axis
        shift = _dyadic(rng, (n, 3), -64, 64)
        return (Ellipsoids(shift, rot, ra), Ellipsoids(shift + axis * (ra[:, :1] + rb[:, :1]), rot, rb))
    if category == "spheres":
        ra, rb = _dyadic(rng, n), _dyadic(rng, n)
        off = np.where(np.arange(n) % 3 == 0, 0.0, sign * 2.0**-40)
        axis = _axis_frames(rng, n)[:, :, 0]
        c = axis * (ra + rb + off)[:, None]
        return (
            Ellipsoids(np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.repeat(ra[:, None], 3, 1)),
            Ellipsoids(c, np.tile(np.eye(3), (n, 1, 1)), np.repeat(rb[:, None], 3, 1)),
        )
    if category == "coaxial spheroids":
        a0, a1, b0, b1 = (_dyadic(rng, n) for _ in range(4))
        rot = _axis_frames(rng, n)
        off = np.where(np.arange(n) % 3 == 0, 0.0, sign * 2.0**-40)
        c = rot[:, :, 0] * (a0 + b0 + off)[:, None]
        return (
            Ellipsoids(np.zeros((n, 3)), rot, np.stack([a0, a1, a1], 1)),
            Ellipsoids(c, rot, np.stack([b0, b1, b1], 1)),
        )
    if category == "identical and contained":
        a = random_ellipsoids(rng, n)
        kind = np.arange(n) % 3
        radii = np.where((kind == 0)[:, None], a.radii, a.radii * 0.5)
        b = Ellipsoids(a.centers, a.rotations, radii)
        tangent = kind == 2  # a sphere of radius r inside one of radius 2r, touching it from inside
        r = _dyadic(rng, n)
        eye = np.tile(np.eye(3), (n, 1, 1))
        a = Ellipsoids(
            np.where(tangent[:, None], 0.0, a.centers),
            np.where(tangent[:, None, None], eye, a.rotations),
            np.where(tangent[:, None], 2 * r[:, None], a.radii),
        )
        b = Ellipsoids(
            np.where(tangent[:, None], np.stack([r, 0 * r, 0 * r], 1), b.centers),
            np.where(tangent[:, None, None], eye, b.rotations),
            np.where(tangent[:, None], r[:, None], b.radii),
        )
        return a, b
    if category.startswith("aspect"):
        big = float(category.split()[1])
        ra = np.column_stack([np.full(n, big), np.ones(n), rng.uniform(1, 3, n)]) * rng.uniform(0.5, 2, (n, 1))
        rb = np.column_stack([rng.uniform(1, 3, n), np.full(n, 1 / big) * big / 10, np.ones(n)]) * rng.uniform(
            0.5, 2, (n, 1)
        )
        a = Ellipsoids.from_quaternions(np.zeros((n, 3)), rng.normal(size=(n, 4)), ra / big)
        b = Ellipsoids.from_quaternions(rng.normal(size=(n, 3)), rng.normal(size=(n, 4)), rb / big)
        return a, _move_to_scale(a, b, 1.0 + sign * 1e-6)
    a, b = random_ellipsoids(rng, n), random_ellipsoids(rng, n)
    b = _move_to_scale(a, b, 1.0 + sign * 1e-6)
    k = float(category.split()[1])
    if category.startswith("offset"):
        shift = rng.normal(size=(n, 3))
        shift *= k / np.linalg.norm(shift, axis=1, keepdims=True)
        return (
            Ellipsoids(a.centers + shift, a.rotations, a.radii),
            Ellipsoids(b.centers + shift, b.rotations, b.radii),
        )
    return (Ellipsoids(a.centers * k, a.rotations, a.radii * k), Ellipsoids(b.centers * k, b.rotations, b.radii * k))
