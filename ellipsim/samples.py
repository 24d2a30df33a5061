"""Reproducible sets of ellipsoid pairs for the demo and the benchmarks.

`generic_pairs` follows the thesis's generic sets (5.1.1): random semi-axes, orientations and
positions, half of the pairs colliding and half separated.  `near_contact_pairs` keeps only pairs
whose Perram-Wertheim scale is within a band around 1, where no shortcut applies.
"""

import numpy as np

from .classify import classify
from .contact import contact_scale
from .ellipsoids import Ellipsoids


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
    rng = np.random.default_rng(seed)
    keep_a, keep_b, total = [], [], 0
    while total < n:
        a, b = random_ellipsoids(rng, 4 * n), random_ellipsoids(rng, 4 * n)
        idx = np.flatnonzero(np.abs(contact_scale(a, b) - 1.0) < band)
        keep_a.append(a[idx])
        keep_b.append(b[idx])
        total += len(idx)
    return Ellipsoids.concatenate(keep_a)[:n], Ellipsoids.concatenate(keep_b)[:n]
