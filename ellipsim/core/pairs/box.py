"""Signed distance of an ellipsoid and a box with a proven global maximum (MuJoCo's ellipsoid x box
narrow phase).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), split into the smooth
strata of the box's support function, each solved globally by Eberly's secular equation
(point_ellipsoid.py; Eberly, "Distance from a point to an ellipse, an ellipsoid, or a
hyperellipsoid", sec. 2-3; GTCG 10.5.2), certified by two convex-duality bounds or by enumerating
every critical point.  Same contract and conventions as capsule.py.

The box K = sum_j r_j [-1, 1] v_j centred at e (v_j its axes in E's principal frame; orthonormal to
rounding from MuJoCo C's float64 rotations, only to ~1e-7 from MuJoCo Warp's float32 ones: K is then the
parallelepiped they span, and face_normal, edge_plane, sd_point_box and upper_bound2 compute for it), so
h_K(n) = sum_j r_j |n.v_j| and sigma is smooth except on the three great circles n.v_j = 0.  Its
strata: the 8 open octants (vertex contacts: sigma = f_q(n) = n.q - h_E(n), q = e minus the box
vertex facing E), the 12 open quarter circles (edge contacts: the 2-D point-ellipse problem in the
plane of the other two axes, q = e minus the edge's midpoint) and the 6 face normals (face contacts).

Local solve (an active set): per box axis, either n.v_j = 0 is imposed (the contact feature extends
along v_j) or the sign of n.v_j is fixed; each state's piece is solved globally (foot3, the projected
ellipse's foot2, or a face normal).  KKT at the result: a free axis whose sign flipped becomes active;
an active axis whose witness coordinate y_j = (e - s_E(n) - sigma n).v_j leaves [-r_j, r_j] is freed
with the sign of y_j.  It starts at the best face normal, so a flush face (the usual resting contact)
costs one support evaluation per face.

Certificates (global upper bounds on max sigma, any unit n; concavity of h on R^3):
* ub1 = sd(e - s_E(n) + rho n, K) - rho, rho the rolling radius of E (E = E' + ball(rho)): the exact
  point-box signed distance.  Tight when separated or shallow.
* ub2 = sd(e - c, E) - t for a ball(c, t) inside K, c the witness clamped into K (t > 0 only for a
  face contact: the largest ball in K tangent to that face at c), sd bounded above by weak duality.
When neither closes (deep crossings), a branch and bound over the 26 pieces (enumerate_max): a piece
whose extended smooth function's certified maximum does not beat the incumbent is skipped, one whose
maximiser lies inside it is taken whole, the others have every critical point evaluated: a complete
case analysis, status ENUMERATED.  Before that, a negative incumbent lets whole closed octants (a vertex
piece with its three edges and corners) and edge arcs be skipped by tangent planes of h_E
(tangent_cones.py): three dot products a node.

Ported from the validated pair-type prototype (10 000 poses: never below a 20 000-direction reference
by more than 1e-12 of the smaller shortest half-size; every maximum certified or enumerated).
"""

import math

from .._jit import jit, stage
from ..distance.sphere_newton import rolling_radius, unit
from ..tolerances import PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
from ..vec3 import column, cross3, norm2, rotate_t
from .point_ellipsoid import (
    circle_max_bound,
    contact_in_world,
    foot2,
    foot3,
    from_plane,
    pole_normal,
    project_ellipse,
    sd_upper,
    sd_upper2,
    secular_roots,
    support,
)
from .tangent_cones import arc_below, cone_below, tangent_point

#: How box_ellipsoid proved its maximum (as capsule.py): CERTIFIED or ENUMERATED, both proofs.
CERTIFIED, ENUMERATED = 0, 1
#: state value of an axis in the local solve: n.v_j = 0 imposed (else the sign +1 / -1 of n.v_j)
ACTIVE = 0
#: active-set switches of the local solve before it hands over to the certificates / enumeration
MAX_SWITCHES = 8
#: the tangent-plane tests' disc axis: none (r = 0, a box has no disc part)
NO_AXIS = (0.0, 0.0, 1.0)


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def to_frame(E, K):
    """(e, a2, V): K's centre in E's principal frame, E's squared semi-axes, K's axes (its local x, y,
    z) in E's frame.  E, K as (centre (3,), rotation row-major (9,), sizes (3,)) tuples, K's sizes its
    half-sizes as in MuJoCo's geom_size."""
    (ce, Re, ra), (ck, Rk, _) = E, K
    e = rotate_t(Re, (ck[0] - ce[0], ck[1] - ce[1], ck[2] - ce[2]))
    V = (rotate_t(Re, column(Rk, 0)), rotate_t(Re, column(Rk, 1)), rotate_t(Re, column(Rk, 2)))
    return e, (ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]), V


@stage
def sigma_box(a2, e, V, r, n):
    """sigma at the unit n (E's frame)."""
    h = math.sqrt(a2[0] * n[0] * n[0] + a2[1] * n[1] * n[1] + a2[2] * n[2] * n[2])
    return (
        n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - h
        - r[0] * abs(_dot(n, V[0])) - r[1] * abs(_dot(n, V[1])) - r[2] * abs(_dot(n, V[2]))
    )  # fmt: skip


@stage
def centre_line_bound(E, K):
    """A lower bound on the signed distance: sigma along the centre line minus its rounding allowance
    (PAIR_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies."""
    e, a2, V = to_frame(E, K)
    ee = norm2(e)
    if not ee > 0.0:
        return -math.inf
    s = 1.0 / math.sqrt(ee)
    ra, rk = E[2], K[2]
    scale = math.sqrt(ee) + max(ra[0], ra[1], ra[2], rk[0], rk[1], rk[2])
    v = sigma_box(a2, e, V, rk, (e[0] * s, e[1] * s, e[2] * s))
    return v - PAIR_SIGMA_SLACK_ULPS * U * scale


@stage
def face_normal(V, i):
    """The outward unit normal of the face +v_i: v_j x v_k turned to v_i's side (v_i itself for orthonormal
    axes; for axes orthonormal only to ~1e-7, as float32 rotations give, v_i misses the face's point of
    the sphere by that angle, and sigma by ~1e-7 of the box's size)."""
    m = unit(cross3(V[(i + 1) % 3], V[(i + 2) % 3]))
    if _dot(m, V[i]) < 0.0:
        return (-m[0], -m[1], -m[2])
    return m


@stage
def edge_plane(V, i):
    """An orthonormal basis (b1, b2) of the plane n.v_i = 0 (the smooth piece of an edge along v_i), b1
    along v_j's part in it (j = i + 1): (v_j, v_k) for orthonormal axes."""
    u = unit(V[i])
    vj = V[(i + 1) % 3]
    d = _dot(vj, u)
    b1 = unit((vj[0] - d * u[0], vj[1] - d * u[1], vj[2] - d * u[2]))
    return b1, cross3(u, b1)


@stage
def face_cosines(V):
    """|v_j . face normal j| per axis (1 for orthonormal axes): face planes j lie 2 r_j times it apart."""
    return (abs(_dot(V[0], face_normal(V, 0))), abs(_dot(V[1], face_normal(V, 1))), abs(_dot(V[2], face_normal(V, 2))))


@stage
def _solve_state(a2, e, V, r, st):
    """The maximiser of the smooth piece of the state st (3-tuple of ACTIVE / +1 / -1)."""
    q0, q1, q2 = e
    nact = 0
    for j in range(3):
        if st[j] == ACTIVE:
            nact += 1
        else:
            q0 -= st[j] * r[j] * V[j][0]
            q1 -= st[j] * r[j] * V[j][1]
            q2 -= st[j] * r[j] * V[j][2]
    q = (q0, q1, q2)
    if nact == 0:
        _, n = foot3(a2, q)
        return n
    if nact == 1:
        i = 0 if st[0] == ACTIVE else (1 if st[1] == ACTIVE else 2)
        b1, b2 = edge_plane(V, i)
        n, _ = circle_max_bound(a2, q, b1, b2)
        return n
    i = 0 if st[0] != ACTIVE else (1 if st[1] != ACTIVE else 2)
    v = face_normal(V, i)
    sg = float(st[i])
    return (sg * v[0], sg * v[1], sg * v[2])


@stage
def _kkt(stj, y, n, v, rj):
    """(new state of axis j, changed): an active axis whose witness coordinate leaves [-r_j, r_j] is
    freed with its sign; a free axis whose sign flipped becomes active."""
    if stj == ACTIVE:
        yj = _dot(y, v)
        if abs(yj) > rj:
            return (1 if yj > 0.0 else -1), True
        return stj, False
    if _dot(n, v) * stj < 0.0:
        return ACTIVE, True
    return stj, False


@stage
def local_max(a2, e, V, r):
    """The unit n of the active-set iteration from the best face normal (module docstring)."""
    best, st = -math.inf, (ACTIVE, ACTIVE, 1)
    for i in range(3):
        for sg in (1, -1):
            v = face_normal(V, i)
            val = sigma_box(a2, e, V, r, (sg * v[0], sg * v[1], sg * v[2]))
            if val > best:
                best = val
                st = (sg if i == 0 else ACTIVE, sg if i == 1 else ACTIVE, sg if i == 2 else ACTIVE)
    n = _solve_state(a2, e, V, r, st)
    for _ in range(MAX_SWITCHES):
        value = sigma_box(a2, e, V, r, n)
        _, s = support(a2, n)
        y = (e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])
        n0, c0 = _kkt(st[0], y, n, V[0], r[0])
        n1, c1 = _kkt(st[1], y, n, V[1], r[1])
        n2, c2 = _kkt(st[2], y, n, V[2], r[2])
        if not (c0 or c1 or c2) or (n0 == ACTIVE and n1 == ACTIVE and n2 == ACTIVE):
            return n
        st = (n0, n1, n2)
        n = _solve_state(a2, e, V, r, st)
    return n


@stage
def sd_point_box(w, V, r):
    """Signed distance of the point w to the box {sum_j c_j v_j : |c_j| <= r_j}, for axes orthonormal to
    rounding or only to ~1e-7 (float32 rotations, where the formula |w.v_j| - r_j is off by that much of
    the box's size): w's coordinates c = G^-1 V w by one correction step (G = V V^T, error O(defect^2));
    outside, |w - x| for the box's point x = sum_j clamp(c_j) v_j (a point of the body: a bound whatever
    the rounding); inside, minus the distance to the nearest face plane, (r_j - |c_j|) face_cosines_j."""
    v0, v1, v2 = _dot(w, V[0]), _dot(w, V[1]), _dot(w, V[2])
    g01, g02, g12 = _dot(V[0], V[1]), _dot(V[0], V[2]), _dot(V[1], V[2])
    g00, g11, g22 = _dot(V[0], V[0]), _dot(V[1], V[1]), _dot(V[2], V[2])
    c0 = 2.0 * v0 - (g00 * v0 + g01 * v1 + g02 * v2)
    c1 = 2.0 * v1 - (g01 * v0 + g11 * v1 + g12 * v2)
    c2 = 2.0 * v2 - (g02 * v0 + g12 * v1 + g22 * v2)
    d0, d1, d2 = abs(c0) - r[0], abs(c1) - r[1], abs(c2) - r[2]
    if d0 <= 0.0 and d1 <= 0.0 and d2 <= 0.0:
        f = face_cosines(V)
        return max(d0 * f[0], d1 * f[1], d2 * f[2])
    k0, k1, k2 = min(max(c0, -r[0]), r[0]), min(max(c1, -r[1]), r[1]), min(max(c2, -r[2]), r[2])
    z0 = w[0] - (k0 * V[0][0] + k1 * V[1][0] + k2 * V[2][0])
    z1 = w[1] - (k0 * V[0][1] + k1 * V[1][1] + k2 * V[2][1])
    z2 = w[2] - (k0 * V[0][2] + k1 * V[1][2] + k2 * V[2][2])
    return math.sqrt(z0 * z0 + z1 * z1 + z2 * z2)


@stage
def upper_bound1(a2, e, V, r, rho, n):
    """ub1 of the module docstring at the unit n."""
    _, s = support(a2, n)
    w = (e[0] - s[0] + rho * n[0], e[1] - s[1] + rho * n[1], e[2] - s[2] + rho * n[2])
    return sd_point_box(w, V, r) - rho


@stage
def upper_bound2(a2, e, V, r, n, value):
    """ub2 of the module docstring: the witness e - s - value n clamped into the box; for a face
    contact the largest ball inside the box tangent to that face there."""
    _, s = support(a2, n)
    y = (e[0] - s[0] - value * n[0], e[1] - s[1] - value * n[1], e[2] - s[2] - value * n[2])
    c0 = min(max(_dot(y, V[0]), -r[0]), r[0])
    c1 = min(max(_dot(y, V[1]), -r[1]), r[1])
    c2 = min(max(_dot(y, V[2]), -r[2]), r[2])
    m0, m1, m2 = abs(_dot(n, V[0])), abs(_dot(n, V[1])), abs(_dot(n, V[2]))
    t = 0.0
    if m1 + m2 < 1e-12:  # a face contact: n along one axis, the others within rounding of zero
        t = min(r[0], r[1] - abs(c1), r[2] - abs(c2))
        c0 = math.copysign(r[0] - t, _dot(n, V[0]))
    elif m0 + m2 < 1e-12:
        t = min(r[1], r[0] - abs(c0), r[2] - abs(c2))
        c1 = math.copysign(r[1] - t, _dot(n, V[1]))
    elif m0 + m1 < 1e-12:
        t = min(r[2], r[0] - abs(c0), r[1] - abs(c1))
        c2 = math.copysign(r[2] - t, _dot(n, V[2]))
    q = (
        e[0] - c0 * V[0][0] - c1 * V[1][0] - c2 * V[2][0],
        e[1] - c0 * V[0][1] - c1 * V[1][1] - c2 * V[2][1],
        e[2] - c0 * V[0][2] - c1 * V[1][2] - c2 * V[2][2],
    )
    # the ball of radius t about c fits an orthonormal box; the one of radius t min_j face_cosines_j fits the
    # parallelepiped of axes orthonormal only to ~1e-7 (its distance to each face plane)
    f = face_cosines(V)
    tt, _ = foot3(a2, q)
    return sd_upper(a2, q, tt) - t * min(f[0], f[1], f[2])


@stage
def upper_bound(a2, e, V, r, rho, n, value, tol):
    """ub1 when it is within tol of value, else the smaller of ub1 and ub2."""
    ub = upper_bound1(a2, e, V, r, rho, n)
    if ub - value <= tol:
        return ub
    return min(ub, upper_bound2(a2, e, V, r, n, value))


@stage
def _vertex_q(e, V, r, s0, s1, s2):
    """e minus the box vertex sum_j s_j r_j v_j."""
    return (
        e[0] - s0 * r[0] * V[0][0] - s1 * r[1] * V[1][0] - s2 * r[2] * V[2][0],
        e[1] - s0 * r[0] * V[0][1] - s1 * r[1] * V[1][1] - s2 * r[2] * V[2][1],
        e[2] - s0 * r[0] * V[0][2] - s1 * r[1] * V[1][2] - s2 * r[2] * V[2][2],
    )


@stage
def _below_slack(q, a2, best):
    """The rounding allowance of the tangent tests: the support point and the node corners are off by
    ulps, sigma by that times its Lipschitz bound |q| + max a."""
    return PAIR_SIGMA_SLACK_ULPS * U * (math.sqrt(_dot(q, q)) + math.sqrt(max(a2[0], a2[1], a2[2])) + abs(best))


@stage
def _consider(a2, e, V, r, n, best, bn):
    v = sigma_box(a2, e, V, r, n)
    if v > best:
        return v, n
    return best, bn


@jit
def enumerate_max(a2, e, V, r, best, bn, tol):
    """Branch and bound over the 26 smooth pieces from the incumbent (best, bn): faces are points; a
    closed octant (bit 4 (s0 < 0) + 2 (s1 < 0) + (s2 < 0) of `done`) whose tangent planes prove f_q below
    the incumbent is skipped with its edges and corners, an edge arc likewise (module docstring); for
    the other edge or vertex pieces, the global maximiser of the extended smooth function is the piece's
    maximum when it lies in the piece; otherwise the piece is skipped when the certified bound on that
    global maximum (weak duality) does not beat the incumbent by tol, else its interior local maxima are
    the candidates (secular_roots, pole_normal) -- its boundary is made of the other pieces.  An edge's
    2-D problem runs through the 3-D enumeration with a third axis longer than both (a2 = (lam, mu,
    2 max), q_3 = 0): its term vanishes and the kept roots are the 2-D ones.  Returns (value, n)."""
    for i in range(3):
        for sg in (1.0, -1.0):
            v = face_normal(V, i)
            best, bn = _consider(a2, e, V, r, (sg * v[0], sg * v[1], sg * v[2]), best, bn)
    xb = tangent_point(a2, NO_AXIS, 0.0, bn)
    f = (face_normal(V, 0), face_normal(V, 1), face_normal(V, 2))
    done = 0
    k = 0
    for s0 in (1.0, -1.0):
        for s1 in (1.0, -1.0):
            for s2 in (1.0, -1.0):
                q = _vertex_q(e, V, r, s0, s1, s2)
                a = (s0 * f[0][0], s0 * f[0][1], s0 * f[0][2])
                b = (s1 * f[1][0], s1 * f[1][1], s1 * f[1][2])
                c = (s2 * f[2][0], s2 * f[2][1], s2 * f[2][2])
                if cone_below(a2, q, NO_AXIS, 0.0, bn, xb, a, b, c, best + tol - _below_slack(q, a2, best)):
                    done |= 1 << k
                k += 1
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        w1, w2 = V[j], V[k]
        b1, b2 = edge_plane(V, i)
        lam, mu, c, s = project_ellipse(a2, b1, b2)
        b3 = (lam, mu, 2.0 * max(lam, mu))
        for sj in (1.0, -1.0):
            for sk in (1.0, -1.0):
                side = (1 << (2 - j) if sj < 0.0 else 0) + (1 << (2 - k) if sk < 0.0 else 0)
                if (done >> side) & 1 and (done >> (side + (1 << (2 - i)))) & 1:
                    continue  # both octants on this edge closed
                q = (
                    e[0] - sj * r[j] * w1[0] - sk * r[k] * w2[0],
                    e[1] - sj * r[j] * w1[1] - sk * r[k] * w2[1],
                    e[2] - sj * r[j] * w1[2] - sk * r[k] * w2[2],
                )
                fa = (sj * f[j][0], sj * f[j][1], sj * f[j][2])
                fb = (sk * f[k][0], sk * f[k][1], sk * f[k][2])
                if arc_below(a2, q, NO_AXIS, 0.0, bn, xb, fa, fb, best + tol - _below_slack(q, a2, best)):
                    continue
                p1, p2 = _dot(q, b1), _dot(q, b2)
                p = (c * p1 + s * p2, -s * p1 + c * p2, 0.0)
                t, m0, m1 = foot2(lam, mu, p[0], p[1])
                n = from_plane(m0, m1, c, s, b1, b2)
                if _dot(n, w1) * sj >= 0.0 and _dot(n, w2) * sk >= 0.0:
                    best, bn = _consider(a2, e, V, r, n, best, bn)
                    continue
                if sd_upper2(lam, mu, p[0], p[1], t) <= best + tol:
                    continue
                for t in secular_roots(b3, p):
                    if t == t:
                        m = unit((p[0] / (t + lam), p[1] / (t + mu), 0.0))
                        best, bn = _consider(a2, e, V, r, from_plane(m[0], m[1], c, s, b1, b2), best, bn)
                for ii in range(2):
                    for sign in (1.0, -1.0):
                        ok, m = pole_normal(b3, p, ii, sign)
                        if ok:
                            best, bn = _consider(a2, e, V, r, from_plane(m[0], m[1], c, s, b1, b2), best, bn)
    k = -1
    for s0 in (1.0, -1.0):
        for s1 in (1.0, -1.0):
            for s2 in (1.0, -1.0):
                k += 1
                if (done >> k) & 1:
                    continue
                q = _vertex_q(e, V, r, s0, s1, s2)
                t, n = foot3(a2, q)
                if _dot(n, V[0]) * s0 >= 0.0 and _dot(n, V[1]) * s1 >= 0.0 and _dot(n, V[2]) * s2 >= 0.0:
                    best, bn = _consider(a2, e, V, r, n, best, bn)
                    continue
                if sd_upper(a2, q, t) <= best + tol:
                    continue
                for t in secular_roots(a2, q):
                    if t == t:
                        m = unit((q[0] / (t + a2[0]), q[1] / (t + a2[1]), q[2] / (t + a2[2])))
                        best, bn = _consider(a2, e, V, r, m, best, bn)
                for ii in range(3):
                    for sign in (1.0, -1.0):
                        ok, m = pole_normal(a2, q, ii, sign)
                        if ok:
                            best, bn = _consider(a2, e, V, r, m, best, bn)
    return best, bn


@jit
def box_ellipsoid(E, K):
    """(status, dist, normal (3,), pos (3,), ub) for the ellipsoid E and the box K, tuples (centre (3,)
    metres, rotation row-major (9,), sizes (3,) metres; K's sizes its half-sizes, as MuJoCo's box
    geom).  dist: the signed distance, metres (sigma at the returned normal, a lower bound of the
    exact maximum); normal: unit, from E to K; pos: the midpoint of the witness points (MuJoCo's
    contact position); ub: the certified upper bound (inf when ENUMERATED); status: CERTIFIED or
    ENUMERATED."""
    e, a2, V = to_frame(E, K)
    r = K[2]
    ra = E[2]
    rho = rolling_radius(ra)
    n = local_max(a2, e, V, r)
    value = sigma_box(a2, e, V, r, n)
    tol = PAIR_CERT_REL * min(ra[0], ra[1], ra[2], r[0], r[1], r[2])
    ub = upper_bound(a2, e, V, r, rho, n, value, tol)
    status = CERTIFIED
    if ub - value > tol:
        found, m = enumerate_max(a2, e, V, r, value, n, tol)
        # the same maximiser gives the same ub, which did not close: skip recomputing it
        same = found == value and m[0] == n[0] and m[1] == n[1] and m[2] == n[2]
        value, n = found, m
        ub2 = math.inf if same else upper_bound(a2, e, V, r, rho, n, value, tol)
        if ub2 - value <= tol:
            ub = ub2
        else:
            status = ENUMERATED
            ub = math.inf
    normal, pos = contact_in_world(E, a2, n, value)
    return status, value, normal, pos, ub
