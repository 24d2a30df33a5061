"""Cylinder x ellipsoid as a Warp function: a float64 port of core/pairs/cylinder.py (its docstring has the
method), and of what it takes from core/distance/spheroids.py (_axis_of, axis_bb for a cylinder on a
spheroid's axis).  Its proofs are the CPU's before the capsule certificate of side contacts (ub4) and the
second-order certificate near the rim's incumbent: the same contract, more lunes on deep crossings.

sigma(n) = n.e - h_E(n) - L |n.u| - r |P n| in E's principal frame (P = I - u u^T): the caps n = +-u, the
side circle n.u = 0 (a 2-D point-ellipse problem, Eberly's secular equation; Schneider & Eberly 10.5.2)
and the two rim regions, where sigma = f_q(n) - r |P n| is smooth.  Local solve: Newton on the rim facing
E in polar coordinates about its cap, the caps and the side by KKT; certificates: the rolling-radius
bound, the inner-ball bound, the side's sweep bound; else the caps and side exactly and each rim by its
azimuth branch and bound over lunes (a node is its level and index: no stack), and for a spheroid about
(nearly) the cylinder's axis the (t, phi) branch and bound of spheroids.axis_bb (no stack either: a cell
is its levels, indices and the bits of its split directions).  status GLOBAL when proven (CERTIFIED or
ENUMERATED on the CPU), UNPROVEN when a rim's branch and bound ran out of budget or the result is not
finite, APART as capsule.py.

Reading of a pose: as kernels.py (the float32 rotations widened, used as given: E's frame is R_E^T, the
cylinder's axis R_E^T times its rotation's third column).  Where the CPU code returns nan or inf as a
flag, these functions return a flag beside the value or 1e300; constant expressions are module constants
(Warp evaluates an expression of literals in float32); Python's float % is fmod plus the divisor when the
signs differ (_pymod); ldexp and 2.0**-n are exact halvings.
"""

import math

import warp as wp

from ..core.distance.spheroids import (
    ERR_C_ULPS,
    ROOT_P,
    ROOT_T,
    T_DOMAIN,
    TILT_DEPTH,
    TILT_LEVELS,
    U4,
    U64,
)
from ..core.pairs.cylinder import CAP_TOL, NEWTON_MAX_ITER, NEWTON_STEP_TOL
from ..core.tolerances import (
    BB_ERR_SIGMA_ULPS,
    BB_TOL_ULPS,
    PAIR_CERT_REL,
    PAIR_SIGMA_SLACK_ULPS,
    RIM_BB_LEVELS,
    RIM_BB_NODES,
    TILTED_MAX_NODES,
    U,
)
from .point_ellipsoid import (
    circle_max_bound,
    copysign,
    foot2,
    foot3,
    from_plane,
    pole_normal,
    project_ellipse,
    root_normal,
    sd_upper,
    sd_upper2,
    secular_roots,
    support,
    tangent_basis,
    unit,
)

F64 = wp.float64
I64 = wp.int64

GLOBAL, UNPROVEN, APART = 0, 1, 2  # kernels' pair statuses
SIDE, CAP_P, CAP_M, RIM_P, RIM_M = 0, 1, 2, 3, 4  # cylinder's strata
CONVERGED, AT_CAP, STALLED = 0, 1, 2  # cylinder._rim_newton's codes

INF = 1e300  # (math.inf as a bound: larger than any finite value the functions compare it with)
PI = math.pi
HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi
HALF_PI_MINUS = 0.5 * math.pi - 1e-6
STEP_TOL2 = NEWTON_STEP_TOL * NEWTON_STEP_TOL
ONE_MINUS_1E9 = 1.0 - 1e-9
SLACK = PAIR_SIGMA_SLACK_ULPS * U
TOL_ULPS = 2.0 * BB_TOL_ULPS * U
THREE_U = 3.0 * U
TWO_U = 2.0 * U
TWELVE_U = 12.0 * U
FOUR_U = 4.0 * U
AXIS_ERR = (ERR_C_ULPS + BB_ERR_SIGMA_ULPS + 8.0) * U
# spheroids.axis_bb
ONE_PLUS_U4 = 1.0 + U4
ONE_MINUS_U4 = 1.0 - U4
ONE_PLUS_1E12 = 1.0 + 1e-12
ONE_MINUS_1E12 = 1.0 - 1e-12
ONE_PLUS_1E15 = 1.0 + 1e-15
TWO_T_DOMAIN = 2.0 * T_DOMAIN
U4_T_DOMAIN = U4 * T_DOMAIN
N_ROOTS = (1 << ROOT_T) * (1 << ROOT_P)
ROOT_P_MASK = (1 << ROOT_P) - 1


@wp.func
def _dot(x: wp.vec3d, y: wp.vec3d) -> wp.float64:
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@wp.func
def _min3(v: wp.vec3d) -> wp.float64:
    return wp.min(v[0], wp.min(v[1], v[2]))


@wp.func
def _max3(v: wp.vec3d) -> wp.float64:
    return wp.max(v[0], wp.max(v[1], v[2]))


@wp.func
def _half(x: wp.float64, n: int) -> wp.float64:
    """x 2^-n (math.ldexp(x, -n), 2.0**-n x): exact halvings, no underflow for the n used here."""
    y = x
    for _ in range(n):
        y = y * F64(0.5)
    return y


@wp.func
def _pymod(x: wp.float64, y: wp.float64) -> wp.float64:
    """Python's x % y for y > 0: fmod, plus y when the remainder is negative (0.0 for a zero one)."""
    m = wp.mod(x, y)
    if m != F64(0.0):
        if m < F64(0.0):
            m = m + y
    else:
        m = F64(0.0)
    return m


@wp.func
def _sgn(x: wp.float64) -> wp.float64:
    """1 for x > 0, else -1 (the `1.0 if x > 0.0 else -1.0` of the CPU code)."""
    if x > F64(0.0):
        return F64(1.0)
    return F64(-1.0)


@wp.func
def _rim_of(sg: wp.float64) -> int:
    if sg > F64(0.0):
        return RIM_P
    return RIM_M


# --- sigma and its pieces (cylinder.perp, sigma_cylinder, sigma_rim, _witness) ------------------------


@wp.func
def perp(n: wp.vec3d, u: wp.vec3d) -> wp.float64:
    """|P n| = |n x u| for the unit u (cylinder.perp)."""
    x0 = n[1] * u[2] - n[2] * u[1]
    x1 = n[2] * u[0] - n[0] * u[2]
    x2 = n[0] * u[1] - n[1] * u[0]
    return wp.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


@wp.func
def sigma_cylinder(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, n: wp.vec3d) -> wp.float64:
    """sigma at the unit n (E's frame)."""
    h = wp.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    nu = _dot(n, u)
    return _dot(n, e) - h - L * wp.abs(nu) - r * perp(n, u)


@wp.func
def sigma_rim(a2: wp.vec3d, q: wp.vec3d, u: wp.vec3d, r: wp.float64, n: wp.vec3d) -> wp.float64:
    """f_rim(n) = n.q - h_E(n) - r |P n| for the unit n."""
    h = wp.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    return _dot(n, q) - h - r * perp(n, u)


@wp.func
def _witness(a2: wp.vec3d, e: wp.vec3d, n: wp.vec3d, value: wp.float64) -> wp.vec3d:
    """K's support point in direction +n relative to K's centre: e - s_E(n) - value n."""
    _h, s = support(a2, n)
    return wp.vec3d(e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])


# --- the local solve (cylinder._rim_newton, local_max) ------------------------------------------------


@wp.func
def _hq(a2: wp.vec3d, an: wp.vec3d, ih: wp.float64, x: wp.vec3d, y: wp.vec3d) -> wp.float64:
    """H = -(A/h - an an^T/h^3) applied to x, y (_rim_newton's hq)."""
    return (
        -(a2[0] * x[0] * y[0] + a2[1] * x[1] * y[1] + a2[2] * x[2] * y[2]) * ih
        + _dot(an, x) * _dot(an, y) * ih * ih * ih
    )


@wp.func
def _polar(sg: wp.float64, u: wp.vec3d, w1: wp.vec3d, w2: wp.vec3d, b: wp.float64, p: wp.float64) -> wp.vec3d:
    """sg cos(b) u + sin(b) (cos(p) w1 + sin(p) w2), each trigonometric call per component as the CPU's."""
    return wp.vec3d(
        sg * wp.cos(b) * u[0] + wp.sin(b) * (wp.cos(p) * w1[0] + wp.sin(p) * w2[0]),
        sg * wp.cos(b) * u[1] + wp.sin(b) * (wp.cos(p) * w1[1] + wp.sin(p) * w2[1]),
        sg * wp.cos(b) * u[2] + wp.sin(b) * (wp.cos(p) * w1[2] + wp.sin(p) * w2[2]),
    )


@wp.func
def _rim_newton(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, sg: wp.float64, n0: wp.vec3d):
    """(n, value, code): Newton for max of f_rim on the rim sg from the unit n0, in polar coordinates
    about the cap sg u (cylinder._rim_newton)."""
    q = wp.vec3d(e[0] - sg * L * u[0], e[1] - sg * L * u[1], e[2] - sg * L * u[2])
    w1, w2 = tangent_basis(u)
    b = wp.atan2(perp(n0, u), sg * _dot(n0, u))
    p = wp.atan2(_dot(n0, w2), _dot(n0, w1))
    b = wp.min(wp.max(b, F64(1e-6)), F64(HALF_PI_MINUS))
    value = F64(-INF)
    n = n0
    for _it in range(NEWTON_MAX_ITER):
        cb = wp.cos(b)
        sb = wp.sin(b)
        cp = wp.cos(p)
        sp = wp.sin(p)
        c = wp.vec3d(cp * w1[0] + sp * w2[0], cp * w1[1] + sp * w2[1], cp * w1[2] + sp * w2[2])
        dc = wp.vec3d(-sp * w1[0] + cp * w2[0], -sp * w1[1] + cp * w2[1], -sp * w1[2] + cp * w2[2])
        n = wp.vec3d(sg * cb * u[0] + sb * c[0], sg * cb * u[1] + sb * c[1], sg * cb * u[2] + sb * c[2])
        nb = wp.vec3d(-sg * sb * u[0] + cb * c[0], -sg * sb * u[1] + cb * c[1], -sg * sb * u[2] + cb * c[2])
        npp = wp.vec3d(sb * dc[0], sb * dc[1], sb * dc[2])
        an = wp.vec3d(a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
        h = wp.sqrt(_dot(an, n))
        ih = F64(1.0) / h
        G = wp.vec3d(q[0] - an[0] * ih, q[1] - an[1] * ih, q[2] - an[2] * ih)
        value = _dot(n, q) - h - r * sb
        fb = _dot(G, nb) - r * cb
        fp = _dot(G, npp)
        fbb = _hq(a2, an, ih, nb, nb) - _dot(G, n) + r * sb
        fpp = _hq(a2, an, ih, npp, npp) - sb * _dot(G, c)
        fbp = _hq(a2, an, ih, nb, npp) + cb * _dot(G, dc)
        det = fbb * fpp - fbp * fbp
        shift = F64(0.0)
        if not (fbb < F64(0.0) and det > F64(0.0)):
            dd = fbb - fpp
            top = F64(0.5) * (fbb + fpp) + wp.sqrt(F64(0.25) * (dd * dd) + fbp * fbp)
            shift = wp.max(top, F64(0.0)) + F64(1e-3) * (wp.abs(fbb) + wp.abs(fpp)) + wp.sqrt(fb * fb + fp * fp)
            fbb = fbb - shift
            fpp = fpp - shift
            det = fbb * fpp - fbp * fbp
        idet = F64(1.0) / det
        db = -(fpp * fb - fbp * fp) * idet
        dp = -(fbb * fp - fbp * fb) * idet
        arc2 = db * db + sb * sb * dp * dp
        if arc2 > F64(0.25):
            f = F64(0.5) / wp.sqrt(arc2)
            db = db * f
            dp = dp * f
            arc2 = F64(0.25)
        if b + db <= F64(0.0):  # towards the cap: at most halfway there
            f = F64(0.5) * b / (-db)
            db = db * f
            dp = dp * f
            arc2 = arc2 * f * f
        for _ in range(12):  # backtrack until f grows
            m = _polar(sg, u, w1, w2, b + db, p + dp)
            if arc2 < F64(1e-12) or sigma_rim(a2, q, u, r, m) >= value:
                break
            db = F64(0.5) * db
            dp = F64(0.5) * dp
            arc2 = F64(0.25) * arc2
        b = b + db
        p = p + dp
        if b <= F64(CAP_TOL):
            m = wp.vec3d(sg * u[0], sg * u[1], sg * u[2])
            return m, sigma_rim(a2, q, u, r, m), AT_CAP
        if arc2 <= F64(STEP_TOL2) and shift == F64(0.0):
            cb = wp.cos(b)
            sb = wp.sin(b)
            m = wp.vec3d(
                sg * cb * u[0] + sb * (wp.cos(p) * w1[0] + wp.sin(p) * w2[0]),
                sg * cb * u[1] + sb * (wp.cos(p) * w1[1] + wp.sin(p) * w2[1]),
                sg * cb * u[2] + sb * (wp.cos(p) * w1[2] + wp.sin(p) * w2[2]),
            )
            return m, sigma_rim(a2, q, u, r, m), CONVERGED
    return n, value, STALLED


@wp.func
def local_max(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64):
    """(n, stratum, converged): the rim facing E first, then the caps and the side by KKT
    (cylinder.local_max)."""
    eu = _dot(e, u)
    ep = wp.vec3d(e[0] - eu * u[0], e[1] - eu * u[1], e[2] - eu * u[2])
    pe = wp.sqrt(_dot(ep, ep))
    c = wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    if pe > F64(0.0):
        c = wp.vec3d(ep[0] / pe, ep[1] / pe, ep[2] / pe)
    else:
        t1, _t2 = tangent_basis(u)
        c = t1
    sg = F64(-1.0)
    if eu >= F64(0.0):
        sg = F64(1.0)
    q = wp.vec3d(e[0] - sg * L * u[0] - r * c[0], e[1] - sg * L * u[1] - r * c[1], e[2] - sg * L * u[2] - r * c[2])
    _t, start = foot3(a2, q)
    if sg * _dot(start, u) > F64(0.0) and wp.abs(_dot(start, u)) < F64(ONE_MINUS_1E9):
        m0, _v0, code0 = _rim_newton(a2, e, u, L, r, sg, start)
        if code0 == CONVERGED and sg * _dot(m0, u) > F64(0.0):
            return m0, _rim_of(sg), True
    # the caps and the side, then their KKT
    best = sigma_cylinder(a2, e, u, L, r, u)
    n = u
    st = int(CAP_P)
    mu_ = wp.vec3d(-u[0], -u[1], -u[2])
    v = sigma_cylinder(a2, e, u, L, r, mu_)
    if v > best:
        best = v
        n = mu_
        st = CAP_M
    w1, w2 = tangent_basis(u)
    ns, _ub = circle_max_bound(a2, e, w1, w2)
    v = sigma_cylinder(a2, e, u, L, r, ns)
    if v > best:
        best = v
        n = ns
        st = SIDE
    f = F64(0.0)
    yr = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    for _ in range(4):
        y = _witness(a2, e, n, best)
        ya = _dot(y, u)
        if st == SIDE:
            if wp.abs(ya) <= L:
                return n, st, True
            sg = _sgn(ya)
            start = unit(
                wp.vec3d(n[0] + F64(0.1) * sg * u[0], n[1] + F64(0.1) * sg * u[1], n[2] + F64(0.1) * sg * u[2])
            )
        else:
            sg = F64(-1.0)
            if st == CAP_P:
                sg = F64(1.0)
            yr = wp.vec3d(y[0] - ya * u[0], y[1] - ya * u[1], y[2] - ya * u[2])
            rad = wp.sqrt(_dot(yr, yr))
            if rad <= r:
                return n, st, True
            # the rim optimum sits off the cap by about (rad - r) / curvature: start there
            f = wp.min(F64(0.3), wp.max(F64(1e-6), F64(10.0) * (rad - r) / rad)) / rad
            start = unit(wp.vec3d(sg * u[0] + f * yr[0], sg * u[1] + f * yr[1], sg * u[2] + f * yr[2]))
        m, val, code = _rim_newton(a2, e, u, L, r, sg, start)
        if code != CONVERGED and st != SIDE:  # a second start closer to the cap
            f2 = F64(0.01) * f
            start = unit(wp.vec3d(sg * u[0] + f2 * yr[0], sg * u[1] + f2 * yr[1], sg * u[2] + f2 * yr[2]))
            m2, val2, code2 = _rim_newton(a2, e, u, L, r, sg, start)
            if code2 == CONVERGED or val2 > val:
                m = m2
                val = val2
                code = code2
        if code == CONVERGED and sg * _dot(m, u) > F64(0.0):
            return m, _rim_of(sg), True
        if code == AT_CAP:
            n = wp.vec3d(sg * u[0], sg * u[1], sg * u[2])
            st = CAP_M
            if sg > F64(0.0):
                st = CAP_P
        elif code == CONVERGED:  # crossed to the other hemisphere: the side
            n = ns
            st = SIDE
        else:
            return m, _rim_of(sg), False
        best = sigma_cylinder(a2, e, u, L, r, n)
    return n, st, False


# --- the certificates (cylinder.sd_point_cylinder, upper_bound1, upper_bound2, _sweep_bound) ---------


@wp.func
def sd_point_cylinder(w: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64) -> wp.float64:
    z = _dot(w, u)
    rad = perp(w, u)
    dz = wp.abs(z) - L
    dr = rad - r
    if dz <= F64(0.0) and dr <= F64(0.0):
        return wp.max(dz, dr)
    oz = wp.max(dz, F64(0.0))
    orr = wp.max(dr, F64(0.0))
    return wp.sqrt(oz * oz + orr * orr)


@wp.func
def upper_bound1(
    a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, rho: wp.float64, n: wp.vec3d
) -> wp.float64:
    _h, s = support(a2, n)
    w = wp.vec3d(e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    return sd_point_cylinder(w, u, L, r) - rho


@wp.func
def upper_bound2(
    a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, n: wp.vec3d, value: wp.float64
) -> wp.float64:
    """ub2: the witness clamped into K, with the largest inner ball tangent there for cap and side contacts."""
    y = _witness(a2, e, n, value)
    ya = _dot(y, u)
    yr = wp.vec3d(y[0] - ya * u[0], y[1] - ya * u[1], y[2] - ya * u[2])
    rad = wp.sqrt(_dot(yr, yr))
    nu = _dot(n, u)
    pn = perp(n, u)
    za = wp.min(wp.max(ya, -L), L)
    t = F64(0.0)
    if pn < F64(1e-12):  # cap
        f = F64(1.0)
        if rad > F64(0.0):
            f = wp.min(F64(1.0), r / rad)
        yr = wp.vec3d(yr[0] * f, yr[1] * f, yr[2] * f)
        t = wp.min(L, r - rad * f)
        za = copysign(L - t, nu)
    elif wp.abs(nu) < F64(1e-12):  # side
        t = wp.min(r, L - wp.abs(za))
        pr = r - t
        yr = wp.vec3d(pr * n[0], pr * n[1], pr * n[2])
    else:  # rim: the rim point
        f = F64(0.0)
        if rad > F64(0.0):
            f = r / rad
        yr = wp.vec3d(yr[0] * f, yr[1] * f, yr[2] * f)
        za = copysign(L, ya)
    q = wp.vec3d(e[0] - za * u[0] - yr[0], e[1] - za * u[1] - yr[1], e[2] - za * u[2] - yr[2])
    tt, _m = foot3(a2, q)
    return sd_upper(a2, q, tt) - t


@wp.func
def _sweep_bound(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64) -> wp.float64:
    """ub3 for a side contact (cylinder._sweep_bound); 1e300 when the test fails."""
    w1, w2 = tangent_basis(u)
    _n, ub2d = circle_max_bound(a2, e, w1, w2)
    if ub2d > F64(0.0):
        return F64(INF)
    d2 = -ub2d
    g = wp.vec3d(u[0] / a2[0], u[1] / a2[1], u[2] / a2[2])
    kappa = _dot(g, u)
    tau = _dot(e, u)
    ep = wp.vec3d(e[0] - tau * u[0], e[1] - tau * u[1], e[2] - tau * u[2])
    c0 = tau + _dot(g, ep) / kappa
    gam2 = wp.max(_dot(g, g) - kappa * kappa, F64(0.0)) / (kappa * kappa)
    dd = d2 + r
    if wp.abs(c0) + wp.sqrt(dd * dd + gam2 * d2 * d2) <= L:
        return -dd
    return F64(INF)


@wp.func
def upper_bound(
    a2: wp.vec3d,
    e: wp.vec3d,
    u: wp.vec3d,
    L: wp.float64,
    r: wp.float64,
    rho: wp.float64,
    n: wp.vec3d,
    value: wp.float64,
    tol: wp.float64,
) -> wp.float64:
    ub = upper_bound1(a2, e, u, L, r, rho, n)
    if ub - value <= tol:
        return ub
    ub = wp.min(ub, upper_bound2(a2, e, u, L, r, n, value))
    if ub - value <= tol:
        return ub
    if wp.abs(_dot(n, u)) < F64(1e-12):
        ub = wp.min(ub, _sweep_bound(a2, e, u, L, r))
    return ub


# --- the rim's branch and bound (cylinder._f, _on_arc, _turn, _arc_max, _lune_bound, _rim_bb) --------


@wp.func
def _f(a2: wp.vec3d, p: wp.vec3d, m: wp.vec3d) -> wp.float64:
    """f_p(m) = m.p - h_E(m)."""
    return _dot(m, p) - wp.sqrt(a2[0] * m[0] * m[0] + a2[1] * m[1] * m[1] + a2[2] * m[2] * m[2])


@wp.func
def _on_arc(m: wp.vec3d, v1: wp.vec3d, v2: wp.vec3d, span: wp.float64) -> bool:
    """Whether the unit m of the plane span(v1, v2) is cos t v1 + sin t v2 with t in [0, span]."""
    y = _dot(m, v2)
    if not (y >= F64(0.0)):
        return False
    return wp.atan2(y, _dot(m, v1)) <= span


@wp.func
def _turn(v1: wp.vec3d, v2: wp.vec3d, t: wp.float64) -> wp.vec3d:
    """cos t v1 + sin t v2."""
    ct = wp.cos(t)
    st = wp.sin(t)
    return wp.vec3d(ct * v1[0] + st * v2[0], ct * v1[1] + st * v2[1], ct * v1[2] + st * v2[2])


@wp.func
def _arc_max(
    a2: wp.vec3d,
    p: wp.vec3d,
    v1: wp.vec3d,
    v2: wp.vec3d,
    span: wp.float64,
    slack: wp.float64,
    floor: wp.float64,
):
    """(bound, m): the maximum of f_p over the arc {cos t v1 + sin t v2 : t in [0, span]} and where it is
    attained (cylinder._arc_max)."""
    lam, mu, c, s = project_ellipse(a2, v1, v2)
    p1 = _dot(p, v1)
    p2 = _dot(p, v2)
    q = wp.vec3d(c * p1 + s * p2, -s * p1 + c * p2, F64(0.0))
    t, m0, m1 = foot2(lam, mu, q[0], q[1])
    top = sd_upper2(lam, mu, q[0], q[1], t)
    m = from_plane(m0, m1, c, s, v1, v2)
    if top <= floor or _on_arc(m, v1, v2, span):
        return top, m
    best = _f(a2, p, v1)
    bm = v1
    end = _turn(v1, v2, span)
    v = _f(a2, p, end)
    if v > best:
        best = v
        bm = end
    b3 = wp.vec3d(lam, mu, F64(2.0) * wp.max(lam, mu))
    ok, roots = secular_roots(b3, q)  # the largest root (entry 0) is foot2's, off the arc
    for k in range(1, 3):
        if ok[k] != 0:
            mm = unit(wp.vec3d(q[0] / (roots[k] + lam), q[1] / (roots[k] + mu), F64(0.0)))
            m = from_plane(mm[0], mm[1], c, s, v1, v2)
            if _on_arc(m, v1, v2, span):
                v = _f(a2, p, m) + slack
                if v > best:
                    best = v
                    bm = m
    for i in range(2):
        for half in range(2):
            sign = F64(1.0)
            if half == 1:
                sign = F64(-1.0)
            okp, mm = pole_normal(b3, q, i, sign)
            if okp:
                m = from_plane(mm[0], mm[1], c, s, v1, v2)
                if _on_arc(m, v1, v2, span):
                    v = _f(a2, p, m) + slack
                    if v > best:
                        best = v
                        bm = m
    return best, bm


@wp.func
def _lune_bound(
    a2: wp.vec3d,
    p: wp.vec3d,
    su: wp.vec3d,
    ca: wp.vec3d,
    cq: wp.vec3d,
    width: wp.float64,
    slack: wp.float64,
    floor: wp.float64,
):
    """(bound, m): the maximum of f_p over the lune {n : n.su >= 0, azimuth about su in [0, width] from ca}
    and where it is attained (cylinder._lune_bound)."""
    t, m = foot3(a2, p)
    top = sd_upper(a2, p, t)
    if top <= floor:
        return top, m
    if _dot(m, su) >= F64(0.0) and _on_arc(m, ca, cq, width):
        return top, m
    best, bm = _arc_max(a2, p, su, ca, F64(HALF_PI), slack, floor)
    v, m1 = _arc_max(a2, p, su, _turn(ca, cq, width), F64(HALF_PI), slack, floor)
    if v > best:
        best = v
        bm = m1
    v2, m2 = _arc_max(a2, p, ca, cq, width, slack, floor)
    if v2 > best:
        best = v2
        bm = m2
    ok, roots = secular_roots(a2, p)  # the largest root (entry 0) is foot3's, outside the lune
    for k in range(1, 3):
        if ok[k] != 0:
            mk = root_normal(a2, p, roots[k])
            if _dot(mk, su) >= F64(0.0) and _on_arc(mk, ca, cq, width):
                vk = _f(a2, p, mk) + slack
                if vk > best:
                    best = vk
                    bm = mk
    for i in range(3):
        for half in range(2):
            sign = F64(1.0)
            if half == 1:
                sign = F64(-1.0)
            okp, mp = pole_normal(a2, p, i, sign)
            if okp and _dot(mp, su) >= F64(0.0) and _on_arc(mp, ca, cq, width):
                vp = _f(a2, p, mp) + slack
                if vp > best:
                    best = vp
                    bm = mp
    return best, bm


@wp.func
def _rim_bb(
    a2: wp.vec3d,
    e: wp.vec3d,
    u: wp.vec3d,
    L: wp.float64,
    r: wp.float64,
    sg: wp.float64,
    best0: wp.float64,
    bn0: wp.vec3d,
    tol: wp.float64,
    slack: wp.float64,
):
    """(best, bn, proven): the branch and bound over the azimuth of the rim piece sg (cylinder._rim_bb):
    four quarter lunes from the incumbent's azimuth, each split in two depth first (a node is its level
    and index, the index an int64: 2^RIM_BB_LEVELS lunes a quarter)."""
    best = best0
    bn = bn0
    q = wp.vec3d(e[0] - sg * L * u[0], e[1] - sg * L * u[1], e[2] - sg * L * u[2])
    su = wp.vec3d(sg * u[0], sg * u[1], sg * u[2])
    w1, w2 = tangent_basis(su)
    quarter = F64(HALF_PI)
    phi = F64(0.0)
    has = perp(bn, u) > F64(0.0)
    if has:
        phi = wp.atan2(_dot(bn, w2), _dot(bn, w1))
    start = phi - F64(0.5) * quarter
    nodes = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    for k in range(4):
        a0 = start + F64(k) * quarter
        lev = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
        idx = I64(0)
        while True:
            width = _half(quarter, lev)
            a = a0 + F64(idx) * width
            ca = _turn(w1, w2, a)
            cq = _turn(w1, w2, a + quarter)
            off = _pymod(phi - a, F64(TWO_PI))
            at = a
            if not has:
                at = a + F64(0.5) * width
            elif off <= width:
                at = a + off  # the incumbent's azimuth
            elif off - width < F64(TWO_PI) - off:  # the end nearer the incumbent
                at = a + width
            c = _turn(w1, w2, at)
            p = wp.vec3d(q[0] - r * c[0], q[1] - r * c[1], q[2] - r * c[2])
            bound, m = _lune_bound(a2, p, su, ca, cq, width, slack, best + tol)
            nodes = nodes + 1
            if bound > best + tol:
                v = sigma_cylinder(a2, e, u, L, r, m)
                if v > best and sg * _dot(m, u) > F64(0.0) and perp(m, u) > F64(0.0):
                    mn, _vn, _code = _rim_newton(a2, e, u, L, r, sg, m)
                    vn = sigma_cylinder(a2, e, u, L, r, mn)
                    if vn > v:
                        v = vn
                        m = mn
                if v > best:  # the children take c from the new incumbent
                    best = v
                    bn = m
                    has = perp(bn, u) > F64(0.0)
                    if has:
                        phi = wp.atan2(_dot(bn, w2), _dot(bn, w1))
            if bound > best + tol:
                if nodes >= RIM_BB_NODES or lev >= RIM_BB_LEVELS:
                    return best, bn, False
                lev = lev + 1
                idx = idx * I64(2)
                continue
            while lev > 0 and idx % I64(2) == I64(1):
                lev = lev - 1
                idx = idx // I64(2)
            if lev == 0:
                break
            idx = idx + I64(1)
    return best, bn, True


@wp.func
def deep_search(
    a2: wp.vec3d,
    e: wp.vec3d,
    u: wp.vec3d,
    L: wp.float64,
    r: wp.float64,
    best0: wp.float64,
    bn0: wp.vec3d,
    tol: wp.float64,
    slack: wp.float64,
):
    """Caps and side exactly, then each rim piece by its branch and bound: (value, n, proven)."""
    best = best0
    bn = bn0
    for half in range(2):
        sg = F64(1.0)
        if half == 1:
            sg = F64(-1.0)
        m = wp.vec3d(sg * u[0], sg * u[1], sg * u[2])
        v = sigma_cylinder(a2, e, u, L, r, m)
        if v > best:
            best = v
            bn = m
    w1, w2 = tangent_basis(u)
    ms, _ub = circle_max_bound(a2, e, w1, w2)
    vs = sigma_cylinder(a2, e, u, L, r, ms)
    if vs > best:
        best = vs
        bn = ms
    proven = bool(True)  # noqa: UP018 (a dynamic variable for Warp's loops)
    for half in range(2):
        sg = F64(1.0)
        if half == 1:
            sg = F64(-1.0)
        b1, n1, ok = _rim_bb(a2, e, u, L, r, sg, best, bn, tol, slack)
        best = b1
        bn = n1
        proven = proven and ok
    return best, bn, proven


# --- spheroids.axis_bb (the (t, phi) branch and bound; balls as (midpoint, radius) vec2d) ------------


@wp.func
def _axis_of(r: wp.vec3d):
    """The axis k whose two other semi-axes are closest to equal: (k, half their difference)."""
    best = F64(INF)
    kb = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    for k in range(3):
        d = wp.abs(r[(k + 1) % 3] - r[(k + 2) % 3])
        if d < best:
            best = d
            kb = k
    return kb, F64(0.5) * best


@wp.func
def _bm(x: wp.vec2d, y: wp.vec2d) -> wp.vec2d:
    m = x[0] * y[0]
    return wp.vec2d(m, wp.abs(x[0]) * y[1] + wp.abs(y[0]) * x[1] + x[1] * y[1] + F64(U4) * wp.abs(m))


@wp.func
def _ba(x: wp.vec2d, y: wp.vec2d, sx: wp.float64, sy: wp.float64) -> wp.vec2d:
    m = sx * x[0] + sy * y[0]
    return wp.vec2d(m, wp.abs(sx) * x[1] + wp.abs(sy) * y[1] + F64(U4) * (wp.abs(sx * x[0]) + wp.abs(sy * y[0])))


@wp.func
def _bc(c: wp.float64, x: wp.vec2d) -> wp.vec2d:
    m = c * x[0]
    return wp.vec2d(m, wp.abs(c) * x[1] + F64(U4) * wp.abs(m))


@wp.func
def _inv_roots(q: wp.vec2d, qlo: wp.float64):
    lo = wp.max(q[0] - q[1], qlo)
    hi = q[0] + q[1]
    i_hi = F64(ONE_PLUS_U4) / wp.sqrt(lo)
    i_lo = F64(ONE_MINUS_U4) / wp.sqrt(hi)
    j_hi = i_hi * i_hi * i_hi * F64(ONE_PLUS_U4)
    j_lo = i_lo * i_lo * i_lo * F64(ONE_MINUS_U4)
    return (
        wp.vec2d(F64(0.5) * (i_hi + i_lo), F64(0.5) * (i_hi - i_lo) * F64(ONE_PLUS_U4)),
        wp.vec2d(F64(0.5) * (j_hi + j_lo), F64(0.5) * (j_hi - j_lo) * F64(ONE_PLUS_U4)),
    )


@wp.func
def _trig_ball(x: wp.float64, h: wp.float64):
    c = wp.cos(x)
    s = wp.sin(x)
    h2 = F64(0.5) * h * h
    return (
        wp.vec2d(c, (wp.abs(s) * h + h2) * F64(ONE_PLUS_U4) + F64(U64)),
        wp.vec2d(s, (wp.abs(c) * h + h2) * F64(ONE_PLUS_U4) + F64(U64)),
    )


@wp.func
def _form_balls(lz: wp.float64, lx: wp.float64, ly: wp.float64, ct: wp.vec2d, st: wp.vec2d, cp: wp.vec2d, sp: wp.vec2d):
    m = _ba(cp, sp, lx, ly)
    mq = _ba(sp, cp, -lx, ly)
    l = _ba(ct, _bm(st, m), lz, F64(1.0))
    lt = _ba(st, _bm(ct, m), -lz, F64(1.0))
    lp = _bm(st, mq)
    lpp = _bc(F64(-1.0), _bm(st, m))
    ltp = _bm(ct, mq)
    return l, lt, lp, wp.vec2d(-l[0], l[1]), lpp, ltp


@wp.func
def _root_second(qxy: wp.vec2d, qx: wp.vec2d, qy: wp.vec2d, i1: wp.vec2d, i3: wp.vec2d) -> wp.vec2d:
    return _ba(_bm(qxy, i1), _bm(_bm(qx, qy), i3), F64(0.5), F64(-0.25))


@wp.func
def _ha_at(hk: int, h1: wp.float64, h2: wp.float64, ct: wp.float64, st: wp.float64):
    if hk == 0:
        ha = wp.sqrt(h1 * ct * ct + h2 * st * st)
        return ha, (h2 - h1) * st * ct / ha
    sg = F64(-1.0)
    if ct >= F64(0.0):
        sg = F64(1.0)
    return h1 * sg * ct + h2 * st, -h1 * sg * st + h2 * ct


@wp.func
def _hessian_balls(
    tc: wp.float64,
    ht: wp.float64,
    pc: wp.float64,
    hp: wp.float64,
    ek: wp.float64,
    ex: wp.float64,
    ey: wp.float64,
    hk: int,
    h1: wp.float64,
    h2: wp.float64,
    kb: wp.float64,
    pb2: wp.float64,
    wz: wp.float64,
    wx: wp.float64,
    wy: wp.float64,
    qlo_a: wp.float64,
    qlo_b: wp.float64,
):
    ct, st = _trig_ball(tc, ht)
    cp, sp = _trig_ball(pc, hp)
    _e0, _e1, _e2, ett, epp, etp = _form_balls(ek, ex, ey, ct, st, cp, sp)
    hatt = wp.vec2d(F64(0.0), F64(0.0))
    if hk == 0:
        c2 = _bm(ct, ct)
        s2 = _bm(st, st)
        cs = _bm(ct, st)
        P = _ba(c2, s2, h1, h2)
        Pt = _bc(F64(2.0) * (h2 - h1), cs)
        Ptt = _bc(F64(2.0) * (h2 - h1), _ba(c2, s2, F64(1.0), F64(-1.0)))
        ia1, ia3 = _inv_roots(P, qlo_a)
        hatt = _root_second(Ptt, Pt, Pt, ia1, ia3)
    else:
        sg = F64(-1.0)
        if ct[0] >= F64(0.0):
            sg = F64(1.0)
        hatt = _ba(ct, st, -h1 * sg, -h2)
    w, w_t, w_p, w_tt, w_pp, w_tp = _form_balls(wz, wx, wy, ct, st, cp, sp)
    Q = _ba(wp.vec2d(pb2, F64(0.0)), _bm(w, w), F64(1.0), kb)
    Qt = _bc(F64(2.0) * kb, _bm(w, w_t))
    Qp = _bc(F64(2.0) * kb, _bm(w, w_p))
    Qtt = _bc(F64(2.0) * kb, _ba(_bm(w_t, w_t), _bm(w, w_tt), F64(1.0), F64(1.0)))
    Qpp = _bc(F64(2.0) * kb, _ba(_bm(w_p, w_p), _bm(w, w_pp), F64(1.0), F64(1.0)))
    Qtp = _bc(F64(2.0) * kb, _ba(_bm(w_t, w_p), _bm(w, w_tp), F64(1.0), F64(1.0)))
    ib1, ib3 = _inv_roots(Q, qlo_b)
    hbtt = _root_second(Qtt, Qt, Qt, ib1, ib3)
    hbpp = _root_second(Qpp, Qp, Qp, ib1, ib3)
    hbtp = _root_second(Qtp, Qt, Qp, ib1, ib3)
    stt = _ba(_ba(ett, hatt, F64(1.0), F64(-1.0)), hbtt, F64(1.0), F64(-1.0))
    return stt, _ba(epp, hbpp, F64(1.0), F64(-1.0)), _ba(etp, hbtp, F64(1.0), F64(-1.0))


@wp.func
def _model_at(
    t: wp.float64,
    p: wp.float64,
    ek: wp.float64,
    ex: wp.float64,
    ey: wp.float64,
    hk: int,
    h1: wp.float64,
    h2: wp.float64,
    kb: wp.float64,
    pb2: wp.float64,
    wz: wp.float64,
    wx: wp.float64,
    wy: wp.float64,
):
    """(sigma_m, s_t, s_p, h_A, h_B) at the float (t, p)."""
    ct = wp.cos(t)
    st = wp.sin(t)
    cp = wp.cos(p)
    sp = wp.sin(p)
    me = ex * cp + ey * sp
    mqe = -ex * sp + ey * cp
    mw = wx * cp + wy * sp
    mqw = -wx * sp + wy * cp
    w = wz * ct + st * mw
    ha, ha_t = _ha_at(hk, h1, h2, ct, st)
    hb = wp.sqrt(pb2 + kb * w * w)
    s = ek * ct + st * me - ha - hb
    wt = -wz * st + ct * mw
    wpp = st * mqw
    s_t = -ek * st + ct * me - ha_t - kb * w * wt / hb
    s_p = st * mqe - kb * w * wpp / hb
    return s, s_t, s_p, ha, hb


@wp.func
def _polish(
    t0: wp.float64,
    p0: wp.float64,
    s0: wp.float64,
    ek: wp.float64,
    ex: wp.float64,
    ey: wp.float64,
    hk: int,
    h1: wp.float64,
    h2: wp.float64,
    kb: wp.float64,
    pb2: wp.float64,
    wz: wp.float64,
    wx: wp.float64,
    wy: wp.float64,
    qlo_a: wp.float64,
    qlo_b: wp.float64,
):
    """Newton on sigma_m in (t, phi) from (t0, p0) of value s0: (t, p, s) no worse (spheroids._polish)."""
    t = t0
    p = p0
    s = s0
    for _ in range(30):
        _s, g1, g2, _ha, _hb = _model_at(t, p, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
        htt, hpp, htp = _hessian_balls(
            t, F64(0.0), p, F64(0.0), ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b
        )
        a11 = htt[0]
        a22 = hpp[0]
        a12 = htp[0]
        top = F64(0.5) * (a11 + a22) + wp.sqrt(F64(0.25) * (a11 - a22) * (a11 - a22) + a12 * a12)
        mu = F64(1e-9) * (wp.abs(a11) + wp.abs(a22)) + F64(1e-300)
        if top > -mu:
            a11 = a11 - top - mu
            a22 = a22 - top - mu
        det = a11 * a22 - a12 * a12
        if not (det > F64(0.0)):
            break
        dt = -(a22 * g1 - a12 * g2) / det
        dp = -(a11 * g2 - a12 * g1) / det
        size = wp.sqrt(dt * dt + dp * dp)
        if not (size > F64(0.0)):
            break
        if size > F64(0.25):
            dt = dt * F64(0.25) / size
            dp = dp * F64(0.25) / size
        better = bool(False)  # noqa: UP018 (a dynamic variable for Warp's loops)
        tn = t
        pn = p
        sn = s
        for _k in range(40):  # backtracking
            tn = t + dt
            pn = p + dp
            if tn < F64(0.0) or tn > F64(PI):
                if tn < F64(0.0):
                    tn = -tn
                else:
                    tn = F64(TWO_PI) - tn
                if pn < F64(0.0):
                    pn = pn + F64(PI)
                else:
                    pn = pn - F64(PI)
            sn, _g1, _g2, _ha2, _hb2 = _model_at(tn, pn, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
            if sn > s:
                better = True
                break
            dt = F64(0.5) * dt
            dp = F64(0.5) * dp
        if not better:
            break
        t = tn
        p = pn
        s = sn
    return t, p, s


@wp.func
def _q(g0: wp.float64, M: wp.float64, h: wp.float64) -> wp.float64:
    """max over |d| <= h of g d + M d^2 / 2 (upwards)."""
    g = wp.abs(g0)
    if M < F64(0.0) and g <= -M * h:
        return g * g / (F64(-2.0) * M) * F64(ONE_PLUS_U4)
    return (g * h + F64(0.5) * M * h * h) * F64(ONE_PLUS_U4) + F64(U4) * wp.abs(M) * h * h


@wp.func
def axis_bb(
    ek: wp.float64,
    ex: wp.float64,
    ey: wp.float64,
    hk: int,
    h1: wp.float64,
    h2: wp.float64,
    kb: wp.float64,
    pb2: wp.float64,
    wz: wp.float64,
    wx: wp.float64,
    wy: wp.float64,
    tol1: wp.float64,
    S: wp.float64,
    curv: wp.float64,
    t0: wp.float64,
    p0: wp.float64,
):
    """(proven, t, p, moved, nodes): spheroids.axis_bb, depth first over the 4 x 8 root cells; a cell is
    its levels (Lt, Lp), indices (it, ip: int64) and the split directions of its path (bits of dims)."""
    qlo_a = F64(1.0)
    if hk == 0:
        qlo_a = wp.min(h1, h2) * F64(ONE_MINUS_1E12)
    ww = wz * wz + wx * wx + wy * wy
    qlo_b = (pb2 + wp.min(kb, F64(0.0)) * ww * F64(ONE_PLUS_1E12)) * F64(ONE_MINUS_1E12)
    if not (tol1 > F64(0.0) and qlo_a > F64(0.0) and qlo_b > F64(0.0)):
        return False, t0, p0, False, 0
    bmax2 = wp.max(pb2, pb2 + kb)
    s0, _s0t, _s0p, _ha0, _hb0 = _model_at(t0, p0, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
    bt, bp, best = _polish(t0, p0, s0, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
    moved = best != s0
    nodes = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    for root in range(N_ROOTS):
        Lt = int(ROOT_T)
        it = I64(root >> ROOT_P)
        Lp = int(ROOT_P)
        ip = I64(root & ROOT_P_MASK)
        depth = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
        dims = I64(0)
        while True:
            nodes = nodes + 1
            if nodes > TILTED_MAX_NODES:
                return False, bt, bp, moved, nodes
            wt = _half(F64(T_DOMAIN), Lt)
            wpp = _half(F64(TWO_T_DOMAIN), Lp)
            tc = wt * (F64(it) + F64(0.5))
            pc = F64(-T_DOMAIN) + wpp * (F64(ip) + F64(0.5))
            ht = F64(0.5) * wt * F64(ONE_PLUS_1E15) + F64(U4) * tc
            hp = F64(0.5) * wpp * F64(ONE_PLUS_1E15) + F64(U4_T_DOMAIN)
            s, s_t, s_p, ha, hb = _model_at(tc, pc, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy)
            if s > best:
                if s > best + tol1:  # a poor incumbent: climb from the better centre
                    t1, p1, s1 = _polish(tc, pc, s, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
                    best = s1
                    bt = t1
                    bp = p1
                else:
                    best = s
                    bt = tc
                    bp = pc
                moved = True
            htt, hpp, htp = _hessian_balls(tc, ht, pc, hp, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b)
            Mtt = htt[0] + htt[1]
            Mpp = hpp[0] + hpp[1]
            Ktp = wp.abs(htp[0]) + htp[1]
            epsg = F64(U64) * (F64(32.0) * (S + curv / ha + bmax2 / hb) + F64(16.0) * S)
            qt = _q(s_t, Mtt, ht) + epsg * ht
            qp = _q(s_p, Mpp, hp) + epsg * hp
            cross = Ktp * ht * hp * F64(ONE_PLUS_U4)
            if s + qt + qp + cross <= best + tol1:
                while depth > 0:  # the next cell after this one's subtree
                    d = (dims >> I64(depth - 1)) & I64(1)
                    if d == I64(0):
                        if (it & I64(1)) == I64(0):
                            it = it + I64(1)
                            break
                        it = it >> I64(1)
                        Lt = Lt - 1
                    else:
                        if (ip & I64(1)) == I64(0):
                            ip = ip + I64(1)
                            break
                        ip = ip >> I64(1)
                        Lp = Lp - 1
                    depth = depth - 1
                if depth == 0:
                    break
            else:
                split_p = qp > qt
                if split_p and Lp >= TILT_LEVELS:
                    split_p = False
                if (not split_p and Lt >= TILT_LEVELS) or depth >= TILT_DEPTH:
                    return False, bt, bp, moved, nodes
                bit = I64(1) << I64(depth)
                if split_p:
                    dims = dims | bit
                    Lp = Lp + 1
                    ip = ip * I64(2)
                else:
                    dims = dims & (~bit)
                    Lt = Lt + 1
                    it = it * I64(2)
                depth = depth + 1
    return True, bt, bp, moved, nodes


@wp.func
def axis_max(
    a2: wp.vec3d,
    e: wp.vec3d,
    u0: wp.vec3d,
    L: wp.float64,
    r: wp.float64,
    tol: wp.float64,
    scale: wp.float64,
    n0: wp.vec3d,
):
    """(proven, n, value): the second chance for a flat rim, E a spheroid about (nearly) the cylinder's
    axis (cylinder.axis_max, its error budget delta0)."""
    ra = wp.vec3d(wp.sqrt(a2[0]), wp.sqrt(a2[1]), wp.sqrt(a2[2]))
    j, db = _axis_of(ra)
    j1 = (j + 1) % 3
    j2 = (j + 2) % 3
    qb = ra[j]
    pb = F64(0.5) * (ra[j1] + ra[j2])
    uu = wp.sqrt(_dot(u0, u0))
    u = wp.vec3d(u0[0] / uu, u0[1] / uu, u0[2] / uu)
    w1, w2 = tangent_basis(u)
    dfu = wp.max(
        wp.abs(_dot(u, u) - F64(1.0)), wp.max(wp.abs(_dot(w1, w1) - F64(1.0)), wp.abs(_dot(w2, w2) - F64(1.0)))
    )
    dfu = wp.max(dfu, wp.max(wp.abs(_dot(u, w1)), wp.max(wp.abs(_dot(u, w2)), wp.abs(_dot(w1, w2))))) + F64(THREE_U)
    delta0 = db * (F64(1.0) + F64(3.0) * dfu) + F64(3.0) * pb * pb * dfu / wp.min(qb, pb) + F64(3.0) * dfu * scale
    delta0 = delta0 + (F64(3.0) * (L + r) * (wp.abs(uu - F64(1.0)) + F64(TWO_U)) + F64(TWELVE_U) * scale)
    delta0 = delta0 + F64(FOUR_U) * L
    tol1 = tol - F64(2.0) * delta0 - F64(AXIS_ERR) * scale
    nu0 = _dot(n0, u)
    nu1 = _dot(n0, w1)
    nu2 = _dot(n0, w2)
    t0 = wp.atan2(wp.sqrt(nu1 * nu1 + nu2 * nu2), nu0)
    p0 = wp.atan2(nu2, nu1)
    ok, t, p, moved, _nodes = axis_bb(
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
        F64(0.0),
        t0,
        p0,
    )
    n = n0
    if moved:
        ct = wp.cos(t)
        st = wp.sin(t)
        cp = wp.cos(p)
        sp = wp.sin(p)
        n = unit(
            wp.vec3d(
                ct * u[0] + st * (cp * w1[0] + sp * w2[0]),
                ct * u[1] + st * (cp * w1[1] + sp * w2[1]),
                ct * u[2] + st * (cp * w1[2] + sp * w2[2]),
            )
        )
    return ok, n, sigma_cylinder(a2, e, u0, L, r, n)


# --- the entry --------------------------------------------------------------------------------------


@wp.func
def centre_line_bound(e: wp.vec3d, a2: wp.vec3d, u: wp.vec3d, ra: wp.vec3d, r: wp.float64, L: wp.float64):
    """A lower bound on the signed distance: sigma along the centre line less its rounding allowance
    (cylinder.centre_line_bound); -1e300 for concentric bodies."""
    ee = _dot(e, e)
    if not (ee > F64(0.0)):
        return F64(-INF)
    s = F64(1.0) / wp.sqrt(ee)
    scale = wp.sqrt(ee) + wp.max(_max3(ra), wp.max(r, L))
    v = sigma_cylinder(a2, e, u, L, r, wp.vec3d(e[0] * s, e[1] * s, e[2] * s))
    return v - F64(SLACK) * scale


@wp.func
def cylinder_ellipsoid(
    ce: wp.vec3d,
    Re: wp.mat33d,
    ra: wp.vec3d,
    ck: wp.vec3d,
    Rk: wp.mat33d,
    r: wp.float64,
    L: wp.float64,
    cutoff: wp.float64,
):
    """(status, dist, normal from the ellipsoid to the cylinder, pos, enumerated) for the ellipsoid
    (ce, Re, ra) and the cylinder (centre ck, rotation Rk, radius r, half-length L, axis its local z),
    world coordinates, float64 (cylinder.cylinder_ellipsoid).  status APART when a direction proves the
    pair at least cutoff apart (dist is then that lower bound, the maximum not sought); enumerated: 1 when
    the certificates did not close and the caps, the side and both rims' branch and bound were run."""
    ReT = wp.transpose(Re)
    e = ReT * (ck - ce)
    u = unit(ReT * wp.vec3d(Rk[0, 2], Rk[1, 2], Rk[2, 2]))  # (cylinder.to_frame: the axis normalised)
    a2 = wp.cw_mul(ra, ra)
    low = centre_line_bound(e, a2, u, ra, r, L)
    if low >= cutoff:
        return APART, low, Re * unit(e), ce, 0
    lo = _min3(ra)
    rho = lo * lo / _max3(ra)
    scale = wp.sqrt(_dot(e, e)) + wp.max(_max3(ra), wp.max(r, L))
    tol = wp.max(F64(PAIR_CERT_REL) * wp.min(lo, wp.min(r, L)), F64(TOL_ULPS) * scale)
    n, _st, _conv = local_max(a2, e, u, L, r)
    value = sigma_cylinder(a2, e, u, L, r, n)
    if value >= cutoff:
        return APART, value, Re * n, ce, 0
    ub = upper_bound(a2, e, u, L, r, rho, n, value, tol)
    status = GLOBAL
    enumerated = 0
    if ub - value > tol:
        enumerated = 1
        slack = F64(SLACK) * scale
        value, n, proven = deep_search(a2, e, u, L, r, value, n, tol, slack)
        ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol)
        by_axis = False
        if not proven and ub2 - value > tol:  # a flat rim: E a spheroid about (nearly) the cylinder's axis
            ok, m, v = axis_max(a2, e, u, L, r, tol, scale, n)
            by_axis = ok
            if ok and v > value:
                value = v
                n = m
        if not by_axis and not (ub2 - value <= tol) and not proven:
            status = UNPROVEN
    if not (wp.abs(value) < F64(INF)):  # (a nan fails the test too)
        status = UNPROVEN
    # the witness points and their midpoint (point_ellipsoid.contact_in_world)
    _h, s = support(a2, n)
    half = F64(0.5) * value
    p = Re * wp.vec3d(s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2])
    return status, value, Re * n, ce + p, enumerated
