"""The tangent-plane pruning of the box and cylinder branch and bounds (core/pairs/tangent_cones.py):
never closes a cone or an arc on which f rises above the floor, and closes most of them when the
floor leaves room."""

import math

import numpy as np
from test_box import make_poses

from ellipsim.core.pairs import box, cylinder, tangent_cones


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
    xb = tangent_cones.tangent_point(a2, tuple(u), r, tuple(bn))
    top = float(np.max(_f(_cone_samples(rng, corners, 3000), q, a2, u, r)))
    a, b, c = (tuple(x) for x in corners)
    args = (a2, tuple(q), tuple(u), r, tuple(bn), xb)
    assert not tangent_cones.cone_below(*args, a, b, c, top - 1e-9 * scale)
    cone = tangent_cones.cone_below(*args, a, b, c, top + 0.02 * scale)
    arcs = 0
    for j, k in ((0, 1), (1, 2), (2, 0)):
        t = rng.uniform(size=(400, 1))
        t[:2, 0] = (0.0, 1.0)
        n = (1.0 - t) * corners[j] + t * corners[k]
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        top = float(np.max(_f(n, q, a2, u, r)))
        aj, ak = tuple(corners[j]), tuple(corners[k])
        assert not tangent_cones.arc_below(*args, aj, ak, top - 1e-9 * scale)
        arcs += tangent_cones.arc_below(*args, aj, ak, top + 0.02 * scale)
    return cone, arcs


def test_box_octants_never_close_above_their_floor():
    """A box's eight octants (vertex pieces with their edges and corners; r = 0) on deep poses."""
    rng = np.random.default_rng(7)
    P, cat, _ = make_poses(seed=3, per=12)
    closed = arcs = tried = 0
    for i in np.flatnonzero(cat == 3):
        E = (tuple(P["cE"][i]), tuple(P["RE"][i].ravel()), tuple(P["rE"][i]))
        K = (tuple(P["cK"][i]), tuple(P["RK"][i].ravel()), tuple(P["sK"][i]))
        e, a2, V = box.to_frame(E, K)
        r = K[2]
        bn = np.array(box.local_max(a2, e, V, r))
        f = np.array([box.face_normal(V, j) for j in range(3)])
        scale = float(np.linalg.norm(e) + max(r) + math.sqrt(max(a2)))
        for s in np.array(np.meshgrid([1.0, -1.0], [1.0, -1.0], [1.0, -1.0])).reshape(3, -1).T:
            q = np.array(box._vertex_q(e, V, r, *s))
            c, a = _check_cones(rng, a2, np.array(box.NO_AXIS), 0.0, q, bn, s[:, None] * f, scale)
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
        n0, _, _ = cylinder.local_max(a2, tuple(e), tuple(u), L, r)
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
