"""Signed distance of an ellipsoid and a capsule with a proven global maximum (MuJoCo's capsule x
ellipsoid narrow phase).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (distance.py), split into the smooth
strata of the capsule's support function, each solved globally by Eberly's secular equation ("Distance
from a point to an ellipse, an ellipsoid, or a hyperellipsoid", Geometric Tools, sec. 2-3; GTCG
10.5.2), certified by the two convex-duality bounds below or by enumerating every critical point.

The pair in E's principal frame: E = {x : sum x_i^2 / a2_i <= 1} (a2 the squared semi-axes), the
capsule K = segment [-L, L] u + ball(r) centred at e, so

    sigma(n) = n.e - h_E(n) - L |n.u| - r = min(f_{e+Lu}(n), f_{e-Lu}(n)) - r,   f_q(n) = n.q - h_E(n),

n pointing from E to K, smooth except on the great circle n.u = 0 (the contact on the capsule's side).
Strata and their maximisers:
* side (n.u = 0): the 2-D point-ellipse problem of e projected along u onto the plane u^perp, against
  E's projection (an ellipse); valid when the segment parameter t = (s_E(n) - e).u lies in [-L, L];
* end point e + sL u (s = +-1, region s n.u <= 0): the point-ellipsoid problem for q = e + sL u.
The local solve takes the side stratum when its segment parameter is admissible, else the end it
points to.

Certificates (global upper bounds on max sigma, from concavity of h on R^3; any unit n):
* ub1 = sd(e - s_E(n) + rho n, K) - rho with rho the rolling radius of E (E = E' + ball(rho)):
  h_E(m) >= rho + m.(s_E(n) - rho n) for unit m, so sigma(m) <= m.w - h_K(m) - rho <= sd(w, K) - rho.
  Tight when separated or shallow.
* ub2 = sd(e - c, E) - r, c the segment point at the contact: h_K(m) >= m.c + r (ball(c, r) in K), so
  sigma(m) <= f_{e-c}(m) - r <= sd(e - c, E) - r, bounded above by weak duality (sd_upper).
  Tight when the capsule's axis point is deep in E.
When neither closes (deep crossings), a branch and bound over the three smooth pieces (enumerate_max):
a piece whose extended smooth function's certified maximum does not beat the incumbent is skipped, one
whose maximiser lies inside it is taken whole, and the rest have every critical point evaluated
(secular_roots, pole_normal): a complete case analysis, status ENUMERATED.

The point-ellipsoid problem (nearest boundary point of E to q, inside or outside, and its outward
unit normal) is the largest root t > -min(a2) of S(t) = sum_i a2_i q_i^2 / (t + a2_i)^2 = 1, solved as
psi(t) = S^(-1/2) - 1 = 0 by Newton: psi is a power mean of exponent -2 of the affine (t + a2_i) /
(a_i |q_i|), concave and increasing, so Newton from the left climbs monotonically to the root.  Weak
duality gives dist(q, boundary E)^2 >= g(t) = t (sum_i q_i^2 / (a2_i + t) - 1) for every t > -min(a2),
with equality at the root: the certified bound sd(q, E) <= -sqrt(g(t)) for q inside E.

Ported from the validated pair-type prototype (10 000 poses: never below a 20 000-direction reference
by more than 1e-12 of the smaller shortest half-size; every maximum certified or enumerated).
"""

import math

from ._jit import jit, stage
from .sigma import rolling_radius, tangent_basis, unit
from .tolerances import (
    CAPSULE_CERT_REL, CAPSULE_SIGMA_SLACK_ULPS, CRITICAL_MAX_ITER, POLE_RTOL, SECULAR_LAST, SECULAR_MAX_ITER, U,
)  # fmt: skip
from .vec3 import column, dot3, matvec, norm2, rotate_t

#: How capsule_ellipsoid proved its maximum: CERTIFIED (an upper bound within CAPSULE_CERT_REL of the
#: smaller shortest half-size of the value) or ENUMERATED (every critical point of every smooth piece
#: evaluated).  Both are proofs; the MuJoCo glue falls back to MuJoCo only on a non-finite result.
CERTIFIED, ENUMERATED = 0, 1

# --- the pair, sigma, and the way back to world coordinates ---------------------------------------


@stage
def to_frame(E, K):
    """(e, a2, u): K's centre in E's principal frame, E's squared semi-axes, K's axis (its local z)
    in E's frame.  E, K as (centre (3,), rotation row-major (9,), sizes (3,)) tuples, K's sizes
    (radius, half-length, -) as in MuJoCo's geom_size."""
    (ce, Re, ra), (ck, Rk, _) = E, K
    e = rotate_t(Re, (ck[0] - ce[0], ck[1] - ce[1], ck[2] - ce[2]))
    u = rotate_t(Re, column(Rk, 2))
    return e, (ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]), u


@stage
def sigma_capsule(a2, e, u, L, r, n):
    """sigma at the unit n (E's frame)."""
    h = math.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    return n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - h - L * abs(n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) - r


@stage
def centre_line_bound(E, K):
    """A lower bound on the signed distance: sigma along the centre line minus its rounding allowance
    (CAPSULE_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies."""
    e, a2, u = to_frame(E, K)
    ee = norm2(e)
    if not ee > 0.0:
        return -math.inf
    s = 1.0 / math.sqrt(ee)
    ra, rk = E[2], K[2]
    scale = math.sqrt(ee) + max(ra[0], ra[1], ra[2], rk[0], rk[1])
    v = sigma_capsule(a2, e, u, rk[1], rk[0], (e[0] * s, e[1] * s, e[2] * s))
    return v - CAPSULE_SIGMA_SLACK_ULPS * U * scale


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
        if tn - t <= SECULAR_LAST * (abs(t) + amin):
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
    qd = (q[0] * q[0] / a2[0] if d0 else 0.0) + (q[1] * q[1] / a2[1] if d1 else 0.0) + (q[2] * q[2] / a2[2] if d2 else 0.0)
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
                if tn - t <= SECULAR_LAST * (abs(t) + bmin):
                    t = tn
                    break
                t = tn
                S, step = _psi2(b0, b1, p0, p1, t)
                if not S > 1.0:
                    break
    if t == t:
        n0, n1 = p0 / (t + b0), p1 / (t + b1)
    else:
        # limit at the pole: the coordinate of the larger axis from the formula, the other what is left
        if b0 - bmin > POLE_RTOL * bmin:
            x0 = b0 * p0 / (b0 - bmin)
            r2 = max(1.0 - x0 * x0 / b0, 0.0)
            x1 = math.sqrt(r2 * b1) * (1.0 if p1 >= 0.0 else -1.0)
        elif b1 - bmin > POLE_RTOL * bmin:
            x1 = b1 * p1 / (b1 - bmin)
            r2 = max(1.0 - x1 * x1 / b1, 0.0)
            x0 = math.sqrt(r2 * b0) * (1.0 if p0 >= 0.0 else -1.0)
        else:  # a circle with p at its centre
            x0, x1 = math.sqrt(b0), 0.0
        n0, n1 = x0 / b0, x1 / b1
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
def _project_ellipse(a2, w1, w2):
    """The projection of E onto span(w1, w2) (orthonormal): support matrix W^T A W = lam c c^T + mu s s^T
    with c = (cs, sn) in (w1, w2) coordinates; returns (lam, mu, cs, sn), lam >= mu."""
    m11 = a2[0] * w1[0] * w1[0] + a2[1] * w1[1] * w1[1] + a2[2] * w1[2] * w1[2]
    m12 = a2[0] * w1[0] * w2[0] + a2[1] * w1[1] * w2[1] + a2[2] * w1[2] * w2[2]
    m22 = a2[0] * w2[0] * w2[0] + a2[1] * w2[1] * w2[1] + a2[2] * w2[2] * w2[2]
    half = 0.5 * (m11 - m22)
    rad = math.sqrt(half * half + m12 * m12)
    lam = 0.5 * (m11 + m22) + rad
    mu = (m11 * m22 - m12 * m12) / lam  # the smaller eigenvalue without cancellation
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
def _from_plane(n0, n1, c, s, w1, w2):
    """The 3-D unit vector with coordinates (n0, n1) along the projected ellipse's axes (c, s), (-s, c)."""
    k1, k2 = c * n0 - s * n1, s * n0 + c * n1
    return unit((k1 * w1[0] + k2 * w2[0], k1 * w1[1] + k2 * w2[1], k1 * w1[2] + k2 * w2[2]))


@stage
def circle_max_bound(a2, q, w1, w2):
    """(n, ub): the unit n in span(w1, w2) (orthonormal) maximising n.q - h(n) -- the normal at the
    point of E's projection onto that plane nearest to the projected q -- and an upper bound on that
    maximum (sd_upper2)."""
    lam, mu, c, s = _project_ellipse(a2, w1, w2)
    p1, p2 = dot3(q[0], q[1], q[2], w1[0], w1[1], w1[2]), dot3(q[0], q[1], q[2], w2[0], w2[1], w2[2])
    r0, r1 = c * p1 + s * p2, -s * p1 + c * p2
    t, n0, n1 = foot2(lam, mu, r0, r1)
    return _from_plane(n0, n1, c, s, w1, w2), sd_upper2(lam, mu, r0, r1, t)


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
def secular_roots(a2, q):
    """The roots of S(t) = 1 that can be local maxima of f_q on the sphere (local minima of the
    distance from q to E's boundary), a 3-tuple with nan where there is none: the largest root and
    the two between the two largest poles.  (The Lagrangian |x - q|^2 + t (x^T A^-1 x - 1) has the
    tangent Hessian 2 (I + t A^-1), with a descent direction of the distance for t < -a2_mid.)"""
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
    S, _, _ = _S3(a2, c, t)
    if S > 1.0:
        r1 = _root(a2, c, t, p, math.inf, scale)
    elif S == 1.0 or t > p + 1e-300:
        r1 = t
    # between the two rightmost poles: psi concave, 0 or 2 roots around its maximum
    pl, pr = -a2[i1], -a2[i2]
    cl, cr = abs(c[i1]), abs(c[i2])
    # S >= cl^2/(t-pl)^2 + cr^2/(pr-t)^2 >= (cl^(2/3) + cr^(2/3))^3 / (pr-pl)^2: no root if >= 1
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
def _pole_normal(a2, q, i, sign):
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


# --- the kernel -----------------------------------------------------------------------------------


@stage
def local_max(a2, e, u, L):
    """(n, stratum): 0 side, +1 / -1 the end e + L u / e - L u."""
    w1, w2 = tangent_basis(u)
    n, _ = circle_max_bound(a2, e, w1, w2)
    _, s = support(a2, n)
    t = dot3(s[0], s[1], s[2], u[0], u[1], u[2]) - dot3(e[0], e[1], e[2], u[0], u[1], u[2])
    if abs(t) <= L:
        return n, 0
    sg = 1.0 if t > 0.0 else -1.0
    q = (e[0] + sg * L * u[0], e[1] + sg * L * u[1], e[2] + sg * L * u[2])
    _, n = foot3(a2, q)
    return n, 1 if sg > 0.0 else -1


@stage
def upper_bound1(a2, e, u, L, r, rho, n):
    """ub1 of the module docstring at the unit n."""
    _, s = support(a2, n)
    w = (e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    t = min(max(dot3(w[0], w[1], w[2], u[0], u[1], u[2]), -L), L)
    z = (w[0] - t * u[0], w[1] - t * u[1], w[2] - t * u[2])
    return math.sqrt(norm2(z)) - r - rho


@stage
def upper_bound2(a2, e, u, L, r, n, value):
    """ub2 of the module docstring: the axis point c = e - s - (value + r) n, clamped to the segment."""
    _, s = support(a2, n)
    d = (e[0] - s[0] - (value + r) * n[0], e[1] - s[1] - (value + r) * n[1], e[2] - s[2] - (value + r) * n[2])
    tc = min(max(dot3(d[0], d[1], d[2], u[0], u[1], u[2]), -L), L)
    q = (e[0] - tc * u[0], e[1] - tc * u[1], e[2] - tc * u[2])
    t2, _ = foot3(a2, q)
    return sd_upper(a2, q, t2) - r


@stage
def upper_bound(a2, e, u, L, r, rho, n, value, tol):
    """The first of ub1, ub2 that is within tol of value, else their minimum."""
    ub = upper_bound1(a2, e, u, L, r, rho, n)
    if ub - value <= tol:
        return ub
    return min(ub, upper_bound2(a2, e, u, L, r, n, value))


@stage
def _consider(a2, e, u, L, r, n, best, bn):
    v = sigma_capsule(a2, e, u, L, r, n)
    if v > best:
        return v, n
    return best, bn


@jit
def enumerate_max(a2, e, u, L, r, best, bn, tol):
    """Branch and bound over the three smooth pieces, from the incumbent (best, bn): a piece is skipped
    when the global maximum of its extended smooth function (a certified upper bound) does not beat the
    incumbent by tol; taken whole when that maximiser lies in the piece; otherwise every critical point
    of the piece is evaluated.  Returns the best (value, n)."""
    for sg in (1.0, -1.0):
        q = (e[0] + sg * L * u[0], e[1] + sg * L * u[1], e[2] + sg * L * u[2])
        t, n = foot3(a2, q)
        if sd_upper(a2, q, t) - r <= best + tol:
            continue
        if sg * dot3(n[0], n[1], n[2], u[0], u[1], u[2]) <= 0.0:  # the maximiser lies in this end's region
            best, bn = _consider(a2, e, u, L, r, n, best, bn)
            continue
        for t in secular_roots(a2, q):
            if t == t:
                m = unit((q[0] / (t + a2[0]), q[1] / (t + a2[1]), q[2] / (t + a2[2])))
                best, bn = _consider(a2, e, u, L, r, m, best, bn)
        for i in range(3):
            for sign in (1.0, -1.0):
                ok, m = _pole_normal(a2, q, i, sign)
                if ok:
                    best, bn = _consider(a2, e, u, L, r, m, best, bn)
    # the side circle: its global maximum is the maximum of the piece (the circle is the whole piece)
    w1, w2 = tangent_basis(u)
    n, _ = circle_max_bound(a2, e, w1, w2)
    return _consider(a2, e, u, L, r, n, best, bn)


@jit
def capsule_ellipsoid(E, K):
    """(status, dist, normal (3,), pos (3,), ub) for the ellipsoid E and the capsule K, tuples
    (centre (3,) metres, rotation row-major (9,), sizes (3,) metres; K's sizes (radius, half-length,
    unused), its axis its local z, as MuJoCo's capsule geom).  dist: the signed distance, metres
    (sigma at the returned normal, a lower bound of the exact maximum); normal: unit, from E to K;
    pos: the midpoint of the witness points (MuJoCo's contact position); ub: the certified upper
    bound (inf when ENUMERATED); status: CERTIFIED or ENUMERATED."""
    e, a2, u = to_frame(E, K)
    r, L = K[2][0], K[2][1]
    ra = E[2]
    rho = rolling_radius(ra)
    n, _ = local_max(a2, e, u, L)
    value = sigma_capsule(a2, e, u, L, r, n)
    tol = CAPSULE_CERT_REL * min(ra[0], ra[1], ra[2], r)
    ub = upper_bound(a2, e, u, L, r, rho, n, value, tol)
    status = CERTIFIED
    if ub - value > tol:
        value, n = enumerate_max(a2, e, u, L, r, value, n, tol)
        ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol)
        if ub2 - value <= tol:
            ub = ub2
        else:
            status = ENUMERATED
            ub = math.inf
    # E's witness s(n) and K's s(n) + value n: their midpoint, in world coordinates
    _, s = support(a2, n)
    half = 0.5 * value
    ce, Re, _ = E
    normal = matvec(Re, n)
    p = matvec(Re, (s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2]))
    return status, value, normal, (ce[0] + p[0], ce[1] + p[1], ce[2] + p[2]), ub
