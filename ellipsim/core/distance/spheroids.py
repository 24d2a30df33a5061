"""Proven maximum of sigma for two spheroids with parallel axes of revolution (issue 18).

When A and B are spheroids (or a spheroid and a sphere) whose axes of revolution are parallel to a
line w, sigma(n) = n.e - h_A(n) - h_B(n) depends on n only through its angle t to w and its azimuth
phi about w, and only the offset e sees the azimuth: sigma = f(t) + |e_perp| sin t cos(phi - phi_e).
For every t the maximum over phi is at phi_e, so the maximum over the sphere is the maximum of two
coaxial ellipses' sigma in the plane of w and e_perp (Schneider & Eberly, Geometric Tools 10.5.2:
h(n) = |D R^T n|, which for a spheroid depends on (n.w)^2 only):
  g(z, r) = e_k z + |e_perp| r - sqrt(qa^2 z^2 + pa^2 r^2) - sqrt(qb^2 z^2 + pb^2 r^2),  (z, r) = (cos t, sin t),
maximised by a branch and bound over t in [0, pi] with the concave majorant of branch_and_bound.py's module
docstring, part 1, in two dimensions (g is concave and 1-homogeneous on R^2: on an arc of chord
radius rho around the unit c, g <= g(c) + |G_T| rho + max(-G.c, 0) rho^2 / 2).  With the axes on one
line through both centres (e_perp = 0) the maxima form circles about w, which branch_and_bound.py's branch
and bound over the sphere cannot isolate; with parallel axes and the centres off that line (a grid,
a line or a keyframe of equal rotations) they are isolated, but so nearly flat along the circle that
it runs out of budget there too.

In A's frame (e, a, U, b as in branch_and_bound.py) w is A's axis k; qa = a_k, pa = the mean of A's other
two semi-axes, qb = b_j for B's axis j nearest to w, pb = the mean of B's other two.  The pair need
not be exactly of revolution nor exactly parallel: for every unit n, with n's own (z, r) in the plane,
sigma(n) <= g(z, r) + delta and sigma(n*) >= g(z*, r*) - delta at the returned n* (in the plane), with
  delta = |a_k1 - a_k2| / 2                                 (A not exactly of revolution)
        + max|b - b0| (1 + 3 def) + |qb^2 - pb^2| eps (2 + eps) / min(qb, pb) + 1.5 pb^2 def / min(qb, pb)
b0 = (qb, pb, pb) in B's order, eps = |u_j - s e_k| (B's axis off w, s its sign) and def =
max |U U^T - I| (h_B(n)^2 - h_B0(n)^2 = (qb^2 - pb^2)((u_j.n)^2 - n_k^2) + pb^2 (|U^T n|^2 - 1) for
B's semi-axes made b0; |(u_j.n)^2 - n_k^2| <= eps (|u_j| + 1), and |x - y| <= |x^2 - y^2| / (x + y)), plus
the roundings of the means, squares and |e_perp| (6 u S, S = |e| + max a + max b).  The answer is
proven within tol when the 1-D branch and bound is run to tol - 2 delta - ERR_G - ERR_SIGMA (g at the
returned angle and sigma at the returned n as computed): axes tilted by more than about tol / max b
go to tilted_max below, a branch and bound over both angles about A's axis that keeps B's tilt exactly
and bounds sigma on a cell by its second-order Taylor expansion (the section's comment).
"""

import math

from .._jit import jit, stage
from ..tolerances import BB_ERR_SIGMA_ULPS, COAXIAL_MAX_NODES, TILTED_MAX_NODES
from ..tolerances import PARALLEL_CANDIDATE_TILT as CANDIDATE_TILT

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
    """(j, qb, pb, delta0, tilt, eps): B's axis nearest to A's axis k and the bound delta = delta0 + tilt
    of the module docstring (upwards; tilt its term in eps), with A's and B's semi-axes across their
    axes taken as their means."""
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
            v = (
                U[3 * p] * U[3 * q]
                + U[3 * p + 1] * U[3 * q + 1]
                + U[3 * p + 2] * U[3 * q + 2]
                - (1.0 if p == q else 0.0)
            )
            dfu = max(dfu, abs(v))
    dfu += 4.0 * U64  # each entry: three products and their sums, <= 3 u, and the - 1
    # |U^T n|^2 = 1 +- 3 def moves h_B^2 by <= 3 pb^2 def, so h_B by that over h_B + its model >= 2 min(qb, pb)
    delta0 = 0.5 * abs(a[k1] - a[k2]) + db * (1.0 + 3.0 * dfu) + 1.5 * pb * pb * dfu / (min(qb, pb) * (1.0 - 1e-9))
    tilt = abs(qb * qb - pb * pb) * eps * (2.0 + eps) / min(qb, pb)
    return j, qb, pb, delta0 * (1.0 + 1e-12) + 6.0 * U64 * S, tilt * (1.0 + 1e-12), eps


@jit
def parallel_max(e, a, U, b, tol, S):
    """The proven maximum of sigma(n) = n.e - |diag(a) n| - |diag(b) U^T n| on the unit sphere for two
    spheroids with (near) parallel axes, in A's frame (module docstring).

    tol: the tolerance to prove (global_max's tol_bb).  Returns (proven, unit n (3,), nodes): when
    proven, max sigma <= sigma(n) + tol for the exact sigma of (e, a, U, b); n lies in the plane of A's
    axis k and e_perp (of A's axes k and k + 1 when e_perp = 0: any azimuth is as good there).  Not
    proven when the axes are too far from parallel (2 delta + ERR_G + ERR_SIGMA leaves less than the
    arcs' rounding slack of tol) or the node budget runs out.  n is then the maximiser of the parallel
    model when the pair is within CANDIDATE_TILT of it (a start for branch_and_bound.py: there the true
    maxima are within 2 delta of that model's), else (0, 0, 0)."""
    none = (False, (0.0, 0.0, 0.0), 0)
    k, _ = _axis_of(a)
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    j, qb, pb, delta0, tilt, eps = _delta(e, a, U, b, k, S)
    delta = delta0 + tilt
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
        gained = False
        for _ in range(40):  # backtracking: a full Newton step may overshoot a sharp peak
            tn = min(math.pi, max(0.0, t + step))
            gn, _, _, _ = _g_grad(math.cos(tn), math.sin(tn), ek, ep, qa2, pa2, qb2, pb2)
            if gn >= best:
                gained = True
                break
            step *= 0.5
        if not gained:
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


# --- Nearly parallel axes: a branch and bound over (t, phi) with second-order bounds -----------------
#
# For spheroids whose axes are tilted by tau from parallel, the maxima of sigma are no longer a circle
# nor nearly flat isolated points of the parallel model: along the circle sigma varies by O(tau max b)
# and across it by O(max b).  The cap bound of branch_and_bound.py pays |sigma| rho^2 / 2 in every direction
# (the sphere's curvature), so it needs caps of radius sqrt(tol / |sigma|) all along the circle.  Here
# n = (cos t, sin t cos phi, sin t sin phi) along A's axes (k, k + 1, k + 2), and the model
#   sigma_m(t, phi) = n.e - sqrt(qa^2 cos^2 t + pa^2 sin^2 t) - sqrt(pb^2 + (qb^2 - pb^2) (u.n)^2)
# (u = B's axis j in A's frame, as given: no tilt is modelled away; |sigma - sigma_m| <= delta0, the
# parallel model's delta without its tilt term) is smooth in (t, phi), poles included.  On a cell
# [tc +- ht] x [pc +- hp], Taylor's theorem with the Lagrange remainder along the segment gives
#   sigma_m <= sigma_m(c) + q(s_t, Mtt, ht) + q(s_p, Mpp, hp) + Ktp ht hp,
#   q(g, M, h) = max_{|d| <= h} g d + M d^2 / 2,
# with Mtt, Mpp upper bounds of the second partials over the cell and Ktp of |s_tp|, evaluated in
# midpoint-radius (ball) interval arithmetic from cos, sin of the cell's centre (|cos(x + d) - cos x|
# <= |sin x| |d| + d^2 / 2).  Along phi s_pp is O(|e_perp| + tau max b), so cells there stay long
# where they are thin across the circle: each cell is split in the direction whose term is larger.
# Every ball operation widens its radius by its own rounding; the centre values carry ERR_C (sigma_m)
# and the gradient's epsg, as parallel_max's.

ERR_C_ULPS = 16.0  # sigma_m at a float centre: cos, sin rounded (n within ~3 u), the two roots, the sums
TILT_LEVELS = 52  # cells of pi 2^-52 in either direction: far below any tolerance's width
TILT_DEPTH = 62  # splits along one root-to-leaf path (their directions are bits of one int64)
ROOT_T, ROOT_P = 2, 3  # 4 x 8 root cells over [0, T] x [-T, T]
T_DOMAIN = 3.1415926535897936  # the float above pi: the cells cover [0, pi] x [-pi, pi]
U4 = 4.0 * U64


@stage
def _bm(x, y):
    """Ball product (midpoint, radius), the rounding of the midpoint added to the radius."""
    m = x[0] * y[0]
    return m, abs(x[0]) * y[1] + abs(y[0]) * x[1] + x[1] * y[1] + U4 * abs(m)


@stage
def _ba(x, y, sx, sy):
    """Ball sx x + sy y for exact scalars sx, sy."""
    m = sx * x[0] + sy * y[0]
    return m, abs(sx) * x[1] + abs(sy) * y[1] + U4 * (abs(sx * x[0]) + abs(sy * y[0]))


@stage
def _bc(c, x):
    """Ball c x for an exact scalar c."""
    m = c * x[0]
    return m, abs(c) * x[1] + U4 * abs(m)


@stage
def _inv_roots(q, qlo):
    """Balls of 1 / sqrt(Q) and 1 / sqrt(Q)^3 for Q in the ball q, known >= qlo > 0."""
    lo, hi = max(q[0] - q[1], qlo), q[0] + q[1]
    i_hi, i_lo = (1.0 + U4) / math.sqrt(lo), (1.0 - U4) / math.sqrt(hi)
    j_hi, j_lo = i_hi * i_hi * i_hi * (1.0 + U4), i_lo * i_lo * i_lo * (1.0 - U4)
    return (0.5 * (i_hi + i_lo), 0.5 * (i_hi - i_lo) * (1.0 + U4)), (
        0.5 * (j_hi + j_lo),
        0.5 * (j_hi - j_lo) * (1.0 + U4),
    )


@stage
def _trig_ball(x, h):
    """Balls of cos and sin over [x - h, x + h]."""
    c, s = math.cos(x), math.sin(x)
    h2 = 0.5 * h * h
    return (c, (abs(s) * h + h2) * (1.0 + U4) + U64), (s, (abs(c) * h + h2) * (1.0 + U4) + U64)


@stage
def _form_balls(lz, lx, ly, ct, st, cp, sp):
    """Balls of l = lz cos t + sin t (lx cos phi + ly sin phi) and of its partials t, p, tt, pp, tp."""
    m = _ba(cp, sp, lx, ly)
    mq = _ba(sp, cp, -lx, ly)  # d m / d phi
    l = _ba(ct, _bm(st, m), lz, 1.0)
    lt = _ba(st, _bm(ct, m), -lz, 1.0)
    lp = _bm(st, mq)
    lpp = _bc(-1.0, _bm(st, m))
    ltp = _bm(ct, mq)
    return l, lt, lp, (-l[0], l[1]), lpp, ltp


@stage
def _root_second(qxy, qx, qy, i1, i3):
    """Ball of d2 sqrt(Q) = Q_xy / (2 sqrt Q) - Q_x Q_y / (4 sqrt(Q)^3)."""
    return _ba(_bm(qxy, i1), _bm(_bm(qx, qy), i3), 0.5, -0.25)


@stage
def _ha_at(hk, h1, h2, ct, st):
    """(h_A, dh_A / dt) at a point: hk = 0 a spheroid, sqrt(h1 cos^2 t + h2 sin^2 t) (h1, h2 the squared
    semi-axes along and across the pole); hk = 1 a cylinder, h1 |cos t| + h2 sin t (h1 its half-length,
    h2 its radius), each of its two pieces h1 s cos t + h2 sin t (s = +-1) an extension that is <= the
    cylinder's sigma term -h1 |cos t| nowhere below it: -|x| = min(x, -x), so sigma <= the piece's model."""
    if hk == 0:
        ha = math.sqrt(h1 * ct * ct + h2 * st * st)
        return ha, (h2 - h1) * st * ct / ha
    sg = 1.0 if ct >= 0.0 else -1.0
    return h1 * sg * ct + h2 * st, -h1 * sg * st + h2 * ct


@stage
def _hessian_balls(tc, ht, pc, hp, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b):
    """Balls of s_tt, s_pp, s_tp of sigma_m over the cell (tc +- ht, pc +- hp); a cylinder's piece is the
    one of the cell's centre."""
    ct, st = _trig_ball(tc, ht)
    cp, sp = _trig_ball(pc, hp)
    _, _, _, ett, epp, etp = _form_balls(ek, ex, ey, ct, st, cp, sp)
    if hk == 0:
        # h_A = sqrt(P), P = h1 cos^2 t + h2 sin^2 t: P_t = 2 (h2 - h1) sin t cos t, P_tt = 2 (h2 - h1) (cos^2 - sin^2)
        c2, s2, cs = _bm(ct, ct), _bm(st, st), _bm(ct, st)
        P = _ba(c2, s2, h1, h2)
        Pt = _bc(2.0 * (h2 - h1), cs)
        Ptt = _bc(2.0 * (h2 - h1), _ba(c2, s2, 1.0, -1.0))
        ia1, ia3 = _inv_roots(P, qlo_a)
        hatt = _root_second(Ptt, Pt, Pt, ia1, ia3)
    else:  # h1 s cos t + h2 sin t: its second derivative is minus itself
        sg = 1.0 if ct[0] >= 0.0 else -1.0
        hatt = _ba(ct, st, -h1 * sg, -h2)
    # h_B = sqrt(Q), Q = pb2 + kb w^2
    w, wt, wp, wtt, wpp, wtp = _form_balls(wz, wx, wy, ct, st, cp, sp)
    Q = _ba((pb2, 0.0), _bm(w, w), 1.0, kb)
    Qt, Qp = _bc(2.0 * kb, _bm(w, wt)), _bc(2.0 * kb, _bm(w, wp))
    Qtt = _bc(2.0 * kb, _ba(_bm(wt, wt), _bm(w, wtt), 1.0, 1.0))
    Qpp = _bc(2.0 * kb, _ba(_bm(wp, wp), _bm(w, wpp), 1.0, 1.0))
    Qtp = _bc(2.0 * kb, _ba(_bm(wt, wp), _bm(w, wtp), 1.0, 1.0))
    ib1, ib3 = _inv_roots(Q, qlo_b)
    hbtt = _root_second(Qtt, Qt, Qt, ib1, ib3)
    hbpp = _root_second(Qpp, Qp, Qp, ib1, ib3)
    hbtp = _root_second(Qtp, Qt, Qp, ib1, ib3)
    stt = _ba(_ba(ett, hatt, 1.0, -1.0), hbtt, 1.0, -1.0)
    return stt, _ba(epp, hbpp, 1.0, -1.0), _ba(etp, hbtp, 1.0, -1.0)


@stage
def _model_at(t, p, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy):
    """(sigma_m, s_t, s_p, h_A, h_B) at the float (t, p)."""
    ct, st, cp, sp = math.cos(t), math.sin(t), math.cos(p), math.sin(p)
    me, mqe = ex * cp + ey * sp, -ex * sp + ey * cp
    mw, mqw = wx * cp + wy * sp, -wx * sp + wy * cp
    w = wz * ct + st * mw
    ha, ha_t = _ha_at(hk, h1, h2, ct, st)
    hb = math.sqrt(pb2 + kb * w * w)
    s = ek * ct + st * me - ha - hb
    wt, wp = -wz * st + ct * mw, st * mqw
    s_t = -ek * st + ct * me - ha_t - kb * w * wt / hb
    s_p = st * mqe - kb * w * wp / hb
    return s, s_t, s_p, ha, hb


@stage
def _polish(t, p, s, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b):
    """Newton on sigma_m in (t, phi) from (t, p) of value s (its Hessian: the balls' midpoints at a
    point): (t, p, s) no worse, only a better incumbent (the proof does not rest on it)."""
    for _ in range(30):
        _, g1, g2, _, _ = _model_at(t, p, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
        htt, hpp, htp = _hessian_balls(t, 0.0, p, 0.0, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
        a11, a22, a12 = htt[0], hpp[0], htp[0]
        # shifted to negative definite where it is not (a saddle, or flat along the circle)
        top = 0.5 * (a11 + a22) + math.sqrt(0.25 * (a11 - a22) * (a11 - a22) + a12 * a12)
        mu = 1e-9 * (abs(a11) + abs(a22)) + 1e-300
        if top > -mu:
            a11, a22 = a11 - top - mu, a22 - top - mu
        det = a11 * a22 - a12 * a12
        if not det > 0.0:
            break
        dt, dp = -(a22 * g1 - a12 * g2) / det, -(a11 * g2 - a12 * g1) / det
        size = math.sqrt(dt * dt + dp * dp)
        if not size > 0.0:
            break
        if size > 0.25:
            dt, dp = dt * 0.25 / size, dp * 0.25 / size
        better = False
        for _ in range(40):  # backtracking
            tn, pn = t + dt, p + dp
            if tn < 0.0 or tn > math.pi:  # the same direction with t in [0, pi], where h_A's model holds
                tn = -tn if tn < 0.0 else 2.0 * math.pi - tn
                pn = pn + math.pi if pn < 0.0 else pn - math.pi
            sn = _model_at(tn, pn, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)[0]
            if sn > s:
                better = True
                break
            dt, dp = 0.5 * dt, 0.5 * dp
        if not better:
            break
        t, p, s = tn, pn, sn
    return t, p, s


@stage
def _q(g, M, h):
    """max over |d| <= h of g d + M d^2 / 2 (upwards)."""
    g = abs(g)
    if M < 0.0 and g <= -M * h:
        return g * g / (-2.0 * M) * (1.0 + U4)
    return (g * h + 0.5 * M * h * h) * (1.0 + U4) + U4 * abs(M) * h * h


@jit
def axis_bb(ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, tol1, S, curv, t0, p0):
    """The branch and bound over (t, phi) of the section's comment for the model sigma_m with pole
    coordinates: e = (ek, ex, ey), A's term by (hk, h1, h2) (_ha_at), B a spheroid sqrt(pb2 + kb (w.n)^2)
    with its axis w = (wz, wx, wy); tol1 what is left of the tolerance once the model's and the centre
    values' errors are taken; curv bounds A's |h_A''| h_A (its squared largest semi-axis; 0 for a
    cylinder).  From the incumbent (t0, p0), polished by Newton first.  Returns (proven, t, p, moved,
    nodes): proven, max sigma_m <= sigma_m(t, p) as computed + tol1; moved, (t, p) is not (t0, p0)."""
    qlo_a = min(h1, h2) * (1.0 - 1e-12) if hk == 0 else 1.0
    ww = wz * wz + wx * wx + wy * wy
    qlo_b = (pb2 + min(kb, 0.0) * ww * (1.0 + 1e-12)) * (1.0 - 1e-12)
    if not (tol1 > 0.0 and qlo_a > 0.0 and qlo_b > 0.0):
        return False, t0, p0, False, 0
    bmax2 = max(pb2, pb2 + kb)
    s0 = _model_at(t0, p0, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)[0]
    bt, bp, best = _polish(t0, p0, s0, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
    moved = best != s0
    nodes = 0
    for root in range((1 << ROOT_T) * (1 << ROOT_P)):
        Lt, it, Lp, ip = ROOT_T, root >> ROOT_P, ROOT_P, root & ((1 << ROOT_P) - 1)
        depth, dims = 0, 0
        while True:
            nodes += 1
            if nodes > TILTED_MAX_NODES:
                return False, bt, bp, moved, nodes
            wt, wp = T_DOMAIN * 2.0**-Lt, 2.0 * T_DOMAIN * 2.0**-Lp
            tc, pc = wt * (it + 0.5), -T_DOMAIN + wp * (ip + 0.5)
            ht = 0.5 * wt * (1.0 + 1e-15) + U4 * tc
            hp = 0.5 * wp * (1.0 + 1e-15) + U4 * T_DOMAIN
            s, s_t, s_p, ha, hb = _model_at(tc, pc, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
            if s > best:
                if s > best + tol1:  # a poor incumbent: climb from the better centre
                    t1, p1, s1 = _polish(tc, pc, s, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
                    best, bt, bp = s1, t1, p1
                else:
                    best, bt, bp = s, tc, pc
                moved = True
            htt, hpp, htp = _hessian_balls(tc, ht, pc, hp, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
            Mtt, Mpp, Ktp = htt[0] + htt[1], hpp[0] + hpp[1], abs(htp[0]) + htp[1]
            epsg = U64 * (32.0 * (S + curv / ha + bmax2 / hb) + 16.0 * S)
            qt, qp = _q(s_t, Mtt, ht) + epsg * ht, _q(s_p, Mpp, hp) + epsg * hp
            cross = Ktp * ht * hp * (1.0 + U4)
            if s + qt + qp + cross <= best + tol1:
                while depth > 0:  # the next cell after this one's subtree
                    d = (dims >> (depth - 1)) & 1
                    if d == 0:
                        if (it & 1) == 0:
                            it += 1
                            break
                        it >>= 1
                        Lt -= 1
                    else:
                        if (ip & 1) == 0:
                            ip += 1
                            break
                        ip >>= 1
                        Lp -= 1
                    depth -= 1
                if depth == 0:
                    break
            else:
                split_p = qp > qt
                if split_p and Lp >= TILT_LEVELS:
                    split_p = False
                if (not split_p and Lt >= TILT_LEVELS) or depth >= TILT_DEPTH:
                    return False, bt, bp, moved, nodes
                if split_p:
                    dims |= 1 << depth
                    Lp += 1
                    ip *= 2
                else:
                    dims &= ~(1 << depth)
                    Lt += 1
                    it *= 2
                depth += 1
    return True, bt, bp, moved, nodes


@jit
def tilted_max(e, a, U, b, tol, S, n0):
    """The proven maximum of sigma for spheroids with nearly parallel axes, in A's frame (axis_bb about
    A's axis), from the incumbent direction n0 (unit; any, e.g. a Newton climb's).

    Returns (proven, n (3,), nodes): when proven, max sigma <= sigma(n) + tol for the exact sigma of
    (e, a, U, b); n is n0 or a cell's centre.  Not proven when the pair is not two spheroids to within
    the tolerance (delta0 + ERR_C + ERR_SIGMA leaves no room), or the budget TILTED_MAX_NODES runs out,
    or a cell at TILT_LEVELS stays undecided; n is then the best found."""
    k, _ = _axis_of(a)
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    j, qb, pb, delta0, _, _ = _delta(e, a, U, b, k, S)  # the model keeps the tilt: delta0 only
    qa, pa = a[k], 0.5 * (a[k1] + a[k2])
    amax = max(a[0], a[1], a[2])
    tol1 = tol - 2.0 * delta0 - (ERR_C_ULPS + BB_ERR_SIGMA_ULPS + 8.0) * U64 * S
    t0 = math.atan2(math.sqrt(n0[k1] * n0[k1] + n0[k2] * n0[k2]), n0[k])
    p0 = math.atan2(n0[k2], n0[k1])
    ok, bt, bp, moved, nodes = axis_bb(
        e[k],
        e[k1],
        e[k2],
        0,
        qa * qa,
        pa * pa,
        qb * qb - pb * pb,
        pb * pb,
        U[3 * k + j],
        U[3 * k1 + j],
        U[3 * k2 + j],
        tol1,
        S,
        amax * amax,
        t0,
        p0,
    )
    if not moved:
        return ok, n0, nodes
    z, r = math.cos(bt), math.sin(bt)
    x, y = r * math.cos(bp), r * math.sin(bp)
    if k == 0:
        return ok, (z, x, y), nodes
    if k == 1:
        return ok, (y, z, x), nodes
    return ok, (x, y, z), nodes
