"""Box x ellipsoid as a Warp function: a float64 port of core/pairs/box.py (its docstring has the method),
with the same proofs.

sigma(n) = n.e - h_E(n) - sum_j r_j |n.v_j| in E's principal frame, smooth on 26 pieces (8 vertex
octants, 12 edge quarter circles, 6 face normals), each solved globally by Eberly's secular equation
(pairs/point_ellipsoid.hpp; Schneider & Eberly 10.5.2).  An active-set local solve from the best face normal,
certified by the rolling-radius and weak-duality bounds, else a complete enumeration of the critical
points of the 26 pieces: both are proofs (status GLOBAL); a result that is not finite is UNPROVEN.

Reading of a pose: as kernels.py (the float32 rotations widened, used as given); the box's axes in E's
frame are the rows of R_K^T R_E, orthonormal only to ~1e-7 (float32), and the box is the parallelepiped
they span, the body sigma's support function describes.  Where box.py relies on orthonormal axes (a face's
normal taken as its axis, an edge's plane spanned by the other two, the point-box distance formula, a
face's inner ball), this port computes for the
parallelepiped (_face_normal, _edge_plane, _sd_point_box, _upper_bound2): on orthonormal axes the same numbers; on the
float32 ones the true maximum where box.py's stays up to ~1e-7 of the box's size below it, and the
certificates close (the bench's shallow pairs: 82 % went to the enumeration before).
"""

import warp as wp

from ..core.tolerances import PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
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
    unit,
)

F64 = wp.float64

SLACK = PAIR_SIGMA_SLACK_ULPS * U
GLOBAL, UNPROVEN, APART = 0, 1, 2  # kernels' pair statuses
#: An axis of the local solve's state with n.v_j = 0 imposed (else the sign +1 / -1 of n.v_j).
ACTIVE = 0
MAX_SWITCHES = 8  # box.MAX_SWITCHES


@wp.func
def sigma_box(a2: wp.vec3d, e: wp.vec3d, V: wp.mat33d, r: wp.vec3d, n: wp.vec3d) -> wp.float64:
    """sigma at the unit n (E's frame); V's rows the box's axes."""
    h = wp.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    return (
        n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - h
        - r[0] * wp.abs(wp.dot(n, V[0])) - r[1] * wp.abs(wp.dot(n, V[1])) - r[2] * wp.abs(wp.dot(n, V[2]))
    )  # fmt: skip


@wp.func
def _face_normal(V: wp.mat33d, i: int) -> wp.vec3d:
    """The outward unit normal of the box's face +v_i: v_j x v_k, turned to v_i's side.  box.py takes v_i
    itself, the same where the axes are orthonormal; on Warp's float32 rotations (orthonormal to ~1e-7)
    v_i misses the face point by that angle, and sigma by ~1e-7 of the box's size."""
    m = unit(wp.cross(V[(i + 1) % 3], V[(i + 2) % 3]))
    if wp.dot(m, V[i]) < F64(0.0):
        return -m
    return m


@wp.func
def _edge_plane(V: wp.mat33d, i: int):
    """An orthonormal basis (b1, b2) of the plane n.v_i = 0 (an edge along v_i: its smooth piece), b1 along
    v_j's part in it (j = i + 1): box.py takes (v_j, v_k), the same where the axes are orthonormal."""
    u = unit(V[i])
    vj = V[(i + 1) % 3]
    b1 = unit(vj - u * wp.dot(vj, u))
    return b1, wp.cross(u, b1)


@wp.func
def _solve_state(a2: wp.vec3d, e: wp.vec3d, V: wp.mat33d, r: wp.vec3d, st: wp.vec3i) -> wp.vec3d:
    """The maximiser of the smooth piece of the state st (box._solve_state)."""
    q0 = e[0]
    q1 = e[1]
    q2 = e[2]
    nact = 0
    for j in range(3):
        if st[j] == ACTIVE:
            nact = nact + 1
        else:
            sj = F64(st[j])
            q0 = q0 - sj * r[j] * V[j][0]
            q1 = q1 - sj * r[j] * V[j][1]
            q2 = q2 - sj * r[j] * V[j][2]
    q = wp.vec3d(q0, q1, q2)
    if nact == 0:
        _t, n = foot3(a2, q)
        return n
    if nact == 1:
        i = 2
        if st[0] == ACTIVE:
            i = 0
        elif st[1] == ACTIVE:
            i = 1
        b1, b2 = _edge_plane(V, i)
        n, _ub = circle_max_bound(a2, q, b1, b2)
        return n
    i = 2
    if st[0] != ACTIVE:
        i = 0
    elif st[1] != ACTIVE:
        i = 1
    return _face_normal(V, i) * F64(st[i])


@wp.func
def _kkt(stj: int, y: wp.vec3d, n: wp.vec3d, v: wp.vec3d, rj: wp.float64):
    """(new state of axis j, changed) (box._kkt)."""
    if stj == ACTIVE:
        yj = wp.dot(y, v)
        if wp.abs(yj) > rj:
            if yj > F64(0.0):
                return 1, True
            return -1, True
        return stj, False
    if wp.dot(n, v) * F64(stj) < F64(0.0):
        return ACTIVE, True
    return stj, False


@wp.func
def _local_max(a2: wp.vec3d, e: wp.vec3d, V: wp.mat33d, r: wp.vec3d) -> wp.vec3d:
    """The active-set iteration from the best face normal (box.local_max)."""
    best = F64(-1e300)
    st = wp.vec3i(ACTIVE, ACTIVE, 1)
    for i in range(3):
        for half in range(2):
            sg = 1
            if half == 1:
                sg = -1
            val = sigma_box(a2, e, V, r, _face_normal(V, i) * F64(sg))
            if val > best:
                best = val
                st = wp.vec3i(ACTIVE, ACTIVE, ACTIVE)
                st[i] = sg
    n = _solve_state(a2, e, V, r, st)
    for _ in range(MAX_SWITCHES):
        value = sigma_box(a2, e, V, r, n)
        _h, s = support(a2, n)
        y = wp.vec3d(e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])
        n0, c0 = _kkt(st[0], y, n, V[0], r[0])
        n1, c1 = _kkt(st[1], y, n, V[1], r[1])
        n2, c2 = _kkt(st[2], y, n, V[2], r[2])
        if not (c0 or c1 or c2) or (n0 == ACTIVE and n1 == ACTIVE and n2 == ACTIVE):
            return n
        st = wp.vec3i(n0, n1, n2)
        n = _solve_state(a2, e, V, r, st)
    return n


@wp.func
def _sd_point_box(w: wp.vec3d, V: wp.mat33d, r: wp.vec3d) -> wp.float64:
    """Signed distance of the point w to the box sigma reads, the parallelepiped {sum_j c_j v_j : |c_j| <= r_j}
    of the given axes (box.sd_point_box's formula where they are orthonormal, off by ~1e-7 of the box's
    size on Warp's float32 rotations): w's coordinates c in the axes (G^-1 V w by one correction step,
    G = V V^T, error O(defect^2)); outside, |w - x| for the box's point x = sum_j clamp(c_j) v_j (a point
    of the body: a bound whatever the rounding); inside, minus the distance to the nearest face plane,
    (r_j - |c_j|) times the cosine of v_j with that face's normal (_face_cosines)."""
    vw = V * w
    c = vw * F64(2.0) - (V * wp.transpose(V)) * vw
    d0 = wp.abs(c[0]) - r[0]
    d1 = wp.abs(c[1]) - r[1]
    d2 = wp.abs(c[2]) - r[2]
    if d0 <= F64(0.0) and d1 <= F64(0.0) and d2 <= F64(0.0):
        f = _face_cosines(V)
        return wp.max(d0 * f[0], wp.max(d1 * f[1], d2 * f[2]))
    x = (
        V[0] * wp.min(wp.max(c[0], -r[0]), r[0])
        + V[1] * wp.min(wp.max(c[1], -r[1]), r[1])
        + V[2] * wp.min(wp.max(c[2], -r[2]), r[2])
    )
    z = w - x
    return wp.sqrt(wp.dot(z, z))


@wp.func
def _face_cosines(V: wp.mat33d) -> wp.vec3d:
    """|v_j . face normal j| per axis (1 for orthonormal axes): the distance between face planes j is
    2 r_j times it."""
    return wp.vec3d(
        wp.abs(wp.dot(V[0], _face_normal(V, 0))),
        wp.abs(wp.dot(V[1], _face_normal(V, 1))),
        wp.abs(wp.dot(V[2], _face_normal(V, 2))),
    )


@wp.func
def _upper_bound2(a2: wp.vec3d, e: wp.vec3d, V: wp.mat33d, r: wp.vec3d, n: wp.vec3d, value: wp.float64) -> wp.float64:
    """ub2 (box.upper_bound2): the witness clamped into the box; a face contact's largest inner ball."""
    _h, s = support(a2, n)
    y = wp.vec3d(e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])
    c0 = wp.min(wp.max(wp.dot(y, V[0]), -r[0]), r[0])
    c1 = wp.min(wp.max(wp.dot(y, V[1]), -r[1]), r[1])
    c2 = wp.min(wp.max(wp.dot(y, V[2]), -r[2]), r[2])
    m0 = wp.abs(wp.dot(n, V[0]))
    m1 = wp.abs(wp.dot(n, V[1]))
    m2 = wp.abs(wp.dot(n, V[2]))
    t = F64(0.0)
    if m1 + m2 < F64(1e-12):
        t = wp.min(r[0], wp.min(r[1] - wp.abs(c1), r[2] - wp.abs(c2)))
        c0 = copysign(r[0] - t, wp.dot(n, V[0]))
    elif m0 + m2 < F64(1e-12):
        t = wp.min(r[1], wp.min(r[0] - wp.abs(c0), r[2] - wp.abs(c2)))
        c1 = copysign(r[1] - t, wp.dot(n, V[1]))
    elif m0 + m1 < F64(1e-12):
        t = wp.min(r[2], wp.min(r[0] - wp.abs(c0), r[1] - wp.abs(c1)))
        c2 = copysign(r[2] - t, wp.dot(n, V[2]))
    q = wp.vec3d(
        e[0] - c0 * V[0][0] - c1 * V[1][0] - c2 * V[2][0],
        e[1] - c0 * V[0][1] - c1 * V[1][1] - c2 * V[2][1],
        e[2] - c0 * V[0][2] - c1 * V[1][2] - c2 * V[2][2],
    )
    # the ball of radius t about the axis point c fits an orthonormal box; in the parallelepiped of Warp's
    # float32 axes, the one of radius t min_j |v_j . face normal j| does (its distance to each face plane)
    f = _face_cosines(V)
    tt, _m = foot3(a2, q)
    return sd_upper(a2, q, tt) - t * wp.min(f[0], wp.min(f[1], f[2]))


@wp.func
def _upper_bound(
    a2: wp.vec3d,
    e: wp.vec3d,
    V: wp.mat33d,
    r: wp.vec3d,
    rho: wp.float64,
    n: wp.vec3d,
    value: wp.float64,
    tol: wp.float64,
) -> wp.float64:
    """ub1 when it is within tol of value, else the smaller of ub1 and ub2 (box.upper_bound)."""
    _h, s = support(a2, n)
    w = wp.vec3d(e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    ub = _sd_point_box(w, V, r) - rho
    if ub - value <= tol:
        return ub
    return wp.min(ub, _upper_bound2(a2, e, V, r, n, value))


@wp.func
def _better(v: wp.float64, m: wp.vec3d, best: wp.float64, bn: wp.vec3d):
    if v > best:
        return v, m
    return best, bn


@wp.func
def _enumerate_max(
    a2: wp.vec3d, e: wp.vec3d, V: wp.mat33d, r: wp.vec3d, best0: wp.float64, bn0: wp.vec3d, tol: wp.float64
):
    """Branch and bound over the 26 smooth pieces from the incumbent (box.enumerate_max)."""
    best = best0
    bn = bn0
    for i in range(3):
        for half in range(2):
            sg = F64(1.0)
            if half == 1:
                sg = F64(-1.0)
            m = _face_normal(V, i) * sg
            best, bn = _better(sigma_box(a2, e, V, r, m), m, best, bn)
    for i in range(3):
        j = (i + 1) % 3
        k = (i + 2) % 3
        w1 = V[j]
        w2 = V[k]
        b1, b2 = _edge_plane(V, i)
        lam, mu, c, s = project_ellipse(a2, b1, b2)
        b3 = wp.vec3d(lam, mu, F64(2.0) * wp.max(lam, mu))
        for corner in range(4):
            sj = F64(1.0)
            sk = F64(1.0)
            if corner >= 2:
                sj = F64(-1.0)
            if corner % 2 == 1:
                sk = F64(-1.0)
            q = wp.vec3d(
                e[0] - sj * r[j] * w1[0] - sk * r[k] * w2[0],
                e[1] - sj * r[j] * w1[1] - sk * r[k] * w2[1],
                e[2] - sj * r[j] * w1[2] - sk * r[k] * w2[2],
            )
            p1 = wp.dot(q, b1)
            p2 = wp.dot(q, b2)
            p = wp.vec3d(c * p1 + s * p2, -s * p1 + c * p2, F64(0.0))
            t, m0, m1 = foot2(lam, mu, p[0], p[1])
            n = from_plane(m0, m1, c, s, b1, b2)
            if wp.dot(n, w1) * sj >= F64(0.0) and wp.dot(n, w2) * sk >= F64(0.0):
                best, bn = _better(sigma_box(a2, e, V, r, n), n, best, bn)
                continue
            if sd_upper2(lam, mu, p[0], p[1], t) <= best + tol:
                continue
            ok, roots = secular_roots(b3, p)
            for kk in range(3):
                if ok[kk] != 0:
                    mm = unit(wp.vec3d(p[0] / (roots[kk] + lam), p[1] / (roots[kk] + mu), F64(0.0)))
                    m = from_plane(mm[0], mm[1], c, s, b1, b2)
                    best, bn = _better(sigma_box(a2, e, V, r, m), m, best, bn)
            for ii in range(2):
                for half in range(2):
                    sign = F64(1.0)
                    if half == 1:
                        sign = F64(-1.0)
                    okp, mm = pole_normal(b3, p, ii, sign)
                    if okp:
                        m = from_plane(mm[0], mm[1], c, s, b1, b2)
                        best, bn = _better(sigma_box(a2, e, V, r, m), m, best, bn)
    for vertex in range(8):
        s0 = F64(1.0)
        s1 = F64(1.0)
        s2 = F64(1.0)
        if vertex >= 4:
            s0 = F64(-1.0)
        if (vertex // 2) % 2 == 1:
            s1 = F64(-1.0)
        if vertex % 2 == 1:
            s2 = F64(-1.0)
        q = wp.vec3d(
            e[0] - s0 * r[0] * V[0][0] - s1 * r[1] * V[1][0] - s2 * r[2] * V[2][0],
            e[1] - s0 * r[0] * V[0][1] - s1 * r[1] * V[1][1] - s2 * r[2] * V[2][1],
            e[2] - s0 * r[0] * V[0][2] - s1 * r[1] * V[1][2] - s2 * r[2] * V[2][2],
        )
        t, n = foot3(a2, q)
        if wp.dot(n, V[0]) * s0 >= F64(0.0) and wp.dot(n, V[1]) * s1 >= F64(0.0) and wp.dot(n, V[2]) * s2 >= F64(0.0):
            best, bn = _better(sigma_box(a2, e, V, r, n), n, best, bn)
            continue
        if sd_upper(a2, q, t) <= best + tol:
            continue
        ok, roots = secular_roots(a2, q)
        for kk in range(3):
            if ok[kk] != 0:
                m = root_normal(a2, q, roots[kk])
                best, bn = _better(sigma_box(a2, e, V, r, m), m, best, bn)
        for ii in range(3):
            for half in range(2):
                sign = F64(1.0)
                if half == 1:
                    sign = F64(-1.0)
                okp, m = pole_normal(a2, q, ii, sign)
                if okp:
                    best, bn = _better(sigma_box(a2, e, V, r, m), m, best, bn)
    return best, bn


@wp.func
def centre_line_bound(e: wp.vec3d, a2: wp.vec3d, V: wp.mat33d, ra: wp.vec3d, r: wp.vec3d) -> wp.float64:
    """A lower bound on the signed distance: sigma along the centre line less its rounding allowance
    (box.centre_line_bound); -1e300 for concentric bodies."""
    ee = wp.dot(e, e)
    if not (ee > F64(0.0)):
        return F64(-1e300)
    s = F64(1.0) / wp.sqrt(ee)
    scale = wp.sqrt(ee) + wp.max(wp.max(ra[0], wp.max(ra[1], ra[2])), wp.max(r[0], wp.max(r[1], r[2])))
    v = sigma_box(a2, e, V, r, wp.vec3d(e[0] * s, e[1] * s, e[2] * s))
    return v - F64(SLACK) * scale


@wp.func
def box_ellipsoid(
    ce: wp.vec3d, Re: wp.mat33d, ra: wp.vec3d, ck: wp.vec3d, Rk: wp.mat33d, r: wp.vec3d, cutoff: wp.float64
):
    """(status, dist, normal from the ellipsoid to the box, pos, enumerated) for the ellipsoid (ce, Re, ra)
    and the box (centre ck, rotation Rk, half-sizes r), world coordinates, float64 (box.box_ellipsoid);
    status APART when a direction proves the pair at least cutoff apart (as capsule.capsule_ellipsoid)."""
    ReT = wp.transpose(Re)
    e = ReT * (ck - ce)
    V = wp.transpose(Rk) * Re
    a2 = wp.cw_mul(ra, ra)
    low = centre_line_bound(e, a2, V, ra, r)
    if low >= cutoff:
        return APART, low, Re * unit(e), ce, 0
    n = _local_max(a2, e, V, r)
    value = sigma_box(a2, e, V, r, n)
    if value >= cutoff:
        return APART, value, Re * n, ce, 0
    rho = wp.min(ra[0], wp.min(ra[1], ra[2]))
    rho = rho * rho / wp.max(ra[0], wp.max(ra[1], ra[2]))
    tol = F64(PAIR_CERT_REL) * wp.min(wp.min(ra[0], wp.min(ra[1], ra[2])), wp.min(r[0], wp.min(r[1], r[2])))
    ub = _upper_bound(a2, e, V, r, rho, n, value, tol)
    enumerated = 0
    if ub - value > tol:
        value, n = _enumerate_max(a2, e, V, r, value, n, tol)
        enumerated = 1
    status = GLOBAL
    if not (wp.abs(value) < F64(1e300)):
        status = UNPROVEN
    _h, s = support(a2, n)
    half = F64(0.5) * value
    p = Re * wp.vec3d(s[0] + half * n[0], s[1] + half * n[1], s[2] + half * n[2])
    return status, value, Re * n, ce + p, enumerated
