"""The C++ core's pairs/point_ellipsoid.hpp on its own (through ext.testing.point_ellipsoid_stages): the
point-ellipsoid and point-ellipse problems (foot3, foot2), their certified bounds (sd_upper, sd_upper2),
every critical point (secular_roots, pole_normal) and the plane-restricted maximum (circle_max_bound), each
against an independent reference.

The reference (`critical_points`) enumerates every critical point of |x - q|^2 on the boundary of
E = {x : sum x_i^2 / a2_i <= 1} in 40-digit mpmath, by bracketing instead of Newton: between
consecutive poles -a2_i of S(t) = sum a2_i q_i^2 / (t + a2_i)^2 the function is convex, its minimum
found by bisection on S' (increasing there), each root of S = 1 by bisection on a bracket where S - 1
changes sign; beyond the outer poles S is monotone.  Where coordinates of q vanish, the limit points
at those poles (x_j = a2_j q_j / (a2_j - a2_i), x_i free on what is left of the quadric) are added.
The nearest boundary point is the best of them; a dense sampling of the boundary checks that nothing
nearer was missed.  Nothing of ellipsim is used by the reference."""

import math

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ellipsim.native import ext

U = 2.0**-53
DPS = 40


# --- the stages (point_ellipsoid.hpp), each as point_ellipsoid.py's took and returned it ----------------


def _stages(a2, q, w1=(1.0, 0.0, 0.0), w2=(0.0, 1.0, 0.0), t=0.0):
    """ext.testing.point_ellipsoid_stages on the one row (a2, q, w1, w2, t): its 56 columns as floats."""
    x = np.array([[*a2, *q, *w1, *w2, t]], dtype=float)
    out = np.empty((1, 56))
    ext.testing.point_ellipsoid_stages(x, out, 0, 1)
    return out[0].tolist()


def _plane(a2, q):
    """The ellipse's (a2, q) as a row's 3-vectors (the third coordinate unused by the planar stages)."""
    return (a2[0], a2[1], a2[0]), (q[0], q[1], 0.0)


def foot3(a2, q):
    o = _stages(a2, q)
    return o[0], tuple(o[1:4])


def sd_upper(a2, q, t):
    return _stages(a2, q, t=t)[5]


def foot2(a0, a1, q0, q1):
    o = _stages(*_plane((a0, a1), (q0, q1)))
    return o[40], o[41], o[42]


def sd_upper2(a0, a1, q0, q1, t):
    return _stages(*_plane((a0, a1), (q0, q1)), t=t)[44]


def support(a2, n):
    o = _stages(a2, (0.0, 0.0, 0.0), w1=n)
    return o[6], tuple(o[7:10])


def secular_roots(a2, q, largest):
    o = _stages(a2, q)
    return tuple(o[10:13] if largest else o[13:16])


def pole_normal(a2, q, i, sign):
    o = _stages(a2, q)[16 + 8 * i + (0 if sign > 0 else 4) :][:4]
    return o[0] == 1.0, tuple(o[1:4])


def circle_max_bound(a2, q, w1, w2):
    o = _stages(a2, q, w1, w2)
    return tuple(o[52:55]), o[55]


# --- the reference -------------------------------------------------------------------------------


def _bisect(f, lo, hi, iters=140):
    """A sign change of f in [lo, hi] (f(lo), f(hi) of opposite signs), in the current precision."""
    flo = f(lo)
    for _ in range(iters):
        mid = (lo + hi) / 2
        fm = f(mid)
        if fm == 0:
            return mid
        if (fm > 0) == (flo > 0):
            lo, flo = mid, fm
        else:
            hi = mid
        if hi - lo <= mp.mpf(10) ** (-DPS + 3) * (1 + abs(lo)):
            break
    return (lo + hi) / 2


def secular_reference(a2, q):
    """Every real root of S(t) = 1 (ascending), the poles used and, between consecutive poles, the
    minimum of S: ([roots], [(pole_left, pole_right, S_min)]).  Poles: the distinct -a2_i with
    q_i != 0 (equal a2_i merge).  20 digits beyond DPS: two float semi-axes a few ulps apart put
    their poles 1e-16 apart, and the bracket between them 1e-35 of that inside."""
    with mp.workdps(DPS + 20):
        a2m = [mp.mpf(float(x)) for x in a2]
        cc = {}
        for ai, qi in zip(a2m, [mp.mpf(float(x)) for x in q]):
            if qi != 0:
                cc[ai] = cc.get(ai, 0) + ai * qi * qi  # c_i^2
        poles = sorted(-ai for ai in cc)  # ascending
        c2 = [cc[-p] for p in poles]

        def S(t):
            return sum(c / (t - p) ** 2 for c, p in zip(c2, poles))

        def dS(t):
            return sum(-2 * c / (t - p) ** 3 for c, p in zip(c2, poles))

        roots, gaps = [], []
        if not poles:
            return roots, gaps
        cs = [mp.sqrt(c) for c in c2]
        ctot = sum(cs)
        # left of the leftmost pole: S increases from 0 to +inf
        p = poles[0]
        roots.append(_bisect(lambda t: S(t) - 1, p - 2 * ctot, p - cs[0] / 2))
        for k in range(len(poles) - 1):
            pl, pr = poles[k], poles[k + 1]
            w = (pr - pl) * mp.mpf(10) ** (-DPS + 5)
            m = _bisect(dS, pl + w, pr - w)  # dS < 0 near pl, > 0 near pr
            Smin = S(m)
            gaps.append((pl, pr, Smin))
            if Smin < 1:
                roots.append(_bisect(lambda t: S(t) - 1, pl + min(cs[k], m - pl) / 2, m))
                roots.append(_bisect(lambda t: S(t) - 1, m, pr - min(cs[k + 1], pr - m) / 2))
        p = poles[-1]
        roots.append(_bisect(lambda t: S(t) - 1, p + cs[-1] / 2, p + 2 * ctot))
        return roots, gaps


def critical_points(a2, q):
    """Every critical point of |x - q|^2 on the boundary of E (or one representative of a circle of
    them), as mpmath 3-vectors (2-vectors for an ellipse: len(a2) == 2)."""
    d = len(a2)
    with mp.workdps(DPS):
        a2m = [mp.mpf(float(x)) for x in a2]
        qm = [mp.mpf(float(x)) for x in q]
        out = []
        roots, _ = secular_reference(a2, q)
        for t in roots:
            out.append([a2m[i] * qm[i] / (t + a2m[i]) for i in range(d)])
        for ai in sorted(set(a2m)):  # pole limits at -ai: every q_j with a2_j == ai must vanish
            same = [j for j in range(d) if a2m[j] == ai]
            if any(qm[j] != 0 for j in same):
                continue
            x = [mp.mpf(0)] * d
            for j in range(d):
                if j not in same:
                    x[j] = a2m[j] * qm[j] / (a2m[j] - ai)
            rest = 1 - sum(x[j] ** 2 / a2m[j] for j in range(d))
            if rest < 0:
                continue
            for sign in (1, -1):
                y = list(x)
                y[same[0]] = sign * mp.sqrt(rest * ai)  # q_same = 0: every point of the circle is as far
                out.append(y)
        return out


def signed_distance_ref(a2, q):
    """Signed distance from q to the boundary of E (negative inside), 40 digits, and the nearest point."""
    with mp.workdps(DPS):
        qm = [mp.mpf(float(x)) for x in q]
        best, arg = None, None
        for x in critical_points(a2, q):
            dd = mp.sqrt(sum((xi - qi) ** 2 for xi, qi in zip(x, qm)))
            if best is None or dd < best:
                best, arg = dd, x
        inside = sum(qi * qi / mp.mpf(float(ai)) for qi, ai in zip(qm, a2)) < 1
        return (-best if inside else best), arg


def sampled_distance(a2, q, k=40_000):
    """min |x - q| over k boundary points (an upper bound of the distance to the boundary, float)."""
    a = np.sqrt(np.asarray(a2, float))
    if len(a2) == 2:
        th = np.linspace(0, 2 * np.pi, k, endpoint=False)
        x = np.stack([a[0] * np.cos(th), a[1] * np.sin(th)], 1)
    else:
        i = np.arange(k) + 0.5
        phi, th = np.arccos(1 - 2 * i / k), np.pi * (1 + 5**0.5) * i
        x = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1) * a
    return float(np.min(np.linalg.norm(x - np.asarray(q, float), axis=1)))


def f_q(a2, q, n):
    """m.q - sqrt(m^T A m) at the unit m along n, in 40 digits (the function foot3 maximises)."""
    with mp.workdps(DPS):
        nm = [mp.mpf(x) for x in n]
        s = mp.sqrt(sum(x * x for x in nm))
        nm = [x / s for x in nm]
        return sum(x * mp.mpf(float(y)) for x, y in zip(nm, q)) - mp.sqrt(
            sum(mp.mpf(float(ai)) * x * x for ai, x in zip(a2, nm))
        )


# --- inputs --------------------------------------------------------------------------------------

semi = st.floats(0.05, 2.0)
flat = st.sampled_from([1e-2, 1e-4, 1e-6])


@st.composite
def ellipsoid_point(draw, d=3):
    """(a2, q): squared semi-axes and a point: generic, very flat, spheroid-like (two equal axes), and
    points inside, outside, near the boundary, on coordinate axes and planes, at the centre."""
    kind = draw(st.sampled_from(["generic", "flat", "spheroid"]))
    a = [draw(semi) for _ in range(d)]
    if kind == "flat":
        a[draw(st.integers(0, d - 1))] = draw(flat) * max(a)
    elif kind == "spheroid":
        i, j = draw(st.permutations(range(d)))[:2]
        a[j] = a[i]
    a2 = tuple(x * x for x in a)
    u = np.array([draw(st.floats(-1, 1)) for _ in range(d)])
    u[np.abs(u) < 1e-3] = 0.0  # exact zeros come from `zero` below; tiny ones need more than 40 digits
    if not np.any(u):
        u[0] = 1.0
    u /= np.linalg.norm(u)
    where = draw(st.sampled_from(["inside", "outside", "near", "deep", "centre"]))
    on_boundary = np.sqrt(1.0 / np.sum(u * u / np.array(a2)))  # |q| where the ray leaves E
    r = {
        "inside": draw(st.floats(0.05, 0.95)),
        "outside": draw(st.floats(1.05, 3.0)),
        "near": 1.0 + draw(st.sampled_from([-1e-3, 1e-3, -1e-8, 1e-8])),
        "deep": draw(st.floats(1e-3, 0.3)),
        "centre": 0.0,
    }[where]
    q = u * on_boundary * r
    zero = draw(st.sampled_from([(), (0,), (1,), (d - 1,), (0, 1)]))  # on coordinate planes and axes
    for k in zero:
        if k < d and (len(zero) < d):
            q[k] = 0.0
    return a2, tuple(float(x) for x in q)


def floats(v):
    return tuple(float(x) for x in v)


def scale_of(a2, q):
    return math.sqrt(max(a2)) + math.sqrt(sum(x * x for x in q))


# --- the reference checks itself -------------------------------------------------------------------


@settings(max_examples=25)
@given(ellipsoid_point())
def test_reference_finds_the_nearest_boundary_point(case):
    """The reference's nearest point is on the boundary, no sampled boundary point is nearer, and
    every critical point it reports is one (x - q normal to the boundary)."""
    a2, q = case
    sd, x = signed_distance_ref(a2, q)
    assert abs(float(sd)) <= sampled_distance(a2, q) + 1e-12
    with mp.workdps(DPS):
        for x in critical_points(a2, q):
            assert abs(sum(xi * xi / mp.mpf(ai) for xi, ai in zip(x, a2)) - 1) < mp.mpf(10) ** -25
            g = [xi / mp.mpf(ai) for xi, ai in zip(x, a2)]  # normal direction
            r = [xi - mp.mpf(qi) for xi, qi in zip(x, q)]
            cross = [r[1] * g[2] - r[2] * g[1], r[2] * g[0] - r[0] * g[2], r[0] * g[1] - r[1] * g[0]]
            assert max(abs(c) for c in cross) < mp.mpf(10) ** -20


# --- foot3 and sd_upper ----------------------------------------------------------------------------


def check_foot3(a2, q):
    a2, q = floats(a2), floats(q)
    sd, _ = signed_distance_ref(a2, q)
    t, n = foot3(a2, q)
    S = scale_of(a2, q)
    assert abs(math.sqrt(sum(x * x for x in n)) - 1.0) <= 4 * U
    # n maximises f_q over the sphere, and that maximum is the signed distance (f_q is stationary at
    # its maximiser: 1e-18 S allows n ~1e-9 rad off where the curvature is ~1 / S, far less on flat E)
    assert abs(float(f_q(a2, q, n) - sd)) <= 1e-18 * S, (float(f_q(a2, q, n)), float(sd))
    # the certified bound from foot3's own t: above the signed distance (to the rounding of the bound
    # itself, 8 u S) and tight
    ub = sd_upper(a2, q, t)
    assert ub >= float(sd) - 8 * U * S
    assert ub <= float(sd) + 1e-12 * S
    return sd, t, n


@settings(max_examples=150)
@given(ellipsoid_point())
def test_foot3_is_the_nearest_boundary_point(case):
    """foot3's normal is the maximiser of f_q (its value the 40-digit signed distance to 1e-13 of the
    scale), inside and outside, on axes and planes (Eberly's degenerate cases), flat and spheroidal."""
    check_foot3(*case)


@pytest.mark.parametrize(
    "a2, q",
    [
        ((1.0, 0.25, 0.04), (0.0, 0.0, 0.0)),  # the centre: the shortest axis, -0.2
        ((1.0, 0.25, 0.04), (0.5, 0.0, 0.0)),  # on the long axis, inside: the pole limit (q_2 = q_3 = 0)
        ((1.0, 0.25, 0.04), (0.0, 0.3, 0.0)),  # on the middle axis, inside
        ((1.0, 0.25, 0.04), (0.99, 0.0, 0.0)),  # on the long axis beyond the last pole-limit point
        ((1.0, 0.25, 0.04), (2.0, 0.0, 0.0)),  # on the long axis, outside
        ((1.0, 0.25, 0.04), (0.0, 0.0, 0.5)),  # on the short axis, outside
        ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)),  # a sphere's centre: every direction
        ((1.0, 1.0, 1.0), (0.3, -0.2, 0.1)),  # a sphere: the closed form
        ((1.0, 1.0, 0.01), (0.2, 0.1, 0.0)),  # an oblate spheroid, in its equatorial plane
        ((0.01, 1.0, 1.0), (0.0, 0.3, 0.0)),  # the same turned
        ((1.0, 0.25, 1e-12), (0.3, 0.2, 1e-7)),  # a disk of half-thickness 1e-6, inside near the face
        ((1.0, 0.25, 1e-12), (0.3, 0.2, 3e-6)),  # just outside the face
        ((1.0, 0.25, 1e-12), (0.9, 0.3, 0.0)),  # beyond the rim in its plane
        ((1.0, 0.25, 0.04), (0.5, 0.0, 1e-12)),  # the root hugs the pole -0.04 (within POLE_RTOL): pole limit
        ((1.0, 0.25, 0.04), (0.5, 1e-12, 0.0)),  # ... near the middle axis' plane instead
    ],
)
def test_foot3_hand_picked(a2, q):
    sd, t, n = check_foot3(a2, q)
    if a2 == (1.0, 1.0, 1.0):
        assert float(sd) == pytest.approx(math.sqrt(sum(x * x for x in q)) - 1.0, abs=1e-15)
    if q == (0.0, 0.0, 0.0):
        assert float(sd) == -math.sqrt(min(a2))


@pytest.mark.parametrize("qk", [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10])  # 1e-10: below POLE_RTOL, the pole limit
def test_foot3_root_hugging_the_pole(qk):
    """q = (0.5, 0, q_k) inside the ellipsoid of semi-axes (1, 0.5, 0.2): the largest root of S = 1 lies
    2.34 q_k beyond the pole -0.04 (the reference's bisection resolves it to 40 digits).  Newton stopped
    relative to |t| + amin left t ~1 % of that distance off at q_k = 1e-8, 1e-9 (f_q(n) 1.4e-6 below the
    signed distance); it stops relative to t + amin now."""
    check_foot3((1.0, 0.25, 0.04), (0.5, 0.0, qk))


@pytest.mark.parametrize("qk", [1e-6, 1e-7, 1e-8, 1e-10])
def test_foot2_root_hugging_the_pole(qk):
    """The same in the plane: p = (0.5, q_k), semi-axes (1, 0.2)."""
    check_foot2((1.0, 0.04), (0.5, qk))


@pytest.mark.parametrize(
    "a2, q",
    [
        ((0.04, 0.04), (3e-12, -4e-12)),
        ((0.04 * (1 + 1e-11), 0.04), (3e-12, -4e-12)),
        ((0.04, 0.04 * (1 + 1e-12)), (1e-13, 2e-11)),
        ((0.09, 0.09 * (1 - 2e-10)), (-2e-9, 1e-10)),
        ((0.04, 0.04), (-5e-11, 0.0)),
    ],
)
def test_foot2_near_a_circle_follows_the_point(a2, q):
    """A (near-)circle with p a hair off its centre (a cylinder or capsule on a spheroid's axis: the
    spheroid projected along the axis): the root hugs the pole.  The limit formula put the normal on
    the first axis whatever p was, 2 |p| below the maximum (5.5e-11 m on a coaxial capsule)."""
    check_foot2(a2, q)


@settings(max_examples=60)
@given(ellipsoid_point(), st.floats(0.0, 1.0), st.floats(-3.0, 1.0))
def test_sd_upper_bounds_for_any_secular_value(case, frac, logt):
    """Weak duality holds for every t > -min(a2), not only at the root: sd_upper is above the signed
    distance whatever t it is given (inside: -sqrt(g(t)); outside: the distance to a point of E)."""
    a2, q = case
    sd, _ = signed_distance_ref(a2, q)
    amin = min(a2)
    t = -amin * (1 - 1e-14) * frac + (10.0**logt) * (1 - frac)
    assert sd_upper(a2, q, t) >= float(sd) - 8 * U * scale_of(a2, q)


# --- foot2 and sd_upper2 ---------------------------------------------------------------------------


@settings(max_examples=100)
@given(ellipsoid_point(d=2))
def test_foot2_is_the_nearest_point_of_the_ellipse(case):
    check_foot2(*case)


def check_foot2(a2, q):
    a2, q = floats(a2), floats(q)
    sd, _ = signed_distance_ref(a2, q)
    t, n0, n1 = foot2(a2[0], a2[1], q[0], q[1])
    S = scale_of(a2, q)
    assert abs(math.hypot(n0, n1) - 1.0) <= 4 * U
    assert abs(float(f_q(a2, q, (n0, n1)) - sd)) <= 1e-18 * S
    ub = sd_upper2(a2[0], a2[1], q[0], q[1], t)
    assert float(sd) - 8 * U * S <= ub <= float(sd) + 1e-12 * S


# --- support, circle_max_bound -----------------------------------------------------------------------


@settings(max_examples=40)
@given(ellipsoid_point(), st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-3))
def test_support_point_is_the_support(case, n):
    """s(n) lies on the boundary and maximises n.x over E (checked on 40 000 boundary points), h = n.s."""
    a2, _ = case
    h, s = support(a2, n)
    a = np.sqrt(np.array(a2))
    assert abs(np.sum(np.array(s) ** 2 / np.array(a2)) - 1) <= 1e-13
    assert h == pytest.approx(float(np.dot(n, s)), rel=1e-14)
    i = np.arange(40_000) + 0.5
    phi, th = np.arccos(1 - 2 * i / 40_000), np.pi * (1 + 5**0.5) * i
    x = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1) * a
    assert np.max(x @ np.array(n)) <= h * (1 + 1e-14)


def circle_reference(a2, q, w1, w2, k=20_000):
    """max over theta of f_q(cos theta w1 + sin theta w2): dense, then golden-section in 40 digits."""
    th = np.linspace(0, 2 * np.pi, k, endpoint=False)
    n = np.cos(th)[:, None] * w1 + np.sin(th)[:, None] * w2
    v = n @ np.array(q) - np.sqrt(np.sum(n * n * np.array(a2), 1))
    best = mp.mpf("-inf")
    with mp.workdps(DPS):
        W1, W2 = [mp.mpf(float(x)) for x in w1], [mp.mpf(float(x)) for x in w2]

        def f(t):
            c, s = mp.cos(t), mp.sin(t)
            m = [c * x + s * y for x, y in zip(W1, W2)]
            r = mp.sqrt(sum(x * x for x in m))  # w1, w2 are orthonormal only to rounding
            m = [x / r for x in m]
            return sum(x * mp.mpf(float(y)) for x, y in zip(m, q)) - mp.sqrt(
                sum(mp.mpf(float(ai)) * x * x for ai, x in zip(a2, m))
            )

        for i in np.argsort(-v)[:2]:  # f is smooth in theta: golden section around each of the best samples
            lo, hi = mp.mpf(th[i]) - 2 * mp.pi / k * 2, mp.mpf(th[i]) + 2 * mp.pi / k * 2
            g = (mp.sqrt(5) - 1) / 2
            x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
            f1, f2 = f(x1), f(x2)
            for _ in range(70):  # the bracket shrinks to 1e-17 rad: f is stationary there, 1e-34 off
                if f1 > f2:
                    hi, x2, f2 = x2, x1, f1
                    x1 = hi - g * (hi - lo)
                    f1 = f(x1)
                else:
                    lo, x1, f1 = x1, x2, f2
                    x2 = lo + g * (hi - lo)
                    f2 = f(x2)
            best = max(best, f1, f2)
    return best


@settings(max_examples=25)
@given(ellipsoid_point(), st.floats(0, 2 * np.pi), st.floats(0, np.pi), st.floats(0, 2 * np.pi))
def test_circle_max_bound_is_the_plane_maximum_and_bounds_it(case, alpha, beta, gamma):
    """The normal returned lies in span(w1, w2), attains the maximum of f_q over that great circle
    (40-digit golden section from a dense sampling) and the bound returned is above it."""
    a2, q = case
    ca, sa, cb, sb, cg, sg = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta), np.cos(gamma), np.sin(gamma)
    R = (
        np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
        @ np.array([[1, 0, 0], [0, cb, -sb], [0, sb, cb]])
        @ np.array([[cg, -sg, 0], [sg, cg, 0], [0, 0, 1]])
    )
    w1, w2 = tuple(R[:, 0]), tuple(R[:, 1])
    n, ub = circle_max_bound(a2, q, w1, w2)
    S = scale_of(a2, q)
    assert abs(np.dot(n, R[:, 2])) <= 1e-14 and abs(np.linalg.norm(n) - 1) <= 4 * U
    ref = circle_reference(a2, q, np.array(w1), np.array(w2))
    # n is in the plane to rounding, which moves f_q to first order (|q| u): compare the point of the
    # circle nearest to n, in 40 digits (the projection onto span(w1, w2) by the 2 x 2 normal equations)
    with mp.workdps(DPS):
        W = mp.matrix([[mp.mpf(w1[i]), mp.mpf(w2[i])] for i in range(3)])
        coef = mp.lu_solve(W.T * W, W.T * mp.matrix([mp.mpf(x) for x in n]))
        on = W * coef
        assert abs(float(f_q(a2, q, [on[i] for i in range(3)]) - ref)) <= 1e-18 * S
    assert abs(float(f_q(a2, q, n) - ref)) <= 4 * U * S
    assert ub >= float(ref) - 8 * U * S


# --- secular_roots and pole_normal ----------------------------------------------------------------


@st.composite
def generic_point(draw):
    """Distinct semi-axes and q off every coordinate plane (S has three poles)."""
    a = sorted({round(draw(semi), 6) for _ in range(3)})
    while len(a) < 3:
        a.append(a[-1] * 1.5 + 0.01)
    a = draw(st.permutations(a))
    a2 = tuple(x * x for x in a)
    q = tuple(
        draw(st.floats(0.001, 1.0)) * draw(st.sampled_from([-1.0, 1.0])) * draw(st.sampled_from([1.0, 0.1, 1e-3]))
        for _ in range(3)
    )
    return a2, q


def _root_ok(t, ref, a2, q):
    """t is ref to the conditioning of S(t) = 1 (an S rounded by a few u moves the root by u / |S'|)."""
    with mp.workdps(DPS):
        dS = sum(-2 * mp.mpf(ai) * mp.mpf(qi) ** 2 / (ref + mp.mpf(ai)) ** 3 for ai, qi in zip(a2, q))
        tol = 1e-13 * (max(a2) + sum(abs(x) for x in q)) + 64 * U / float(abs(dS))
        return abs(t - float(ref)) <= tol, (t, float(ref), tol)


@settings(max_examples=150)
@given(generic_point())
def test_secular_roots_are_every_candidate_maximum(case):
    """With three poles S = 1 has 2, 4 or 6 real roots (the bracketing reference); secular_roots
    returns the largest one and the pair between the two largest poles, nan where the reference has
    none (S's minimum there above 1: no normal line through q touches that part)."""
    a2, q = case
    roots, gaps = secular_reference(a2, q)
    r1, ra, rb = secular_roots(a2, q, True)
    ok, why = _root_ok(r1, roots[-1], a2, q)
    assert ok, why
    pl, pr, Smin = gaps[-1]  # between the two largest poles (-a2_mid, -a2_min)
    inner = [r for r in roots if pl < r < pr]
    if Smin < 1 - 1e-9:  # two roots, well apart
        for t, ref in zip((ra, rb), inner):
            ok, why = _root_ok(t, ref, a2, q)
            assert ok, why
    elif Smin > 1 + 1e-9:
        assert math.isnan(ra) and math.isnan(rb)
    else:  # nearly a double root: whatever is returned solves S = 1 between the poles
        for t in (ra, rb):
            if not math.isnan(t):
                assert float(pl) < t < float(pr)
    assert math.isnan(secular_roots(a2, q, False)[0])
    # each root is a critical point of f_q: the normal n ~ q / (t + a2) has q - s(n) along n
    for t in (r1, ra, rb):
        if not math.isnan(t):
            x = np.array(a2) * np.array(q) / (t + np.array(a2))
            assert abs(np.sum(x * x / np.array(a2)) - 1) <= 1e-6


@pytest.mark.parametrize(
    "a2, q, expect",
    [
        # q on the long axis of (1, 0.5, 0.2), inside: no root between the poles -0.25, -0.04 (both c = 0)
        ((1.0, 0.25, 0.04), (0.5, 0.0, 0.0), 0),
        # off-axis, near the centre: the evolute's inside, six normals through q (two between the top poles)
        ((1.0, 0.25, 0.04), (0.01, 0.01, 0.01), 2),
        # far outside: two normals only, none between the poles
        ((1.0, 0.25, 0.04), (3.0, 2.0, 1.0), 0),
    ],
)
def test_secular_roots_hand_picked(a2, q, expect):
    roots, _ = secular_reference(a2, q)
    r1, ra, rb = secular_roots(a2, q, True)
    if q[1] == q[2] == 0.0:  # every root left of the pole -a2_min: none there, foot3's is the pole limit
        assert math.isnan(r1) and max(roots) < -min(a2) and foot3(a2, q)[0] == -min(a2)
    else:
        assert _root_ok(r1, roots[-1], a2, q)[0]
    assert (not math.isnan(ra)) + (not math.isnan(rb)) == expect


@pytest.mark.parametrize(
    "q", [(0.5, 1e-9, 1e-8), (0.5, 0.0, 1e-8), (0.5, 1e-3, 1e-8), (0.1, 0.2, 1e-9), (0.5, 0.0, 1e-7)]
)
def test_secular_roots_resolve_roots_hugging_the_poles(q):
    """Roots within 1e-8 of the poles (where foot3 falls short, above): secular_roots has each of them to
    the conditioning of S = 1, the largest and those between the two largest poles."""
    a2 = (1.0, 0.25, 0.04)
    roots, _ = secular_reference(a2, q)
    found = [t for t in secular_roots(a2, q, True) if not math.isnan(t)]
    assert len(found) >= 2
    for t in found:
        ref = min(roots, key=lambda r: abs(r - t))
        ok, why = _root_ok(t, ref, a2, q)
        assert ok, why
    assert _root_ok(found[0], roots[-1], a2, q)[0]


@settings(max_examples=80)
@given(ellipsoid_point())
def test_pole_normal_is_the_critical_point_at_the_pole(case):
    """For q_i = 0 (on a coordinate plane) the pole limit at -a2_i is a critical point of f_q: its foot
    s(n) is on the boundary with q - s(n) along n, and it is one of the reference's points; it is
    refused (ok False) exactly when the reference has no limit point there."""
    a2, q = case
    refs = critical_points(a2, q)
    for i in range(3):
        if q[i] != 0.0 or sum(1 for x in a2 if x == a2[i]) > 1:
            continue
        for sign in (1.0, -1.0):
            ok, n = pole_normal(a2, q, i, sign)
            x = [a2[j] * q[j] / (a2[j] - a2[i]) if j != i else 0.0 for j in range(3)]
            rest = 1 - sum(x[j] ** 2 / a2[j] for j in range(3))
            if rest < -1e-12:
                assert not ok
                continue
            if rest < 1e-12:
                continue  # the limit point meets the coordinate plane: either answer is right
            assert ok
            h, s = support(a2, n)
            r = np.array(q) - np.array(s)
            assert np.linalg.norm(np.cross(r, n)) <= 1e-12 * scale_of(a2, q)
            assert np.sign(s[i]) == sign
            d = min(float(mp.sqrt(sum((mp.mpf(y) - xi) ** 2 for y, xi in zip(s, xr)))) for xr in refs)
            assert d <= 1e-12 * scale_of(a2, q)
