"""Broad phase over many frames: which ellipsoid pairs of which frames may touch, in one batch.

A kinematic replay (or a recording) poses the same g ellipsoids in F frames.  Sweep and prune per
frame over bounding spheres (Cohen, Lin, Manocha & Ponamgi, I-COLLIDE, 1995: sort the intervals
along an axis, sweep) gives the candidate pairs; ellipsim.mujoco.geoms filters them by MuJoCo's
rules, and one batched exact `classify` decides them all.

Between two consecutive frames (swept_pairs, for ellipsim.mujoco.between): the same sweep once per
block of steps over each geom's box of centres, then per step the centres' closest approach and
enclosing capsules bounded over the step by conservative advancement.
"""

import math

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..tolerances import PARALLEL_MIN_PAIRS, U


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


@jit
def _block_pairs(centers, rho, block, g_unit, allowed, out, count, lo, hi):
    """Geoms whose boxes of centres over a block's frames, grown by rho (and rounding room), overlap
    (and allowed[i, j], unless allowed is (0, 0)): sweep and prune along the axis of widest spread.
    Block bk is swept by the call whose [lo, hi) holds bk * g_unit (threads.run's ranges); its pairs
    (i, j), i < j, go to out[bk, :cap], their number to count[bk] (all of them: more than cap asks for
    a rerun with more room)."""
    F, g = centers.shape[0], centers.shape[1]
    cap = out.shape[1]
    check = allowed.shape[0] > 0
    lo3 = np.empty((g, 3))
    hi3 = np.empty((g, 3))
    for bk in range((lo + g_unit - 1) // g_unit, (hi + g_unit - 1) // g_unit):
        f0, f1 = bk * block, min((bk + 1) * block, F - 1)  # frames f0..f1
        for i in range(g):
            room = rho[i] * (1 + 8 * U)
            for k in range(3):
                a = b = centers[f0, i, k]
                for f in range(f0 + 1, f1 + 1):
                    a = min(a, centers[f, i, k])
                    b = max(b, centers[f, i, k])
                r = room + 32 * U * max(abs(a), abs(b))
                lo3[i, k], hi3[i, k] = a - r, b + r
        axis, widest = 0, -1.0
        for k in range(3):
            spread = hi3[:, k].max() - lo3[:, k].min()
            if spread > widest:
                axis, widest = k, spread
        order = np.argsort(lo3[:, axis])
        n = 0
        for a in range(g):
            i = order[a]
            top = hi3[i, axis]
            for b in range(a + 1, g):
                j = order[b]
                if lo3[j, axis] > top:
                    break
                if (lo3[j, 0] > hi3[i, 0] or lo3[i, 0] > hi3[j, 0] or lo3[j, 1] > hi3[i, 1] or lo3[i, 1] > hi3[j, 1]
                        or lo3[j, 2] > hi3[i, 2] or lo3[i, 2] > hi3[j, 2]):  # fmt: skip
                    continue
                if check and not allowed[i, j]:
                    continue
                if n < cap:
                    out[bk, n, 0], out[bk, n, 1] = min(i, j), max(i, j)
                n += 1
        count[bk] = n


@jit
def _compact(out, count, blocks):
    """blocks (sum(count), 3): (block, i, j) of out[bk, :count[bk]], block by block."""
    n = 0
    for bk in range(count.shape[0]):
        for m in range(count[bk]):
            blocks[n, 0], blocks[n, 1], blocks[n, 2] = bk, out[bk, m, 0], out[bk, m, 1]
            n += 1


@jit
def _segment_distance(p0, p1, p2, q0, q1, q2, d10, d11, d12, d20, d21, d22):
    """Distance between segments p + s d1 and q + t d2, s, t in [0, 1]: Ericson, Real-Time Collision
    Detection (2005) 5.1.9, ClosestPtSegmentSegment.  Computed on the offsets scaled by a power of two
    to the order of 1 (exact: same result bit for bit at ordinary scales), since its denominator is
    of the fourth power of the scale: at 2^+-260 it overflowed or underflowed."""
    r0, r1, r2 = p0 - q0, p1 - q1, p2 - q2
    m = max(abs(r0), abs(r1), abs(r2), abs(d10), abs(d11), abs(d12), abs(d20), abs(d21), abs(d22))
    k = math.frexp(m)[1] if 0.0 < m < math.inf else 0
    if -200 < k < 200:  # a * e - b * b within float64's range: as written
        return _segment_distance_scaled(r0, r1, r2, d10, d11, d12, d20, d21, d22)
    u = math.ldexp(1.0, -k)
    dist = _segment_distance_scaled(r0 * u, r1 * u, r2 * u, d10 * u, d11 * u, d12 * u, d20 * u, d21 * u, d22 * u)
    return math.ldexp(dist, k)


@stage
def _segment_distance_scaled(r0, r1, r2, d10, d11, d12, d20, d21, d22):
    """_segment_distance on the offset r = p - q of the segments' starts."""
    a = d10 * d10 + d11 * d11 + d12 * d12
    e = d20 * d20 + d21 * d21 + d22 * d22
    f = d20 * r0 + d21 * r1 + d22 * r2
    s = t = 0.0
    if a == 0.0:
        if e > 0.0:
            t = min(max(f / e, 0.0), 1.0)
    else:
        c = d10 * r0 + d11 * r1 + d12 * r2
        if e == 0.0:
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d10 * d20 + d11 * d21 + d12 * d22
            denom = a * e - b * b
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 0.0 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    x0 = r0 + s * d10 - t * d20
    x1 = r1 + s * d11 - t * d21
    x2 = r2 + s * d12 - t * d22
    return math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


@jit
def _capsule_motion(centers, rotations, axis, half, ends, bend):
    """Per frame and geom, ends (F, g, 2, 3): the capsule segment's two ends (centre -/+ half along its
    axis); per step and geom, bend (F - 1, g): how far the rotating segment strays from the lerp of
    its ends, inf beyond PLAIN_COS.

    A point at distance h from the centre turns on a circle, by theta, so it stays within
    h theta^2 / 8 of the chord's point at the same t (interpolation error: t (1 - t) / 2 max |f''|),
    and theta / 2 <= tan(theta / 2) = sqrt((1 - c) / (1 + c)), c = cos theta = (tr R0^T R1 - 1) / 2."""
    F, g = centers.shape[0], centers.shape[1]
    for f in range(F):
        for i in range(g):
            h, ax = half[i], axis[i]
            for k in range(3):
                c, d = centers[f, i, k], h * rotations[f, i, k, ax]
                ends[f, i, 0, k], ends[f, i, 1, k] = c - d, c + d
    for f in range(F - 1):
        for i in range(g):
            tr = 0.0
            for k in range(3):
                for m in range(3):
                    tr += rotations[f, i, k, m] * rotations[f + 1, i, k, m]
            c = 0.5 * (tr - 1.0)
            if c < PLAIN_COS:
                bend[f, i] = math.inf
            else:
                bend[f, i] = half[i] * min(0.5 * max(1.0 - c, 0.0) / (1.0 + c), 2.0)


@jit
def _capsule_gap(a0, a1, b0, b1, t, reach):
    """Distance less `reach` at t of the segments whose ends (2, 3) move linearly from a0 to a1 and
    from b0 to b1."""
    pa0, pa1, pa2 = (
        a0[0, 0] + t * (a1[0, 0] - a0[0, 0]),
        a0[0, 1] + t * (a1[0, 1] - a0[0, 1]),
        a0[0, 2] + t * (a1[0, 2] - a0[0, 2]),
    )
    qa0, qa1, qa2 = (
        a0[1, 0] + t * (a1[1, 0] - a0[1, 0]),
        a0[1, 1] + t * (a1[1, 1] - a0[1, 1]),
        a0[1, 2] + t * (a1[1, 2] - a0[1, 2]),
    )
    pb0, pb1, pb2 = (
        b0[0, 0] + t * (b1[0, 0] - b0[0, 0]),
        b0[0, 1] + t * (b1[0, 1] - b0[0, 1]),
        b0[0, 2] + t * (b1[0, 2] - b0[0, 2]),
    )
    qb0, qb1, qb2 = (
        b0[1, 0] + t * (b1[1, 0] - b0[1, 0]),
        b0[1, 1] + t * (b1[1, 1] - b0[1, 1]),
        b0[1, 2] + t * (b1[1, 2] - b0[1, 2]),
    )
    return (
        _segment_distance(
            pa0, pa1, pa2, pb0, pb1, pb2, qa0 - pa0, qa1 - pa1, qa2 - pa2, qb0 - pb0, qb1 - pb1, qb2 - pb2
        )
        - reach
    )


@jit
def _capsules_apart(a0, a1, b0, b1, speed, reach):
    """True when the segments whose ends (2, 3) move linearly from a0 to a1 and from b0 to b1 stay
    further apart than `reach` for every t in [0, 1]: conservative advancement (with a
    gap d - reach > 0 at t, every t' within gap / speed of t is apart: `speed` bounds the rate of
    change of their distance), from the middle outwards, CAPSULE_STEPS distances at most."""
    gap = _capsule_gap(a0, a1, b0, b1, 0.5, reach)
    if gap <= 0.0:  # the capsules meet at t = 1/2
        return False
    reach_up = 0.5 + gap / speed * (1 - 1e-9)  # proven: (0.5 - gap / speed, reach_up)
    reach_down = 0.5 - gap / speed * (1 - 1e-9)
    for _ in range(CAPSULE_STEPS - 1):
        if reach_up >= 1.0 and reach_down <= 0.0:
            return True
        up = reach_up < 1.0 and (reach_down <= 0.0 or 1.0 - reach_up <= reach_down)  # the shorter side first
        t = reach_up if up else reach_down
        gap = _capsule_gap(a0, a1, b0, b1, t, reach)
        if gap <= 0.0:
            return False
        if up:
            reach_up = t + gap / speed * (1 - 1e-9)
        else:
            reach_down = t - gap / speed * (1 - 1e-9)
    return reach_up >= 1.0 and reach_down <= 0.0


@jit
def _step_pairs(blocks, block, centers, rho, ends, bend, cap, big, keep, lo, hi):
    """keep[p, k]: block pair p = (block, i, j) of `blocks` passes the per-step tests at the block's
    step k, for p in [lo, hi)."""
    F = centers.shape[0]
    for p in range(lo, hi):
        bk, i, j = blocks[p, 0], blocks[p, 1], blocks[p, 2]
        for s in range(bk * block, bk * block + block):
            keep[p, s - bk * block] = False
            if s >= F - 1:
                continue
            # the closest approach of the centres' straight paths against the bounding radii, with
            # room for the rounding of the differences (a few ulps of the coordinates)
            d0x = centers[s, j, 0] - centers[s, i, 0]
            d0y = centers[s, j, 1] - centers[s, i, 1]
            d0z = centers[s, j, 2] - centers[s, i, 2]
            ex = (centers[s + 1, j, 0] - centers[s + 1, i, 0]) - d0x
            ey = (centers[s + 1, j, 1] - centers[s + 1, i, 1]) - d0y
            ez = (centers[s + 1, j, 2] - centers[s + 1, i, 2]) - d0z
            ee = ex * ex + ey * ey + ez * ez
            t = min(max(-(d0x * ex + d0y * ey + d0z * ez) / (ee if ee > 0.0 else 1.0), 0.0), 1.0)
            cx, cy, cz = d0x + t * ex, d0y + t * ey, d0z + t * ez
            coord = 0.0
            for f in range(2):
                for k in range(3):
                    coord = max(coord, abs(centers[s + f, i, k]), abs(centers[s + f, j, k]))
            rr = (rho[i] + rho[j]) * (1 + 8 * U) + 64 * U * coord
            if cx * cx + cy * cy + cz * cz > rr * rr:
                continue
            if bend[s, i] < math.inf and bend[s, j] < math.inf:
                a0, a1, b0, b1 = ends[s, i], ends[s + 1, i], ends[s, j], ends[s + 1, j]
                # a point of one lerped segment less one of the other moves by a convex combination
                # of the four differences of their ends' displacements: the distance's speed is at
                # most the largest of them
                speed = 0.0
                for x in range(2):
                    for y in range(2):
                        m = 0.0
                        for k in range(3):
                            m += ((a1[x, k] - a0[x, k]) - (b1[y, k] - b0[y, k])) ** 2
                        speed = max(speed, m)
                speed = math.sqrt(speed)
                room = cap[i] + cap[j] + bend[s, i] + bend[s, j] + CAPSULE_SLACK * (big[i] + big[j]) + 1e-12 * coord
                if _capsules_apart(a0, a1, b0, b1, speed * (1 + 1e-9), room):
                    continue
            keep[p, s - bk * block] = True


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
