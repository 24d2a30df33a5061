"""Exact first derivatives of the signed distance of an ellipsoid E and a capsule, box or cylinder K, of
its normal and of its contact point, on the feature of K that carries the contact (issue 24).

sigma(n) = n.d - h_E(n) - h_K(n), d = c_K - c_E (box.py, capsule.py, cylinder.py), is smooth except on
the kinks of h_K.  The maximiser n* lies on one stratum, where (Rockafellar & Wets, Variational Analysis,
10.C: a piecewise-smooth max is smooth on each stratum)

    h_K(n) = n.w + rho |n|_P   subject to   G n = 0   (G: k orthonormal rows, all orthogonal to n*)

    box    VERTEX  w = sum_j s_j r_j v_j                        k = 0
           EDGE    w = the sum over the two free axes            k = 1, G = (v_i)     (n* along no v_i)
           FACE    w = s_i r_i v_i                               k = 2, G = the other two axes
    capsule END    w = s L u, rho = r, P = I (the end's ball)    k = 0
           SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
    cylinder RIM   w = s L u, rho = r, P = I - u u^T            k = 0
           SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
           CAP     w = s L u, rho = 0                            k = 2, G = a basis of u^perp

(s: the sign of n*.v on the free axes; |n|_P = sqrt(n^T P n); on SIDE, r |P n| and r |n| agree to second
order on the stratum, so the simpler one.)  KKT on {|n| = 1, G n = 0}: grad sigma = sigma n + G^T mu.
Implicit function theorem on it: the part of dn along G's rows is -G^T (dG n); the rest, in the stratum's
tangent space T (2 - k dimensions), solves (T^T H T) a = -T^T (b + H dn_G), H = hess sigma - sigma I,
b = d grad sigma / d theta - dG^T mu.  The envelope theorem with the constraints' multipliers:
d dist / d theta = d sigma / d theta (n* held) - mu . (dG n*).  The contact point, pos = c_E + g_E(n*) +
dist n* / 2 (contact_in_world), follows by the chain rule.  Parameters, 18 columns (PARAMETERS): E's
centre, rotation vector and semi-axes, K's centre, rotation vector (both as derivatives.py: a turn about
the body's centre about a world axis) and MuJoCo's geom_size (box: half-sizes; capsule and cylinder:
radius, half-length, and a third column that is zero).

Status (status.DerivativeStatus):
* the subgradient of the kinks' terms bounds the multipliers (|mu_j| <= r_j on a box face or edge,
  |mu| <= L on a side, |mu| <= r on a cap: the contact point inside its face, side or cap); one within
  DERIV_KINK_REL S of its bound puts the contact where two features meet, and the derivatives given
  (the named feature's, held) are one-sided: ONE_SIDED;
* otherwise the feature stays active under a small change and, separated (the maximiser is then unique:
  E is strictly convex), these are the derivatives: SMOOTH; touching or penetrating, BRANCH (as
  derivatives.py: another maximiser could tie);
* a reduced Hessian not negative definite to DERIV_FLAT_REL S (a circle of maxima, as a spheroid
  coaxial with a cylinder has): FLAT, NaN; an unproven maximum (a cylinder's rim): UNPROVEN, NaN.
n* is first polished by Newton's method on the stratum, as derivatives.py does.
"""

import math
from typing import NamedTuple

import numpy as np

from .._jit import jit, stage
from ..distance.derivatives import (
    BRANCH,
    FLAT,
    SMOOTH,
    UNPROVEN,
    _cross,
    _dot,
    _hess,
    _support,
    _tangent,
    _write_nan,
)
from ..tolerances import (
    DERIV_FLAT_REL,
    DERIV_KINK_COS,
    DERIV_KINK_REL,
    DERIV_POLISH_SLACK_ULPS,
    DERIV_POLISH_STEPS,
    U,
)
from ..vec3 import column, load, matvec, norm2, scaled, unit_scale

#: the 18 columns, 3 each: (name, metres or radians)
PARAMETERS = ("center_e", "rotation_e", "radii_e", "center_k", "rotation_k", "size_k")

#: a fifth DerivativeStatus code (status.py): the feature held, at the edge of its normal cone
ONE_SIDED = 4

#: The feature of K that carries the contact (status.ContactFeature by name)
FACE, EDGE, VERTEX, SIDE, END, CAP, RIM = 0, 1, 2, 3, 4, 5, 6

#: the kernel's codes for K's type
CAPSULE, BOX, CYLINDER = 0, 1, 2

_Z = (0.0, 0.0, 0.0)


class ShapeDerivatives(NamedTuple):
    """shape_distance(..., derivatives=True)'s fifth result; columns as PARAMETERS, 3 each.

    dist : (n, 18) d dist / d parameter
    normal : (n, 3, 18) d normal / d parameter
    pos : (n, 3, 18) d contact point / d parameter
    status : (n,) int8, DerivativeStatus (SMOOTH, BRANCH, ONE_SIDED: defined; FLAT, UNPROVEN: NaN)
    feature : (n,) int8, ContactFeature: the feature of the other body that carries the contact
    """

    dist: np.ndarray
    normal: np.ndarray
    pos: np.ndarray
    status: np.ndarray
    feature: np.ndarray


@stage
def _unit(v):
    s = 1.0 / math.sqrt(norm2(v))
    return (v[0] * s, v[1] * s, v[2] * s)


@stage
def _axpy(a, x, y):
    return (a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2])


@stage
def _pnorm(n, pt, u):
    """(|n|_P, P n) for P = I (pt 1) or I - u u^T (pt 2); (1, 0) for no such term (pt 0)."""
    if pt == 1:
        return math.sqrt(norm2(n)), n
    if pt == 2:
        c = _dot(n, u)
        p = (n[0] - c * u[0], n[1] - c * u[1], n[2] - c * u[2])
        return math.sqrt(norm2(p)), p
    return 1.0, _Z


@stage
def _stratum(kind, n, V, sk):
    """(feature, k, rows g0, g1, w, rho, pt, axis u, bound0, bound1) of the stratum holding the
    unit n (module docstring), in the units of V and sk; bound_i: the bound of the i-th row's multiplier."""
    if kind == BOX:
        c = (_dot(n, V[0]), _dot(n, V[1]), _dot(n, V[2]))
        a0, a1, a2 = abs(c[0]) <= DERIV_KINK_COS, abs(c[1]) <= DERIV_KINK_COS, abs(c[2]) <= DERIV_KINK_COS
        k = int(a0) + int(a1) + int(a2)
        w = _Z
        for j in range(3):
            if abs(c[j]) > DERIV_KINK_COS:
                w = _axpy(math.copysign(sk[j], c[j]), V[j], w)
        if k == 0:
            return VERTEX, 0, _Z, _Z, w, 0.0, 0, _Z, 0.0, 0.0
        if k == 1:
            i = 0 if a0 else (1 if a1 else 2)
            return EDGE, 1, V[i], _Z, w, 0.0, 0, _Z, sk[i], 0.0
        i = 0 if not a0 else (1 if not a1 else 2)  # the free axis (k = 3 cannot hold for a unit n)
        j0, j1 = (i + 1) % 3, (i + 2) % 3
        return FACE, 2, V[j0], V[j1], w, 0.0, 0, _Z, sk[j0], sk[j1]
    r, L, u = sk[0], sk[1], V[2]
    c = _dot(n, u)
    w = (math.copysign(L, c) * u[0], math.copysign(L, c) * u[1], math.copysign(L, c) * u[2])
    if abs(c) <= DERIV_KINK_COS:
        return SIDE, 1, u, _Z, _Z, r, 1, u, L, 0.0
    if kind == CAPSULE:
        return END, 0, _Z, _Z, w, r, 1, u, 0.0, 0.0
    if math.sqrt(norm2(_cross(n, u))) <= DERIV_KINK_COS:
        t1, t2 = _tangent(u)
        return CAP, 2, t1, t2, w, 0.0, 0, u, r, r
    return RIM, 0, _Z, _Z, w, r, 2, u, 0.0, 0.0


@stage
def _entry(Jab, dab, ua, ub, Qa, Qb, rp, al, qq, s):
    """One entry of H = -J - rho hess|n|_P - sigma I (_local)."""
    return -Jab - rp * (dab - al * ua * ub - Qa * Qb * qq) - s * dab


@stage
def _local(n, dw, Re, re, rho, pt, u, g0, k):
    """sigma, grad sigma, E's (h, g, z, J), H = hess sigma - sigma I (row-major 9), the stratum's tangent
    basis (t1, t2: zero beyond its 2 - k dimensions) and the reduced Hessian (h11, h12, h22), at unit n."""
    h, g, z = _support(Re, re, n)
    J = _hess(Re, re, g, h)
    npn, Pn = _pnorm(n, pt, u)
    s = _dot(n, dw) - h - rho * npn
    rp = rho / npn
    grad = (dw[0] - g[0] - rp * Pn[0], dw[1] - g[1] - rp * Pn[1], dw[2] - g[2] - rp * Pn[2])
    # hess (rho |n|_P) = rho (P - P n n^T P / |n|_P^2) / |n|_P: P = I - al u u^T, P n = Q
    al, Q = (1.0, Pn) if pt == 2 else (0.0, n)
    qq = 1.0 / (npn * npn)
    Ht = (
        _entry(J[0], 1.0, u[0], u[0], Q[0], Q[0], rp, al, qq, s),
        _entry(J[1], 0.0, u[0], u[1], Q[0], Q[1], rp, al, qq, s),
        _entry(J[2], 0.0, u[0], u[2], Q[0], Q[2], rp, al, qq, s),
        _entry(J[3], 0.0, u[1], u[0], Q[1], Q[0], rp, al, qq, s),
        _entry(J[4], 1.0, u[1], u[1], Q[1], Q[1], rp, al, qq, s),
        _entry(J[5], 0.0, u[1], u[2], Q[1], Q[2], rp, al, qq, s),
        _entry(J[6], 0.0, u[2], u[0], Q[2], Q[0], rp, al, qq, s),
        _entry(J[7], 0.0, u[2], u[1], Q[2], Q[1], rp, al, qq, s),
        _entry(J[8], 1.0, u[2], u[2], Q[2], Q[2], rp, al, qq, s),
    )
    if k == 0:
        t1, t2 = _tangent(n)
    elif k == 1:
        t1, t2 = _unit(_cross(n, g0)), _Z
    else:
        t1, t2 = _Z, _Z
    Ht1, Ht2 = matvec(Ht, t1), matvec(Ht, t2)
    return s, grad, h, g, z, J, Ht, t1, t2, (_dot(t1, Ht1), _dot(t1, Ht2), _dot(t2, Ht2))


@stage
def _top(R, k):
    """The larger eigenvalue of the reduced Hessian (-inf when the stratum is a point)."""
    if k == 0:
        m, q = 0.5 * (R[0] + R[2]), 0.5 * (R[0] - R[2])
        return m + math.sqrt(q * q + R[1] * R[1])
    if k == 1:
        return R[0]
    return -math.inf


@stage
def _reduced_solve(R, k, r1, r2):
    """-(T^T H T)^-1 (r1, r2) in the stratum's tangent coordinates."""
    if k == 0:
        det = R[0] * R[2] - R[1] * R[1]
        return -(R[2] * r1 - R[1] * r2) / det, -(R[0] * r2 - R[1] * r1) / det
    if k == 1:
        return -r1 / R[0], 0.0
    return 0.0, 0.0


@stage
def _pair(E, K, kind, normal, proven, grad, jn, jp, feature, i):
    """The derivatives of pair i at its maximiser `normal` (world, unit) into grad[i], jn[i], jp[i], and its
    feature into feature[i]; returns the DerivativeStatus."""
    (ce, Re, re), (ck, Rk, sk) = E, K
    if kind != BOX:  # (a capsule's or cylinder's third size is not theirs: it must not scale anything)
        sk = (sk[0], sk[1], 0.0)
    sc = unit_scale(re, sk)  # a power of two (exact), as derivatives.py
    re, sk = scaled(re, sc), scaled(sk, sc)
    d = ((ck[0] - ce[0]) * sc, (ck[1] - ce[1]) * sc, (ck[2] - ce[2]) * sc)
    V = (column(Rk, 0), column(Rk, 1), column(Rk, 2))
    if kind != BOX:
        V = (V[0], V[1], _unit(V[2]))
    n = normal
    f, k, g0, g1, w, rho, pt, u, bound0, bound1 = _stratum(kind, n, V, sk)
    feature[i] = f
    if not proven:
        _write_nan(grad, jn, jp, i)
        return UNPROVEN
    if k == 2:  # a face or cap: n* is the feature's normal itself
        n = _unit(_cross(g0, g1))
        if _dot(n, normal) < 0.0:
            n = (-n[0], -n[1], -n[2])
    elif k == 1:  # an edge or side: onto its great circle (the narrow phase leaves n*.v at ~1e-11 there)
        c = _dot(n, g0)
        n = _unit((n[0] - c * g0[0], n[1] - c * g0[1], n[2] - c * g0[2]))
    S = math.sqrt(norm2(d)) + max(re[0], re[1], re[2]) + max(sk[0], sk[1], sk[2])
    dw = (d[0] - w[0], d[1] - w[1], d[2] - w[2])
    s, gs, h, g, z, J, H, t1, t2, R = _local(n, dw, Re, re, rho, pt, u, g0, k)
    for _ in range(DERIV_POLISH_STEPS if k < 2 else 0):  # Newton on the stratum
        if not _top(R, k) < -DERIV_FLAT_REL * S:
            break
        a1, a2 = _reduced_solve(R, k, _dot(t1, gs), _dot(t2, gs))
        m = _unit((n[0] + a1 * t1[0] + a2 * t2[0], n[1] + a1 * t1[1] + a2 * t2[1], n[2] + a1 * t1[2] + a2 * t2[2]))
        local = _local(m, dw, Re, re, rho, pt, u, g0, k)
        if local[0] < s - DERIV_POLISH_SLACK_ULPS * U * S:
            break
        n = m
        s, gs, h, g, z, J, H, t1, t2, R = local
        if a1 * a1 + a2 * a2 < 1e-32:
            break
    if not _top(R, k) < -DERIV_FLAT_REL * S:
        _write_nan(grad, jn, jp, i)
        return FLAT
    mu0, mu1 = _dot(g0, gs), _dot(g1, gs)  # grad sigma = sigma n + G^T mu
    status = SMOOTH if s > 0.0 else BRANCH
    slack = DERIV_KINK_REL * S
    if k == 2 and f == CAP:
        if math.sqrt(mu0 * mu0 + mu1 * mu1) >= bound0 - slack:
            status = ONE_SIDED
    elif (k >= 1 and abs(mu0) >= bound0 - slack) or (k == 2 and abs(mu1) >= bound1 - slack):
        status = ONE_SIDED
    npn, Pn = _pnorm(n, pt, u)
    iu = 1.0 / sc
    for j in range(18):
        body, kd, axis = j // 9, (j % 9) // 3, j % 3
        e = (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0, 1.0 if axis == 2 else 0.0)
        # dv: d sigma (n held); b: d grad sigma - dG^T mu; q: pos's explicit part; dg0, dg1: (dG n)_i
        dv, b, q, dg0, dg1 = 0.0, _Z, _Z, 0.0, 0.0
        cols = (1.0, sc, 1.0)
        if body == 0 and kd == 0:  # E's centre: d -= e
            dv, b, q = -n[axis], (-e[0], -e[1], -e[2]), e
        elif body == 0 and kd == 1:  # E's rotation: dh = -(n x g).e, dg = e x g - J (e x n)
            dv = _cross(n, g)[axis]
            Jn = matvec(J, _cross(e, n))
            exg = _cross(e, g)
            q = (exg[0] - Jn[0], exg[1] - Jn[1], exg[2] - Jn[2])
            b = (-q[0], -q[1], -q[2])
            cols = (iu, 1.0, iu)
        elif body == 0:  # E's semi-axis: as derivatives.py
            rk, zk = re[axis], z[axis]
            dv = -rk * zk * zk / h
            c = (Re[axis], Re[3 + axis], Re[6 + axis])
            t = rk * zk * zk / h
            q = ((2.0 * rk * zk * c[0] - g[0] * t) / h, (2.0 * rk * zk * c[1] - g[1] * t) / h,
                 (2.0 * rk * zk * c[2] - g[2] * t) / h)  # fmt: skip
            b = (-q[0], -q[1], -q[2])
        elif kd == 0:  # K's centre: d += e
            dv, b = n[axis], e
        elif kd == 1:  # K's rotation about its centre: w, the rows, u turn by e x .
            dwk = _cross(e, w)
            dv = -_dot(n, dwk)
            b = (-dwk[0], -dwk[1], -dwk[2])
            if pt == 2:  # d (rho |n|_P) with dP = -(du u^T + u du^T)
                du = _cross(e, u)
                cu, cd = _dot(u, n), _dot(du, n)
                dnpn = -cd * cu / npn  # n^T dP n / (2 |n|_P)
                dv -= rho * dnpn
                dPn = (-(du[0] * cu + u[0] * cd), -(du[1] * cu + u[1] * cd), -(du[2] * cu + u[2] * cd))
                b = (b[0] - rho * (dPn[0] - Pn[0] * dnpn / npn) / npn,
                     b[1] - rho * (dPn[1] - Pn[1] * dnpn / npn) / npn,
                     b[2] - rho * (dPn[2] - Pn[2] * dnpn / npn) / npn)  # fmt: skip
            if k >= 1:
                dr0 = _cross(e, g0)
                dg0 = _dot(dr0, n)
                b = _axpy(-mu0, dr0, b)
            if k == 2:
                dr1 = _cross(e, g1)
                dg1 = _dot(dr1, n)
                b = _axpy(-mu1, dr1, b)
            cols = (iu, 1.0, iu)
        elif kind == BOX:  # a half-size: w moves along a free axis
            cj = _dot(n, V[axis])
            if abs(cj) > DERIV_KINK_COS:
                sg = math.copysign(1.0, cj)
                dv, b = -abs(cj), (-sg * V[axis][0], -sg * V[axis][1], -sg * V[axis][2])
        elif axis == 0 and f != CAP:  # a radius: d rho
            dv, b = -npn, (-Pn[0] / npn, -Pn[1] / npn, -Pn[2] / npn)
        elif axis == 1 and f != SIDE:  # a half-length: w = s L u
            cu = _dot(n, u)
            sg = math.copysign(1.0, cu)
            dv, b = -abs(cu), (-sg * u[0], -sg * u[1], -sg * u[2])
        dd = dv - mu0 * dg0 - mu1 * dg1
        # dn: -G^T (dG n) along the rows, the reduced solve in the tangent space
        dnG = (-(dg0 * g0[0] + dg1 * g1[0]), -(dg0 * g0[1] + dg1 * g1[1]), -(dg0 * g0[2] + dg1 * g1[2]))
        Hg = matvec(H, dnG)
        r = (b[0] + Hg[0], b[1] + Hg[1], b[2] + Hg[2])
        a1, a2 = _reduced_solve(R, k, _dot(t1, r), _dot(t2, r))
        dn = (dnG[0] + a1 * t1[0] + a2 * t2[0], dnG[1] + a1 * t1[1] + a2 * t2[1], dnG[2] + a1 * t1[2] + a2 * t2[2])
        Jdn = matvec(J, dn)
        grad[i, j] = dd * cols[0]
        for m in range(3):
            jn[i, m, j] = dn[m] * cols[1]
            jp[i, m, j] = (q[m] + Jdn[m] + 0.5 * (dd * n[m] + s * dn[m])) * cols[2]
    return status


@jit
def shape_derivatives(Ce, Re, re, Ck, Rk, sk, kind, normal, proven, grad, jn, jp, status, feature, lo, hi):
    """The derivatives of pairs lo..hi (E batch, K batch of kind `kind`; a batch of one broadcasts) at the
    narrow phase's normals, into grad, jn, jp, status and feature."""
    sa, sb = int(Ce.shape[0] > 1), int(Ck.shape[0] > 1)
    for i in range(lo, hi):
        n = (normal[i, 0], normal[i, 1], normal[i, 2])
        E, K = load(Ce, Re, re, i * sa), load(Ck, Rk, sk, i * sb)
        status[i] = _pair(E, K, kind, n, proven[i], grad, jn, jp, feature, i)
