"""The C++ core's distance/branch_and_bound.hpp (its stages through tests/distance_stages.py) on its own: the branch and bound over the sphere and its parts, each against an
independent reference.

sigma(n) = n.e - |diag(a) n| - |diag(b) U^T n| in A's principal frame is written out here in numpy and in
40-digit mpmath (nothing of ellipsim); the global maximum is test_distance.reference (projected gradient
ascent from 300 directions, the best maxima polished by Newton in 40 digits: reference.sigma_stationary).
Checked: sigma_grad (values, the gradient against 40-digit central differences within the documented
rounding bound, the supergradient inequality the patch bounds rest on); the quadtree caps (every point
of a patch is in its cap, the tabulated radii are the circumradii, every direction is in some patch at
every level); certify_region (sigma <= value + tol at points sampled all over the certified region, and
in every cap in_region accepts); global_max (GLOBAL within tol of the reference, seeded or not, SEPARATED_MAX,
the budget's UNPROVEN, flat maxima)."""

import math

import distance_stages as gm
import leaves_poses
import mpmath as mp
import numpy as np
import pytest
import strategies as S
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import sigma_stationary
from scipy.spatial.transform import Rotation as Rot
from test_distance import reference

from ellipsim import Ellipsoids

U64 = 2.0**-53
DPS = 40
I9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


# --- the pair in A's frame, and sigma written out -------------------------------------------------


class Pair:
    """(e, a, U, b) in A's principal frame as global_max takes them (U row-major 9-tuple), with M =
    U diag(b^2) U^T for its Newton, the proof's tolerance in that frame (tol_bb for an exactly
    orthonormal R_A: TOL - 16 u S) and the reference's Ellipsoids."""

    def __init__(self, ca, Ra, ra, cb, Rb, rb):
        Ra, Rb = np.asarray(Ra, float), np.asarray(Rb, float)
        e = Ra.T @ (np.asarray(cb, float) - np.asarray(ca, float))
        Um = Ra.T @ Rb
        self.e, self.a, self.b = tuple(map(float, e)), tuple(map(float, ra)), tuple(map(float, rb))
        self.U = tuple(float(x) for x in Um.ravel())
        self.Um = Um
        self.B2 = Um * np.array(rb, float) ** 2 @ Um.T
        self.M = tuple(float(x) for x in self.B2.ravel())
        self.S = float(np.linalg.norm(e)) + max(ra) + max(rb)
        self.scale = max(max(ra), max(rb))
        rmin = min(min(ra), min(rb))
        self.tol = max(1e-12 * rmin, 96 * U64 * self.S) - 16 * U64 * self.S
        self.err_sigma = gm.ERR_SIGMA_ULPS * U64 * self.S

    def __repr__(self):
        return f"Pair(e={self.e}, a={self.a}, U={self.U}, b={self.b})"

    @classmethod
    def of(cls, A, B):
        return cls(A.centers[0], A.rotations[0], A.radii[0], B.centers[0], B.rotations[0], B.radii[0])

    def ellipsoids(self):
        return Ellipsoids([0.0, 0.0, 0.0], np.eye(3), self.a), Ellipsoids(self.e, self.Um, self.b)

    def sigma(self, n):
        """numpy, any nonzero n (k, 3): sigma at n / |n|."""
        n = np.atleast_2d(n)
        n = n / np.linalg.norm(n, axis=1)[:, None]
        return n @ self.e - np.linalg.norm(n * self.a, axis=1) - np.linalg.norm((n @ self.Um) * self.b, axis=1)

    def sigma_mp(self, n, unit=True):
        """40 digits; homogeneous of degree 1 (unit=False: at n itself)."""
        with mp.workdps(DPS):
            v = [mp.mpf(x) for x in n]
            if unit:
                r = mp.sqrt(sum(x * x for x in v))
                v = [x / r for x in v]
            w = [sum(mp.mpf(self.U[3 * i + j]) * v[i] for i in range(3)) for j in range(3)]  # U^T v
            return (
                sum(mp.mpf(x) * y for x, y in zip(self.e, v))
                - mp.sqrt(sum((mp.mpf(x) * y) ** 2 for x, y in zip(self.a, v)))
                - mp.sqrt(sum((mp.mpf(x) * y) ** 2 for x, y in zip(self.b, w)))
            )

    def run(self, n0=(1.0, 0.0, 0.0), v0=-math.inf, have0=False, max_patches=gm.MAX_PATCHES):
        return gm.global_max(
            tuple(map(float, n0)),
            float(v0),
            bool(have0),
            self.e,
            self.a,
            self.U,
            self.b,
            self.M,
            float(self.scale),
            float(self.tol),
            int(max_patches),
        )

    def certify(self, m):
        return gm.certify_region_call(
            tuple(map(float, m)),
            self.e,
            self.a,
            self.U,
            self.b,
            max(self.a),
            max(self.b),
            float(self.S),
            float(self.err_sigma),
            float(self.tol),
        )


DENSE = None


def reference_max(P):
    """The best of test_distance.reference and of 40-digit polishes (reference.sigma_stationary) from the
    3 best distinct of 20 000 Fibonacci directions and from the 4 best of A's and B's axes (gradient ascent
    alone misses the maxima of thin pairs, where sigma's curvature is ~1 / r_min)."""
    global DENSE
    if DENSE is None:
        from test_distance import fibonacci_sphere

        DENSE = fibonacci_sphere(20_000)
    v = P.sigma(DENSE)
    seeds = []
    for i in np.argsort(-v)[:400]:
        if len(seeds) < 3 and all(DENSE[i] @ m < 0.99 for m in seeds):
            seeds.append(DENSE[i])
    # the axes of A and B: a plate's peak of sigma (width ~ its thickness) lies near its normal
    axes = np.concatenate([np.eye(3), -np.eye(3), P.Um.T, -P.Um.T])
    seeds += list(axes[np.argsort(-P.sigma(axes))[:4]])
    A2 = np.diag(np.array(P.a) ** 2)
    polished = [float(sigma_stationary(P.e, A2, P.B2, m)) for m in seeds]
    return max([reference(*P.ellipsoids()), float(np.max(v))] + polished)


near = st.tuples(*[st.floats(-0.3, 0.3)] * 3).map(np.array)


@st.composite
def crossing_pair(draw):
    """Deep crossings of elongated ellipsoids (several local maxima of sigma: the global one is needed)."""
    a = Ellipsoids.from_quaternions([0, 0, 0], draw(S.quaternions), [draw(st.floats(0.15, 0.4)), 0.03, 0.04])
    b = Ellipsoids.from_quaternions(draw(near) * 0.1, draw(S.quaternions), [draw(st.floats(0.15, 0.4)), 0.035, 0.025])
    return Pair.of(a, b)


@st.composite
def deep_pair(draw):
    """crossing_pair, or a generic random pair with nearby centres (three distinct semi-axes each: the
    flat maxima of concentric spheres and coaxial spheroids are test_flat_maxima's)."""
    if draw(st.booleans()):
        return draw(crossing_pair())
    else:
        distinct = S.radii.map(lambda r: np.sort(r) + np.array([0.0, 0.01, 0.02]))
        a, b = draw(S.ellipsoid(radius=distinct)), draw(S.ellipsoid(radius=distinct, center=near))
        b = Ellipsoids(a.centers + b.centers, b.rotations, b.radii)
    return Pair.of(a, b)


# --- sigma_grad -------------------------------------------------------------------------------------


@settings(max_examples=60)
@given(
    deep_pair(),
    st.tuples(*[st.floats(-2, 2)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-2),
    st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-2),
)
def test_sigma_grad_matches_central_differences(P, c, n):
    """At any nonzero c (sigma is homogeneous: not only unit c): the value and h_A, h_B to rounding,
    the gradient against 40-digit central differences (step 1e-15, error ~1e-30) within the rounding
    bound the module docstring gives it (32 u (S + max b^2 / h_B)), Euler's G.c = sigma(c), and the
    supergradient inequality sigma(n) <= G(c).n for any n (concavity: what every patch bound rests on)."""
    s, G, ha, hb = gm.sigma_grad(c, P.e, P.a, P.U, P.b)
    cn = float(np.linalg.norm(c))
    assert abs(s - float(P.sigma_mp(c, unit=False))) <= 11 * U64 * P.S * cn
    assert s == gm.sigma_only(c, P.e, P.a, P.U, P.b)
    assert ha == pytest.approx(float(np.linalg.norm(np.array(P.a) * c)), rel=4 * U64)
    assert hb == pytest.approx(float(np.linalg.norm((np.array(c) @ P.Um) * P.b)), rel=16 * U64)
    eps = 32 * U64 * (P.S + max(P.b) ** 2 / (hb / cn))
    with mp.workdps(DPS):
        h = mp.mpf(10) ** -15
        for k in range(3):
            up, dn = list(map(mp.mpf, c)), list(map(mp.mpf, c))
            up[k] += h
            dn[k] -= h
            g = (P.sigma_mp(up, unit=False) - P.sigma_mp(dn, unit=False)) / (2 * h)
            assert abs(G[k] - float(g)) <= eps, (k, G[k], float(g), eps)
        assert abs(sum(mp.mpf(x) * y for x, y in zip(G, c)) - P.sigma_mp(c, unit=False)) <= 2 * eps * cn
        # supergradient: sigma(n) <= G.n, to the gradient's rounding (eps |n|)
        assert P.sigma_mp(n, unit=False) <= sum(mp.mpf(x) * y for x, y in zip(G, n)) + eps * float(np.linalg.norm(n))


# --- the quadtree's caps ----------------------------------------------------------------------------


def face_point(face, u, v):
    """The cube face's point for gnomonic (u, v), as the module docstring lays the faces out (face
    2k + 1 the mirror of face 2k): k = 0: (1, u, v), k = 1: (v, 1, u), k = 2: (u, v, 1)."""
    k, sg = face >> 1, (1.0 if face % 2 == 0 else -1.0)
    one = np.ones_like(u)
    p = [np.stack([one, u, v], -1), np.stack([v, one, u], -1), np.stack([u, v, one], -1)][k]
    return sg * p


def patch_samples(face, level, i, j, Qm, k=9):
    """k x k points of the patch's square (edges and corners included), as unit directions, turned by Q."""
    w = 2.0**-level
    u = -1.0 + 2.0 * w * i + np.linspace(0.0, 2.0 * w, k)
    v = -1.0 + 2.0 * w * j + np.linspace(0.0, 2.0 * w, k)
    uu, vv = np.meshgrid(u, v)
    p = face_point(face, uu.ravel(), vv.ravel()) @ Qm.T
    return p / np.linalg.norm(p, axis=1)[:, None]


def chord_to_corners(face, level, i, j):
    c = patch_samples(face, level, i, j, np.eye(3), k=3)
    return float(np.max(np.linalg.norm(c[[0, 2, 6, 8]] - c[4], axis=1)))


@settings(max_examples=40)
@given(
    S.quaternions,
    st.integers(0, 5),
    st.integers(1, 12),
    st.floats(0, 1, exclude_max=True),
    st.floats(0, 1, exclude_max=True),
)
def test_patch_cap_holds_its_patch(q, face, level, fi, fj):
    """Every point of a quadtree patch (81 of its square, edges and corners) lies in the cap patch_cap
    returns, for the tabulated levels (<= RHO_LEVELS) and the Lipschitz radius beyond; its centre is the
    patch's centre; face 2k + 1 is face 2k mirrored."""
    Qm = Rot.from_quat(q).as_matrix()
    Q = tuple(float(x) for x in Qm.ravel())
    n = 1 << level
    i, j = int(fi * n), int(fj * n)
    c, rho = gm.patch_cap(face, level, i, j, Q)
    pts = patch_samples(face, level, i, j, Qm)
    assert np.max(np.linalg.norm(pts - np.array(c), axis=1)) <= rho
    centre = patch_samples(face, level, i, j, Qm, k=3)[4]
    assert np.linalg.norm(centre - np.array(c)) <= 1e-15
    mirror, rho2 = gm.patch_cap(face ^ 1, level, i, j, Q)
    assert np.array_equal(np.array(mirror), -np.array(c)) and rho2 == rho
    corner = chord_to_corners(face, level, i, j)
    if level <= gm.RHO_LEVELS:  # the circumradius itself, rounded up by 1e-14 relative + 4e-15
        assert corner <= rho <= corner * (1 + 1e-13) + 1e-14
    else:  # the Lipschitz radius: at most ~20 % (module docstring) above it
        assert corner <= rho <= corner * 1.25 + 1e-14


def test_rho_table_is_the_circumradius_of_every_patch():
    """The table gm.RHO_TABLE holds for every patch of levels 1..RHO_LEVELS: a dense 17 x 17 sampling of
    each square stays within its radius, and the radius is the largest corner chord."""
    off = 0
    for level in range(1, gm.RHO_LEVELS + 1):
        n = 1 << level
        for i in range(n):
            for j in range(n):
                rho = gm.RHO_TABLE[off + i * n + j]
                pts = patch_samples(0, level, i, j, np.eye(3), k=17)
                c = patch_samples(0, level, i, j, np.eye(3), k=3)[4]
                far = float(np.max(np.linalg.norm(pts - c, axis=1)))
                assert far <= rho <= chord_to_corners(0, level, i, j) * (1 + 1e-13) + 1e-14
        off += n * n
    assert off == len(gm.RHO_TABLE)


@pytest.mark.parametrize("level", [1, 3, 5, 6, 9])
def test_every_direction_lies_in_a_patch_cap(level):
    """The cover is complete: each of 3000 directions (a random turn Q of the cube) is in the cap of the
    patch that holds it, found here from its gnomonic coordinates (no direction falls between patches)."""
    rng = np.random.default_rng(level)
    Qm = Rot.random(random_state=rng).as_matrix()
    Q = tuple(float(x) for x in Qm.ravel())
    dirs = rng.normal(size=(3000, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    dirs[:6] = (
        np.array([[1, 1, 1], [1, -1, 1], [-1, 1, 1], [1, 1, -1], [1, 0, 0], [0, 0, -1]], float) @ Qm.T
    )  # corners, centres
    dirs[:6] /= np.linalg.norm(dirs[:6], axis=1)[:, None]
    n = 1 << level
    for d in dirs:
        x = Qm.T @ d
        k = int(np.argmax(np.abs(x)))
        sg = 1.0 if x[k] > 0 else -1.0
        u, v = {0: (x[1], x[2]), 1: (x[2], x[0]), 2: (x[0], x[1])}[k]
        u, v = u / x[k], v / x[k]
        i, j = min(int((u + 1) / 2 * n), n - 1), min(int((v + 1) / 2 * n), n - 1)
        c, rho = gm.patch_cap(2 * k + (sg < 0), level, i, j, Q)
        assert np.linalg.norm(d - np.array(c)) <= rho


# --- certify_region ---------------------------------------------------------------------------------


def seeded_deep_pairs(k, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(k):
        Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
        ra = [rng.uniform(0.15, 0.4), rng.uniform(0.02, 0.06), rng.uniform(0.02, 0.06)]
        rb = [rng.uniform(0.15, 0.4), rng.uniform(0.02, 0.06), rng.uniform(0.02, 0.06)]
        out.append(Pair([0, 0, 0], Ra, ra, rng.uniform(-0.03, 0.03, 3), Rb, rb))
    return out


def local_maxima(P, k=3):
    """Distinct local maxima of sigma: numpy projected gradient ascent from 300 directions."""
    from test_distance import fibonacci_sphere

    n = fibonacci_sphere(300)
    step = 0.2 / max(max(P.a), max(P.b))
    A2, B2 = np.diag(np.array(P.a) ** 2), P.Um * np.array(P.b) ** 2 @ P.Um.T
    for _ in range(800):
        ga, gb = n @ A2, n @ B2
        g = np.array(P.e) - ga / np.sqrt(np.sum(n * ga, 1))[:, None] - gb / np.sqrt(np.sum(n * gb, 1))[:, None]
        n = n + step * (g - np.sum(g * n, 1)[:, None] * n)
        n /= np.linalg.norm(n, axis=1)[:, None]
    v = P.sigma(n)
    out = []
    for i in np.argsort(-v):
        if all(n[i] @ m < 0.999 for m in out):
            out.append(n[i])
    return out[:k]


def region_parts(reg):
    m, t1, t2 = np.array(reg[0:3]), np.array(reg[3:6]), np.array(reg[6:9])
    Ki = np.array([[reg[9], reg[10]], [reg[10], reg[11]]])
    Pm = np.array([[reg[13], reg[14]], [reg[14], reg[15]]])
    return m, t1, t2, Ki, Pm, reg[16], reg[17], reg[18], reg[19]


def in_omega(reg, x):
    """The certified set in plane coordinates x (k, 2), as certify_region defines it: the ellipse
    |K^-1 x| <= 1 united with |K^-1 x| (|V'| |x|^2 + 2 |g| |x|) <= x^T P x."""
    m, t1, t2, Ki, Pm, Vp, g, _, _ = region_parts(reg)
    kx = np.linalg.norm(x @ Ki, axis=1)
    r = np.linalg.norm(x, axis=1)
    return (kx <= 1) | (kx * (Vp * r * r + 2 * g * r) <= np.einsum("ki,ij,kj->k", x, Pm, x))


def assert_below(P, dirs, bound):
    """sigma <= bound at every direction (float where it is 1e-10 clear, else 40 digits)."""
    v = P.sigma(dirs)
    close = v > bound - 1e-10
    for d in dirs[close]:
        assert P.sigma_mp(d) <= bound, (d, float(P.sigma_mp(d)), bound)
    assert np.all(v[~close] <= bound)


def thin_deep_pairs(k, seed):
    """Plates 1 x 0.01 x 0.5 across 0.3 x 0.3 x 0.01, and leaves 25:10:1 nearly coplanar, alternately
    (the separated ones dropped: a region is certified only where sigma < 0)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(k):
        Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
        if i % 2:
            Rb = (
                Ra
                @ Rot.from_rotvec(
                    [rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0, 2 * np.pi)]
                ).as_matrix()
            )
            ra, rb = [0.025, 0.01, 0.001], list(np.array([0.025, 0.01, 0.001]) * rng.uniform(0.5, 1.5))
            cb = Ra @ (rng.uniform(-0.01, 0.01, 3) * np.array([1, 1, 0.1]))
        else:
            ra, rb, cb = [1.0, 0.01, 0.5], [0.3, 0.3, 0.01], rng.uniform(-0.3, 0.3, 3)
        out.append(Pair([0, 0, 0], Ra, ra, cb, Rb, rb))
    return out


@pytest.fixture(scope="module")
def certified():
    """(pair, value, region) for the two best local maxima of 6 deep crossings (12 tries) and for the
    global maximum of each deep one of 8 thin pairs."""
    out, thin = [], 0
    for P in seeded_deep_pairs(6, 19):
        for m in local_maxima(P, 2):
            ok, mm, v, reg = P.certify(m)
            if ok:
                out.append((P, v, reg))
    crossing = len(out)
    for P in thin_deep_pairs(8, 21):
        status, n, value, count, runs = P.run()
        if value < 0:
            thin += 1
            ok, mm, v, reg = P.certify(n)
            assert ok, P  # the maximum global_max proved is strict: certified again from its normal
            out.append((P, v, reg))
    assert crossing >= 9 and thin >= 5, (crossing, thin)
    return out


def test_certify_region_certifies_strict_local_maxima(certified):
    """Deep crossings' maxima are strict: most of them (>= 9 of 12) get a region, and so does every
    deep thin pair's maximum (the fixture), each with its maximum m the polished local maximum (sigma's
    tangent gradient ~0 there, to 1e-7 of S) and R_in > 0."""
    for P, v, reg in certified:
        m = np.array(reg[0:3])
        assert abs(np.linalg.norm(m) - 1) <= 1e-15 and reg[18] > 0 and reg[19] >= reg[18]
        assert abs(v - float(P.sigma_mp(m))) <= P.err_sigma
        t1, t2 = np.array(reg[3:6]), np.array(reg[6:9])
        for t in (t1, t2):  # directional derivative along the tangent plane vanishes
            h = 1e-6
            d = (P.sigma(m + h * t) - P.sigma(m - h * t))[0] / (2 * h)
            assert abs(d) <= 1e-7 * P.S
        # the region's claim at its tightest, at m's own local maximum (40-digit Newton polish)
        assert float(sigma_stationary(P.e, np.diag(np.array(P.a) ** 2), P.B2, m)) <= v + P.tol


@settings(max_examples=30)
@given(crossing_pair(), st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-2))
def test_climb_ends_at_a_local_maximum(P, c):
    """climb (Newton from c, given the semi-axes a) converges to a local maximum of sigma: the 40-digit
    polish from m moves sigma by no more than rounding.  The value it returns is sigma before Newton's
    last step (sigma.newton; a step below NEWTON_STEP_TOL = 1e-5 rad): never above that maximum, and
    within ~|Hess| 1e-10 below it."""
    c = np.array(c) / np.linalg.norm(c)
    conv, m, v = gm.climb(tuple(map(float, c)), P.e, P.a, P.M, float(P.scale))
    assert conv and abs(np.linalg.norm(m) - 1) <= 1e-15
    polished = sigma_stationary(P.e, np.diag(np.array(P.a) ** 2), P.B2, m)
    assert abs(P.sigma_mp(m) - polished) <= P.err_sigma
    assert float(polished) - 1e-9 * P.S <= v <= float(polished) + P.err_sigma


def test_certified_region_bounds_sigma(certified):
    """sigma <= value + tol everywhere in Omega: on 2000 points of the inscribed cap (chord R_in around
    m), 2000 of the ellipse {K z : |z| <= 1} and every one of 20 000 points of the plane disk of radius
    tan(2 asin(R_out / 2)) that lies in Omega (the second set included: checked to be met)."""
    rng = np.random.default_rng(7)
    outer = 0
    for P, v, reg in certified:
        m, t1, t2, Ki, Pm, Vp, g, R_in, R_out = region_parts(reg)
        bound = v + P.tol
        # the inscribed cap: chord <= R_in
        th = rng.uniform(0, 2 * np.pi, 2000)
        ang = 2 * np.arcsin(R_in / 2) * np.sqrt(rng.uniform(0, 1, 2000))
        caps = np.cos(ang)[:, None] * m + np.sin(ang)[:, None] * (np.cos(th)[:, None] * t1 + np.sin(th)[:, None] * t2)
        assert np.all(np.linalg.norm(caps - m, axis=1) <= R_in * (1 + 1e-12))
        assert_below(P, caps, bound)
        # the ellipse
        K = np.linalg.inv(Ki)
        z = rng.normal(size=(2000, 2))
        z *= (np.sqrt(rng.uniform(0, 1, 2000)) / np.linalg.norm(z, axis=1))[:, None]
        x = z @ K.T
        assert_below(P, m + x[:, :1] * t1 + x[:, 1:] * t2, bound)
        # Omega within the disk of R_out
        rmax = math.tan(2 * math.asin(R_out / 2)) if R_out < 1.4 else 10.0
        z = rng.normal(size=(20000, 2))
        x = z * (rmax * np.sqrt(rng.uniform(0, 1, 20000)) / np.linalg.norm(z, axis=1))[:, None]
        inside = in_omega(reg, x)
        outer += int(np.sum(inside & (np.linalg.norm(x @ Ki, axis=1) > 1)))
        x = x[inside]
        assert_below(P, m + x[:, :1] * t1 + x[:, 1:] * t2, bound)
    assert outer > 0  # the set beyond the ellipse was sampled too


def test_in_region_accepts_only_caps_inside_the_region(certified):
    """Every cap (c, rho) that in_region accepts lies in Omega and below value + tol: 300 points of each
    accepted cap; caps near m of every size are tried and a fair share is accepted."""
    rng = np.random.default_rng(8)
    accepted = 0
    for P, v, reg in certified:
        m, t1, t2, Ki, Pm, Vp, g, R_in, R_out = region_parts(reg)
        for _ in range(40):
            rho = float(R_out * 10.0 ** rng.uniform(-3, 0))
            off = rng.normal(size=3)
            c = m + off / np.linalg.norm(off) * R_out * rng.uniform(0, 1.2)
            c = c / np.linalg.norm(c)
            if not gm.in_region(tuple(map(float, c)), rho, reg):
                continue
            accepted += 1
            w = rng.normal(size=(300, 3))
            w -= (w @ c)[:, None] * c
            w /= np.linalg.norm(w, axis=1)[:, None]
            ang = 2 * np.arcsin(rho / 2) * np.sqrt(rng.uniform(0, 1, 300))
            pts = np.cos(ang)[:, None] * c + np.sin(ang)[:, None] * w  # chord <= rho from c
            s = pts @ m
            assert np.all(s > 0)
            x = np.stack([pts @ t1, pts @ t2], 1) / s[:, None]  # central projection onto the tangent plane
            assert np.all(in_omega(reg, x))
            assert_below(P, pts, v + P.tol)
    assert accepted >= 40


# --- global_max -------------------------------------------------------------------------------------


def check_global(P, status, n, value):
    assert abs(np.linalg.norm(n) - 1) <= 1e-14
    assert abs(value - float(P.sigma_mp(n))) <= P.err_sigma  # sigma(n) as computed
    ref = reference_max(P)
    if status in (gm.GLOBAL, gm.SEPARATED_MAX):
        assert ref <= value + P.tol, (ref, value, P.tol)  # the proof's claim
        # and n is (to tol) the maximum of its own basin: the 40-digit polish from it gains no more
        local = float(sigma_stationary(P.e, np.diag(np.array(P.a) ** 2), P.B2, n))
        assert value - P.err_sigma <= local <= value + P.tol, (local, value)
    return ref


@settings(max_examples=50)
@given(deep_pair())
def test_global_max_is_within_tol_of_the_reference(P):
    """Unseeded (have0 False): every generic pair ends GLOBAL (or SEPARATED_MAX for a separated one) and
    the 40-digit reference maximum is at most value + tol (the proof's claim, tol_bb of A's frame)."""
    status, n, value, count, runs = P.run()
    assert status in (gm.GLOBAL, gm.SEPARATED_MAX), (status, count)
    check_global(P, status, n, value)
    if status == gm.SEPARATED_MAX:
        assert value > 0


def test_seeded_deep_pairs_are_proven_from_every_local_maximum():
    """Seeded with each local maximum in turn (the narrow phase hands over its first run's), the proof
    reaches the global one: the same value to tol whatever the seed."""
    for P in seeded_deep_pairs(4, 2026):
        values = []
        for m in local_maxima(P, 3):
            status, n, value, count, runs = P.run(m, P.sigma(m)[0], True)
            assert status == gm.GLOBAL
            values.append(value)
        ref = check_global(P, status, n, value)
        assert max(values) - min(values) <= P.tol and ref <= min(values) + P.tol


@pytest.mark.parametrize("pose", leaves_poses.POSES, ids=lambda p: f"step{p['step']}")
def test_leaves_contacts_seeded_with_the_wrong_maximum(pose):
    """MuJoCo's leaves.xml contacts where the first release stopped at a local maximum: seeded with that
    (the climb from the centre line's direction that lands there), the branch and bound finds sigma
    above MuJoCo's normal and well above the first release's value."""
    P = Pair(pose["ca"], pose["Ra"], pose["ra"], pose["cb"], pose["Rb"], pose["rb"])
    d = np.array(P.e) / np.linalg.norm(P.e)
    conv, m, v = gm.climb(tuple(map(float, d)), P.e, P.a, P.M, float(P.scale))
    status, n, value, count, runs = P.run(m, v, conv)
    assert status == gm.GLOBAL
    check_global(P, status, n, value)
    assert value >= pose["sigma_mujoco"] and value - pose["base"] > 1e-7


def test_separated_pair_ends_at_the_first_positive_maximum():
    """A separated pair: the first climb reaches sigma > 0, which is global (sigma concave on the ball):
    SEPARATED_MAX with the distance of the two (spheres: |d| - r_a - r_b)."""
    P = Pair(
        [0, 0, 0],
        np.eye(3),
        [0.3, 0.3, 0.3],
        [0.5, 0.4, -0.2],
        Rot.from_rotvec([0.1, 0.2, 0.3]).as_matrix(),
        [0.2, 0.2, 0.2],
    )
    status, n, value, count, runs = P.run()
    assert status == gm.SEPARATED_MAX and runs >= 1
    assert value == pytest.approx(math.sqrt(0.5**2 + 0.4**2 + 0.2**2) - 0.5, abs=1e-15)
    q = Pair(
        [0, 0, 0],
        np.eye(3),
        [0.3, 0.1, 0.05],
        [0.2, 0.3, 0.1],
        Rot.from_rotvec([1.0, -0.5, 0.2]).as_matrix(),
        [0.15, 0.05, 0.1],
    )
    status, n, value, count, runs = q.run()
    assert status == gm.SEPARATED_MAX and value > 0
    check_global(q, status, n, value)


def test_budget_runs_out_unproven():
    """max_patches too small for the proof: UNPROVEN after max_patches + 1 nodes, with the best point found
    (sigma at the returned normal, never above the maximum)."""
    P = seeded_deep_pairs(1, 5)[0]
    full = P.run()
    assert full[0] == gm.GLOBAL and full[3] > 20
    status, n, value, count, runs = P.run(max_patches=10)
    assert status == gm.UNPROVEN and count == 11
    check_global(P, status, n, value)


def test_flat_maxima():
    """Concentric spheres (sigma constant) and concentric coaxial spheroids (maxima on circles): whatever
    the status, the value is sigma at the normal; where GLOBAL, it is the maximum to tol."""
    for ra, rb, best in [((0.5,) * 3, (0.3,) * 3, -0.8), ((0.5, 0.5, 0.2), (0.3, 0.3, 0.7), -0.8)]:
        P = Pair([0, 0, 0], np.eye(3), ra, [0, 0, 0], np.eye(3), rb)
        status, n, value, count, runs = P.run(max_patches=2000)
        assert abs(value - float(P.sigma_mp(n))) <= P.err_sigma and value <= best + P.err_sigma
        if status == gm.GLOBAL:
            assert best <= value + P.tol


@pytest.mark.parametrize("kind", ["aspect 1:100-1:1000", "leaves 25:10:1"])
def test_thin_pairs_are_proven_within_tol_of_the_reference(kind):
    """20 seeded pairs each: a plate 1 x 1/k x 0.5 across a needle-ended 0.3 x 0.3 x 1/k (k = 100, 1000),
    centres within 0.3; two leaves of 25:10:1 (MuJoCo's leaves.xml sizes) nearly coplanar and crossing.
    Every one ends GLOBAL or SEPARATED_MAX, within tol of the reference."""
    rng = np.random.default_rng(19 if kind.startswith("aspect") else 20)
    for _ in range(20):
        Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
        if kind.startswith("aspect"):
            big = 10.0 ** rng.integers(2, 4)
            ra, rb, cb = [1.0, 1.0 / big, 0.5], [0.3, 0.3, 1.0 / big], rng.uniform(-0.3, 0.3, 3)
        else:
            Rb = (
                Ra
                @ Rot.from_rotvec(
                    [rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0, 2 * np.pi)]
                ).as_matrix()
            )
            ra, rb = [0.025, 0.01, 0.001], list(np.array([0.025, 0.01, 0.001]) * rng.uniform(0.5, 1.5))
            cb = Ra @ (rng.uniform(-0.01, 0.01, 3) * np.array([1, 1, 0.1]))
        P = Pair([0, 0, 0], Ra, ra, cb, Rb, rb)
        status, n, value, count, runs = P.run()
        assert status in (gm.GLOBAL, gm.SEPARATED_MAX), (status, count, P)
        check_global(P, status, n, value)
