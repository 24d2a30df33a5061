"""The point-ellipsoid and point-ellipse problems as Warp functions: a float64 port of
ellipsim/native/include/ellipsim/pairs/point_ellipsoid.hpp (same method, same tolerances, same order of operations), the primitives
of the capsule x ellipsoid kernel (capsule.py).

E = {x : sum x_i^2 / a2_i <= 1} in its principal frame, support h(n) = sqrt(n^T A n); the boundary point
of E nearest to q is the largest root t > -min(a2) of S(t) = sum_i a2_i q_i^2 / (t + a2_i)^2 = 1,
solved as psi(t) = S^(-1/2) - 1 = 0 by Newton from the left (Eberly, "Distance from a point to an
ellipse, an ellipsoid, or a hyperellipsoid", Geometric Tools, sec. 2-3; Schneider & Eberly 10.5.2);
weak duality gives the certified bound sd(q, E) <= -sqrt(t (sum_i q_i^2 / (a2_i + t) - 1)) inside E.

Where the CPU code returns nan for "no root", these functions return a flag beside the value.  Constant
expressions are module constants: Warp evaluates an expression of literals such as 2.0 / 3.0 in float32.
"""

import warp as wp

from ..core.tolerances import CRITICAL_MAX_ITER, POLE_RTOL, SECULAR_LAST, SECULAR_MAX_ITER, U

F64 = wp.float64

TWO_THIRDS = 2.0 / 3.0
FOUR_U = 4.0 * U
ONE_MINUS_POLE = 1.0 - POLE_RTOL
ONE_MINUS_1E15 = 1.0 - 1e-15
SHRINK = 1.0 - 4e-16
SPLIT_SLACK = 1.0 + 1e-12
INF = 1e300  # (math.inf as a bound: larger than any finite value the functions compare it with)


@wp.func
def unit(v: wp.vec3d) -> wp.vec3d:
    """v / |v|, or e_x for the zero vector (sphere_newton.unit)."""
    s = wp.dot(v, v)
    if s == F64(0.0):
        return wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    s = F64(1.0) / wp.sqrt(s)
    return wp.vec3d(v[0] * s, v[1] * s, v[2] * s)


@wp.func
def tangent_basis(n: wp.vec3d):
    """Two unit vectors completing the unit n to an orthonormal frame (sphere_newton.tangent_basis)."""
    t = wp.vec3d(-n[2], F64(0.0), n[0])  # e_y x n
    if wp.abs(n[0]) < F64(0.6):
        t = wp.vec3d(F64(0.0), n[2], -n[1])  # e_x x n
    s = F64(1.0) / wp.sqrt(wp.dot(t, t))
    t1 = wp.vec3d(t[0] * s, t[1] * s, t[2] * s)
    t2 = wp.vec3d(n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])
    return t1, t2


@wp.func
def support(a2: wp.vec3d, n: wp.vec3d):
    """(h(n), s(n)): E's support function and support point, any nonzero n."""
    an0 = a2[0] * n[0]
    an1 = a2[1] * n[1]
    an2 = a2[2] * n[2]
    h = wp.sqrt(an0 * n[0] + an1 * n[1] + an2 * n[2])
    ih = F64(1.0) / h
    return h, wp.vec3d(an0 * ih, an1 * ih, an2 * ih)


@wp.func
def _min3(v: wp.vec3d) -> wp.float64:
    return wp.min(v[0], wp.min(v[1], v[2]))


@wp.func
def _max3(v: wp.vec3d) -> wp.float64:
    return wp.max(v[0], wp.max(v[1], v[2]))


@wp.func
def _psi3(a2: wp.vec3d, q: wp.vec3d, t: wp.float64):
    """(S(t), Newton step of psi) (point_ellipsoid._psi3)."""
    p0 = t + a2[0]
    p1 = t + a2[1]
    p2 = t + a2[2]
    p01 = p0 * p1
    inv = F64(1.0) / (p01 * p2)
    d0 = p1 * p2 * inv
    d1 = p0 * p2 * inv
    d2 = p01 * inv
    w0 = q[0] * d0
    w1 = q[1] * d1
    w2 = q[2] * d2
    s0 = a2[0] * w0 * w0
    s1 = a2[1] * w1 * w1
    s2 = a2[2] * w2 * w2
    S = s0 + s1 + s2
    T = s0 * d0 + s1 * d1 + s2 * d2
    return S, S * (F64(1.0) - wp.sqrt(S)) / T


@wp.func
def _secular_root3(a2: wp.vec3d, q: wp.vec3d, amin: wp.float64, amax: wp.float64, qq: wp.float64):
    """(ok, t): the largest root of S(t) = 1; ok False when it lies within POLE_RTOL * amin of the pole."""
    lo = -amin + F64(POLE_RTOL) * amin
    t = lo
    for i in range(3):
        t = wp.max(t, -a2[i] + wp.sqrt(a2[i]) * wp.abs(q[i]))
    hi = wp.sqrt(amax * qq)
    S, step = _psi3(a2, q, t)
    if not (S > F64(1.0)):
        return (S == F64(1.0) or t > lo), t
    for _ in range(SECULAR_MAX_ITER):
        tn = wp.min(t - step, hi)
        if tn - t <= wp.max(F64(SECULAR_LAST) * (tn + amin), F64(FOUR_U) * (wp.abs(tn) + amin)):
            return True, tn
        t = tn
        S, step = _psi3(a2, q, t)
        if not (S > F64(1.0)):
            return True, t
    return True, t


@wp.func
def _pole_limit(a2: wp.vec3d, q: wp.vec3d, amin: wp.float64) -> wp.vec3d:
    """The normal at the degenerate root -amin (point_ellipsoid._pole_limit)."""
    tol = F64(POLE_RTOL) * amin
    d0 = a2[0] - amin <= tol
    d1 = a2[1] - amin <= tol
    d2 = a2[2] - amin <= tol
    x0 = F64(0.0)
    x1 = F64(0.0)
    x2 = F64(0.0)
    if not d0:
        x0 = a2[0] * q[0] / (a2[0] - amin)
    if not d1:
        x1 = a2[1] * q[1] / (a2[1] - amin)
    if not d2:
        x2 = a2[2] * q[2] / (a2[2] - amin)
    rest = wp.max(F64(1.0) - x0 * x0 / a2[0] - x1 * x1 / a2[1] - x2 * x2 / a2[2], F64(0.0))
    qd = F64(0.0)
    if d0:
        qd = qd + q[0] * q[0] / a2[0]
    if d1:
        qd = qd + q[1] * q[1] / a2[1]
    if d2:
        qd = qd + q[2] * q[2] / a2[2]
    if qd > F64(0.0):
        f = wp.sqrt(rest / qd)
        if d0:
            x0 = q[0] * f
        if d1:
            x1 = q[1] * f
        if d2:
            x2 = q[2] * f
    elif d0:
        x0 = wp.sqrt(rest * a2[0])
    elif d1:
        x1 = wp.sqrt(rest * a2[1])
    else:
        x2 = wp.sqrt(rest * a2[2])
    return unit(wp.vec3d(x0 / a2[0], x1 / a2[1], x2 / a2[2]))


@wp.func
def foot3(a2: wp.vec3d, q: wp.vec3d):
    """(t, n): the largest secular root (-min(a2) for the degenerate limit) and the outward unit normal
    at the boundary point of E nearest to q (point_ellipsoid.foot3)."""
    amin = _min3(a2)
    amax = _max3(a2)
    qq = wp.dot(q, q)
    ok = False
    t = F64(0.0)
    if qq > F64(0.0):
        ok, t = _secular_root3(a2, q, amin, amax, qq)
    if ok:
        return t, unit(wp.vec3d(q[0] / (t + a2[0]), q[1] / (t + a2[1]), q[2] / (t + a2[2])))
    return -amin, _pole_limit(a2, q, amin)


@wp.func
def _dual_bound(a2: wp.vec3d, q: wp.vec3d, t: wp.float64, d: int) -> wp.float64:
    """-sqrt(g(t)) for q inside the d-dimensional ellipse/ellipsoid a2 (point_ellipsoid._dual_bound)."""
    amin = wp.min(a2[0], a2[1])
    if d == 3:
        amin = _min3(a2)
    tt = t
    if not (tt > -amin * F64(ONE_MINUS_1E15)):
        c = F64(0.0)
        srest = F64(0.0)
        for i in range(d):
            den = a2[i] - amin
            if den > F64(POLE_RTOL) * amin:
                srest = srest + a2[i] * q[i] * q[i] / (den * den)
            else:
                c = c + a2[i] * q[i] * q[i]
        delta = F64(POLE_RTOL) * amin
        if srest < F64(1.0):
            delta = wp.sqrt(c / (F64(1.0) - srest))
        tt = -amin + wp.max(delta, F64(1e-15) * amin)
    g = F64(0.0)
    for i in range(d):
        g = g + q[i] * q[i] / (a2[i] + tt)
    g = tt * (g - F64(1.0))
    if not (g > F64(0.0)):
        return F64(0.0)
    return -wp.sqrt(g)


@wp.func
def _outside_bound(a2: wp.vec3d, q: wp.vec3d, t: wp.float64, d: int) -> wp.float64:
    """|q - x| for the foot point x at t, pulled onto the body if rounding left it outside."""
    amin = wp.min(a2[0], a2[1])
    if d == 3:
        amin = _min3(a2)
    ok = t > -amin * F64(ONE_MINUS_POLE)
    x = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    if ok:
        x = wp.vec3d(a2[0] * q[0] / (t + a2[0]), a2[1] * q[1] / (t + a2[1]), F64(0.0))
        if d == 3:
            x[2] = a2[2] * q[2] / (t + a2[2])
    k = x[0] * x[0] / a2[0] + x[1] * x[1] / a2[1]
    if d == 3:
        k = k + x[2] * x[2] / a2[2]
    if k > F64(1.0):
        f = F64(1.0) / wp.sqrt(k) * F64(SHRINK)
        x = wp.vec3d(x[0] * f, x[1] * f, x[2] * f)
    d0 = q[0] - x[0]
    d1 = q[1] - x[1]
    d2 = F64(0.0)
    if d == 3:
        d2 = q[2] - x[2]
    return wp.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@wp.func
def sd_upper(a2: wp.vec3d, q: wp.vec3d, t: wp.float64) -> wp.float64:
    """An upper bound on the signed distance of q to E from foot3's t (point_ellipsoid.sd_upper)."""
    if q[0] * q[0] / a2[0] + q[1] * q[1] / a2[1] + q[2] * q[2] / a2[2] < F64(1.0):
        return _dual_bound(a2, q, t, 3)
    return _outside_bound(a2, q, t, 3)


@wp.func
def _psi2(b0: wp.float64, b1: wp.float64, p0: wp.float64, p1: wp.float64, t: wp.float64):
    r0 = t + b0
    r1 = t + b1
    inv = F64(1.0) / (r0 * r1)
    d0 = r1 * inv
    d1 = r0 * inv
    w0 = p0 * d0
    w1 = p1 * d1
    s0 = b0 * w0 * w0
    s1 = b1 * w1 * w1
    S = s0 + s1
    T = s0 * d0 + s1 * d1
    return S, S * (F64(1.0) - wp.sqrt(S)) / T


@wp.func
def _pole_normal2(b0: wp.float64, b1: wp.float64, p0: wp.float64, p1: wp.float64, bmin: wp.float64):
    """foot2's normal at a root within POLE_RTOL bmin of the pole (point_ellipsoid._pole_normal2)."""
    d0 = b0 - bmin
    d1 = b1 - bmin
    c0 = b0 * p0 * p0
    c1 = b1 * p1 * p1
    zero = F64(0.0)
    at_pole = (c0 > zero and d0 == zero) or (c1 > zero and d1 == zero)
    s0 = zero
    if d0 > zero:
        s0 += c0 / (d0 * d0)
    if d1 > zero:
        s0 += c1 / (d1 * d1)
    n0 = zero
    n1 = zero
    if at_pole or s0 > F64(1.0):
        delta = F64(POLE_RTOL) * bmin
        for _ in range(SECULAR_MAX_ITER):
            r0 = delta + d0
            r1 = delta + d1
            S = c0 / (r0 * r0) + c1 / (r1 * r1)
            dS = F64(-2.0) * (c0 / (r0 * r0 * r0) + c1 / (r1 * r1 * r1))
            step = (F64(1.0) / wp.sqrt(S) - F64(1.0)) / (F64(-0.5) * dS / (S * wp.sqrt(S)))
            dn = delta - step
            if not (dn > zero):
                dn = F64(1e-3) * delta
            if wp.abs(dn - delta) <= F64(FOUR_U) * delta:
                delta = dn
                break
            delta = dn
        n0 = p0 / (delta + d0)
        n1 = p1 / (delta + d1)
    else:
        x0 = zero
        x1 = zero
        if d0 > zero:
            x0 = b0 * p0 / d0
        if d1 > zero:
            x1 = b1 * p1 / d1
        rest = wp.max(F64(1.0) - x0 * x0 / b0 - x1 * x1 / b1, zero)
        if d0 == zero:
            x0 = wp.sqrt(rest * b0)
        else:
            x1 = wp.sqrt(rest * b1)
        n0 = x0 / b0
        n1 = x1 / b1
    return n0, n1


@wp.func
def foot2(b0: wp.float64, b1: wp.float64, p0: wp.float64, p1: wp.float64):
    """2-D point-ellipse (squared semi-axes b0, b1): (t, n0, n1) (point_ellipsoid.foot2)."""
    bmin = wp.min(b0, b1)
    bmax = wp.max(b0, b1)
    pp = p0 * p0 + p1 * p1
    ok = False
    t = F64(0.0)
    if pp > F64(0.0):
        ok = True
        lo = -bmin + F64(POLE_RTOL) * bmin
        t = wp.max(lo, wp.max(-b0 + wp.sqrt(b0) * wp.abs(p0), -b1 + wp.sqrt(b1) * wp.abs(p1)))
        hi = wp.sqrt(bmax * pp)
        S, step = _psi2(b0, b1, p0, p1, t)
        if not (S > F64(1.0)):
            if not (S == F64(1.0) or t > lo):
                ok = False
        else:
            for _ in range(SECULAR_MAX_ITER):
                tn = wp.min(t - step, hi)
                if tn - t <= wp.max(F64(SECULAR_LAST) * (tn + bmin), F64(FOUR_U) * (wp.abs(tn) + bmin)):
                    t = tn
                    break
                t = tn
                S, step = _psi2(b0, b1, p0, p1, t)
                if not (S > F64(1.0)):
                    break
    n0 = F64(0.0)
    n1 = F64(0.0)
    if ok:
        n0 = p0 / (t + b0)
        n1 = p1 / (t + b1)
    else:
        n0, n1 = _pole_normal2(b0, b1, p0, p1, bmin)
        t = -bmin
    s = wp.sqrt(n0 * n0 + n1 * n1)
    return t, n0 / s, n1 / s


@wp.func
def sd_upper2(b0: wp.float64, b1: wp.float64, p0: wp.float64, p1: wp.float64, t: wp.float64) -> wp.float64:
    """sd_upper for the ellipse (squared semi-axes b0, b1) and the point p, from foot2's t."""
    b = wp.vec3d(b0, b1, F64(1.0))
    p = wp.vec3d(p0, p1, F64(0.0))
    if p0 * p0 / b0 + p1 * p1 / b1 < F64(1.0):
        return _dual_bound(b, p, t, 2)
    return _outside_bound(b, p, t, 2)


@wp.func
def project_ellipse(a2: wp.vec3d, w1: wp.vec3d, w2: wp.vec3d):
    """E's projection onto span(w1, w2): (lam, mu, cs, sn), lam >= mu (point_ellipsoid.project_ellipse)."""
    m11 = a2[0] * w1[0] * w1[0] + a2[1] * w1[1] * w1[1] + a2[2] * w1[2] * w1[2]
    m12 = a2[0] * w1[0] * w2[0] + a2[1] * w1[1] * w2[1] + a2[2] * w1[2] * w2[2]
    m22 = a2[0] * w2[0] * w2[0] + a2[1] * w2[1] * w2[1] + a2[2] * w2[2] * w2[2]
    half = F64(0.5) * (m11 - m22)
    rad = wp.sqrt(half * half + m12 * m12)
    lam = F64(0.5) * (m11 + m22) + rad
    # det / lam with det by Cauchy-Binet, a sum of positive terms (point_ellipsoid.project_ellipse)
    x0 = w1[1] * w2[2] - w1[2] * w2[1]
    x1 = w1[2] * w2[0] - w1[0] * w2[2]
    x2 = w1[0] * w2[1] - w1[1] * w2[0]
    mu = (a2[1] * a2[2] * x0 * x0 + a2[0] * a2[2] * x1 * x1 + a2[0] * a2[1] * x2 * x2) / lam
    c = F64(1.0)
    s = F64(0.0)
    if rad > F64(0.0):
        if half >= F64(0.0):
            c = half + rad
            s = m12
        else:
            c = m12
            s = rad - half
        f = F64(1.0) / wp.sqrt(c * c + s * s)
        c = c * f
        s = s * f
    return lam, mu, c, s


@wp.func
def from_plane(m0: wp.float64, m1: wp.float64, c: wp.float64, s: wp.float64, w1: wp.vec3d, w2: wp.vec3d):
    """The unit vector with coordinates (m0, m1) along the projected ellipse's axes (c, s), (-s, c) of the
    plane span(w1, w2) (point_ellipsoid.from_plane)."""
    k1 = c * m0 - s * m1
    k2 = s * m0 + c * m1
    return unit(wp.vec3d(k1 * w1[0] + k2 * w2[0], k1 * w1[1] + k2 * w2[1], k1 * w1[2] + k2 * w2[2]))


@wp.func
def copysign(x: wp.float64, y: wp.float64) -> wp.float64:
    """|x| with the sign of y (math.copysign; -0.0 counts as negative, as there)."""
    if y < F64(0.0) or (y == F64(0.0) and F64(1.0) / y < F64(0.0)):
        return -wp.abs(x)
    return wp.abs(x)


@wp.func
def circle_max_bound(a2: wp.vec3d, q: wp.vec3d, w1: wp.vec3d, w2: wp.vec3d):
    """(n, ub): the unit n in span(w1, w2) maximising n.q - h(n), and an upper bound on that maximum
    (point_ellipsoid.circle_max_bound)."""
    lam, mu, c, s = project_ellipse(a2, w1, w2)
    p1 = wp.dot(q, w1)
    p2 = wp.dot(q, w2)
    r0 = c * p1 + s * p2
    r1 = -s * p1 + c * p2
    t, n0, n1 = foot2(lam, mu, r0, r1)
    return from_plane(n0, n1, c, s, w1, w2), sd_upper2(lam, mu, r0, r1, t)


# --- every critical point of f_q on the sphere (point_ellipsoid's enumeration) ---------------------


@wp.func
def _S3(a2: wp.vec3d, c: wp.vec3d, t: wp.float64):
    """S(t), S'(t), S''(t) (c_i = a_i q_i; zero c_i contribute nothing)."""
    S = F64(0.0)
    dS = F64(0.0)
    ddS = F64(0.0)
    for i in range(3):
        if c[i] != F64(0.0):
            r = F64(1.0) / (t + a2[i])
            w = c[i] * r
            w2 = w * w
            S = S + w2
            dS = dS - F64(2.0) * w2 * r
            ddS = ddS + F64(6.0) * w2 * r * r
    return S, dS, ddS


@wp.func
def _root(a2: wp.vec3d, c: wp.vec3d, t0: wp.float64, lo: wp.float64, hi: wp.float64, scale: wp.float64):
    """The root of psi in [lo, hi] by monotone Newton from t0 (point_ellipsoid._root)."""
    t = t0
    for _ in range(CRITICAL_MAX_ITER):
        S, dS, _dd = _S3(a2, c, t)
        if not (S > F64(1.0)):
            return t
        step = F64(-2.0) * S * (F64(1.0) - wp.sqrt(S)) / dS
        tn = wp.min(wp.max(t - step, lo), hi)
        if wp.abs(tn - t) <= F64(1e-15) * scale:
            return tn
        t = tn
    return t


@wp.func
def _split(
    a2: wp.vec3d, c: wp.vec3d, lo0: wp.float64, hi0: wp.float64, cl: wp.float64, cr: wp.float64, scale: wp.float64
):
    """(ok, t): a point of (lo, hi) where S < 1; ok False when S >= 1 on the whole interval
    (point_ellipsoid._split)."""
    lo = lo0
    hi = hi0
    wl = wp.pow(cl, F64(TWO_THIRDS))
    wr = wp.pow(cr, F64(TWO_THIRDS))
    f = F64(0.5)
    if wl + wr > F64(0.0):
        f = wl / (wl + wr)
    t = lo + (hi - lo) * f
    for _ in range(CRITICAL_MAX_ITER):
        S, dS, ddS = _S3(a2, c, t)
        if S < F64(1.0):
            return True, t
        if dS == F64(0.0):
            return False, t
        if dS < F64(0.0):
            lo = t
        else:
            hi = t
        tn = F64(0.5) * (lo + hi)
        if ddS > F64(0.0):
            tn = t - dS / ddS
        if not (lo < tn and tn < hi):
            tn = F64(0.5) * (lo + hi)
        if wp.abs(tn - t) <= F64(1e-15) * scale or hi - lo <= F64(1e-15) * scale:
            S2, _d1, _d2 = _S3(a2, c, tn)
            return S2 < F64(1.0), tn
        t = tn
    return False, t


@wp.func
def secular_roots(a2: wp.vec3d, q: wp.vec3d):
    """(ok, t): the roots of S(t) = 1 that can be local maxima of f_q on the sphere, the largest (entry 0)
    and the two between the two largest poles (entries 1, 2), ok[k] = 1 where root k exists
    (point_ellipsoid.secular_roots, largest=True; its nan is ok[k] = 0)."""
    i0 = 0
    i1 = 1
    i2 = 2
    if a2[i1] > a2[i0]:
        i0 = 1
        i1 = 0
    if a2[i2] > a2[i1]:
        k = i1
        i1 = i2
        i2 = k
    if a2[i1] > a2[i0]:
        k = i0
        i0 = i1
        i1 = k
    c = wp.vec3d(wp.sqrt(a2[0]) * q[0], wp.sqrt(a2[1]) * q[1], wp.sqrt(a2[2]) * q[2])
    scale = _max3(a2) + wp.abs(c[0]) + wp.abs(c[1]) + wp.abs(c[2])
    ok1 = False
    oka = False
    okb = False
    r1 = F64(0.0)
    ra = F64(0.0)
    rb = F64(0.0)
    p = -a2[i2]
    t = p + F64(1e-300)
    for i in range(3):
        t = wp.max(t, -a2[i] + wp.abs(c[i]))
    S, _d1, _d2 = _S3(a2, c, t)
    if S > F64(1.0):
        ok1 = True
        r1 = _root(a2, c, t, p, F64(INF), scale)
    elif S == F64(1.0) or t > p + F64(1e-300):
        ok1 = True
        r1 = t
    pl = -a2[i1]
    pr = -a2[i2]
    cl = wp.abs(c[i1])
    cr = wp.abs(c[i2])
    g = wp.pow(cl, F64(TWO_THIRDS)) + wp.pow(cr, F64(TWO_THIRDS))
    if pr > pl and g * g * g < (pr - pl) * (pr - pl) * F64(SPLIT_SLACK):
        eps = F64(1e-15) * scale
        okm, m = _split(a2, c, pl + eps, pr - eps, cl, cr, scale)
        if okm:
            if cl != F64(0.0):
                t = wp.min(pl + cl, m)
                for _ in range(CRITICAL_MAX_ITER):
                    S, _d1, _d2 = _S3(a2, c, t)
                    if S > F64(1.0):
                        break
                    t = pl + F64(0.5) * (t - pl)
                oka = True
                ra = _root(a2, c, t, pl, m, scale)
            if cr != F64(0.0):
                t = wp.max(pr - cr, m)
                for _ in range(CRITICAL_MAX_ITER):
                    S, _d1, _d2 = _S3(a2, c, t)
                    if S > F64(1.0):
                        break
                    t = pr - F64(0.5) * (pr - t)
                okb = True
                rb = _root(a2, c, t, m, pr, scale)
    return wp.vec3i(int(ok1), int(oka), int(okb)), wp.vec3d(r1, ra, rb)


@wp.func
def root_normal(a2: wp.vec3d, q: wp.vec3d, t: wp.float64) -> wp.vec3d:
    """E's unit normal at the foot point of the secular root t: q_i / (t + a2_i), normalised."""
    return unit(wp.vec3d(q[0] / (t + a2[0]), q[1] / (t + a2[1]), q[2] / (t + a2[2])))


@wp.func
def pole_normal(a2: wp.vec3d, q: wp.vec3d, i: int, sign: wp.float64):
    """(ok, n): the limit critical point at the pole t = -a2_i (point_ellipsoid.pole_normal)."""
    ai = a2[i]
    x = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    rest = F64(1.0)
    ok = True
    for j in range(3):
        if j != i:
            den = a2[j] - ai
            if den != F64(0.0):
                x[j] = a2[j] * q[j] / den
            else:
                ok = False
            rest = rest - x[j] * x[j] / a2[j]
    if not ok or rest < F64(0.0):
        return False, wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    x[i] = sign * wp.sqrt(rest * ai)
    n = wp.vec3d(x[0] / a2[0], x[1] / a2[1], x[2] / a2[2])
    if not (wp.dot(n, n) > F64(0.0)):
        return False, wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    return True, unit(n)
