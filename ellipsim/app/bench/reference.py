"""The suite's yardstick for distance errors: signed distances to ~30 digits with mpmath.

sigma(n) = n.d - h_A(n) - h_B(-n) is polished by Newton in 40-digit arithmetic from given seed
normals (the narrow phase's own, in the suite: the reference measures how far a converged float
maximum is from the exact one, not whether it is global; the tests check that with oracles of their
own in tests/).
"""

import numpy as np

from ...core.distance.ellipsoid_pair import signed_distance


def reference_distances(a, b, seeds):
    """Signed distances to ~30 digits: sigma(n) polished by Newton in mpmath from each seed normal
    (k, 3) per pair (the best local maximum among them is kept)."""
    import mpmath

    mpmath.mp.dps = 40
    out = np.empty(len(a))
    for k in range(len(a)):
        d = b.centers[k] - a.centers[k]
        Ma = a.rotations[k] * a.radii[k] ** 2 @ a.rotations[k].T
        Mb = b.rotations[k] * b.radii[k] ** 2 @ b.rotations[k].T
        out[k] = max(float(polish_sigma(d, Ma, Mb, s[k])) for s in seeds if np.all(np.isfinite(s[k])))
    return out


def polish_sigma(d, Ma, Mb, n0, iterations=40):
    """sigma(n) = n.d - sqrt(n'Ma n) - sqrt(n'Mb n) at the local maximum nearest the unit normal n0,
    by Newton in the tangent plane in the current mpmath precision (d, Ma, Mb, n0 are float arrays;
    Ma = R diag(r^2) R' is the support-function matrix of an ellipsoid, Eberly GTCG 10.5.2)."""
    import mpmath as mp

    d = [mp.mpf(float(x)) for x in d]
    Ma, Mb = mp.matrix(np.asarray(Ma).tolist()), mp.matrix(np.asarray(Mb).tolist())
    n0 = mp.matrix([mp.mpf(float(x)) for x in n0])
    n0 /= mp.norm(n0)
    t1 = mp.matrix([0, n0[2], -n0[1]]) if abs(n0[0]) < 0.6 else mp.matrix([-n0[2], 0, n0[0]])
    t1 /= mp.norm(t1)
    t2 = mp.matrix([n0[1] * t1[2] - n0[2] * t1[1], n0[2] * t1[0] - n0[0] * t1[2], n0[0] * t1[1] - n0[1] * t1[0]])

    def f(u, v):
        n = n0 + u * t1 + v * t2
        n /= mp.norm(n)
        return sum(n[i] * d[i] for i in range(3)) - mp.sqrt((n.T * Ma * n)[0]) - mp.sqrt((n.T * Mb * n)[0])

    u = v = mp.mpf(0)
    for _ in range(iterations):
        gu, gv = mp.diff(lambda x: f(x, v), u), mp.diff(lambda y: f(u, y), v)
        huu, hvv = mp.diff(lambda x: f(x, v), u, 2), mp.diff(lambda y: f(u, y), v, 2)
        huv = mp.diff(lambda x: mp.diff(lambda y: f(x, y), v), u)
        det = huu * hvv - huv**2
        if det == 0:
            break
        du, dv = -(hvv * gu - huv * gv) / det, -(huu * gv - huv * gu) / det
        u, v = u + du, v + dv
        if abs(du) + abs(dv) < mp.mpf(10) ** (10 - mp.mp.dps):
            break
    return f(u, v)


def normals(a, b):
    """ellipsim's converged normals as seeds for the reference polish."""
    return signed_distance(a, b, parallel=False)[1]
