"""Capsule x ellipsoid as a Warp function: a float64 port of core/pairs/capsule.py (its docstring has the
method), with the same proofs.

sigma(n) = n.e - h_E(n) - L |n.u| - r in E's principal frame, maximised over the smooth strata of the
capsule's support function (the side circle n.u = 0: a 2-D point-ellipse problem; each end point: a
point-ellipsoid problem; Eberly's secular equation, Schneider & Eberly 10.5.2), certified by the two
convex-duality bounds (rolling radius; the axis point's weak-duality bound), else a complete
enumeration of the critical points of the three pieces: both are proofs (status GLOBAL).  A result
that is not finite is the one case left unproven.

Reading of a pose: as kernels.py, the float32 rotation widened and used as given (E's frame is R_E^T,
the capsule's axis R_E^T times its rotation's third column).
"""

import warp as wp

from ..core.tolerances import PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
from .point_ellipsoid import (
    circle_max_bound,
    foot3,
    pole_normal,
    root_normal,
    sd_upper,
    secular_roots,
    support,
    tangent_basis,
    unit,
)

F64 = wp.float64

SLACK = PAIR_SIGMA_SLACK_ULPS * U
GLOBAL, UNPROVEN, APART = 0, 1, 2  # kernels' pair statuses


@wp.func
def sigma_capsule(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, n: wp.vec3d) -> wp.float64:
    """sigma at the unit n (E's frame)."""
    h = wp.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    return n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - h - L * wp.abs(n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) - r


@wp.func
def centre_line_bound(e: wp.vec3d, a2: wp.vec3d, u: wp.vec3d, ra: wp.vec3d, r: wp.float64, L: wp.float64):
    """A lower bound on the signed distance: sigma along the centre line less its rounding allowance
    (capsule.centre_line_bound); -1e300 for concentric bodies."""
    ee = wp.dot(e, e)
    if not (ee > F64(0.0)):
        return F64(-1e300)
    s = F64(1.0) / wp.sqrt(ee)
    scale = wp.sqrt(ee) + wp.max(wp.max(ra[0], wp.max(ra[1], ra[2])), wp.max(r, L))
    v = sigma_capsule(a2, e, u, L, r, wp.vec3d(e[0] * s, e[1] * s, e[2] * s))
    return v - F64(SLACK) * scale


@wp.func
def _local_max(a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64) -> wp.vec3d:
    """The local solve: the side stratum's maximiser when its segment parameter is admissible, else the
    foot normal of the end it points to (capsule.local_max)."""
    w1, w2 = tangent_basis(u)
    n, _ub = circle_max_bound(a2, e, w1, w2)
    _h, s = support(a2, n)
    t = wp.dot(s, u) - wp.dot(e, u)
    if wp.abs(t) <= L:
        return n
    sg = F64(-1.0)
    if t > F64(0.0):
        sg = F64(1.0)
    q = e + u * (sg * L)
    _t, m = foot3(a2, q)
    return m


@wp.func
def _upper_bound1(
    a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, rho: wp.float64, n: wp.vec3d
) -> wp.float64:
    _h, s = support(a2, n)
    w = wp.vec3d(e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    t = wp.min(wp.max(wp.dot(w, u), -L), L)
    z = wp.vec3d(w[0] - t * u[0], w[1] - t * u[1], w[2] - t * u[2])
    return wp.sqrt(wp.dot(z, z)) - r - rho


@wp.func
def _upper_bound2(
    a2: wp.vec3d, e: wp.vec3d, u: wp.vec3d, L: wp.float64, r: wp.float64, n: wp.vec3d, value: wp.float64
) -> wp.float64:
    _h, s = support(a2, n)
    k = value + r
    d = wp.vec3d(e[0] - s[0] - k * n[0], e[1] - s[1] - k * n[1], e[2] - s[2] - k * n[2])
    tc = wp.min(wp.max(wp.dot(d, u), -L), L)
    q = wp.vec3d(e[0] - tc * u[0], e[1] - tc * u[1], e[2] - tc * u[2])
    t2, _m = foot3(a2, q)
    return sd_upper(a2, q, t2) - r


@wp.func
def _upper_bound(
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
    """The first of ub1, ub2 within tol of value, else their minimum (capsule.upper_bound)."""
    ub = _upper_bound1(a2, e, u, L, r, rho, n)
    if ub - value <= tol:
        return ub
    return wp.min(ub, _upper_bound2(a2, e, u, L, r, n, value))


@wp.func
def _enumerate_max(
    a2: wp.vec3d,
    e: wp.vec3d,
    u: wp.vec3d,
    L: wp.float64,
    r: wp.float64,
    best0: wp.float64,
    bn0: wp.vec3d,
    tol: wp.float64,
):
    """Branch and bound over the three smooth pieces from the incumbent (capsule.enumerate_max)."""
    best = best0
    bn = bn0
    for side in range(2):
        sg = F64(1.0)
        if side == 1:
            sg = F64(-1.0)
        q = e + u * (sg * L)
        t, n = foot3(a2, q)
        if sd_upper(a2, q, t) - r <= best + tol:
            continue
        if sg * wp.dot(n, u) <= F64(0.0):  # the maximiser lies in this end's region
            v = sigma_capsule(a2, e, u, L, r, n)
            if v > best:
                best = v
                bn = n
            continue
        ok, roots = secular_roots(a2, q)
        for k in range(3):
            if ok[k] != 0:
                m = root_normal(a2, q, roots[k])
                v = sigma_capsule(a2, e, u, L, r, m)
                if v > best:
                    best = v
                    bn = m
        for i in range(3):
            for half in range(2):
                sign = F64(1.0)
                if half == 1:
                    sign = F64(-1.0)
                okp, m = pole_normal(a2, q, i, sign)
                if okp:
                    v = sigma_capsule(a2, e, u, L, r, m)
                    if v > best:
                        best = v
                        bn = m
    w1, w2 = tangent_basis(u)
    n, _ub = circle_max_bound(a2, e, w1, w2)
    v = sigma_capsule(a2, e, u, L, r, n)
    if v > best:
        best = v
        bn = n
    return best, bn


@wp.func
def capsule_ellipsoid(
    ce: wp.vec3d,
    Re: wp.mat33d,
    ra: wp.vec3d,
    ck: wp.vec3d,
    Rk: wp.mat33d,
    r: wp.float64,
    L: wp.float64,
    cutoff: wp.float64,
):
    """(status, dist, normal from the ellipsoid to the capsule, pos, enumerated) for the ellipsoid
    (ce, Re, ra) and the capsule (centre ck, rotation Rk, radius r, half-length L, axis its local z), world
    coordinates, float64 (capsule.capsule_ellipsoid).  status APART when a direction proves the pair at
    least cutoff apart (dist is then that lower bound, the maximum not sought); enumerated: 1 when the
    certificates did not close and every critical point was evaluated (a deep crossing)."""
    ReT = wp.transpose(Re)
    e = ReT * (ck - ce)
    u = ReT * wp.vec3d(Rk[0, 2], Rk[1, 2], Rk[2, 2])
    a2 = wp.cw_mul(ra, ra)
    low = centre_line_bound(e, a2, u, ra, r, L)
    if low >= cutoff:
        return APART, low, Re * unit(e), ce, 0
    rho = wp.min(ra[0], wp.min(ra[1], ra[2]))
    rho = rho * rho / wp.max(ra[0], wp.max(ra[1], ra[2]))
    n = _local_max(a2, e, u, L)
    value = sigma_capsule(a2, e, u, L, r, n)
    if value >= cutoff:
        return APART, value, Re * n, ce, 0
    tol = F64(PAIR_CERT_REL) * wp.min(wp.min(ra[0], wp.min(ra[1], ra[2])), r)
    ub = _upper_bound(a2, e, u, L, r, rho, n, value, tol)
    enumerated = 0
    if ub - value > tol:
        value, n = _enumerate_max(a2, e, u, L, r, value, n, tol)
        enumerated = 1
    status = GLOBAL
    if not (wp.abs(value) < F64(1e300)):  # (a nan fails the test too)
        status = UNPROVEN
    # the witness points and their midpoint (point_ellipsoid.contact_in_world)
    _h, s = support(a2, n)
    half = F64(0.5) * value
    p = Re * wp.vec3d(s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2])
    return status, value, Re * n, ce + p, enumerated
