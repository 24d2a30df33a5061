"""Broad phase over many frames: which ellipsoid pairs of which frames may touch, in one batch.

A kinematic replay (or a recording) poses the same g ellipsoids in F frames.  Sweep and prune per
frame over bounding spheres (Cohen, Lin, Manocha & Ponamgi, I-COLLIDE, 1995: sort the intervals
along an axis, sweep) gives the candidate pairs; ellipsim.mujoco.geoms filters them by MuJoCo's
rules, and one batched exact `classify` decides them all.

Between two consecutive frames (swept_pairs, for ellipsim.mujoco.between): the same sweep once per
block of steps over each geom's box of centres, then per step the centres' closest approach and
enclosing capsules bounded over the step by conservative advancement.

The kernels are C++, ellipsim/native/include/ellipsim/motion/broad_phase.hpp (bound in the _ellipsim module).
"""

import numpy as np

from ...native import ext
from .. import threads
from ..tolerances import PARALLEL_MIN_PAIRS


def sweep_and_prune(centers, rho):
    """Pairs (frame, i, j), i < j, whose bounding spheres overlap in each frame: sort by c - rho along
    the frame's axis of widest spread (figures in a line along y must not be swept along x), sweep.

    centers : (F, g, 3), rho : (g,) bounding radii.  Returns (P, 3) int64, sorted by frame.  Which
    of these pairs may collide at all (MuJoCo's contype, parent and exclude rules) is the caller's
    filter: a (g, g) matrix here would be quadratic in memory.
    """
    return ext.sweep_and_prune(
        np.ascontiguousarray(centers, dtype=np.float64), np.ascontiguousarray(rho, dtype=np.float64)
    )


# --- between two frames ---------------------------------------------------------------------------

#: Steps per sweep in swept_pairs: one sweep over each geom's box of centres across the block, then
#: the per-step tests on the pairs it finds.  Sweeps + per-step tests per 1024 frames of the 16-figure
#: replays (gentle / violent hinge motions, one thread): 2 steps 48 / 110 ms, 4 26 / 89, 8 18 / 94.
SWEEP_BLOCK = 4

#: Pairs per geom each block's sweep has room for at first (a crowded block reruns the sweep with
#: room for all; 16 figures: 2-8 pairs per geom).
BLOCK_ROOM = 16

#: Room the capsule test of swept_pairs leaves, relative to the pair's longest semi-axes: rotations are
#: orthonormal only to ORTHONORMAL_TOL = 1e-6 (the ellipsoid of such an R lies within ~3e-6 r of its
#: capsule), the interpolated rotation reaches R1 within that too, and the segment distance is rounded
#: (~sqrt(u) relative when the segments are nearly parallel).  1e-4 is 30x the largest of these; a pair
#: within it of touching just goes on to the exact time_of_impact.
CAPSULE_SLACK = 1e-4

#: Distances the capsule test's conservative advancement evaluates before it gives up (the pair is
#: kept).  16 keeps 10% fewer pairs of the violent replay (71k of 79k per 1024 frames) for about the
#: time time_of_impact saves on them; 3 keeps 50% more.
CAPSULE_STEPS = 8

#: Geoms whose cos theta = (tr R0^T R1 - 1) / 2 in a step is below PLAIN_COS (turning by more than
#: ~120 degrees) get the sphere tests only: core.motion.interpolation has no motion near a half turn, and
#: mujoco.between reports those pairs as they are, deciding the half turn from cos < -1/2 and then
#: the angle; 1e-3 is room for rotations orthonormal to 1e-6 only.
PLAIN_COS = -0.5 + 1e-3


def capsules(radii):
    """Capsules enclosing the ellipsoids: (g,) int64 axis (the column of R along the longest
    semi-axis r1), (g,) half-length r1 - r2 of the segment, (g,) radius r2 (the second largest).

    With x1 along the longest axis, x2^2 + x3^2 <= r2^2 (1 - x1^2 / r1^2) on the ellipsoid, so a point
    at |x1| > r1 - r2 lies within r2 of the segment's end: |x1| - r1 + r2 <= r2 |x1| / r1 there."""
    radii = np.asarray(radii, dtype=np.float64)
    axis = np.argmax(radii, axis=1).astype(np.int64)
    s = np.sort(radii, axis=1)
    return axis, s[:, 2] - s[:, 1], np.ascontiguousarray(s[:, 1])


def swept_pairs(centers, rotations, radii, rho, allowed=None):
    """Pairs (step, i, j), i < j, of consecutive frames step, step + 1 whose ellipsoids may touch in
    between while each moves as core.motion.interpolation interpolates (centre linear, rotation at constant angular
    velocity): a necessary condition, with room for rounding.

    centers : (F, g, 3) metres; rotations : (F, g, 3, 3); radii : (g, 3) semi-axes, metres; rho : (g,)
    bounding radii (at least the longest semi-axis); allowed : which geom pairs may collide at all (the
    caller's rules), optional: a (g, g) bool matrix, or a callable(i, j) -> (k,) bool for a g too large
    for one.  Returns (P, 3) int64, sorted by step.

    Sweep and prune (I-COLLIDE, above) once per SWEEP_BLOCK steps over each geom's box of centres
    grown by rho; `allowed`; then per step the exact closest approach of the two centres' straight
    paths against rho_i + rho_j, and enclosing capsules (`capsules`) whose segments' ends move
    linearly, grown by the rotation's bend, apart over the whole step by conservative advancement
    (Mirtich, "Timewarp rigid body simulation", SIGGRAPH 2000: distance minus speed times time).
    Geoms turning by more than ~120 degrees in a step (PLAIN_COS) get the sphere tests only.
    """
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    rotations = np.ascontiguousarray(rotations, dtype=np.float64)
    F, g = centers.shape[0], centers.shape[1]
    if F < 2 or g < 2:
        return np.zeros((0, 3), dtype=np.int64)
    rho = np.ascontiguousarray(rho, dtype=np.float64)
    nb = (F - 2) // SWEEP_BLOCK + 1
    parallel = nb * g >= PARALLEL_MIN_PAIRS
    matrix = allowed if isinstance(allowed, np.ndarray) else np.zeros((0, 0), dtype=bool)
    if len(matrix) and matrix.shape != (g, g):
        raise ValueError(f"allowed must be a ({g}, {g}) matrix or a callable, got shape {matrix.shape}")
    out, count = np.empty((nb, BLOCK_ROOM * g, 2), dtype=np.int32), np.zeros(nb, dtype=np.int64)
    threads.run(ext.block_pairs, nb * g, parallel, centers, rho, SWEEP_BLOCK, g, matrix, out, count)
    if count.max() > out.shape[1]:  # a crowded block: all of them again with room for the most
        out = np.empty((nb, int(count.max()), 2), dtype=np.int32)
        threads.run(ext.block_pairs, nb * g, parallel, centers, rho, SWEEP_BLOCK, g, matrix, out, count)
    blocks = np.empty((int(count.sum()), 3), dtype=np.int64)
    ext.compact(out, count, blocks)
    if callable(allowed):
        blocks = np.ascontiguousarray(blocks[allowed(blocks[:, 1], blocks[:, 2])])
    axis, half, cap = capsules(radii)
    big = np.asarray(radii, dtype=np.float64).max(axis=1)
    ends, bend = np.empty((F, g, 2, 3)), np.empty((F - 1, g))
    ext.capsule_motion(centers, rotations, axis, half, ends, bend)
    keep = np.empty((len(blocks), SWEEP_BLOCK), dtype=bool)
    threads.run(
        ext.step_pairs,
        len(blocks),
        len(blocks) >= PARALLEL_MIN_PAIRS,
        blocks,
        SWEEP_BLOCK,
        centers,
        rho,
        ends,
        bend,
        cap,
        big,
        keep,
    )
    p, k = np.nonzero(keep)
    pairs = np.column_stack([blocks[p, 0] * SWEEP_BLOCK + k, blocks[p, 1], blocks[p, 2]])
    return pairs[np.argsort(pairs[:, 0], kind="stable")]
