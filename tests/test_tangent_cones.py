"""The tangent-plane pruning of the box and cylinder branch and bounds (the C++ core's
pairs/tangent_cones.hpp, through ext.testing): never closes a cone or an arc on which f rises above the
floor, and closes most of them when the floor leaves room."""

import math

import numpy as np
from test_box import make_poses

from ellipsim.native import ext

NO_AXIS = ext.testing.BOX_CONSTANTS["NO_AXIS"]


def _row(kernel, x, columns):
    """kernel(x, out, 0, 1) on the one row x (numbers and 3-vectors, flattened in order): out's row."""
    flat = np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in x])
    out = np.empty((1, columns))
    kernel(flat[None, :], out, 0, 1)
    return out[0].tolist()


def cone_below(a2, q, u, r, bn, a, b, c, floor, rho=0.0):
    """tangent_cones.hpp's cone_below at xb = tangent_point(a2, u, r, bn) (rho: its rolling-ball planes)."""
    return _row(ext.testing.tangent_cones_stages, (a2, q, u, r, bn, a, b, c, floor, rho), 7)[3] == 1.0


def arc_below(a2, q, u, r, bn, a, b, floor):
    """tangent_cones.hpp's arc_below at xb = tangent_point(a2, u, r, bn)."""
    return _row(ext.testing.tangent_cones_stages, (a2, q, u, r, bn, a, b, a, floor, 0.0), 7)[4] == 1.0


def box_frame(E, K):
    """box.hpp's to_frame (e, a2, V) and face_normal of the three axes, from ext.testing.box_stages."""
    shapes = ((1, 3), (1, 3, 3), (1, 3))
    args = [np.array(x, dtype=float).reshape(shape) for body in (E, K) for x, shape in zip(body, shapes)]
    out = np.empty((1, 61))
    ext.testing.box_stages(*args, out, 0, 1)
    o = out[0].tolist()
    return tuple(o[0:3]), tuple(o[3:6]), tuple(tuple(o[6 + 3 * j : 9 + 3 * j]) for j in range(3)), o[15:24]


def box_vertex(a2, e, V, r, s):
    """box.hpp's local_max(a2, e, V, r) and vertex_q(e, V, r, *s)."""
    o = _row(ext.testing.box_vertex_stages, (a2, e, *V, r, s), 6)
    return tuple(o[:3]), tuple(o[3:])


def cylinder_local_max(a2, e, u, L, r):
    """cylinder.hpp's local_max: its n."""
    return tuple(_row(ext.testing.cylinder_local_max, (a2, e, u, L, r), 5)[:3])


def _f(n, q, a2, u, r):
    """f(n) = n.q - h_E(n) - r |P n| at the unit rows of n."""
    pn = n - np.outer(n @ u, u)
    return n @ q - np.sqrt(n * n @ np.asarray(a2)) - r * np.linalg.norm(pn, axis=1)


def _cone_samples(rng, corners, m):
    """m unit directions in the closed cone of the three corners (random positive combinations, some on
    its edges and corners)."""
    w = rng.exponential(size=(m, 3))
    w[: m // 4, rng.integers(3)] = 0.0  # on an edge
    w[: m // 16, :] = np.eye(3)[rng.integers(3, size=m // 16)]  # at a corner
    n = w @ corners
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _check_cones(rng, a2, u, r, q, bn, corners, scale):
    """(cone closed at a roomy floor, arcs closed at a roomy floor) after asserting that neither closes
    below the sampled maximum."""
    top = float(np.max(_f(_cone_samples(rng, corners, 3000), q, a2, u, r)))
    a, b, c = (tuple(x) for x in corners)
    args = (a2, tuple(q), tuple(u), r, tuple(bn))  # (cone_below and arc_below take xb = tangent_point of these)
    assert not cone_below(*args, a, b, c, top - 1e-9 * scale)
    cone = cone_below(*args, a, b, c, top + 0.02 * scale)
    arcs = 0
    for j, k in ((0, 1), (1, 2), (2, 0)):
        t = rng.uniform(size=(400, 1))
        t[:2, 0] = (0.0, 1.0)
        n = (1.0 - t) * corners[j] + t * corners[k]
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        top = float(np.max(_f(n, q, a2, u, r)))
        aj, ak = tuple(corners[j]), tuple(corners[k])
        assert not arc_below(*args, aj, ak, top - 1e-9 * scale)
        arcs += arc_below(*args, aj, ak, top + 0.02 * scale)
    return cone, arcs


def test_box_octants_never_close_above_their_floor():
    """A box's eight octants (vertex pieces with their edges and corners; r = 0) on deep poses."""
    rng = np.random.default_rng(7)
    P, cat, _ = make_poses(seed=3, per=12)
    closed = arcs = tried = 0
    for i in np.flatnonzero(cat == 3):
        E = (tuple(P["cE"][i]), tuple(P["RE"][i].ravel()), tuple(P["rE"][i]))
        K = (tuple(P["cK"][i]), tuple(P["RK"][i].ravel()), tuple(P["sK"][i]))
        e, a2, V, faces = box_frame(E, K)
        r = K[2]
        bn = np.array(box_vertex(a2, e, V, r, (1.0, 1.0, 1.0))[0])
        f = np.array(faces).reshape(3, 3)
        scale = float(np.linalg.norm(e) + max(r) + math.sqrt(max(a2)))
        for s in np.array(np.meshgrid([1.0, -1.0], [1.0, -1.0], [1.0, -1.0])).reshape(3, -1).T:
            q = np.array(box_vertex(a2, e, V, r, s)[1])
            c, a = _check_cones(rng, a2, np.array(NO_AXIS), 0.0, q, bn, s[:, None] * f, scale)
            closed, arcs, tried = closed + c, arcs + a, tried + 1
    assert tried == 96 and closed > 0.8 * tried and arcs > 2.5 * tried


def test_cylinder_quarter_lunes_never_close_above_their_floor():
    """A cylinder's rim hemispheres (r > 0: the disc's r |P n| in f) as four quarter lunes each (the
    pole and two ends on the equator), on crossings of a random ellipsoid and cylinder."""
    rng = np.random.default_rng(8)
    closed = arcs = tried = 0
    for _ in range(16):
        a2 = tuple(rng.uniform(0.02, 0.3, 3) ** 2)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        r, L = rng.uniform(0.01, 0.15), rng.uniform(0.02, 0.3)
        e = rng.uniform(-0.1, 0.1, 3)
        n0 = cylinder_local_max(a2, tuple(e), tuple(u), L, r)
        w1 = np.cross(u, rng.normal(size=3))
        w1 /= np.linalg.norm(w1)
        w2 = np.cross(u, w1)
        scale = float(np.linalg.norm(e) + L + r + math.sqrt(max(a2)))
        for sg in (1.0, -1.0):
            q = e - sg * L * u
            for k in range(4):
                ca, cb = (math.cos(t) * w1 + math.sin(t) * w2 for t in (k * math.pi / 2, (k + 1) * math.pi / 2))
                corners = np.array([sg * u, ca, cb])
                c, a = _check_cones(rng, a2, u, r, q, np.array(n0), corners, scale)
                closed, arcs, tried = closed + c, arcs + a, tried + 1
    assert tried == 128 and closed > 0.8 * tried and arcs > 2.5 * tried


def test_rolling_ball_planes_never_close_above_their_floor_and_never_lose_to_the_bare_planes():
    """cone_below with rho, E's rolling radius (the polytope's fans): E holds a ball of radius rho tangent at each
    boundary point, so a node's plane gains rho (1 - cos) away from its tangent point.  On random deep cones
    (the floor below -rho, where it applies) it never closes a cone above the sampled maximum of f, closes every
    cone the bare planes close, and more of them at a tight floor."""
    rng = np.random.default_rng(11)
    tight = bare = ball = 0
    for _ in range(200):
        r = np.sort(rng.uniform(0.03, 0.2, 3))
        a2 = tuple(r**2)
        rho = r[0] ** 2 / r[2]
        q = rng.normal(size=3) * 0.05
        centre = rng.normal(size=3)
        centre /= np.linalg.norm(centre)
        corners = centre + 0.35 * rng.normal(size=(3, 3))
        top = float(np.max(_f(_cone_samples(rng, corners, 4000), q, a2, NO_AXIS, 0.0)))
        if not top < -1.5 * rho:
            continue
        a, b, c = (tuple(x) for x in corners)
        bn = tuple(centre)
        args = (a2, tuple(q), NO_AXIS, 0.0, bn, a, b, c)
        scale = float(np.linalg.norm(q) + r[2])
        assert not cone_below(*args, top - 1e-9 * scale, rho)
        floor = top + 2e-4 * scale
        plain, rolled = cone_below(*args, floor), cone_below(*args, floor, rho)
        assert rolled or not plain
        tight, bare, ball = tight + 1, bare + plain, ball + rolled
    assert tight > 100 and ball >= bare + 5
