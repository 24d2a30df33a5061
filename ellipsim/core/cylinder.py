"""Signed distance of an ellipsoid and a cylinder (MuJoCo's ellipsoid x cylinder narrow phase): the
maximum proven global, or reported UNPROVEN (deep rim contacts only; the MuJoCo glue then falls back
to MuJoCo's own function and counts it).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (distance.py), with the cylinder
K = segment [-L, L] u + disc(r) (the disc perpendicular to u) centred at e in E's principal frame:
h_K(n) = L |n.u| + r |P n|, P = I - u u^T, so

    sigma(n) = n.e - h_E(n) - L |n.u| - r |P n|.

Strata: the caps n = +-u (face contacts: no unknown), the side circle n.u = 0 (sigma = f_e(n) - r, the
2-D point-ellipse problem in E's projection along u; point_ellipsoid.py, after Eberly, "Distance from
a point to an ellipse, an ellipsoid, or a hyperellipsoid", and GTCG 10.5.2), and the two rim regions
sign(n.u) = s where sigma = f_rim(n) = n.(e - s L u) - h_E(n) - r |P n| is smooth (rim-circle
contacts).  Local solve: Newton on the rim facing E, in polar coordinates about its cap (the cone
point of r |P n| at the cap is then just the boundary b = 0); if it leaves its region, the caps and the
side, checked by KKT (the witness's radial part within r on a cap, its axial part within L on the
side), hand back to the rim the violation points to.

Certificates (global upper bounds on max sigma):
* ub1 = sd(e - s_E(n) + rho n, K) - rho (rho the rolling radius of E; the exact point-cylinder sd);
* ub2 = sd(e - c, E) - t for a ball(c, t) inside K at the witness (t > 0 for cap and side contacts);
* ub3 (side contacts of a cylinder crossing E): the ball of radius delta + r around e lies in E + K
  when the chords of E along u, lengthened by L, cover it (_sweep_bound).
When none closes: caps and side are exact; a rim piece is bounded above by the maximum of f_{q - r c}
over its closed hemisphere (h_K(m) >= m.(s L u + r c) for any unit c perpendicular to u), tried for c
at the incumbent's azimuth, the centre's and 6 around (every critical point, point_ellipsoid); a rim
piece this does not prune is climbed by Newton from 7 starts and the result is UNPROVEN.

Ported from the pair-type prototype (10 000 poses: never below a 20 000-direction reference by more
than 1e-12 of the smaller shortest half-size; half of its deep crossings UNPROVEN).
"""

import math

from ._jit import jit, stage
from .point_ellipsoid import circle_max_bound, foot3, pole_normal, sd_upper, secular_roots, support
from .sigma import rolling_radius, tangent_basis, unit
from .tolerances import PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
from .vec3 import column, cross3, matvec, norm2, rotate_t

#: How cylinder_ellipsoid ended: CERTIFIED (an upper bound within PAIR_CERT_REL of the smaller
#: shortest half-size of the value), ENUMERATED (every piece bounded or solved) or UNPROVEN.
CERTIFIED, ENUMERATED, UNPROVEN = 0, 1, 2


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def to_frame(E, K):
    """(e, a2, u): K's centre in E's principal frame, E's squared semi-axes, K's axis (its local z)."""
    (ce, Re, ra), (ck, Rk, _) = E, K
    e = rotate_t(Re, (ck[0] - ce[0], ck[1] - ce[1], ck[2] - ce[2]))
    u = rotate_t(Re, column(Rk, 2))
    return e, (ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]), u


NEWTON_MAX_ITER = 30
#: Newton's last step: below this many radians the next would be ~1e-18 (quadratic convergence).
NEWTON_STEP_TOL = 1e-8
#: A polar angle from the axis below this many radians is the cap (the rim function's cone point).
CAP_TOL = 1e-12

SIDE, CAP_P, CAP_M, RIM_P, RIM_M = 0, 1, 2, 3, 4
CONVERGED, AT_CAP, STALLED = 0, 1, 2


@stage
def perp(n, u):
    """|P n| = |n x u| for the unit u: no cancellation near the caps (sqrt(1 - (n.u)^2) loses half the
    digits there: 1e-8 relative at n = u)."""
    x = cross3(n, u)
    return math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])


@stage
def sigma_cylinder(a2, e, u, L, r, n):
    h = math.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    nu = _dot(n, u)
    return _dot(n, e) - h - L * abs(nu) - r * perp(n, u)


@jit
def _rim_newton(a2, e, u, L, r, sg, n):
    """Newton for max of f_rim (the rim sg = +-1) from the unit n, in polar coordinates about the cap
    sg u: n = sg cos(b) u + sin(b) (cos(p) w1 + sin(p) w2), f = g(n) - r sin(b) with g(n) = n.q - h_E(n).
    f is smooth in (b, p) for 0 < b, so the cone point of r |P n| at the cap (b = 0), where a Newton
    iteration on the sphere crawls, is just the boundary b = 0.  Returns (n, value, code): CONVERGED,
    AT_CAP (b reached 0) or STALLED; b beyond pi/2 is reported CONVERGED with n in the other hemisphere
    (the caller then takes the side)."""
    q = (e[0] - sg * L * u[0], e[1] - sg * L * u[1], e[2] - sg * L * u[2])
    w1, w2 = tangent_basis(u)
    b = math.atan2(perp(n, u), sg * _dot(n, u))
    p = math.atan2(_dot(n, w2), _dot(n, w1))
    b = min(max(b, 1e-6), 0.5 * math.pi - 1e-6)
    value = -math.inf
    for it in range(NEWTON_MAX_ITER):
        cb, sb, cp, sp = math.cos(b), math.sin(b), math.cos(p), math.sin(p)
        c = (cp * w1[0] + sp * w2[0], cp * w1[1] + sp * w2[1], cp * w1[2] + sp * w2[2])
        dc = (-sp * w1[0] + cp * w2[0], -sp * w1[1] + cp * w2[1], -sp * w1[2] + cp * w2[2])
        n = (sg * cb * u[0] + sb * c[0], sg * cb * u[1] + sb * c[1], sg * cb * u[2] + sb * c[2])
        nb = (-sg * sb * u[0] + cb * c[0], -sg * sb * u[1] + cb * c[1], -sg * sb * u[2] + cb * c[2])
        npp = (sb * dc[0], sb * dc[1], sb * dc[2])
        an = (a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
        h = math.sqrt(_dot(an, n))
        ih = 1.0 / h
        G = (q[0] - an[0] * ih, q[1] - an[1] * ih, q[2] - an[2] * ih)
        value = _dot(n, q) - h - r * sb
        fb = _dot(G, nb) - r * cb
        fp = _dot(G, npp)

        # H = -(A/h - an an^T/h^3) applied to x, y
        def hq(x, y):
            return -(a2[0] * x[0] * y[0] + a2[1] * x[1] * y[1] + a2[2] * x[2] * y[2]) * ih + _dot(an, x) * _dot(an, y) * ih * ih * ih

        fbb = hq(nb, nb) - _dot(G, n) + r * sb
        fpp = hq(npp, npp) - sb * _dot(G, c)
        fbp = hq(nb, npp) + cb * _dot(G, dc)
        det = fbb * fpp - fbp * fbp
        shift = 0.0
        if not (fbb < 0.0 and det > 0.0):
            top = 0.5 * (fbb + fpp) + math.sqrt(0.25 * (fbb - fpp) ** 2 + fbp * fbp)
            shift = max(top, 0.0) + 1e-3 * (abs(fbb) + abs(fpp)) + math.sqrt(fb * fb + fp * fp)
            fbb, fpp = fbb - shift, fpp - shift
            det = fbb * fpp - fbp * fbp
        idet = 1.0 / det
        db = -(fpp * fb - fbp * fp) * idet
        dp = -(fbb * fp - fbp * fb) * idet
        arc2 = db * db + sb * sb * dp * dp
        if arc2 > 0.25:
            f = 0.5 / math.sqrt(arc2)
            db, dp, arc2 = db * f, dp * f, 0.25
        if b + db <= 0.0:  # towards the cap: at most halfway there (the optimum may sit just off it)
            f = 0.5 * b / (-db)
            db, dp, arc2 = db * f, dp * f, arc2 * f * f
        for _ in range(12):  # backtrack until f grows
            bn_ = b + db
            m = (sg * math.cos(bn_) * u[0] + math.sin(bn_) * (math.cos(p + dp) * w1[0] + math.sin(p + dp) * w2[0]),
                 sg * math.cos(bn_) * u[1] + math.sin(bn_) * (math.cos(p + dp) * w1[1] + math.sin(p + dp) * w2[1]),
                 sg * math.cos(bn_) * u[2] + math.sin(bn_) * (math.cos(p + dp) * w1[2] + math.sin(p + dp) * w2[2]))  # fmt: skip
            if arc2 < 1e-12 or sigma_rim(a2, q, u, r, m) >= value:
                break
            db, dp, arc2 = 0.5 * db, 0.5 * dp, 0.25 * arc2
        b, p = b + db, p + dp
        if b <= CAP_TOL:
            m = (sg * u[0], sg * u[1], sg * u[2])
            return m, sigma_rim(a2, q, u, r, m), AT_CAP
        if arc2 <= NEWTON_STEP_TOL * NEWTON_STEP_TOL and shift == 0.0:
            cb, sb = math.cos(b), math.sin(b)
            m = (sg * cb * u[0] + sb * (math.cos(p) * w1[0] + math.sin(p) * w2[0]),
                 sg * cb * u[1] + sb * (math.cos(p) * w1[1] + math.sin(p) * w2[1]),
                 sg * cb * u[2] + sb * (math.cos(p) * w1[2] + math.sin(p) * w2[2]))  # fmt: skip
            return m, sigma_rim(a2, q, u, r, m), CONVERGED
    return n, value, STALLED


@stage
def sigma_rim(a2, q, u, r, n):
    """f_rim(n) = n.q - h_E(n) - r |P n| for the unit n."""
    h = math.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    nu = _dot(n, u)
    return _dot(n, q) - h - r * perp(n, u)


@stage
def _witness(a2, e, n, value):
    """K's support point in direction +n relative to K's centre: e - s_E(n) - value n."""
    _, s = support(a2, n)
    return (e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])


@stage
def local_max(a2, e, u, L, r):
    """(n, stratum, converged).  Rim first (the generic contact): Newton on the rim facing E from the
    normal of E at the foot of the rim point nearest the centre line; if it leaves its region or meets
    the cap, the side / cap candidates are checked by KKT."""
    eu = _dot(e, u)
    ep = (e[0] - eu * u[0], e[1] - eu * u[1], e[2] - eu * u[2])
    pe = math.sqrt(_dot(ep, ep))
    if pe > 0.0:
        c = (ep[0] / pe, ep[1] / pe, ep[2] / pe)
    else:
        c, _ = tangent_basis(u)
    # K's support point in direction +n ~ +e: sg L u + r c, with sg = sign(e.u), c along e_perp
    sg = 1.0 if eu >= 0.0 else -1.0
    q = (e[0] - sg * L * u[0] - r * c[0], e[1] - sg * L * u[1] - r * c[1], e[2] - sg * L * u[2] - r * c[2])
    _, start = foot3(a2, q)
    if sg * _dot(start, u) > 0.0 and abs(_dot(start, u)) < 1.0 - 1e-9:
        m, val, code = _rim_newton(a2, e, u, L, r, sg, start)
        if code == CONVERGED and sg * _dot(m, u) > 0.0:
            return m, RIM_P if sg > 0.0 else RIM_M, True
    # the caps and the side, then their KKT
    best, n, st = sigma_cylinder(a2, e, u, L, r, u), u, CAP_P
    mu_ = (-u[0], -u[1], -u[2])
    v = sigma_cylinder(a2, e, u, L, r, mu_)
    if v > best:
        best, n, st = v, mu_, CAP_M
    w1, w2 = tangent_basis(u)
    ns, _ = circle_max_bound(a2, e, w1, w2)
    v = sigma_cylinder(a2, e, u, L, r, ns)
    if v > best:
        best, n, st = v, ns, SIDE
    for _ in range(4):
        y = _witness(a2, e, n, best)
        ya = _dot(y, u)
        if st == SIDE:
            if abs(ya) <= L:
                return n, st, True
            sg = 1.0 if ya > 0.0 else -1.0
            start = unit((n[0] + 0.1 * sg * u[0], n[1] + 0.1 * sg * u[1], n[2] + 0.1 * sg * u[2]))
        else:
            sg = 1.0 if st == CAP_P else -1.0
            yr = (y[0] - ya * u[0], y[1] - ya * u[1], y[2] - ya * u[2])
            rad = math.sqrt(_dot(yr, yr))
            if rad <= r:
                return n, st, True
            # the rim optimum sits off the cap by about (rad - r) / curvature: start there, on the azimuth
            # of the violation (a far start may crawl along the cap's degenerate azimuth)
            f = min(0.3, max(1e-6, 10.0 * (rad - r) / rad)) / rad
            start = unit((sg * u[0] + f * yr[0], sg * u[1] + f * yr[1], sg * u[2] + f * yr[2]))
        m, val, code = _rim_newton(a2, e, u, L, r, sg, start)
        if code != CONVERGED and st != SIDE:  # a second start closer to the cap
            f2 = 0.01 * f
            start = unit((sg * u[0] + f2 * yr[0], sg * u[1] + f2 * yr[1], sg * u[2] + f2 * yr[2]))
            m2, val2, code2 = _rim_newton(a2, e, u, L, r, sg, start)
            if code2 == CONVERGED or val2 > val:
                m, val, code = m2, val2, code2
        if code == CONVERGED and sg * _dot(m, u) > 0.0:
            return m, RIM_P if sg > 0.0 else RIM_M, True
        if code == AT_CAP:
            n, st = (sg * u[0], sg * u[1], sg * u[2]), CAP_P if sg > 0.0 else CAP_M
        elif code == CONVERGED:  # crossed to the other hemisphere: the side
            n, st = ns, SIDE
        else:
            return m, RIM_P if sg > 0.0 else RIM_M, False
        best = sigma_cylinder(a2, e, u, L, r, n)
    return n, st, False


@stage
def sd_point_cylinder(w, u, L, r):
    z = _dot(w, u)
    rad = perp(w, u)  # |w x u|: sqrt(|w|^2 - z^2) would lose half the digits near the axis
    dz, dr = abs(z) - L, rad - r
    if dz <= 0.0 and dr <= 0.0:
        return max(dz, dr)
    oz, orr = max(dz, 0.0), max(dr, 0.0)
    return math.sqrt(oz * oz + orr * orr)


@stage
def upper_bound1(a2, e, u, L, r, rho, n):
    _, s = support(a2, n)
    w = (e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    return sd_point_cylinder(w, u, L, r) - rho


@stage
def upper_bound2(a2, e, u, L, r, n, value):
    """ub2: the witness clamped into K, with the largest ball inside K tangent there for cap (n = +-u)
    and side (n perpendicular to u) contacts."""
    y = _witness(a2, e, n, value)
    ya = _dot(y, u)
    yr = (y[0] - ya * u[0], y[1] - ya * u[1], y[2] - ya * u[2])
    rad = math.sqrt(_dot(yr, yr))
    nu = _dot(n, u)
    pn = perp(n, u)
    za = min(max(ya, -L), L)
    t = 0.0
    if pn < 1e-12:  # cap: centre axial sign(nu)(L - t), radial the witness's (within r)
        f = min(1.0, r / rad) if rad > 0.0 else 1.0
        yr = (yr[0] * f, yr[1] * f, yr[2] * f)
        t = min(L, r - rad * f)
        za = math.copysign(L - t, nu)
    elif abs(nu) < 1e-12:  # side: centre radial (r - t) n, axial the witness's (within L)
        t = min(r, L - abs(za))
        pr = r - t
        yr = (pr * n[0], pr * n[1], pr * n[2])
    else:  # rim: the rim point
        f = r / rad if rad > 0.0 else 0.0
        yr = (yr[0] * f, yr[1] * f, yr[2] * f)
        za = math.copysign(L, ya)
    q = (e[0] - za * u[0] - yr[0], e[1] - za * u[1] - yr[1], e[2] - za * u[2] - yr[2])
    tt, _ = foot3(a2, q)
    return sd_upper(a2, q, tt) - t


@stage
def _sweep_bound(a2, e, u, L, r, n):
    """ub3 for a side contact n (n.u = 0): with delta2 the certified depth of e's projection in E's
    projection along u (2-D weak duality), the chords of E along u have midpoints t_mid(y) = gamma.y
    (gamma = -(A^-1 u)_perp / kappa, kappa = u^T A^-1 u, the conjugate diametral plane).  The ball of
    radius delta2 + r around e lies in E + K when |e.u - t_mid(e_perp)| + sqrt((delta2 + r)^2 +
    |gamma|^2 delta2^2) <= L (split each ball point's transverse offset between E's projection and the
    disc in proportion delta2 : r); then max sigma <= -(delta2 + r).  inf when the test fails."""
    w1, w2 = tangent_basis(u)
    _, ub2d = circle_max_bound(a2, e, w1, w2)
    if ub2d > 0.0:
        return math.inf
    d2 = -ub2d
    g = (u[0] / a2[0], u[1] / a2[1], u[2] / a2[2])
    kappa = _dot(g, u)
    tau = _dot(e, u)
    ep = (e[0] - tau * u[0], e[1] - tau * u[1], e[2] - tau * u[2])
    c0 = tau + _dot(g, ep) / kappa
    gam2 = max(_dot(g, g) - kappa * kappa, 0.0) / (kappa * kappa)
    dd = d2 + r
    if abs(c0) + math.sqrt(dd * dd + gam2 * d2 * d2) <= L:
        return -dd
    return math.inf


@stage
def upper_bound(a2, e, u, L, r, rho, n, value, tol):
    ub = upper_bound1(a2, e, u, L, r, rho, n)
    if ub - value <= tol:
        return ub
    ub = min(ub, upper_bound2(a2, e, u, L, r, n, value))
    if ub - value <= tol:
        return ub
    if abs(_dot(n, u)) < 1e-12:
        ub = min(ub, _sweep_bound(a2, e, u, L, r, n))
    return ub


@stage
def _rim_bound(a2, e, u, L, r, sg, c, slack):
    """Upper bound on sigma over the rim piece sg (the hemisphere sg n.u >= 0): there
    h_K(m) >= m.(sg L u + r c) for any unit c perpendicular to u, so sigma <= f_p with p = e - sg L u - r c,
    and the maximum of f_p over the closed hemisphere is the global one if its maximiser lies there, else
    the larger of the interior local maxima (secular_roots, maxima only) and the maximum over
    the bounding great circle n.u = 0 (2-D, certified by weak duality)."""
    p = (e[0] - sg * L * u[0] - r * c[0], e[1] - sg * L * u[1] - r * c[1], e[2] - sg * L * u[2] - r * c[2])
    t, n = foot3(a2, p)
    if sg * _dot(n, u) >= 0.0:
        return sd_upper(a2, p, t)
    w1, w2 = tangent_basis(u)
    _, best = circle_max_bound(a2, p, w1, w2)
    for tt in secular_roots(a2, p):
        if tt == tt:
            m = unit((p[0] / (tt + a2[0]), p[1] / (tt + a2[1]), p[2] / (tt + a2[2])))
            if sg * _dot(m, u) > 0.0:
                h = math.sqrt(a2[0] * m[0] * m[0] + a2[1] * m[1] * m[1] + a2[2] * m[2] * m[2])
                best = max(best, _dot(m, p) - h + slack)
    for i in range(3):
        for sign in (1.0, -1.0):
            ok, m = pole_normal(a2, p, i, sign)
            if ok and sg * _dot(m, u) > 0.0:
                h = math.sqrt(a2[0] * m[0] * m[0] + a2[1] * m[1] * m[1] + a2[2] * m[2] * m[2])
                best = max(best, _dot(m, p) - h + slack)
    return best


@jit
def deep_search(a2, e, u, L, r, best, bn, tol, slack, climb):
    """Caps and side exactly; each rim pruned by _rim_bound at a few rim points, else climbed from
    several starts (climb; else the search stops there, unproven).  Returns (value, n, proven)."""
    for sg in (1.0, -1.0):
        m = (sg * u[0], sg * u[1], sg * u[2])
        v = sigma_cylinder(a2, e, u, L, r, m)
        if v > best:
            best, bn = v, m
    w1, w2 = tangent_basis(u)
    m, _ = circle_max_bound(a2, e, w1, w2)
    v = sigma_cylinder(a2, e, u, L, r, m)
    if v > best:
        best, bn = v, m
    proven = True
    for sg in (1.0, -1.0):
        # rim points to bound with: towards the incumbent's and towards the centre's azimuth, and 6 around
        pruned = False
        for k in range(8):
            if k == 0:
                c = (bn[0] - _dot(bn, u) * u[0], bn[1] - _dot(bn, u) * u[1], bn[2] - _dot(bn, u) * u[2])
            elif k == 1:
                c = (e[0] - _dot(e, u) * u[0], e[1] - _dot(e, u) * u[1], e[2] - _dot(e, u) * u[2])
            else:
                ang = (k - 2) * (math.pi / 3.0)
                c = (math.cos(ang) * w1[0] + math.sin(ang) * w2[0], math.cos(ang) * w1[1] + math.sin(ang) * w2[1],
                     math.cos(ang) * w1[2] + math.sin(ang) * w2[2])  # fmt: skip
            cc = _dot(c, c)
            if not cc > 1e-24:
                continue
            c = unit(c)
            if _rim_bound(a2, e, u, L, r, sg, c, slack) <= best + tol:
                pruned = True
                break
        if pruned:
            continue
        proven = False
        if not climb:
            break
        for k in range(7):
            if k == 6:
                start = unit((sg * u[0] + bn[0], sg * u[1] + bn[1], sg * u[2] + bn[2]))
            else:
                ang = k * (math.pi / 3.0)
                start = unit((0.7 * sg * u[0] + math.cos(ang) * w1[0] + math.sin(ang) * w2[0],
                              0.7 * sg * u[1] + math.cos(ang) * w1[1] + math.sin(ang) * w2[1],
                              0.7 * sg * u[2] + math.cos(ang) * w1[2] + math.sin(ang) * w2[2]))  # fmt: skip
            m, v, code = _rim_newton(a2, e, u, L, r, sg, start)
            if code == CONVERGED and sg * _dot(m, u) > 0.0:
                v = sigma_cylinder(a2, e, u, L, r, m)
                if v > best:
                    best, bn = v, m
    return best, bn, proven


@jit
def cylinder_ellipsoid(E, K, climb=True):
    """(status, dist, normal (3,), pos (3,), ub) for the ellipsoid E and the cylinder K, tuples (centre
    (3,) metres, rotation row-major (9,), sizes (3,) metres; K's sizes (radius, half-length, unused),
    its axis its local z, as MuJoCo's cylinder geom).  dist: sigma at the returned normal (a lower bound
    of the exact signed distance, metres); normal: unit, from E to K; pos: the midpoint of the witness
    points; ub: the certified upper bound (inf unless CERTIFIED); status: CERTIFIED, ENUMERATED (both
    proofs) or UNPROVEN (a deep rim piece neither bound pruned: the best of several Newton climbs, or,
    climb False, whatever the search had when it met that piece -- for callers that discard unproven
    results, as the MuJoCo glue does)."""
    e, a2, u = to_frame(E, K)
    r, L = K[2][0], K[2][1]
    ra = E[2]
    rho = rolling_radius(ra)
    tol = PAIR_CERT_REL * min(ra[0], ra[1], ra[2], r, L)
    n, _, _ = local_max(a2, e, u, L, r)
    value = sigma_cylinder(a2, e, u, L, r, n)
    ub = upper_bound(a2, e, u, L, r, rho, n, value, tol)
    status = CERTIFIED
    if ub - value > tol:
        scale = math.sqrt(norm2(e)) + max(ra[0], ra[1], ra[2], r, L)
        slack = PAIR_SIGMA_SLACK_ULPS * U * scale
        value, n, proven = deep_search(a2, e, u, L, r, value, n, tol, slack, climb)
        ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol)
        if ub2 - value <= tol:
            ub = ub2
        else:
            status = ENUMERATED if proven else UNPROVEN
            ub = math.inf
    _, s = support(a2, n)
    half = 0.5 * value
    ce, Re, _ = E
    normal = matvec(Re, n)
    p = matvec(Re, (s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2]))
    return status, value, normal, (ce[0] + p[0], ce[1] + p[1], ce[2] + p[2]), ub


@stage
def centre_line_bound(E, K):
    """A lower bound on the signed distance: sigma along the centre line minus its rounding allowance
    (PAIR_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies."""
    e, a2, u = to_frame(E, K)
    ee = norm2(e)
    if not ee > 0.0:
        return -math.inf
    s = 1.0 / math.sqrt(ee)
    ra, rk = E[2], K[2]
    scale = math.sqrt(ee) + max(ra[0], ra[1], ra[2], rk[0], rk[1])
    v = sigma_cylinder(a2, e, u, rk[1], rk[0], (e[0] * s, e[1] * s, e[2] * s))
    return v - PAIR_SIGMA_SLACK_ULPS * U * scale
