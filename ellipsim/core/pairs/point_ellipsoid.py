"""The point-ellipsoid and point-ellipse problems, with certified bounds and every critical point:
the primitives of the ellipsoid x {capsule, box, cylinder} kernels (capsule.py, box.py).

E = {x : sum x_i^2 / a2_i <= 1} in its principal frame (a2 the squared semi-axes); support function
h(n) = sqrt(n^T A n), support point s(n) = A n / h(n).  f_q(n) = n.q - h(n) is maximised over unit n at
the outward normal of E at the boundary point nearest to q (inside or outside).

The nearest boundary point is the largest root t > -min(a2) of S(t) = sum_i a2_i q_i^2 / (t + a2_i)^2
= 1, solved as psi(t) = S^(-1/2) - 1 = 0 by Newton: psi is a power mean of exponent -2 of the affine
(t + a2_i) / (a_i |q_i|), concave and increasing, so Newton from the left climbs monotonically to the
root (Eberly, "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", Geometric
Tools, sec. 2-3; GTCG 10.5.2).  Weak duality gives dist(q, boundary E)^2 >= g(t) = t (sum_i q_i^2 /
(a2_i + t) - 1) for every t > -min(a2), with equality at the root: the certified bound sd(q, E) <=
-sqrt(g(t)) for q inside E.  The 2-D problem (an ellipse in a plane) is solved the same way.
"""

import math

from .._jit import jit, stage
from ..distance.sphere_newton import unit
from ..tolerances import CRITICAL_MAX_ITER, POLE_RTOL, SECULAR_LAST, SECULAR_MAX_ITER, U
from ..vec3 import dot3, matvec, norm2


@stage
def contact_in_world(E, a2, n, value):
    """(normal, pos) in world coordinates for the ellipsoid E (centre, rotation row-major, sizes) of a
    pair, the maximiser n in E's principal frame and the signed distance value: E's witness s(n) and
    the other body's s(n) + value n, pos their midpoint (MuJoCo's contact position, mjc_penetration)."""
    _, s = support(a2, n)
    half = 0.5 * value
    ce, Re, _ = E
    p = matvec(Re, (s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2]))
    return matvec(Re, n), (ce[0] + p[0], ce[1] + p[1], ce[2] + p[2])


@stage
def support(a2, n):
    """(h(n), s(n)): E's support function and support point, any nonzero n."""
    an0, an1, an2 = a2[0] * n[0], a2[1] * n[1], a2[2] * n[2]
    h = math.sqrt(an0 * n[0] + an1 * n[1] + an2 * n[2])
    ih = 1.0 / h
    return h, (an0 * ih, an1 * ih, an2 * ih)


# --- the point-ellipsoid and point-ellipse problems (module docstring) ----------------------------


@stage
def _psi3(a2, q, t):
    """(S(t), Newton step of psi = S^(-1/2) - 1): psi/psi' = S (1 - sqrt(S)) / T with T = -S'/2;
    one division for the three 1/(t + a2_i)."""
    p0, p1, p2 = t + a2[0], t + a2[1], t + a2[2]
    p01 = p0 * p1
    inv = 1.0 / (p01 * p2)
    d0, d1, d2 = p1 * p2 * inv, p0 * p2 * inv, p01 * inv
    w0, w1, w2 = q[0] * d0, q[1] * d1, q[2] * d2
    s0, s1, s2 = a2[0] * w0 * w0, a2[1] * w1 * w1, a2[2] * w2 * w2
    S = s0 + s1 + s2
    T = s0 * d0 + s1 * d1 + s2 * d2
    return S, S * (1.0 - math.sqrt(S)) / T


@stage
def _secular_root3(a2, q, amin, amax, qq):
    """The largest root of S(t) = 1, or nan when it lies within POLE_RTOL * amin of the pole -amin.
    Start: the largest -a2_i + a_i |q_i| right of the pole, where term i of S alone is 1."""
    lo = -amin + POLE_RTOL * amin
    t = lo
    for i in range(3):
        t = max(t, -a2[i] + math.sqrt(a2[i]) * abs(q[i]))
    hi = math.sqrt(amax * qq)  # S(hi) <= 1
    S, step = _psi3(a2, q, t)
    if not S > 1.0:
        return t if S == 1.0 or t > lo else math.nan
    for _ in range(SECULAR_MAX_ITER):
        tn = min(t - step, hi)
        # converged relative to the root's distance from the pole -amin (the normal's q_i / (t + a2_i) is
        # as accurate as that), down to what t's float resolution allows
        if tn - t <= max(SECULAR_LAST * (tn + amin), 4.0 * U * (abs(tn) + amin)):
            return tn
        t = tn
        S, step = _psi3(a2, q, t)
        if not S > 1.0:
            return t
    return t


@stage
def _pole_limit(a2, q, amin):
    """The normal at the degenerate root -amin: coordinates with a2_i > amin from the formula, the
    others share what is left of the unit quadric along q's direction among them (Eberly, q_k = 0)."""
    d0, d1, d2 = a2[0] - amin <= POLE_RTOL * amin, a2[1] - amin <= POLE_RTOL * amin, a2[2] - amin <= POLE_RTOL * amin
    x0 = 0.0 if d0 else a2[0] * q[0] / (a2[0] - amin)
    x1 = 0.0 if d1 else a2[1] * q[1] / (a2[1] - amin)
    x2 = 0.0 if d2 else a2[2] * q[2] / (a2[2] - amin)
    rest = max(1.0 - x0 * x0 / a2[0] - x1 * x1 / a2[1] - x2 * x2 / a2[2], 0.0)
    qd = (
        (q[0] * q[0] / a2[0] if d0 else 0.0)
        + (q[1] * q[1] / a2[1] if d1 else 0.0)
        + (q[2] * q[2] / a2[2] if d2 else 0.0)
    )
    if qd > 0.0:
        f = math.sqrt(rest / qd)
        x0 = q[0] * f if d0 else x0
        x1 = q[1] * f if d1 else x1
        x2 = q[2] * f if d2 else x2
    elif d0:
        x0 = math.sqrt(rest * a2[0])
    elif d1:
        x1 = math.sqrt(rest * a2[1])
    else:
        x2 = math.sqrt(rest * a2[2])
    return unit((x0 / a2[0], x1 / a2[1], x2 / a2[2]))


@stage
def foot3(a2, q):
    """(t, n): the largest secular root (t = -min(a2) for the degenerate limit) and the outward unit
    normal at the boundary point of E nearest to q.  max over unit m of m.q - h(m) is attained at n."""
    amin = min(a2[0], a2[1], a2[2])
    amax = max(a2[0], a2[1], a2[2])
    qq = norm2(q)
    t = math.nan
    if qq > 0.0:
        t = _secular_root3(a2, q, amin, amax, qq)
    if t == t:
        return t, unit((q[0] / (t + a2[0]), q[1] / (t + a2[1]), q[2] / (t + a2[2])))
    return -amin, _pole_limit(a2, q, amin)


@stage
def _dual_bound(a2, q, t, d):
    """-sqrt(g(t)) (module docstring) for q inside the d-dimensional ellipse/ellipsoid a2, at foot's
    secular value t; at a degenerate root, at the dual's best point just right of the pole, where the
    pole terms c / delta^2 make up what the others leave of S = 1 (g' = S - 1)."""
    amin = min(a2[0], a2[1], a2[2]) if d == 3 else min(a2[0], a2[1])
    tt = t
    if not tt > -amin * (1.0 - 1e-15):
        c, srest = 0.0, 0.0
        for i in range(d):
            den = a2[i] - amin
            if den > POLE_RTOL * amin:
                srest += a2[i] * q[i] * q[i] / (den * den)
            else:
                c += a2[i] * q[i] * q[i]
        delta = math.sqrt(c / (1.0 - srest)) if srest < 1.0 else POLE_RTOL * amin
        tt = -amin + max(delta, 1e-15 * amin)
    g = 0.0
    for i in range(d):
        g += q[i] * q[i] / (a2[i] + tt)
    g = tt * (g - 1.0)
    if not g > 0.0:
        return 0.0
    return -math.sqrt(g)


@stage
def _outside_bound(a2, q, t, d):
    """|q - x| for the foot point x at t (pulled onto the body if rounding left it outside: a point
    of the body is all the bound needs)."""
    amin = min(a2[0], a2[1], a2[2]) if d == 3 else min(a2[0], a2[1])
    ok = t > -amin * (1.0 - POLE_RTOL)
    x = (
        a2[0] * q[0] / (t + a2[0]) if ok else 0.0,
        a2[1] * q[1] / (t + a2[1]) if ok else 0.0,
        a2[2] * q[2] / (t + a2[2]) if ok and d == 3 else 0.0,
    )
    k = x[0] * x[0] / a2[0] + x[1] * x[1] / a2[1] + (x[2] * x[2] / a2[2] if d == 3 else 0.0)
    if k > 1.0:
        f = 1.0 / math.sqrt(k) * (1.0 - 4e-16)
        x = (x[0] * f, x[1] * f, x[2] * f)
    d0, d1, d2 = q[0] - x[0], q[1] - x[1], (q[2] - x[2] if d == 3 else 0.0)
    return math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@stage
def sd_upper(a2, q, t):
    """An upper bound on the signed distance of q to E (negative inside) from foot3's secular value t:
    outside, |q - x| for a point x of E; inside, -sqrt(g(t)) by weak duality."""
    if q[0] * q[0] / a2[0] + q[1] * q[1] / a2[1] + q[2] * q[2] / a2[2] < 1.0:
        return _dual_bound(a2, q, t, 3)
    return _outside_bound(a2, q, t, 3)


@stage
def _psi2(b0, b1, p0, p1, t):
    r0, r1 = t + b0, t + b1
    inv = 1.0 / (r0 * r1)
    d0, d1 = r1 * inv, r0 * inv
    w0, w1 = p0 * d0, p1 * d1
    s0, s1 = b0 * w0 * w0, b1 * w1 * w1
    S = s0 + s1
    T = s0 * d0 + s1 * d1
    return S, S * (1.0 - math.sqrt(S)) / T


@stage
def _pole_normal2(b0, b1, p0, p1, bmin):
    """foot2's normal when the largest root lies within POLE_RTOL bmin of the pole -bmin, where t itself
    cannot resolve it: the root in delta = t + bmin of S = c0 / (delta + d0)^2 + c1 / (delta + d1)^2 = 1
    (c_i = b_i p_i^2, d_i = b_i - bmin exact by Sterbenz), by Newton on the concave increasing
    S^(-1/2) - 1 (its first step from the right lands left of the root, or is cut to 1e-3 of delta;
    from the left it rises monotonically), then n ~ p_i / (delta + d_i): on a (near-)circle it follows
    p, where Eberly's limit formula would put it on an axis whatever p is (2 |p| below the maximum).
    When S stays at most 1 as delta -> 0 (p zero on the pole's axis), Eberly's limit point (his q_k = 0
    case, GTCG 10.5.2)."""
    d0, d1 = b0 - bmin, b1 - bmin
    c0, c1 = b0 * p0 * p0, b1 * p1 * p1
    at_pole = (c0 > 0.0 and d0 == 0.0) or (c1 > 0.0 and d1 == 0.0)
    s0 = (c0 / (d0 * d0) if d0 > 0.0 else 0.0) + (c1 / (d1 * d1) if d1 > 0.0 else 0.0)
    if at_pole or s0 > 1.0:
        delta = POLE_RTOL * bmin
        for _ in range(SECULAR_MAX_ITER):
            r0, r1 = delta + d0, delta + d1
            S = c0 / (r0 * r0) + c1 / (r1 * r1)
            dS = -2.0 * (c0 / (r0 * r0 * r0) + c1 / (r1 * r1 * r1))
            step = (1.0 / math.sqrt(S) - 1.0) / (-0.5 * dS / (S * math.sqrt(S)))
            dn = delta - step
            if not dn > 0.0:
                dn = 1e-3 * delta
            if abs(dn - delta) <= 4.0 * U * delta:
                delta = dn
                break
            delta = dn
        return p0 / (delta + d0), p1 / (delta + d1)
    x0 = b0 * p0 / d0 if d0 > 0.0 else 0.0
    x1 = b1 * p1 / d1 if d1 > 0.0 else 0.0
    rest = max(1.0 - x0 * x0 / b0 - x1 * x1 / b1, 0.0)
    if d0 == 0.0:
        x0 = math.sqrt(rest * b0)
    else:
        x1 = math.sqrt(rest * b1)
    return x0 / b0, x1 / b1


@stage
def foot2(b0, b1, p0, p1):
    """2-D point-ellipse (squared semi-axes b0, b1): (t, n0, n1), the secular value and the outward
    unit normal at the boundary point nearest to p, by the same Newton as foot3."""
    bmin = min(b0, b1)
    bmax = max(b0, b1)
    pp = p0 * p0 + p1 * p1
    t = math.nan
    if pp > 0.0:
        lo = -bmin + POLE_RTOL * bmin
        t = max(lo, -b0 + math.sqrt(b0) * abs(p0), -b1 + math.sqrt(b1) * abs(p1))
        hi = math.sqrt(bmax * pp)
        S, step = _psi2(b0, b1, p0, p1, t)
        if not S > 1.0:
            if not (S == 1.0 or t > lo):
                t = math.nan
        else:
            for _ in range(SECULAR_MAX_ITER):
                tn = min(t - step, hi)
                if tn - t <= max(SECULAR_LAST * (tn + bmin), 4.0 * U * (abs(tn) + bmin)):
                    t = tn
                    break
                t = tn
                S, step = _psi2(b0, b1, p0, p1, t)
                if not S > 1.0:
                    break
    if t == t:
        n0, n1 = p0 / (t + b0), p1 / (t + b1)
    else:
        n0, n1 = _pole_normal2(b0, b1, p0, p1, bmin)
    s = math.sqrt(n0 * n0 + n1 * n1)
    return (t if t == t else -bmin), n0 / s, n1 / s


@stage
def sd_upper2(b0, b1, p0, p1, t):
    """sd_upper for the ellipse (squared semi-axes b0, b1) and the point p, from foot2's t."""
    b, p = (b0, b1, 1.0), (p0, p1, 0.0)
    if p0 * p0 / b0 + p1 * p1 / b1 < 1.0:
        return _dual_bound(b, p, t, 2)
    return _outside_bound(b, p, t, 2)


@stage
def project_ellipse(a2, w1, w2):
    """The projection of E onto span(w1, w2) (orthonormal): support matrix W^T A W = lam c c^T + mu s s^T
    with c = (cs, sn) in (w1, w2) coordinates; returns (lam, mu, cs, sn), lam >= mu."""
    m11 = a2[0] * w1[0] * w1[0] + a2[1] * w1[1] * w1[1] + a2[2] * w1[2] * w1[2]
    m12 = a2[0] * w1[0] * w2[0] + a2[1] * w1[1] * w2[1] + a2[2] * w1[2] * w2[2]
    m22 = a2[0] * w2[0] * w2[0] + a2[1] * w2[1] * w2[1] + a2[2] * w2[2] * w2[2]
    half = 0.5 * (m11 - m22)
    rad = math.sqrt(half * half + m12 * m12)
    lam = 0.5 * (m11 + m22) + rad
    # the smaller eigenvalue as det / lam, det = m11 m22 - m12^2 by Cauchy-Binet: a sum of positive terms
    # a_i a_j (w1 x w2)_k^2, where the difference cancels for a thin projection (aspect 100: 1e4 u)
    x0 = w1[1] * w2[2] - w1[2] * w2[1]
    x1 = w1[2] * w2[0] - w1[0] * w2[2]
    x2 = w1[0] * w2[1] - w1[1] * w2[0]
    mu = (a2[1] * a2[2] * x0 * x0 + a2[0] * a2[2] * x1 * x1 + a2[0] * a2[1] * x2 * x2) / lam
    if rad > 0.0:
        if half >= 0.0:
            c, s = half + rad, m12
        else:
            c, s = m12, rad - half
        f = 1.0 / math.sqrt(c * c + s * s)
        c, s = c * f, s * f
    else:
        c, s = 1.0, 0.0
    return lam, mu, c, s


@stage
def from_plane(n0, n1, c, s, w1, w2):
    """The 3-D unit vector with coordinates (n0, n1) along the projected ellipse's axes (c, s), (-s, c)."""
    k1, k2 = c * n0 - s * n1, s * n0 + c * n1
    return unit((k1 * w1[0] + k2 * w2[0], k1 * w1[1] + k2 * w2[1], k1 * w1[2] + k2 * w2[2]))


@stage
def circle_max_bound(a2, q, w1, w2):
    """(n, ub): the unit n in span(w1, w2) (orthonormal) maximising n.q - h(n) -- the normal at the
    point of E's projection onto that plane nearest to the projected q -- and an upper bound on that
    maximum (sd_upper2)."""
    lam, mu, c, s = project_ellipse(a2, w1, w2)
    p1, p2 = dot3(q[0], q[1], q[2], w1[0], w1[1], w1[2]), dot3(q[0], q[1], q[2], w2[0], w2[1], w2[2])
    r0, r1 = c * p1 + s * p2, -s * p1 + c * p2
    t, n0, n1 = foot2(lam, mu, r0, r1)
    return from_plane(n0, n1, c, s, w1, w2), sd_upper2(lam, mu, r0, r1, t)


# --- every critical point of f_q on the sphere: the deep-penetration enumeration ------------------
# The critical points of f_q are E's normals at the feet of the normal lines through q: the real roots
# of S(t) = 1 (at most 6) and, where some q_i vanish, the limit points at the poles t = -a2_i (Eberly,
# sec. 2-3).  Between consecutive poles S is convex, so it has 0 or 2 roots there, split by any point
# where S < 1; beyond the outer poles S is monotone with one root.  The limit points at every pole are
# added whatever q is: exact when q_i = 0, within O(|q_i|) of the roots that hug the pole otherwise.


@stage
def _S3(a2, c, t):
    """S(t), S'(t), S''(t) (c_i = a_i q_i; zero c_i contribute nothing)."""
    S, dS, ddS = 0.0, 0.0, 0.0
    for i in range(3):
        if c[i] != 0.0:
            r = 1.0 / (t + a2[i])
            w = c[i] * r
            w2 = w * w
            S += w2
            dS -= 2.0 * w2 * r
            ddS += 6.0 * w2 * r * r
    return S, dS, ddS


@stage
def _root(a2, c, t, lo, hi, scale):
    """The root of psi = S^(-1/2) - 1 in [lo, hi], by Newton from t (S(t) > 1, on the side of the root
    away from psi's maximum): psi is concave between poles, so the iterates move monotonically to the
    root; a step leaving [lo, hi] (rounding) ends at the bound."""
    for _ in range(CRITICAL_MAX_ITER):
        S, dS, _ = _S3(a2, c, t)
        if not S > 1.0:
            return t
        step = -2.0 * S * (1.0 - math.sqrt(S)) / dS  # psi / psi' with psi' = -S' / (2 S^1.5)
        tn = min(max(t - step, lo), hi)
        if abs(tn - t) <= 1e-15 * scale:
            return tn
        t = tn
    return t


@stage
def _split(a2, c, lo, hi, cl, cr, scale):
    """A point of (lo, hi) where S < 1, or nan when S >= 1 on the whole interval (no root there):
    from the minimiser of the two pole terms alone, cl^2/(t-lo)^2 + cr^2/(hi-t)^2, safeguarded Newton
    on S' towards the minimiser of the convex S while S stays >= 1."""
    wl, wr = cl ** (2.0 / 3.0), cr ** (2.0 / 3.0)
    t = lo + (hi - lo) * (wl / (wl + wr) if wl + wr > 0.0 else 0.5)
    for _ in range(CRITICAL_MAX_ITER):
        S, dS, ddS = _S3(a2, c, t)
        if S < 1.0:
            return t
        if dS == 0.0:
            return math.nan
        if dS < 0.0:
            lo = t
        else:
            hi = t
        tn = t - dS / ddS if ddS > 0.0 else 0.5 * (lo + hi)
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) <= 1e-15 * scale or hi - lo <= 1e-15 * scale:
            S, _, _ = _S3(a2, c, tn)
            return tn if S < 1.0 else math.nan
        t = tn
    return math.nan


@jit
def secular_roots(a2, q, largest=True):
    """The roots of S(t) = 1 that can be local maxima of f_q on the sphere (local minima of the
    distance from q to E's boundary), a 3-tuple with nan where there is none: the largest root (nan
    unless `largest`: foot3's root, for callers that have it) and the two between the two largest
    poles.  (The Lagrangian |x - q|^2 + t (x^T A^-1 x - 1) has the tangent Hessian 2 (I + t A^-1), with
    a descent direction of the distance for t < -a2_mid.)"""
    i0, i1, i2 = 0, 1, 2  # poles -a2_i ascending
    if a2[i1] > a2[i0]:
        i0, i1 = i1, i0
    if a2[i2] > a2[i1]:
        i1, i2 = i2, i1
    if a2[i1] > a2[i0]:
        i0, i1 = i1, i0
    c = (math.sqrt(a2[0]) * q[0], math.sqrt(a2[1]) * q[1], math.sqrt(a2[2]) * q[2])
    scale = max(a2[0], a2[1], a2[2]) + abs(c[0]) + abs(c[1]) + abs(c[2])
    r1, ra, rb = math.nan, math.nan, math.nan
    # right of the rightmost pole: psi increasing to +inf; start where the largest single term is 1
    p = -a2[i2]
    t = p + 1e-300
    for i in range(3):
        t = max(t, -a2[i] + abs(c[i]))
    if largest:
        S, _, _ = _S3(a2, c, t)
        if S > 1.0:
            r1 = _root(a2, c, t, p, math.inf, scale)
        elif S == 1.0 or t > p + 1e-300:
            r1 = t
    # between the two rightmost poles: psi concave, 0 or 2 roots around its maximum
    pl, pr = -a2[i1], -a2[i2]
    cl, cr = abs(c[i1]), abs(c[i2])
    # S >= cl^2/(t-pl)^2 + cr^2/(pr-t)^2 >= (cl^(2/3) + cr^(2/3))^3 / (pr-pl)^2: no root if >= 1
    # (cl + cr)^2 <= g^3 (the 2/3-power mean): far enough beyond, g^3 is not computed
    if (cl + cr) * (cl + cr) >= (pr - pl) * (pr - pl) * (1.0 + 1e-9):
        return r1, ra, rb
    g = cl ** (2.0 / 3.0) + cr ** (2.0 / 3.0)
    if pr > pl and g * g * g < (pr - pl) * (pr - pl) * (1.0 + 1e-12):
        eps = 1e-15 * scale
        m = _split(a2, c, pl + eps, pr - eps, cl, cr, scale)
        if m == m:
            if cl != 0.0:
                t = min(pl + cl, m)
                for _ in range(CRITICAL_MAX_ITER):  # towards the pole until S > 1 (term l alone is 1 at pl + cl)
                    S, _, _ = _S3(a2, c, t)
                    if S > 1.0:
                        break
                    t = pl + 0.5 * (t - pl)
                ra = _root(a2, c, t, pl, m, scale)
            if cr != 0.0:
                t = max(pr - cr, m)
                for _ in range(CRITICAL_MAX_ITER):
                    S, _, _ = _S3(a2, c, t)
                    if S > 1.0:
                        break
                    t = pr - 0.5 * (pr - t)
                rb = _root(a2, c, t, m, pr, scale)
    return r1, ra, rb


@stage
def pole_normal(a2, q, i, sign):
    """The limit critical point at the pole t = -a2_i (exact when q_i = 0): x_j = a2_j q_j / (a2_j - a2_i)
    for j != i, x_i = sign * sqrt(a2_i (1 - sum_j x_j^2 / a2_j)); (ok, unit normal ~ x / a2)."""
    ai = a2[i]
    x0 = x1 = x2 = 0.0
    rest = 1.0
    ok = True
    if i != 0:
        den = a2[0] - ai
        ok = ok and den != 0.0
        x0 = a2[0] * q[0] / den if den != 0.0 else 0.0
        rest -= x0 * x0 / a2[0]
    if i != 1:
        den = a2[1] - ai
        ok = ok and den != 0.0
        x1 = a2[1] * q[1] / den if den != 0.0 else 0.0
        rest -= x1 * x1 / a2[1]
    if i != 2:
        den = a2[2] - ai
        ok = ok and den != 0.0
        x2 = a2[2] * q[2] / den if den != 0.0 else 0.0
        rest -= x2 * x2 / a2[2]
    if not ok or rest < 0.0:
        return False, (1.0, 0.0, 0.0)
    xi = sign * math.sqrt(rest * ai)
    x0, x1, x2 = (xi if i == 0 else x0), (xi if i == 1 else x1), (xi if i == 2 else x2)
    n = (x0 / a2[0], x1 / a2[1], x2 / a2[2])
    if not norm2(n) > 0.0:
        return False, (1.0, 0.0, 0.0)
    return True, unit(n)
