"""Broad phase over many frames: which ellipsoid pairs of which frames may touch, in one batch.

A kinematic replay (or a recording) poses the same g ellipsoids in F frames.  Sweep and prune per
frame over bounding spheres (Cohen, Lin, Manocha & Ponamgi, I-COLLIDE, 1995: sort the intervals
along an axis, sweep) gives the candidate pairs; ellipsim.mujoco.geoms filters them by MuJoCo's
rules, and one batched exact `classify` decides them all.
"""

import numpy as np

from ._jit import jit


@jit
def sweep_and_prune(centers, rho):
    """Pairs (frame, i, j), i < j, whose bounding spheres overlap in each frame: sort by c - rho along
    the frame's axis of widest spread (figures in a line along y must not be swept along x), sweep.

    centers : (F, g, 3), rho : (g,) bounding radii.  Returns (P, 3) int64, sorted by frame.  Which
    of these pairs may collide at all (MuJoCo's contype, parent and exclude rules) is the caller's
    filter: a (g, g) matrix here would be quadratic in memory.
    """
    F, g = centers.shape[0], centers.shape[1]
    cap = 1024
    out = np.empty((cap, 3), dtype=np.int64)
    n = 0
    for f in range(F):
        axis, widest = 0, -1.0
        for k in range(3):
            spread = centers[f, :, k].max() - centers[f, :, k].min() if g else 0.0
            if spread > widest:
                axis, widest = k, spread
        lo = centers[f, :, axis] - rho
        order = np.argsort(lo)
        for a in range(g):
            i = order[a]
            hi = centers[f, i, axis] + rho[i]
            for b in range(a + 1, g):
                j = order[b]
                if lo[j] > hi:
                    break
                dx = centers[f, i, 0] - centers[f, j, 0]
                dy = centers[f, i, 1] - centers[f, j, 1]
                dz = centers[f, i, 2] - centers[f, j, 2]
                r = rho[i] + rho[j]
                if dx * dx + dy * dy + dz * dz <= r * r:
                    if n == cap:
                        bigger = np.empty((2 * cap, 3), dtype=np.int64)
                        bigger[:n] = out[:n]
                        out, cap = bigger, 2 * cap
                    out[n, 0], out[n, 1], out[n, 2] = f, min(i, j), max(i, j)
                    n += 1
    return out[:n]
