"""Proving f(n) <= floor < 0 over a whole cone of directions by tangent planes, cheaply: the pruning
step of the box's and the cylinder's branch and bound (box.enumerate_max, cylinder._rim_bb).

f(n) = n.q - h_E(n) - r |P n| (P = I - u u^T; r = 0 for the box's pieces, r |P n| the support of the
cylinder's disc for its rim) is concave and 1-homogeneous, and for any point x of E and y of the disc,
h_E(n) + r |P n| >= n.(x + y), so f(n) <= g.n with g = q - x - y, linear.  A linear function below
floor < 0 at every corner c_k of a cone is below it on all of the cone's unit directions:
g.sum l_k c_k <= floor sum l_k |c_k| <= floor |sum l_k c_k| (triangle inequality, floor < 0), so a
node costs a support point and three dot products, the corners need not be unit, and a cone splits
at its flat midpoints (sums of corners).  x + y is the support point of E + disc at the node's centre,
or, for the box (r = 0), at the incumbent's normal when the node holds it (there the bound is exact at
the incumbent and falls with f as long as f falls: a kink of sigma, as a flush face; a cylinder's
rim incumbent is a smooth maximum, where the plane rises: 5% slower to try).  The planes are the same
weak-duality step as the point-ellipsoid bounds (Schneider & Eberly, GTCG 10.5.2; Boyd &
Vandenberghe 5.1), taken on pieces of the sphere instead of its whole.
"""

import math

from .._jit import stage
from ..vec3 import cross3
from .point_ellipsoid import support

#: levels of halvings of an arc before arc_below gives up (a cone gets 4 levels of quarters)
ARC_DEPTH = 5


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@stage
def _twice(a):
    return (2.0 * a[0], 2.0 * a[1], 2.0 * a[2])


@stage
def tangent_point(a2, u, r, n):
    """The support point of E + disc(r, perpendicular to the unit u) at the nonzero n (the disc's part
    0 where P n = 0, or for r = 0)."""
    _, s = support(a2, n)
    if r == 0.0:
        return s
    d = _dot(n, u)
    pn = (n[0] - d * u[0], n[1] - d * u[1], n[2] - d * u[2])
    pp = _dot(pn, pn)
    k = r / math.sqrt(pp) if pp > 0.0 else 0.0
    return (s[0] + k * pn[0], s[1] + k * pn[1], s[2] + k * pn[2])


@stage
def _corner_below(g, c, floor):
    """g.c / |c| <= floor (< 0), without a square root."""
    d = _dot(g, c)
    return d <= 0.0 and d * d >= floor * floor * _dot(c, c)


@stage
def _plane_below(q, x, a, b, c, floor):
    """(q - x).n <= floor on the cone of a, b, c (c = a for an arc)."""
    g = (q[0] - x[0], q[1] - x[1], q[2] - x[2])
    return _corner_below(g, a, floor) and _corner_below(g, b, floor) and _corner_below(g, c, floor)


@stage
def _holds(n, a, b, c):
    """n in the cone of a, b, c (counter-clockwise), to a margin that lets a corner or an edge count:
    only the choice of tangent point hangs on it."""
    eps = -1e-9 * (_dot(a, a) + _dot(b, b) + _dot(c, c))
    return _dot(cross3(a, b), n) >= eps and _dot(cross3(b, c), n) >= eps and _dot(cross3(c, a), n) >= eps


@stage
def _node_below(a2, q, u, r, bn, xb, a, b, c, floor):
    """f <= floor on the cone a, b, c: the plane at the incumbent bn (xb its tangent point; r > 0: not
    tried, the cylinder's rim incumbent is smooth) when the cone holds it, else (or then) the plane at
    the cone's centre."""
    if r == 0.0 and _holds(bn, a, b, c) and _plane_below(q, xb, a, b, c, floor):
        return True
    return _plane_below(q, tangent_point(a2, u, r, _add(_add(a, b), c)), a, b, c, floor)


@stage
def _quarter(a, b, c, k):
    """Child k of the cone a, b, c split at its flat midpoints (corners doubled: the test is scale-free;
    children share their computed corners, so they tile the parent)."""
    if k == 0:
        return _twice(a), _add(a, b), _add(c, a)
    if k == 1:
        return _add(a, b), _twice(b), _add(b, c)
    if k == 2:
        return _add(c, a), _add(b, c), _twice(c)
    return _add(a, b), _add(b, c), _add(c, a)


@stage
def cone_below(a2, q, u, r, bn, xb, a, b, c, floor):
    """True when f <= floor on the whole closed cone of a, b, c (module docstring), proven on up to 4
    levels of quarters; False when floor >= 0 or a leaf does not close.  xb = tangent_point(bn), unused
    when r > 0."""
    if not floor < 0.0:
        return False
    if _dot(cross3(a, b), c) < 0.0:
        b, c = c, b
    if _node_below(a2, q, u, r, bn, xb, a, b, c, floor):
        return True
    for k1 in range(4):  # the 4 levels written out (numba: no recursion in a stage)
        a1, b1, c1 = _quarter(a, b, c, k1)
        if _node_below(a2, q, u, r, bn, xb, a1, b1, c1, floor):
            continue
        for k2 in range(4):
            a2_, b2, c2 = _quarter(a1, b1, c1, k2)
            if _node_below(a2, q, u, r, bn, xb, a2_, b2, c2, floor):
                continue
            for k3 in range(4):
                a3, b3, c3 = _quarter(a2_, b2, c2, k3)
                if _node_below(a2, q, u, r, bn, xb, a3, b3, c3, floor):
                    continue
                for k4 in range(4):
                    a4, b4, c4 = _quarter(a3, b3, c3, k4)
                    if not _node_below(a2, q, u, r, bn, xb, a4, b4, c4, floor):
                        return False
    return True


@stage
def _arc_node_below(a2, q, u, r, bn, xb, a, b, floor):
    """f <= floor on the arc of the corners a, b: as _node_below, a cone of two corners."""
    m = cross3(a, b)
    mm = _dot(m, m)
    mn = _dot(m, bn)
    if (
        r == 0.0
        and mn * mn <= 1e-18 * mm
        and _dot(cross3(a, bn), m) >= -1e-9 * mm
        and _dot(cross3(bn, b), m) >= -1e-9 * mm
    ):
        if _plane_below(q, xb, a, b, a, floor):
            return True
    return _plane_below(q, tangent_point(a2, u, r, _add(a, b)), a, b, a, floor)


@stage
def arc_below(a2, q, u, r, bn, xb, a, b, floor):
    """True when f <= floor on the whole arc from a to b, proven on dyadic pieces of the chord a..b down
    to 2^-ARC_DEPTH, depth first (t0 the piece's start, w its width, in finest pieces); False when
    floor >= 0 or a finest piece does not close."""
    if not floor < 0.0:
        return False
    full = 1 << ARC_DEPTH
    t0, w = 0, full
    while t0 < full:
        u0, u1 = t0 / full, (t0 + w) / full
        pa = ((1.0 - u0) * a[0] + u0 * b[0], (1.0 - u0) * a[1] + u0 * b[1], (1.0 - u0) * a[2] + u0 * b[2])
        pb = ((1.0 - u1) * a[0] + u1 * b[0], (1.0 - u1) * a[1] + u1 * b[1], (1.0 - u1) * a[2] + u1 * b[2])
        if _arc_node_below(a2, q, u, r, bn, xb, pa, pb, floor):
            t0 += w
            while w < full and t0 % (2 * w) == 0:
                w *= 2
        elif w > 1:
            w //= 2
        else:
            return False
    return True
