"""Signed distance of an ellipsoid and a capsule with a proven global maximum (MuJoCo's capsule x
ellipsoid narrow phase).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), split into the smooth
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

The point-ellipsoid primitives (secular equation, certified bounds, critical points) are in
point_ellipsoid.py, shared with box.py.

Ported from the validated pair-type prototype (10 000 poses: never below a 20 000-direction reference
by more than 1e-12 of the smaller shortest half-size; every maximum certified or enumerated).
"""

import math

from .._jit import jit, stage
from ..distance.sphere_newton import rolling_radius, tangent_basis, unit
from ..tolerances import PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
from ..vec3 import column, dot3, norm2, rotate_t
from .point_ellipsoid import (
    circle_max_bound,
    contact_in_world,
    foot3,
    pole_normal,
    sd_upper,
    secular_roots,
    support,
)

#: How capsule_ellipsoid proved its maximum: CERTIFIED (an upper bound within PAIR_CERT_REL of the
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
    (PAIR_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies."""
    e, a2, u = to_frame(E, K)
    ee = norm2(e)
    if not ee > 0.0:
        return -math.inf
    s = 1.0 / math.sqrt(ee)
    ra, rk = E[2], K[2]
    scale = math.sqrt(ee) + max(ra[0], ra[1], ra[2], rk[0], rk[1])
    v = sigma_capsule(a2, e, u, rk[1], rk[0], (e[0] * s, e[1] * s, e[2] * s))
    return v - PAIR_SIGMA_SLACK_ULPS * U * scale


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
                ok, m = pole_normal(a2, q, i, sign)
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
    tol = PAIR_CERT_REL * min(ra[0], ra[1], ra[2], r)
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
    normal, pos = contact_in_world(E, a2, n, value)
    return status, value, normal, pos, ub
