"""Ellipsoid x convex polytope, the slow reference written apart from the library (issue 48's oracle).

The signed distance of the ellipsoid E = {c + R diag(r) u : |u| <= 1} and the convex hull P of the vertices V is
the maximum over unit n of (Schneider & Eberly 10.5.2: support functions)

    sigma(n) = min_v n.v - n.c - |diag(r) R^T n|,        the normal n from E to P,

positive apart, minus the penetration depth when they overlap.  sigma is smooth except where the minimising
vertex changes: the sphere splits into each vertex's open region (sigma = f_v(n) = n.(v - c) - h_E(n), smooth),
the arcs where two vertices tie (an edge's: n normal to it) and the points where three tie (a face's normal).

Here: sigma on a Fibonacci grid of 20 000 directions; from its best directions, each stratum they lie near
refined in 40-digit mpmath (a vertex's f_v by Newton on the sphere, an edge's arc by golden section on the great
circle normal to the edge, a face's normal as it is), kept where the refined point still lies in its stratum
(its vertices the minimisers, to 1e-20).  The best of the grid and the refined candidates: a lower bound on the
maximum that the grid makes tight (the true maximiser lies in one of the strata refined).  Nothing here is
shared with ellipsim's kernels.
"""

import itertools

import mpmath as mp
import numpy as np

DPS = 40
GOLDEN = (mp.sqrt(5) - 1) / 2


def fibonacci(k):
    i = np.arange(k) + 0.5
    phi, th = np.arccos(1 - 2 * i / k), np.pi * (1 + 5**0.5) * i
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1)


GRID = fibonacci(20_000)


def sigma_np(n, c, R, r, V):
    """sigma at the rows of n (k, 3), float64."""
    n = n / np.linalg.norm(n, axis=1)[:, None]
    return (n @ V.T).min(1) - n @ c - np.linalg.norm((n @ R) * r, axis=1)


class _Mp:
    """The pose in mpmath numbers: E's quadratic form M = R diag(r^2) R^T, c, the vertices."""

    def __init__(self, c, R, r, V):
        R = np.asarray(R, float)
        self.M = mp.matrix((R * np.asarray(r, float) ** 2 @ R.T).tolist())
        self.c = mp.matrix([mp.mpf(float(x)) for x in c])
        self.V = [mp.matrix([mp.mpf(float(x)) for x in v]) for v in V]

    def h(self, n):
        return mp.sqrt((n.T * self.M * n)[0])

    def sigma(self, n):
        n = n / mp.norm(n)
        return min((n.T * v)[0] for v in self.V) - (n.T * self.c)[0] - self.h(n)

    def minimisers(self, n, tie):
        n = n / mp.norm(n)
        vals = [(n.T * v)[0] for v in self.V]
        lo = min(vals)
        return {i for i, x in enumerate(vals) if x - lo <= tie}


def _vertex_max(P, i, n0, iterations=80):
    """Newton on the sphere for f_v(n) = n.(v - c) - h_E(n), v = V[i], from n0: the Lagrange system
    q - M n / h - lam n = 0, |n| = 1 (q = v - c)."""
    q = P.V[i] - P.c
    n = mp.matrix([mp.mpf(float(x)) for x in n0])
    n = n / mp.norm(n)
    for _ in range(iterations):
        Mn = P.M * n
        h = mp.sqrt((n.T * Mn)[0])
        g = q - Mn / h
        lam = (n.T * g)[0]
        F = g - lam * n
        if mp.norm(F) < mp.mpf(10) ** (-DPS + 5):
            break
        # the tangent Hessian of f_v: -(M / h - Mn Mn^T / h^3) - lam I, projected; a Newton step in the plane
        H = -(P.M / h - Mn * Mn.T / h**3) - lam * mp.eye(3)
        Pn = mp.eye(3) - n * n.T
        A = Pn * H * Pn + n * n.T  # (the normal direction pinned)
        try:
            step = mp.lu_solve(A, -(Pn * F))
        except ZeroDivisionError:
            break
        if mp.norm(step) > 0.3:
            step = step * (0.3 / mp.norm(step))
        m = n + step
        n = m / mp.norm(m)
    return n


def _circle_max(P, w, n0, iterations=200):
    """Golden section for sigma on the great circle normal to w, around n0's angle (+- 0.4 rad)."""
    w = w / mp.norm(w)
    n0 = mp.matrix([mp.mpf(float(x)) for x in n0])
    p1 = n0 - (n0.T * w)[0] * w
    if mp.norm(p1) < mp.mpf(10) ** -30:
        return None
    p1 = p1 / mp.norm(p1)
    p2 = mp.matrix([w[1] * p1[2] - w[2] * p1[1], w[2] * p1[0] - w[0] * p1[2], w[0] * p1[1] - w[1] * p1[0]])

    def at(t):
        return mp.cos(t) * p1 + mp.sin(t) * p2

    lo, hi = mp.mpf(-0.4), mp.mpf(0.4)
    x1, x2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    f1, f2 = P.sigma(at(x1)), P.sigma(at(x2))
    for _ in range(iterations):
        if f1 >= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - GOLDEN * (hi - lo)
            f1 = P.sigma(at(x1))
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + GOLDEN * (hi - lo)
            f2 = P.sigma(at(x2))
    return at(x1)


def signed_distance(c, R, r, V, seeds=6):
    """(value, normal): the reference maximum of sigma (module docstring) for one ellipsoid (c, R (3, 3), r) and
    the hull of V (m, 3), the normal from E to P."""
    c, R, r, V = (np.asarray(x, float) for x in (c, R, r, V))
    g = sigma_np(GRID, c, R, r, V)
    best_v, best_n = float(np.max(g)), GRID[int(np.argmax(g))]
    chosen = []
    for i in np.argsort(-g)[:2000]:
        if len(chosen) < seeds and all(GRID[i] @ m < np.cos(0.05) for m in chosen):
            chosen.append(GRID[i])
    scale = float(np.abs(V - c).max() + r.max())
    with mp.workdps(DPS):
        P = _Mp(c, R, r, V)
        tie = mp.mpf(10) ** -20 * scale
        for n0 in chosen:
            lows = np.argsort(n0 @ V.T)[:8]  # the vertices nearest to minimising n.v there, at most 8
            near = sorted(i for i in P.minimisers(mp.matrix(n0.tolist()), mp.mpf(0.05) * scale) if i in lows)
            candidates = []
            for i in near:  # vertex regions
                n = _vertex_max(P, i, n0)
                if i in P.minimisers(n, tie):
                    candidates.append(n)
            for i, j in itertools.combinations(near, 2):  # edges' arcs
                n = _circle_max(P, P.V[i] - P.V[j], n0)
                if n is not None and {i, j} <= P.minimisers(n, tie):
                    candidates.append(n)
            for i, j, k in itertools.combinations(near, 3):  # faces' normals
                a, b = P.V[j] - P.V[i], P.V[k] - P.V[i]
                m = mp.matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
                if mp.norm(m) == 0:
                    continue
                for n in (m, -m):
                    if {i, j, k} <= P.minimisers(n, tie):
                        candidates.append(n / mp.norm(n))
            for n in candidates:
                v = P.sigma(n)
                if v > best_v:
                    best_v, best_n = v, np.array([float(x) for x in n / mp.norm(n)])
    return float(best_v), best_n
