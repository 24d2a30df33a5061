"""Proven maximum of sigma for two spheroids with parallel axes of revolution (issue 18).

When A and B are spheroids (or a spheroid and a sphere) whose axes of revolution are parallel to a
line w, sigma(n) = n.e - h_A(n) - h_B(n) depends on n only through its angle t to w and its azimuth
phi about w, and only the offset e sees the azimuth: sigma = f(t) + |e_perp| sin t cos(phi - phi_e).
For every t the maximum over phi is at phi_e, so the maximum over the sphere is the maximum of two
coaxial ellipses' sigma in the plane of w and e_perp (Schneider & Eberly, Geometric Tools 10.5.2:
h(n) = |D R^T n|, which for a spheroid depends on (n.w)^2 only):
  g(z, r) = e_k z + |e_perp| r - sqrt(qa^2 z^2 + pa^2 r^2) - sqrt(qb^2 z^2 + pb^2 r^2),  (z, r) = (cos t, sin t),
maximised by a branch and bound over t in [0, pi] with the concave majorant of global_max.py's module
docstring, part 1, in two dimensions (g is concave and 1-homogeneous on R^2: on an arc of chord
radius rho around the unit c, g <= g(c) + |G_T| rho + max(-G.c, 0) rho^2 / 2).  With the axes on one
line through both centres (e_perp = 0) the maxima form circles about w, which global_max.py's branch
and bound over the sphere cannot isolate; with parallel axes and the centres off that line (a grid,
a line or a keyframe of equal rotations) they are isolated, but so nearly flat along the circle that
it runs out of budget there too.

In A's frame (e, a, U, b as in global_max.py) w is A's axis k; qa = a_k, pa = the mean of A's other
two semi-axes, qb = b_j for B's axis j nearest to w, pb = the mean of B's other two.  The pair need
not be exactly of revolution nor exactly parallel: for every unit n, with n's own (z, r) in the plane,
sigma(n) <= g(z, r) + delta and sigma(n*) >= g(z*, r*) - delta at the returned n* (in the plane), with
  delta = |a_k1 - a_k2| / 2                                 (A not exactly of revolution)
        + max|b - b0| (1 + 3 def) + (|qb^2 - pb^2| eps (2 + eps) + 3 pb^2 def) / min(qb, pb)
b0 = (qb, pb, pb) in B's order, eps = |u_j - s e_k| (B's axis off w, s its sign) and def =
max |U U^T - I| (h_B(n)^2 - h_B0(n)^2 = (qb^2 - pb^2)((u_j.n)^2 - n_k^2) + pb^2 (|U^T n|^2 - 1) for
B's semi-axes made b0; |(u_j.n)^2 - n_k^2| <= eps (|u_j| + 1), and |x - y| <= |x^2 - y^2| / y), plus
the roundings of the means, squares and |e_perp| (6 u S, S = |e| + max a + max b).  The answer is
proven within tol when the 1-D branch and bound is run to tol - 2 delta - ERR_G - ERR_SIGMA (g at the
returned angle and sigma at the returned n as computed): axes tilted by more than about tol / max b
are left to global_max.py.
"""

import math

from ._jit import jit, stage
from .tolerances import BB_ERR_SIGMA_ULPS, COAXIAL_MAX_NODES, PARALLEL_CANDIDATE_TILT as CANDIDATE_TILT

U64 = 2.0**-53
MAX_LEVEL = 52  # arcs of pi 2^-52: far below any tolerance reached
# Rounding, S = |e| + max a + max b: g at a float point c = (cos t, sin t) errs by <= 3 u |e| (two
# products, a sum) + 2.5 u max a + 2.5 u max b (each root of a sum of two rounded products of rounded
# squares) + 2 u S (the subtractions) + u S (|c| = 1 +- u, g is 1-homogeneous): ERR_G = 8 u S covers it;
# an arc's bound adds ~4 u S of its own sum to that (the gradient's error is epsg, times rho):
ERR_G_ULPS = 8.0
ARC_SLACK_ULPS = 12.0


@stage
def _g_grad(z, r, ek, ep, qa2, pa2, qb2, pb2):
    """(g(z, r), G = grad g (2,), h_A, h_B) at any nonzero (z, r)."""
    ha = math.sqrt(qa2 * z * z + pa2 * r * r)
    hb = math.sqrt(qb2 * z * z + pb2 * r * r)
    ia, ib = 1.0 / ha, 1.0 / hb
    return ek * z + ep * r - ha - hb, (ek - qa2 * z * ia - qb2 * z * ib, ep - pa2 * r * ia - pb2 * r * ib), ha, hb


@stage
def _arc_test(z, r, rho, g, G, epsg, lv):
    """g <= lv on the arc |n - c| <= rho around the unit c = (z, r): global_max._test in 2-D."""
    gc = G[0] * z + G[1] * r
    gt = abs(G[1] * z - G[0] * r)  # |G - (G.c) c|
    return g + (gt + epsg) * rho + max(-gc, 0.0) * rho * rho * 0.5000000000001 <= lv


@stage
def _axis_of(r):
    """The axis k whose two other semi-axes are closest to equal: (k, half their difference)."""
    best, kb = math.inf, 0
    for k in range(3):
        d = abs(r[(k + 1) % 3] - r[(k + 2) % 3])
        if d < best:
            best, kb = d, k
    return kb, 0.5 * best


@stage
def _delta(e, a, U, b, k, S):
    """(j, qb, pb, delta, eps): B's axis nearest to A's axis k and the bound delta of the module docstring
    (upwards), with A's and B's semi-axes across their axes taken as their means."""
    _, dbb = _axis_of(b)
    j, db = -1, math.inf
    for jj in range(3):  # B's axes of revolution (any, for a sphere): the one nearest to A's axis k
        d = 0.5 * abs(b[(jj + 1) % 3] - b[(jj + 2) % 3])
        if d <= dbb * (1.0 + 1e-9) and (j < 0 or abs(U[3 * k + jj]) > abs(U[3 * k + j])):
            j, db = jj, d
    k1, k2, j1, j2 = (k + 1) % 3, (k + 2) % 3, (j + 1) % 3, (j + 2) % 3
    qb, pb = b[j], 0.5 * (b[j1] + b[j2])
    ujk = U[3 * k + j]
    s = 1.0 if ujk >= 0.0 else -1.0
    eps = math.sqrt(U[3 * k1 + j] * U[3 * k1 + j] + U[3 * k2 + j] * U[3 * k2 + j] + (ujk - s) * (ujk - s))
    dfu = 0.0
    for p in range(3):
        for q in range(p, 3):
            v = U[3 * p] * U[3 * q] + U[3 * p + 1] * U[3 * q + 1] + U[3 * p + 2] * U[3 * q + 2] - (1.0 if p == q else 0.0)
            dfu = max(dfu, abs(v))
    dfu += 8.0 * U64
    delta = 0.5 * abs(a[k1] - a[k2]) + db * (1.0 + 3.0 * dfu)
    delta += (abs(qb * qb - pb * pb) * eps * (2.0 + eps) + 3.0 * pb * pb * dfu) / min(qb, pb)
    amax, bmax = max(a[0], a[1], a[2]), max(b[0], b[1], b[2])
    return j, qb, pb, delta * (1.0 + 1e-12) + 6.0 * U64 * S, eps


@jit
def parallel_max(e, a, U, b, tol, S):
    """The proven maximum of sigma(n) = n.e - |diag(a) n| - |diag(b) U^T n| on the unit sphere for two
    spheroids with (near) parallel axes, in A's frame (module docstring).

    tol: the tolerance to prove (global_max's tol_bb).  Returns (proven, unit n (3,), nodes): when
    proven, max sigma <= sigma(n) + tol for the exact sigma of (e, a, U, b); n lies in the plane of A's
    axis k and e_perp (of A's axes k and k + 1 when e_perp = 0: any azimuth is as good there).  Not
    proven when the axes are too far from parallel (2 delta + ERR_G + ERR_SIGMA leaves less than the
    arcs' rounding slack of tol) or the node budget runs out.  n is then the maximiser of the parallel
    model when the pair is within CANDIDATE_TILT of it (a start for global_max.py: there the true
    maxima are within 2 delta of that model's), else (0, 0, 0)."""
    none = (False, (0.0, 0.0, 0.0), 0)
    k, _ = _axis_of(a)
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    j, qb, pb, delta, eps = _delta(e, a, U, b, k, S)
    qa, pa = a[k], 0.5 * (a[k1] + a[k2])
    amax, bmax = max(a[0], a[1], a[2]), max(b[0], b[1], b[2])
    slack = ARC_SLACK_ULPS * U64 * S
    tol1 = tol - 2.0 * delta - (ERR_G_ULPS + BB_ERR_SIGMA_ULPS) * U64 * S
    provable = tol1 >= (ARC_SLACK_ULPS + 4.0) * U64 * S
    if not provable and not (eps <= CANDIDATE_TILT and delta <= CANDIDATE_TILT * S):
        return none
    ek, ep = e[k], math.sqrt(e[k1] * e[k1] + e[k2] * e[k2])
    qa2, pa2, qb2, pb2 = qa * qa, pa * pa, qb * qb, pb * pb
    # incumbent: the best of 33 angles, polished by Newton in t (only a start: the branch and bound
    # proves whatever it ends with)
    best, bt = -math.inf, 0.0
    for i in range(33):
        t = math.pi * i / 32.0
        g, _, _, _ = _g_grad(math.cos(t), math.sin(t), ek, ep, qa2, pa2, qb2, pb2)
        if g > best:
            best, bt = g, t
    t = bt
    for _ in range(30):
        z, r = math.cos(t), math.sin(t)
        g, G, ha, hb = _g_grad(z, r, ek, ep, qa2, pa2, qb2, pb2)
        # g(t) = ek cos t + ep sin t - sqrt(alpha) - sqrt(beta), alpha = pa2 + (qa2 - pa2) cos^2 t
        d1 = G[1] * z - G[0] * r
        s2, c2 = math.sin(2.0 * t), math.cos(2.0 * t)
        al1, be1 = -(qa2 - pa2) * s2, -(qb2 - pb2) * s2
        al2, be2 = -2.0 * (qa2 - pa2) * c2, -2.0 * (qb2 - pb2) * c2
        d2 = -ek * z - ep * r - (al2 / (2.0 * ha) - al1 * al1 / (4.0 * ha * ha * ha))
        d2 -= be2 / (2.0 * hb) - be1 * be1 / (4.0 * hb * hb * hb)
        if not d2 < 0.0:
            break
        step = max(-0.2, min(0.2, -d1 / d2))
        tn = min(math.pi, max(0.0, t + step))
        gn, _, _, _ = _g_grad(math.cos(tn), math.sin(tn), ek, ep, qa2, pa2, qb2, pb2)
        if not gn >= best:
            break
        best, bt, t = gn, tn, tn
        if abs(step) < 1e-15:
            break
    # the branch and bound over the arcs (level L, index i) of [0, pi], depth first, no allocation
    nodes = 0
    L, i = 1, 0
    while provable:
        nodes += 1
        if nodes > COAXIAL_MAX_NODES:
            return none
        w = math.pi * 2.0**-L
        tc = w * (i + 0.5)
        z, r = math.cos(tc), math.sin(tc)
        g, G, ha, hb = _g_grad(z, r, ek, ep, qa2, pa2, qb2, pb2)
        if g > best:
            best, bt = g, tc
        rho = 0.5 * w * (1.0 + 1e-15) + 4.0 * U64  # chord <= half the arc's length; c rounded by a few u
        epsg = U64 * (32.0 * (S + amax * amax / ha + bmax * bmax / hb) + 16.0 * S)
        if _arc_test(z, r, rho, g, G, epsg, best + tol1 - slack):
            while (i & 1) == 1 and L > 1:  # the next arc after this one's subtree
                i >>= 1
                L -= 1
            if (i & 1) == 1:
                break
            i += 1
        elif L >= MAX_LEVEL:
            return none
        else:
            L += 1
            i *= 2
    z, r = math.cos(bt), math.sin(bt)
    u1, u2 = (e[k1] / ep, e[k2] / ep) if ep > 0.0 else (1.0, 0.0)
    x, y = r * u1, r * u2  # (z, x, y) along A's axes (k, k1, k2)
    if k == 0:
        return provable, (z, x, y), nodes
    if k == 1:
        return provable, (y, z, x), nodes
    return provable, (x, y, z), nodes
