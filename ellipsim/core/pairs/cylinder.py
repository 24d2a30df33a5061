"""Signed distance of an ellipsoid and a cylinder (MuJoCo's ellipsoid x cylinder narrow phase): the
maximum proven global, or reported UNPROVEN (a rim branch and bound out of budget; the MuJoCo glue
then falls back to MuJoCo's own function and counts it).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), with the cylinder
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
  when the chords of E along u, lengthened by L, cover it (_sweep_bound);
* ub4 (side contacts): a capsule inside K with K's support at the contact normal bounds sigma above
  everywhere; its maximum is proven by capsule.py (_capsule_bound).
When none closes: caps and side are exact; a rim piece is bounded above by the maximum of f_{q - r c}
over its closed hemisphere (h_K(m) >= m.(s L u + r c) for any unit c perpendicular to u), tried for c
on lunes of azimuths about u: c at the incumbent's azimuth on the lune holding it, at the lune's
middle elsewhere, the maximum of f_{q - r c} over the lune found from every critical point on its
boundary arcs and inside it; lunes are bisected until each bound is within the tolerance of the
incumbent (_rim_bb).  That linear bound exceeds sigma by r |P n| (1 - cos) of the azimuth from c,
which near the incumbent outgrows sigma's own fall once the crossing is deeper than E's radius of
curvature along the rim: ~20 bisections for 1e-12.  So lunes near the incumbent are split at its
polar band instead (_split_settles): the band by a second-order certificate, sigma = G(x) / |x| for
the concave 1-homogeneous G on the gnomonic chart at the incumbent, Taylor with a proven third-
derivative bound (_cert_model, _cert_region), the rest of the lune by f_{q - r c} over spherical
polygons (_poly_bound).  Before either, a lune that tangent planes of h_E + r |P n| close
(tangent_cones.py) is skipped.  A rim whose branch and bound runs out of budget leaves the pair UNPROVEN.

Ported from the pair-type prototype (10 000 poses: never below a 20 000-direction reference by more
than 1e-12 of the smaller shortest half-size), with the rim's branch and bound in place of its
bounds at 8 fixed azimuths and 7-start Newton climb, which left half of its deep crossings unproven.
"""

import math

from .._jit import jit, stage
from ..distance.sphere_newton import rolling_radius, tangent_basis, unit
from ..distance.spheroids import BB_ERR_SIGMA_ULPS, ERR_C_ULPS, _axis_of, axis_bb
from ..tolerances import BB_TOL_ULPS, PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, RIM_BB_LEVELS, RIM_BB_NODES, U
from ..vec3 import column, cross3, norm2, rotate_t
from . import capsule
from .point_ellipsoid import (
    circle_max_bound,
    contact_in_world,
    foot3,
    from_plane,
    pole_normal,
    project_ellipse,
    sd_upper,
    secular_roots,
    support,
)
from .tangent_cones import cone_below

#: How cylinder_ellipsoid ended: CERTIFIED (an upper bound within PAIR_CERT_REL of the smaller
#: shortest half-size of the value), ENUMERATED (every piece bounded or solved) or UNPROVEN.
CERTIFIED, ENUMERATED, UNPROVEN = 0, 1, 2


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def to_frame(E, K):
    """(e, a2, u): K's centre in E's principal frame, E's squared semi-axes, K's unit axis (its local z,
    normalised: rotations orthonormal only to ~1e-7, as MuJoCo Warp's float32 ones, leave it that far
    from unit, and every formula below takes it unit)."""
    (ce, Re, ra), (ck, Rk, _) = E, K
    e = rotate_t(Re, (ck[0] - ce[0], ck[1] - ce[1], ck[2] - ce[2]))
    u = unit(rotate_t(Re, column(Rk, 2)))
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
    for _it in range(NEWTON_MAX_ITER):
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
            return (
                -(a2[0] * x[0] * y[0] + a2[1] * x[1] * y[1] + a2[2] * x[2] * y[2]) * ih
                + _dot(an, x) * _dot(an, y) * ih * ih * ih
            )

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


#: ub4 is not tried when its capsule's radius t is below this fraction of the cylinder's (a witness within
#: r / 2 of an end): on the pair benchmark's deep poses it proved 2 of the 126 such side contacts (15% at
#: t in [0.6 r, r), 85% at t = r), at ~1.4 us a failure; deep 2.7% faster (A/B, the same values; a pose
#: it would have certified is proven by the rim's branch and bound instead, ENUMERATED).
CAPSULE_MIN_FIT = 0.5


@jit
def _capsule_bound(a2, e, u, L, r, rho, n, value, tol, slack):
    """ub4 (side contacts, n.u = 0): the capsule of radius t = min(r, L - |y.u|) (y the witness) on the
    segment [-(L - t), L - t] u, moved by (r - t) to the side of K facing E (centre e - (r - t) n), lies
    in K and has K's support there, so max sigma <= its maximum, proven by capsule.py: ub1, ub2, else
    its enumeration (every critical point of a piece whose certified bound exceeds the best by more
    than tol / 2, each within slack: the capsule's maximum is below the best found + tol / 2).  Tight
    when that capsule's own maximum is at n: the witness on its side, and the rim's curvature r - t not
    beyond sigma's along the side.  inf when t <= CAPSULE_MIN_FIT r."""
    ya = _dot(_witness(a2, e, n, value), u)
    t = min(r, L - abs(ya))
    if not t > CAPSULE_MIN_FIT * r:  # (a thinner capsule's round end rarely fits under the rim)
        return math.inf
    ec = (e[0] - (r - t) * n[0], e[1] - (r - t) * n[1], e[2] - (r - t) * n[2])
    lc = L - t
    ub = capsule.upper_bound(a2, ec, u, lc, t, rho, n, value, tol)
    if ub - value <= tol:
        return ub
    best, _ = capsule.enumerate_max(a2, ec, u, lc, t, value, n, 0.5 * tol)
    return min(ub, best + 0.5 * tol)  # tol / 2 >= 96 u S covers the critical points' slack (64 u S)


@stage
def upper_bound(a2, e, u, L, r, rho, n, value, tol, slack):
    ub = upper_bound1(a2, e, u, L, r, rho, n)
    if ub - value <= tol:
        return ub
    ub = min(ub, upper_bound2(a2, e, u, L, r, n, value))
    if ub - value <= tol:
        return ub
    if abs(_dot(n, u)) < 1e-12:
        ub = min(ub, _sweep_bound(a2, e, u, L, r, n))
        if ub - value > tol:
            ub = min(ub, _capsule_bound(a2, e, u, L, r, rho, n, value, tol, slack))
    return ub


@stage
def _f(a2, p, m):
    """f_p(m) = m.p - h_E(m)."""
    return _dot(m, p) - math.sqrt(a2[0] * m[0] * m[0] + a2[1] * m[1] * m[1] + a2[2] * m[2] * m[2])


@stage
def _on_arc(m, v1, v2, cs, sn):
    """Whether the unit m of the plane span(v1, v2) is cos t v1 + sin t v2 with t in [0, span], span
    given by its cosine and sine (sn >= 0): m.v2 >= 0 and sin(span - t) >= 0, no arctangent."""
    x, y = _dot(m, v1), _dot(m, v2)
    return y >= 0.0 and x * sn - y * cs >= 0.0


@stage
def _turn(v1, v2, t):
    """cos t v1 + sin t v2."""
    ct, st = math.cos(t), math.sin(t)
    return (ct * v1[0] + st * v2[0], ct * v1[1] + st * v2[1], ct * v1[2] + st * v2[2])


@stage
def _arc_top(a2, p, m, v1, v2, cs, sn, slack, best, bm):
    """(best, bm) raised by f_p(m) + slack when the unit m lies on the arc."""
    if _on_arc(m, v1, v2, cs, sn):
        v = _f(a2, p, m) + slack
        if v > best:
            return v, m
    return best, bm


@stage
def _plane_pole(la, lb, qb):
    """The limit point of the 2-D point-ellipse problem at its pole -la (la != lb, qb the point's other
    coordinate): (ok, n_a, n_b), the normal's coordinates up to sign of n_a; one square root for both signs."""
    xb = lb * qb / (lb - la)
    rest = 1.0 - xb * xb / lb
    if not rest >= 0.0:
        return False, 0.0, 0.0
    return True, math.sqrt(rest * la) / la, xb / lb


@stage
def _sub_max(g, x0, y0, x1, y1):
    """max of g.(x, y) over the unit directions from (x0, y0) to (x1, y1) (counter-clockwise, less
    than pi apart)."""
    if x0 * g[1] - y0 * g[0] >= 0.0 and g[0] * y1 - g[1] * x1 >= 0.0:
        return math.sqrt(g[0] * g[0] + g[1] * g[1])
    return max(g[0] * x0 + g[1] * y0, g[0] * x1 + g[1] * y1)


@stage
def _split_max(ga, gb, x0, y0, x1, y1):
    """An upper bound of min(ga.x, gb.x) over the unit directions x from (x0, y0) to (x1, y1)
    (counter-clockwise, at most pi / 2 apart): ga's maximum up to a split direction, gb's after it,
    the split where the two are equal (any split bounds it; that one is the tightest)."""
    dx, dy = gb[1] - ga[1], ga[0] - gb[0]  # ga.x = gb.x where x is perpendicular to ga - gb
    if x0 * dy - y0 * dx < 0.0:
        dx, dy = -dx, -dy
    if not (x0 * dy - y0 * dx >= 0.0 and dx * y1 - dy * x1 >= 0.0):
        dx, dy = x0 + x1, y0 + y1  # no crossing inside (rounding): the bisector
    nd = math.sqrt(dx * dx + dy * dy)
    if not nd > 0.0:
        return max(_sub_max(ga, x0, y0, x1, y1), _sub_max(gb, x0, y0, x1, y1))
    dx, dy = dx / nd, dy / nd
    return max(_sub_max(ga, x0, y0, dx, dy), _sub_max(gb, dx, dy, x1, y1))


@stage
def _envelope(g0, gm, g2, cs, sn):
    """An upper bound of min_k g_k.(cos t, sin t) over t in [0, span] (cs, sn its cosine and sine),
    g0, gm, g2 the planes tangent at its start, middle and end: the start's plane up to where it
    meets the middle's, and so on."""
    nm = math.sqrt(2.0 + 2.0 * cs)
    if not nm > 0.0:
        return max(_sub_max(g0, 1.0, 0.0, cs, sn), _sub_max(g2, 1.0, 0.0, cs, sn))
    xm, ym = (1.0 + cs) / nm, sn / nm
    return max(_split_max(g0, gm, 1.0, 0.0, xm, ym), _split_max(gm, g2, xm, ym, cs, sn))


@jit
def _arc_max(a2, p, v1, v2, cs, sn, end, slack, floor, stop):
    """(bound, m): the maximum of f_p over the arc {cos t v1 + sin t v2 : t in [0, span]} (v1, v2
    orthonormal, span <= pi given by cs, sn; `end` its far end) and where it is attained: the two ends
    and every local maximum of f_p on the great circle that lies on the arc (the 2-D point-ellipse
    problem in the plane; its secular roots through the 3-D enumeration with a third axis longer than
    both, as in box.enumerate_max, and the limit points at its two poles), the latter plus slack (their
    rounding).  First, the tangent planes at the arc's two ends and middle (f_p(m) <= m.(p - s) for s
    = s_E(m_k), so f_p is below their lower envelope, whose maximum over the arc _envelope bounds) when
    that, plus slack, is below `floor` (an upper bound then, by weak duality; first, before the
    projection).  On the pair benchmark's deep poses the middle's plane alone settled 4% of the lunes'
    meridian edges, the three 56% (of the 83% whose maximum is below `floor`): deep 8.6% faster, A/B
    with identical values; the ends' supports are the ends' h_E, used again for f_p there.  An end above
    `stop` as soon as one is (callers that only ask whether the maximum exceeds a level pass it as
    `stop`; inf for the maximum itself).  The circle's global maximum is one of the roots, not tried
    first by foot2: on the pair benchmark's deep poses it lay on the arc for none of 1677 arcs and
    settled 6 below `floor` (deep 4% faster without).  The arc's end is `end` itself and its test is by
    products, without angles (tangent-plane idea: tangent_cones.py; GTCG 10.5.2)."""
    p1, p2 = _dot(p, v1), _dot(p, v2)
    # tangent planes at the arc's ends and middle: f_p(m) <= m.(p - s_E(m_k)) everywhere (weak duality)
    h0, s0 = support(a2, v1)
    h2, s2 = support(a2, end)
    mid = (v1[0] + end[0], v1[1] + end[1], v1[2] + end[2])
    _, sm = support(a2, mid)
    lin = _envelope(
        (p1 - _dot(s0, v1), p2 - _dot(s0, v2)),
        (p1 - _dot(sm, v1), p2 - _dot(sm, v2)),
        (p1 - _dot(s2, v1), p2 - _dot(s2, v2)),
        cs,
        sn,
    )
    if lin + slack <= floor:
        return lin + slack, v1
    lam, mu, c, s = project_ellipse(a2, v1, v2)
    q = (c * p1 + s * p2, -s * p1 + c * p2, 0.0)
    best, bm = p1 - h0, v1
    v = _dot(p, end) - h2
    if v > best:
        best, bm = v, end
    if best > stop:
        return best, bm
    b3 = (lam, mu, 2.0 * max(lam, mu))
    for t in secular_roots(b3, q, True):
        if t == t:
            best, bm = _arc_top(
                a2, p, from_plane(q[0] / (t + lam), q[1] / (t + mu), c, s, v1, v2), v1, v2, cs, sn, slack, best, bm
            )
    # the limit points at the poles -lam, -mu (pole_normal of b3 in the plane: its third axis is not E's)
    if lam != mu:
        ok, x0, y1 = _plane_pole(lam, mu, q[1])
        ok2, x1, y0 = _plane_pole(mu, lam, q[0])
        for sign in (1.0, -1.0):  # (the order of the written-out blocks before: ties keep their point)
            if ok:
                best, bm = _arc_top(a2, p, from_plane(sign * x0, y1, c, s, v1, v2), v1, v2, cs, sn, slack, best, bm)
        for sign in (1.0, -1.0):
            if ok2:
                best, bm = _arc_top(a2, p, from_plane(y0, sign * x1, c, s, v1, v2), v1, v2, cs, sn, slack, best, bm)
    return best, bm


#: The split certificate (_split_settles) takes lunes whose far end lies within this multiple of the
#: incumbent's reach (_reach) along the rim, with a polar band of that half-width (1.4: the fastest of
#: 0.7, 1.4 and 2.5 on the pair benchmark's penetrating and deep poses; the certificate is checked
#: whatever the multiple).
SPLIT_REACH = 1.4
#: Band half-widths _split_settles tries, halving from the reach, before it gives the lune back: a band
#: as wide as the reach often leaves the model's concavity to the cubic remainder (the certificate
#: failed 7.2 times per uncertified penetrating pair at one try; penetrating 9% faster with three).
SPLIT_TRIES = 3
#: A lune holding the incumbent's azimuth, out of its reach, is split without a bound when the last
#: failed bound of such a lune, scaled by 4 a level (the linear bound's excess r |P n| (1 - cos) is
#: quadratic in the width), predicts an excess above this many tol: on a flat maximum the descent to the
#: reach fails one bound a level (penetrating 9%, deep 6% faster on the pair benchmark's poses; 8 gained
#: nothing more).  A skipped bound only costs its two children: the proof is theirs.
SKIP_EXCESS = 64.0
#: The rim's branch and bound starts from this many equal lunes, the first centred on the incumbent's
#: azimuth (6: deep and penetrating 7% faster than 4 quarters on the pair benchmark's poses, 5 and 7 the
#: same as 6; a narrower first lune leaves its linear bound less excess and its tangent cones less to do).
#: At least 3: a lune's bound (_poly_bound, cone_below) needs its ends less than pi apart (with 2, half
#: circles, it missed maxima by up to 1e-3 on the deep poses).
RIM_LUNES = 6
#: |D^3 |z|[w, w, w]| <= 3 |a| b^2 / |z|^2 with a^2 + b^2 = |w|^2, at most 2 / sqrt(3) |w|^3 / |z|^2.
D3_NORM = 1.1548
#: Steps of _reach's fixed-point iteration (odd: the radius then stays below the fixed point; 3 and 5
#: measured the same on the pair benchmark's deep poses).
REACH_STEPS = 5


@stage
def _edge_normal(a, b, cen):
    """a x b, pointing to the side of cen (zero when a = b: a repeated vertex)."""
    k = cross3(a, b)
    if _dot(k, cen) < 0.0:
        return (-k[0], -k[1], -k[2])
    return k


@stage
def _edge_max(a2, p, a, b, slack, floor, stop):
    """_arc_max over the great-circle arc from the unit a to the unit b (shorter than pi)."""
    k = cross3(a, b)
    sn = math.sqrt(norm2(k))
    if sn == 0.0:
        return -math.inf, a
    cs = _dot(a, b)
    w = (b[0] - cs * a[0], b[1] - cs * a[1], b[2] - cs * a[2])
    nw = math.sqrt(norm2(w))
    if not nw > 0.0:
        return -math.inf, a
    w = (w[0] / nw, w[1] / nw, w[2] / nw)
    return _arc_max(a2, p, a, w, cs, nw, b, slack, floor, stop)


@jit
def _poly_bound(a2, p, v0, v1, v2, v3, slack, floor, stop, edge12):
    """(bound, m): the maximum of f_p over the convex spherical quadrilateral v0 v1 v2 v3 (unit, in
    cyclic order, within an open hemisphere; a repeated vertex makes it a triangle, as a lune of the
    rim: its pole and its two ends on the equator) and where it is attained: the maxima over its
    great-circle edges (_arc_max) and every local maximum of f_p on the sphere (secular_roots,
    pole_normal) inside it.  Once an edge is above `stop`, that value and point, without the interior
    (_rim_bb and _split_settles only ask whether the maximum exceeds best + tol, and take the point as
    a start for a local climb; inf for the maximum itself).  The global maximum of f_p is one of the
    roots, not tried first by foot3: on the pair benchmark's deep poses it lay inside none of 575
    lunes and settled none below `floor`.  edge12: a known upper bound of f_p on the edge v1 v2 (inf if
    none), taken for that edge when <= floor."""
    cen = (v0[0] + v1[0] + v2[0] + v3[0], v0[1] + v1[1] + v2[1] + v3[1], v0[2] + v1[2] + v2[2] + v3[2])
    k0, k1 = _edge_normal(v0, v1, cen), _edge_normal(v1, v2, cen)
    k2, k3 = _edge_normal(v2, v3, cen), _edge_normal(v3, v0, cen)
    best, bm = _edge_max(a2, p, v0, v1, slack, floor, stop)
    v, m = edge12, v1
    if not edge12 <= floor:
        v, m = _edge_max(a2, p, v1, v2, slack, floor, stop)
    if v > best:
        best, bm = v, m
    v, m = _edge_max(a2, p, v2, v3, slack, floor, stop)
    if v > best:
        best, bm = v, m
    v, m = _edge_max(a2, p, v3, v0, slack, floor, stop)
    if v > best:
        best, bm = v, m
    if best > stop:
        return best, bm
    for t in secular_roots(a2, p, True):
        if t == t:
            m = unit((p[0] / (t + a2[0]), p[1] / (t + a2[1]), p[2] / (t + a2[2])))
            if _dot(m, k0) >= 0.0 and _dot(m, k1) >= 0.0 and _dot(m, k2) >= 0.0 and _dot(m, k3) >= 0.0:
                v = _f(a2, p, m) + slack
                if v > best:
                    best, bm = v, m
    for i in range(3):
        for sign in (1.0, -1.0):
            ok, m = pole_normal(a2, p, i, sign)
            if ok and _dot(m, k0) >= 0.0 and _dot(m, k1) >= 0.0 and _dot(m, k2) >= 0.0 and _dot(m, k3) >= 0.0:
                v = _f(a2, p, m) + slack
                if v > best:
                    best, bm = v, m
    return best, bm


@stage
def _cert_model(a2, q, su, r, n):
    """The second-order model of the rim function at the unit n for _cert_region: G(x) = x.q - h_E(x) -
    r |P x|, concave and 1-homogeneous, so sigma on the sphere is G(x) / |x| on the tangent plane x =
    n + y (y = y1 t1 + y2 t2, the gnomonic chart: great circles are its lines).  Returns (ok, (t1, t2),
    (g1, g2), (H11, H12, H22), G(n), h_E(n), |P n|, the largest |B y| of a unit y of the plane (B =
    diag(sqrt(a2))), the errors of g and H): G's gradient and Hessian on the plane, from
    grad h_E = A n / h, hess h_E = (A - A n n^T A / h^2) / h and hess |P x| = (P - P n n^T P / |P n|^2) / |P n|."""
    an = (a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
    h = math.sqrt(_dot(an, n))
    ss = perp(n, su)
    t1, t2 = tangent_basis(n)
    nu = _dot(n, su)
    if not ss > 0.0:
        return False, (t1, t2), (0.0, 0.0), (0.0, 0.0, 0.0), 0.0, h, ss, 0.0, 0.0, 0.0, 0.0
    pn = (n[0] - nu * su[0], n[1] - nu * su[1], n[2] - nu * su[2])
    ih, iss = 1.0 / h, 1.0 / ss
    grad = (
        q[0] - an[0] * ih - r * pn[0] * iss,
        q[1] - an[1] * ih - r * pn[1] * iss,
        q[2] - an[2] * ih - r * pn[2] * iss,
    )
    at = (_dot(an, t1), _dot(an, t2))
    ut = (_dot(su, t1), _dot(su, t2))
    pt = (-nu * ut[0], -nu * ut[1])  # P n . t_i = n.t_i - (n.u)(u.t_i), n.t_i = 0
    a11 = a2[0] * t1[0] * t1[0] + a2[1] * t1[1] * t1[1] + a2[2] * t1[2] * t1[2]
    a12 = a2[0] * t1[0] * t2[0] + a2[1] * t1[1] * t2[1] + a2[2] * t1[2] * t2[2]
    a22 = a2[0] * t2[0] * t2[0] + a2[1] * t2[1] * t2[1] + a2[2] * t2[2] * t2[2]
    ih2, iss2 = ih * ih, iss * iss
    h11 = -(a11 - at[0] * at[0] * ih2) * ih - r * ((1.0 - ut[0] * ut[0]) - pt[0] * pt[0] * iss2) * iss
    h12 = -(a12 - at[0] * at[1] * ih2) * ih - r * (-ut[0] * ut[1] - pt[0] * pt[1] * iss2) * iss
    h22 = -(a22 - at[1] * at[1] * ih2) * ih - r * ((1.0 - ut[1] * ut[1]) - pt[1] * pt[1] * iss2) * iss
    bt = math.sqrt(0.5 * (a11 + a22) + math.sqrt(0.25 * (a11 - a22) ** 2 + a12 * a12))
    amax = max(a2[0], a2[1], a2[2])
    eg = 64.0 * U * (math.sqrt(norm2(q)) + math.sqrt(amax) + r)
    eh = 256.0 * U * (amax * ih + r * iss) + 64.0 * U * r * iss2  # |P n| near 0: 1 - ut^2 and pt lose U / |P n|^2
    value = _dot(n, q) - h - r * ss
    g = (_dot(grad, t1), _dot(grad, t2))
    return (
        True,
        (t1, t2),
        g,
        (h11, h12, h22),
        value,
        h,
        ss,
        bt,
        eg,
        eh,
        _reach(g, (h11, h12, h22), value, h, ss, bt, r, _dot(su, t1), _dot(su, t2)),
    )


@stage
def _reach(g, H, value, h, ss, bt, r, s1, s2):
    """A chart radius within which _cert_region is likely to hold (a heuristic: the certificate itself
    is checked there): where M(rho) rho / 3 is half the margin of the concavity -(H - min(value, 0) I)
    along the rim (the chart direction perpendicular to u) and, across it, half of that margin or, for
    an incumbent on the side circle whose gradient points off the rim (g.s < 0), what that slope allows.
    M(rho), the third-derivative bound on the chart disc of radius rho, falls as rho does, so the radius
    is the fixed point of rho = 1.5 mu / M(rho) (capped at rho0), approached from below by REACH_STEPS
    (odd) steps from rho0: M taken at rho0 alone left it up to 4x short (deep 4-7% faster)."""
    c = min(value, 0.0)
    ns = math.sqrt(s1 * s1 + s2 * s2)
    if not ns > 0.0:
        return 0.0
    s = (s1 / ns, s2 / ns)  # the chart direction towards the cap
    a = (-s[1], s[0])  # along the rim
    qaa = H[0] * a[0] * a[0] + 2.0 * H[1] * a[0] * a[1] + H[2] * a[1] * a[1] - c
    qss = H[0] * s[0] * s[0] + 2.0 * H[1] * s[0] * s[1] + H[2] * s[1] * s[1] - c
    if not qaa < 0.0:
        return 0.0
    mu = min(-qaa, -qss) if qss < 0.0 else -qaa
    rho0 = 0.5 * min(h / bt, ss)
    rho = rho0
    for _ in range(REACH_STEPS):  # odd steps end below the fixed point: M(rho) rho <= 1.5 mu holds there
        M = D3_NORM * (bt * bt * bt / ((h - bt * rho) ** 2) + r / ((ss - rho) ** 2))
        rho = min(rho0, 1.5 * mu / M)
    if qss > 0.0:
        rho = min(rho, max(-(g[0] * s[0] + g[1] * s[1]), 0.0) / qss)
    return rho


@stage
def _chart(n, t, v):
    """(ok, y): the gnomonic coordinates of the unit v about the unit n (t its tangent basis)."""
    d = _dot(v, n)
    if not d > 0.0:
        return False, (0.0, 0.0)
    return True, (_dot(v, t[0]) / d, _dot(v, t[1]) / d)


@stage
def _quad_edge(g, Q, y, z):
    """max over the segment y z of Phi(w) = g.w + w^T Q w / 2 (Q = (Q11, Q12, Q22))."""
    d = (z[0] - y[0], z[1] - y[1])
    qy = (g[0] + Q[0] * y[0] + Q[1] * y[1], g[1] + Q[1] * y[0] + Q[2] * y[1])
    dqd = Q[0] * d[0] * d[0] + 2.0 * Q[1] * d[0] * d[1] + Q[2] * d[1] * d[1]
    s = qy[0] * d[0] + qy[1] * d[1]
    phi = g[0] * y[0] + g[1] * y[1] + 0.5 * (Q[0] * y[0] * y[0] + 2.0 * Q[1] * y[0] * y[1] + Q[2] * y[1] * y[1])
    best = max(phi, phi + s + 0.5 * dqd)
    if dqd < 0.0:
        tau = -s / dqd
        if 0.0 < tau < 1.0:
            best = max(best, phi + 0.5 * s * tau)
    return best


@stage
def _cert_region(cm, n, r, v0, v1, v2, v3, room):
    """Whether sigma stays below W = G(n) + slack + room (the caller's best + tol) on the convex
    spherical quadrilateral v0..v3, from the model cm of the rim function at n (_cert_model; room > 0).
    On the chart disc |y| <= rho holding its vertices, G(n + y) <= G(n) + g.y + y^T H y / 2 + M |y|^3 / 6
    (Taylor; M bounds G's third derivative along the plane: D3_NORM (b^3 / |B x|^2 + r / |P x|^2),
    |B x| >= h_E(n) - b rho, |P x| >= |P n| - rho), and sigma = G(x) / |x| <= W when G(x) <= W +
    min(W, 0) |y|^2 / 2 (|x| = sqrt(1 + |y|^2) <= 1 + |y|^2 / 2; min(W - slack, 0) is used, lower).  So
    it suffices that the quadratic Phi(y) = g.y + y^T Q y / 2, Q = H + (eh + M rho / 3 - min(W - slack,
    0)) I, stays below room - eg (rho + 1) on the quadrilateral's chart image (convex): at its vertices,
    on its edges and at the stationary point of a definite Q inside."""
    ok, t, g, H, value, h, ss, bt, eg, eh, _ = cm
    ok0, y0 = _chart(n, t, v0)
    ok1, y1 = _chart(n, t, v1)
    ok2, y2 = _chart(n, t, v2)
    ok3, y3 = _chart(n, t, v3)
    if not (ok and ok0 and ok1 and ok2 and ok3):
        return False
    rho = math.sqrt(
        max(
            y0[0] * y0[0] + y0[1] * y0[1],
            y1[0] * y1[0] + y1[1] * y1[1],
            y2[0] * y2[0] + y2[1] * y2[1],
            y3[0] * y3[0] + y3[1] * y3[1],
        )
    )
    rho *= 1.0 + 1e-9  # the chart's own rounding
    hl, sl = h - bt * rho, ss - rho
    if not (hl > 0.0 and sl > 0.0):
        return False
    M = D3_NORM * (bt * bt * bt / (hl * hl) + r / (sl * sl))
    V = value + room
    shift = eh + M * rho / 3.0 - min(V, 0.0)
    Q = (H[0] + shift, H[1], H[2] + shift)
    d = room - eg * (rho + 1.0)  # eg: also the O(u) slivers of the quadrilateral the float chart misses
    if d <= 0.0:
        return False
    best = max(_quad_edge(g, Q, y0, y1), _quad_edge(g, Q, y1, y2), _quad_edge(g, Q, y2, y3), _quad_edge(g, Q, y3, y0))
    det = Q[0] * Q[2] - Q[1] * Q[1]
    if Q[0] < 0.0 and det > 0.0:  # negative definite: the stationary point y* = -Q^-1 g, Phi(y*) = g.y* / 2
        ys = (-(Q[2] * g[0] - Q[1] * g[1]) / det, -(Q[0] * g[1] - Q[1] * g[0]) / det)
        s0 = (y1[0] - y0[0]) * (ys[1] - y0[1]) - (y1[1] - y0[1]) * (ys[0] - y0[0])
        s1 = (y2[0] - y1[0]) * (ys[1] - y1[1]) - (y2[1] - y1[1]) * (ys[0] - y1[0])
        s2 = (y3[0] - y2[0]) * (ys[1] - y2[1]) - (y3[1] - y2[1]) * (ys[0] - y2[0])
        s3 = (y0[0] - y3[0]) * (ys[1] - y3[1]) - (y0[1] - y3[1]) * (ys[0] - y3[0])
        if (s0 >= 0.0 and s1 >= 0.0 and s2 >= 0.0 and s3 >= 0.0) or (
            s0 <= 0.0 and s1 <= 0.0 and s2 <= 0.0 and s3 <= 0.0
        ):
            best = max(best, 0.5 * (g[0] * ys[0] + g[1] * ys[1]))
    return best <= d


@stage
def _split_settles(a2, p, su, ca, cb, b, cm, n, theta, r, room, floor, slack, equator):
    """Whether the lune between the meridians of ca and cb holds no sigma above floor = best + tol: on
    the incumbent n's polar band [theta - b, theta + b] (theta n's polar angle from su) by n's
    second-order model (_cert_region, room = floor - G(n) - slack), above and below it by the maximum
    of f_p (p = q - r c, sigma <= f_p) over the two pieces (_poly_bound).  The band starts at the
    half-width b and is halved while the certificate fails on it (SPLIT_TRIES widths).  equator: an
    upper bound of f_p on the lune's equator arc ca cb (_poly_bound's edge12)."""
    for _ in range(SPLIT_TRIES):  # a band too wide for the model's concavity: halve it
        ta, tb = max(theta - b, 0.0), min(theta + b, 0.5 * math.pi)
        va, vb = _turn(su, ca, ta), _turn(su, cb, ta)  # su itself at ta = 0
        wa, wb = (ca, cb) if tb == 0.5 * math.pi else (_turn(su, ca, tb), _turn(su, cb, tb))
        if _cert_region(cm, n, r, va, wa, wb, vb, room):
            break
        b *= 0.5
    else:
        return False
    if ta > 0.0 and _poly_bound(a2, p, su, va, vb, su, slack, floor, floor, math.inf)[0] > floor:
        return False
    return not (tb < 0.5 * math.pi and _poly_bound(a2, p, wa, ca, cb, wb, slack, floor, floor, equator)[0] > floor)


@stage
def _equator_bound(side_ub, r, ca, cb, c, slack):
    """An upper bound of f_p (p = q - r c) on the equator arc from ca to cb of a rim lune, c on that arc:
    there n.q = n.e, so f_p = sigma_side(n) + r (1 - n.c) <= side_ub + r (1 - min(ca.c, cb.c)) (n.c is
    smallest at an end), plus slack for ca, cb, c being perpendicular to u only to rounding.  Below the
    level it settles that edge of the lune's bound without the arc's roots (_poly_bound's edge12; on
    the pair benchmark's deep poses 40% of the bounds, 3% faster, penetrating 8%)."""
    return side_ub + r * (1.0 - min(_dot(ca, c), _dot(cb, c))) + slack


@jit
def _rim_bb(a2, e, u, L, r, sg, best, bn, tol, slack, side_ub):
    """Branch and bound over the azimuth of the rim piece sg (the hemisphere sg n.u >= 0), where
    sigma(n) = f_q(n) - r |P n| with q = e - sg L u.  For any unit c perpendicular to u, r |P n| >= r n.c,
    so on a lune of azimuths sigma <= f_{q - r c}, whose maximum over the lune (the spherical triangle
    of the pole and the lune's ends on the equator) is found exactly (_poly_bound).  c is the
    incumbent's azimuth on the lunes that contain it -- the bound there is sigma's own maximum once
    the lune is narrow enough to hold no other local maximum of f_{q - r c} -- and the lune's end
    nearer to it elsewhere (the bound equals sigma along that meridian and exceeds it by r |P n|
    (1 - cos) of the azimuth from it); lunes within the incumbent's reach go to _split_settles.
    A lune whose tangent planes close it (cone_below: the cone of the pole and its two ends; three dot
    products a node) skips all that, and a lune holding the incumbent whose bound is predicted to fail
    (SKIP_EXCESS) is split without one.  The cone is not tried on a lune holding the incumbent itself
    (on this rim, or on the side circle to rounding): sigma reaches best there, a hair below the cone's
    level best + tol - slack, and on the pair benchmark's deep poses the planes closed 18 of the 216
    lunes holding its azimuth on the rim facing E, ~600 ns a failure (deep 3% faster without); nor on a
    lune within the incumbent's reach, which goes to _split_settles at once (those two: deep and
    penetrating 2-3% faster, A/B).  RIM_LUNES lunes from the incumbent's azimuth, each split in two
    depth first (no allocation: a node is its level and index) until its bound is within tol of the
    incumbent; a lune whose maximiser beats the incumbent starts a rim Newton run there.  A node starts
    on the vector its predecessor ended on (a first child on its parent's start) and only a split turns
    a new end (a sine and cosine), the last lune ending on the first one's start: the lunes tile the
    circle with shared end vectors, and a lune that settles whole costs one turn (deep 2.5% faster than
    two a node); c at the incumbent is its own azimuth's.  Returns (best, bn, proven): proven False
    when RIM_BB_NODES lunes or RIM_BB_LEVELS levels did not settle it.  side_ub: an upper bound of
    sigma on the side circle (deep_search's), which bounds f_p on a lune's equator arc
    (_equator_bound)."""
    q = (e[0] - sg * L * u[0], e[1] - sg * L * u[1], e[2] - sg * L * u[2])
    su = (sg * u[0], sg * u[1], sg * u[2])
    w1, w2 = tangent_basis(su)
    first = 2.0 * math.pi / RIM_LUNES
    phi = 0.0
    has = perp(bn, u) > 0.0  # an azimuth: on this rim, on the side circle, or on the other rim
    if has:
        phi = math.atan2(_dot(bn, w2), _dot(bn, w1))
    ci = _turn(w1, w2, phi)
    cm = _cert_model(a2, q, su, r, bn)
    theta = math.atan2(perp(bn, u), _dot(bn, su))
    start = phi - 0.5 * first
    nodes = 0
    xs, xl = 0.0, 0  # the last failed bound of a lune holding the incumbent: its excess and level
    e0 = _turn(w1, w2, start)
    cb = e0
    for k in range(RIM_LUNES):
        a0 = start + k * first
        end = e0 if k == RIM_LUNES - 1 else _turn(w1, w2, a0 + first)  # the last closes the circle on e0
        lev, idx = 0, 0
        ca = cb  # the next lune starts where the last one ended
        while True:
            width = math.ldexp(first, -lev)
            a = a0 + idx * width
            cb = end if idx + 1 == (1 << lev) else _turn(w1, w2, a + width)  # the lune's far end
            off = (phi - a) % (2.0 * math.pi)
            if not has:
                c = _turn(w1, w2, a + 0.5 * width)
            elif off <= width:
                c = ci  # the incumbent's azimuth
            else:  # the end nearer the incumbent: the bound is sigma itself along that meridian
                c = cb if off - width < 2.0 * math.pi - off else ca
            p = (q[0] - r * c[0], q[1] - r * c[1], q[2] - r * c[2])
            equator = _equator_bound(side_ub, r, ca, cb, c, slack)
            nodes += 1
            room = best + tol - cm[4] - slack
            reach = SPLIT_REACH * cm[10]
            far = max(off, width - off) if off <= width else min(off, 2.0 * math.pi - off + width)
            near = reach > 0.0 and far * cm[6] <= reach and room > 0.0  # within the incumbent's reach
            holds = has and off <= width and not near
            if holds and math.ldexp(xs, 2 * (xl - lev)) > SKIP_EXCESS * tol:
                bound, m = math.inf, bn  # its bound would fail too (SKIP_EXCESS): split it unbounded
            elif (
                not near
                and not (holds and sg * _dot(bn, u) >= -1e-12)
                and cone_below(a2, q, u, r, bn, bn, su, ca, cb, best + tol - slack)
            ):
                bound, m = -math.inf, bn  # closed by tangent planes (tangent_cones.py)
            elif near and _split_settles(a2, p, su, ca, cb, reach, cm, bn, theta, r, room, best + tol, slack, equator):
                bound, m = -math.inf, bn
            else:
                bound, m = _poly_bound(a2, p, su, ca, cb, su, slack, best + tol, best + tol, equator)
                if holds and bound > best + tol:
                    xs, xl = bound - best, lev
            if bound > best + tol:
                v = sigma_cylinder(a2, e, u, L, r, m)
                if v > best and sg * _dot(m, u) > 0.0 and perp(m, u) > 0.0:
                    mn, _, code = _rim_newton(a2, e, u, L, r, sg, m)
                    vn = sigma_cylinder(a2, e, u, L, r, mn)
                    if vn > v:
                        v, m = vn, mn
                if v > best:  # the children take c and the second-order model from the new incumbent
                    best, bn = v, m
                    xs = 0.0  # no prediction for the new incumbent's lunes
                    has = perp(bn, u) > 0.0
                    if has:
                        phi = math.atan2(_dot(bn, w2), _dot(bn, w1))
                        ci = _turn(w1, w2, phi)
                    cm = _cert_model(a2, q, su, r, bn)
                    theta = math.atan2(perp(bn, u), _dot(bn, su))
            if bound > best + tol:
                if nodes >= RIM_BB_NODES or lev >= RIM_BB_LEVELS:
                    return best, bn, False
                lev, idx = lev + 1, 2 * idx  # the first child: its parent's start ca
                continue
            while lev > 0 and idx % 2 == 1:
                lev, idx = lev - 1, idx // 2
            if lev == 0:
                break
            idx += 1
            ca = cb  # the next node starts where this one ended
    return best, bn, True


@stage
def _mirrored(a2, e, u):
    """Whether sigma on the rim facing away from E's centre (sg e.u < 0) is nowhere above its value at
    the mirror image n' = n - 2 (n.u) u / |u|^2 (on the other rim): h_K(n') = h_K(n) (|n'| = |n|,
    |n'.u| = |n.u|, |n' x u| = |n x u|, for the float u too), and with h_E(n') - h_E(n) <= s_E(n').(n' - n)
    (convexity), sigma(n) - sigma(n') <= 2 (n.u) (e.u - s_E(n').u) / |u|^2 <= 2 |n.u| (h_E(u) - |e.u|) / |u|^2,
    at most 0 when |e.u| >= h_E(u): E on one side of K's mid-plane (80 of the 107 penetrating poses of
    the pair benchmark that reach the branch and bound; none of the deep ones).  Tested with 64 u of
    margin on each side for the rounding of the dot product and the square root."""
    eu = _dot(e, u)
    spread = abs(e[0] * u[0]) + abs(e[1] * u[1]) + abs(e[2] * u[2])
    hu = math.sqrt(a2[0] * u[0] * u[0] + a2[1] * u[1] * u[1] + a2[2] * u[2] * u[2])
    return abs(eu) - 64.0 * U * spread >= hu * (1.0 + 64.0 * U)


@jit
def deep_search(a2, e, u, L, r, best, bn, tol, slack):
    """Caps and side exactly, then each rim piece by its azimuth branch and bound (_rim_bb), the rim
    facing E's centre (sg e.u >= 0) first.  The other is skipped once that one is proven when E lies
    on its side of K's mid-plane, |e.u| >= h_E(u) (_mirrored).  Returns (value, n, proven)."""
    for sg in (1.0, -1.0):
        m = (sg * u[0], sg * u[1], sg * u[2])
        v = sigma_cylinder(a2, e, u, L, r, m)
        if v > best:
            best, bn = v, m
    w1, w2 = tangent_basis(u)
    m, side_ub = circle_max_bound(a2, e, w1, w2)
    v = sigma_cylinder(a2, e, u, L, r, m)
    if v > best:
        best, bn = v, m
    s0 = -1.0 if _dot(e, u) < 0.0 else 1.0
    best, bn, proven = _rim_bb(a2, e, u, L, r, s0, best, bn, tol, slack, side_ub - r)
    if not (proven and _mirrored(a2, e, u)):
        best, bn, ok = _rim_bb(a2, e, u, L, r, -s0, best, bn, tol, slack, side_ub - r)
        proven = proven and ok
    return best, bn, proven


@jit
def axis_max(a2, e, u, L, r, tol, scale, n0):
    """A second chance for a rim left unproven when E is a spheroid whose axis is (nearly) along the
    cylinder's: sigma is then (nearly) constant along the rim, which no lune is short enough to settle.
    spheroids.axis_bb about u (h_K = L |cos t| + r sin t in polar coordinates about u, E a spheroid
    about its axis j: the model's errors delta0 below), in the frame B = (u, w1, w2) (tangent_basis):
    sigma(B nu) for unit nu differs from the model by the rounding of B^T e and B^T e_j and by B's
    orthonormality defect def (|B nu|^2 = 1 +- 3 def: sigma, 1-homogeneous, moves by <= 1.5 def S, h_E's
    model by 3 pb^2 def / min(qb, pb)), and by the axis u / |u| in place of u (|u| = 1 to ~1e-15).
    Returns (proven, n, value): max sigma <= value + tol when proven."""
    ra = (math.sqrt(a2[0]), math.sqrt(a2[1]), math.sqrt(a2[2]))
    j, db = _axis_of(ra)
    j1, j2 = (j + 1) % 3, (j + 2) % 3
    qb, pb = ra[j], 0.5 * (ra[j1] + ra[j2])
    uu = math.sqrt(_dot(u, u))  # u from to_frame is unit to ~1e-15: the model's axis is u / |u|
    u0 = u
    u = (u[0] / uu, u[1] / uu, u[2] / uu)
    w1, w2 = tangent_basis(u)
    dfu = max(abs(_dot(u, u) - 1.0), abs(_dot(w1, w1) - 1.0), abs(_dot(w2, w2) - 1.0))
    dfu = max(dfu, abs(_dot(u, w1)), abs(_dot(u, w2)), abs(_dot(w1, w2))) + 3.0 * U  # + the dots' rounding
    delta0 = db * (1.0 + 3.0 * dfu) + 3.0 * pb * pb * dfu / min(qb, pb) + 3.0 * dfu * scale
    delta0 += 3.0 * (L + r) * (abs(uu - 1.0) + 2.0 * U) + 12.0 * U * scale
    delta0 += 4.0 * U * L  # the cells at t = T/2 reach ~2e-16 past pi / 2, where a piece exceeds sigma by 2 L |cos t|
    tol1 = tol - 2.0 * delta0 - (ERR_C_ULPS + BB_ERR_SIGMA_ULPS + 8.0) * U * scale
    nu = (_dot(n0, u), _dot(n0, w1), _dot(n0, w2))
    t0, p0 = math.atan2(math.sqrt(nu[1] * nu[1] + nu[2] * nu[2]), nu[0]), math.atan2(nu[2], nu[1])
    ok, t, p, moved, _ = axis_bb(
        _dot(e, u),
        _dot(e, w1),
        _dot(e, w2),
        1,
        L,
        r,
        qb * qb - pb * pb,
        pb * pb,
        u[j],
        w1[j],
        w2[j],
        tol1,
        scale,
        0.0,
        t0,
        p0,
    )
    n = n0
    if moved:
        ct, st, cp, sp = math.cos(t), math.sin(t), math.cos(p), math.sin(p)
        n = unit(
            (
                ct * u[0] + st * (cp * w1[0] + sp * w2[0]),
                ct * u[1] + st * (cp * w1[1] + sp * w2[1]),
                ct * u[2] + st * (cp * w1[2] + sp * w2[2]),
            )
        )
    return ok, n, sigma_cylinder(a2, e, u0, L, r, n)


@jit
def cylinder_ellipsoid(E, K):
    """(status, dist, normal (3,), pos (3,), ub) for the ellipsoid E and the cylinder K, tuples (centre
    (3,) metres, rotation row-major (9,), sizes (3,) metres; K's sizes (radius, half-length, unused),
    its axis its local z, as MuJoCo's cylinder geom).  dist: sigma at the returned normal (a lower bound
    of the exact signed distance, metres); normal: unit, from E to K; pos: the midpoint of the witness
    points; ub: the certified upper bound (inf unless CERTIFIED); status: CERTIFIED, ENUMERATED (both
    proofs) or UNPROVEN (a rim branch and bound out of budget: the best maximum found)."""
    e, a2, u = to_frame(E, K)
    r, L = K[2][0], K[2][1]
    ra = E[2]
    rho = rolling_radius(ra)
    scale = math.sqrt(norm2(e)) + max(ra[0], ra[1], ra[2], r, L)
    # the contract's 1e-12 of the smallest size, floored (as two ellipsoids' in ellipsoid_pair.py) by what
    # float64 evaluates sigma to: a 0.02 m thin disc on a 1.3 m limb asks for 1e-14 m, 100 ulps of the
    # pair's scale, less than axis_max's own rounding budget (~110 u S); twice the ellipsoids' floor
    tol = max(PAIR_CERT_REL * min(ra[0], ra[1], ra[2], r, L), 2.0 * BB_TOL_ULPS * U * scale)
    n, _, _ = local_max(a2, e, u, L, r)
    value = sigma_cylinder(a2, e, u, L, r, n)
    slack = PAIR_SIGMA_SLACK_ULPS * U * scale
    ub = upper_bound(a2, e, u, L, r, rho, n, value, tol, slack)
    status = CERTIFIED
    if ub - value > tol:
        v0, n0 = value, n
        value, n, proven = deep_search(a2, e, u, L, r, value, n, tol, slack)
        ub2 = ub  # the same incumbent: the same certificates, already failed (deep 4% faster)
        if value != v0 or n[0] != n0[0] or n[1] != n0[1] or n[2] != n0[2]:
            ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol, slack)
        by_axis = False
        if not proven and ub2 - value > tol:  # a flat rim: E a spheroid about (nearly) the cylinder's axis
            by_axis, m, v = axis_max(a2, e, u, L, r, tol, scale, n)
            if by_axis and v > value:  # (else proven from the incumbent itself: max <= v + tol <= value + tol)
                value, n = v, m
        if by_axis:
            ub = value + tol
        elif ub2 - value <= tol:
            ub = ub2
        else:
            status = ENUMERATED if proven else UNPROVEN
            ub = math.inf
    normal, pos = contact_in_world(E, a2, n, value)
    return status, value, normal, pos, ub


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
