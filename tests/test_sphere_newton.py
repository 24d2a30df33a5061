"""The C++ core's distance/sphere_newton.hpp (its stages through tests/distance_stages.py) on its own: the pair in A's principal frame (a_frame), sigma, unit,
tangent_basis, rolling_radius, bisector_seed and the Riemannian Newton run (newton), each against an
independent reference.

The references use nothing of ellipsim: the frame is numpy's R_A^T (c_B - c_A) and R_A^T R_B; sigma is
written from the support function h(n) = |D R^T n| (Schneider & Eberly, Geometric Tools 10.5.2) in
40-digit mpmath, with B's term through U (not through the module's M = U diag(b^2) U^T); Newton's
gradient and Hessian are checked by one step against 40-digit central differences of
F(x) = sigma((n + x) / |n + x|) in the step's own tangent plane; its maxima against the analytic
Riemannian gradient and Hessian in mpmath (the remaining Newton step), sigma at nearby directions and
reference.sigma_stationary (a 40-digit Newton polish on the Lagrange system); separated and touching
pairs are built around a known normal m and gap, their distance bracketed in 40 digits by weak duality
(sigma(m) <= dist <= |x_B - x_A| for the support points x_A, x_B at m).  rolling_radius is checked
against balls placed inside the ellipsoid, bisector_seed against the normals of A and B where the centre
line leaves them."""

import math

import distance_stages as sn
import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import fibonacci, sigma_stationary
from scipy.spatial.transform import Rotation as Rot

from ellipsim.core.tolerances import NEWTON_MAX_ITER, NEWTON_STEP_TOL

U64 = 2.0**-53
DPS = 40
NEG_INF = -math.inf


# --- the pair, and sigma written out ---------------------------------------------------------------


class Pair:
    """Two ellipsoids in world coordinates; the reference frame (e, U) by numpy, the library's by a_frame."""

    def __init__(self, ca, Ra, ra, cb, Rb, rb):
        self.ca, self.cb = np.asarray(ca, float), np.asarray(cb, float)
        self.Ra, self.Rb = np.asarray(Ra, float), np.asarray(Rb, float)
        self.ra, self.rb = np.asarray(ra, float), np.asarray(rb, float)
        self.d = self.cb - self.ca
        self.e_np = self.Ra.T @ self.d
        self.U_np = self.Ra.T @ self.Rb
        A = (tuple(map(float, self.ca)), tuple(map(float, self.Ra.ravel())), tuple(map(float, self.ra)))
        B = (tuple(map(float, self.cb)), tuple(map(float, self.Rb.ravel())), tuple(map(float, self.rb)))
        self.e, self.a2, self.M, self.U = sn.a_frame(A, B)
        self.S = float(np.linalg.norm(self.d) + self.ra.max() + self.rb.max())
        self.scale = float(max(self.ra.max(), self.rb.max()))

    def __repr__(self):
        return f"Pair({self.ca.tolist()}, {self.Ra.tolist()}, {self.ra.tolist()}, {self.cb.tolist()}, ...)"

    def sigma_np(self, n):
        """numpy, directions (k, 3) in A's frame, scaled to unit length."""
        n = np.atleast_2d(n)
        n = n / np.linalg.norm(n, axis=1)[:, None]
        return n @ self.e_np - np.linalg.norm(n * self.ra, axis=1) - np.linalg.norm((n @ self.U_np) * self.rb, axis=1)

    def parts_mp(self, n):
        """(sigma, h_A, h_B) at n / |n| (A's frame, floats or mpf) in 40 digits."""
        with mp.workdps(DPS):
            v = [x if isinstance(x, mp.mpf) else mp.mpf(float(x)) for x in n]
            r = mp.sqrt(sum(x * x for x in v))
            v = [x / r for x in v]
            w = [sum(mp.mpf(float(self.U_np[i, j])) * v[i] for i in range(3)) for j in range(3)]
            ha = mp.sqrt(sum((mp.mpf(float(x)) * y) ** 2 for x, y in zip(self.ra, v)))
            hb = mp.sqrt(sum((mp.mpf(float(x)) * y) ** 2 for x, y in zip(self.rb, w)))
            return sum(mp.mpf(float(x)) * y for x, y in zip(self.e_np, v)) - ha - hb, ha, hb

    def sigma_mp(self, n):
        return self.parts_mp(n)[0]

    def riemannian(self, n):
        """Analytic Riemannian gradient (3,) and Hessian (3 x 3, on the tangent plane; -1 along n) of sigma
        on the unit sphere at the unit n, in 40 digits: P grad, P Hess P - sigma I."""
        with mp.workdps(DPS):
            v = mp.matrix([mp.mpf(float(x)) for x in n])
            v /= mp.norm(v)
            Aq = mp.diag([mp.mpf(float(x)) ** 2 for x in self.ra])
            Um = mp.matrix(self.U_np.tolist())
            Bq = Um * mp.diag([mp.mpf(float(x)) ** 2 for x in self.rb]) * Um.T
            an, bn = Aq * v, Bq * v
            ha, hb = mp.sqrt((v.T * an)[0]), mp.sqrt((v.T * bn)[0])
            e = mp.matrix([mp.mpf(float(x)) for x in self.e_np])
            s = (v.T * e)[0] - ha - hb
            g = e - an / ha - bn / hb
            H = -(Aq / ha - an * an.T / ha**3) - (Bq / hb - bn * bn.T / hb**3)
            P = mp.eye(3) - v * v.T
            return P * g, P * H * P - s * P - v * v.T

    def remaining_step(self, n):
        """|Hess^-1 grad| on the tangent plane at n (rad): how far Newton would still move."""
        g, H = self.riemannian(n)
        with mp.workdps(DPS):
            return float(mp.norm(mp.lu_solve(H, g)))

    def newton(self, n0, max_iter=NEWTON_MAX_ITER, target=NEG_INF):
        return sn.newton(tuple(map(float, n0)), self.e, self.a2, self.M, self.scale, float(target), int(max_iter))

    def polished(self, n):
        """reference.sigma_stationary from n (40 digits)."""
        Ma = self.Ra * self.ra**2 @ self.Ra.T
        Mb = self.Rb * self.rb**2 @ self.Rb.T
        return sigma_stationary(self.d, Ma, Mb, self.Ra @ np.asarray(n, float))


def unit_np(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def random_pair(rng, aspect_max=1e3, spread=(0.1, 1.0, 4.0)):
    """A random pair: A (1, 1/k, w) and B (w', 1, 1/k') times a size, k, k' log-uniform in [1, aspect_max],
    turned at random, the centre offset at one of three spreads (deep, crossing, apart)."""
    Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
    ka, kb = 10.0 ** rng.uniform(0, np.log10(aspect_max), 2)
    ra = np.array([1.0, 1.0 / ka, rng.uniform(0.2, 1.0)]) * rng.uniform(0.5, 2.0)
    rb = np.array([rng.uniform(0.2, 1.0), 1.0, 1.0 / kb]) * rng.uniform(0.5, 2.0)
    cb = rng.normal(size=3) * rng.choice(spread)
    return Pair(rng.normal(size=3), Ra, ra, cb, Rb, rb)


def support_point(c, R, r, m):
    """c + grad h(m) = c + R D^2 R^T m / |D R^T m| in 40 digits (mpmath lists): the point of the ellipsoid
    farthest along the unit m, on its boundary to 40 digits."""
    with mp.workdps(DPS):
        R = mp.matrix(np.asarray(R, float).tolist())
        m = mp.matrix([mp.mpf(float(x)) for x in m])
        D2 = mp.diag([mp.mpf(float(x)) ** 2 for x in r])
        q = R.T * m
        h = mp.sqrt((q.T * D2 * q)[0])
        return mp.matrix([mp.mpf(float(x)) for x in c]) + R * D2 * q / h


def touching_pair(rng, gap_rel, aspect_max=1e3):
    """(pair, m in A's frame): B placed so that its support point at -m is A's at m plus gap m, for a
    random unit m and gap = gap_rel times the larger semi-axis: the distance is gap and m the normal (to
    the rounding of c_B, bracketed in the tests)."""
    P = random_pair(rng, aspect_max)
    gap = gap_rel * P.scale
    m = unit_np(rng.normal(size=3))
    pa = support_point(P.ca, P.Ra, P.ra, m)
    gb = support_point(np.zeros(3), P.Rb, P.rb, m)  # c_B - (B's support point at -m)
    with mp.workdps(DPS):
        cb = [float(pa[i] + mp.mpf(gap) * m[i] + gb[i]) for i in range(3)]
    Q = Pair(P.ca, P.Ra, P.ra, cb, P.Rb, P.rb)
    return Q, P.Ra.T @ m


# --- a_frame, sigma ---------------------------------------------------------------------------------


def test_a_frame_is_the_pair_in_As_principal_frame():
    """e = R_A^T (c_B - c_A) and U = R_A^T R_B to the rounding of their dot products, a2 = r_A^2 exactly, M
    exactly symmetric and U diag(r_B^2) U^T (of the returned U, in 40 digits) to a few u max r_B^2."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        P = random_pair(rng)
        assert np.all(np.abs(np.array(P.e) - P.e_np) <= 8 * U64 * (np.abs(P.d).sum() + np.abs(P.e_np).max()))
        assert np.all(np.abs(np.array(P.U) - P.U_np.ravel()) <= 4 * U64)
        assert P.a2 == tuple(float(x) * float(x) for x in P.ra)
        M = np.array(P.M).reshape(3, 3)
        assert np.array_equal(M, M.T)
        with mp.workdps(DPS):
            Um = mp.matrix(np.array(P.U).reshape(3, 3).tolist())
            ref = Um * mp.diag([mp.mpf(float(x)) ** 2 for x in P.rb]) * Um.T
            for i in range(3):
                for j in range(3):
                    assert abs(M[i, j] - ref[i, j]) <= 8 * U64 * P.rb.max() ** 2


@st.composite
def pairs_and_directions(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    aspect = 10.0 ** draw(st.floats(0.0, 3.0))
    P = random_pair(np.random.default_rng(seed), aspect)
    n = np.array(draw(st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-4)))
    return P, n * 10.0 ** draw(st.floats(-3.0, 3.0))


@settings(max_examples=80)
@given(pairs_and_directions(), st.integers(-20, 20))
def test_sigma_is_the_support_function_difference(pn, k):
    """sigma(n) = u.e - h_A(u) - h_B(u) at u = n / |n| for any nonzero n: against 40 digits within the
    rounding of h_B through M (u max b^2 / h_B per entry) and of the rest (u S); exactly invariant
    under n -> 2^k n (the scaling is exact)."""
    P, n = pn
    s = sn.sigma(tuple(map(float, n)), P.e, P.a2, P.M)
    ref, _, hb = P.parts_mp(n)
    assert abs(s - float(ref)) <= 32 * U64 * (P.S + P.rb.max() ** 2 / float(hb)), (s, float(ref))
    assert sn.sigma(tuple(float(x) * 2.0**k for x in n), P.e, P.a2, P.M) == s


def test_sigma_of_spheres_is_the_closed_form():
    """Spheres: sigma(n) = n.e / |n| - r_A - r_B."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        ra, rb = rng.uniform(0.1, 2.0, 2)
        P = Pair(
            rng.normal(size=3),
            Rot.random(random_state=rng).as_matrix(),
            [ra] * 3,
            rng.normal(size=3),
            np.eye(3),
            [rb] * 3,
        )
        n = rng.normal(size=3)
        ref = float(np.dot(unit_np(n), P.e_np) - ra - rb)
        assert sn.sigma(tuple(n), P.e, P.a2, P.M) == pytest.approx(ref, abs=16 * U64 * P.S)


# --- unit, tangent_basis, rolling_radius ------------------------------------------------------------


def test_unit_normalises_and_falls_back_on_zero():
    """unit(v) is v / |v| (norm 1 to 2 u, parallel to v to 2 u) over magnitudes 1e-100..1e100; unit(0) = e_x."""
    rng = np.random.default_rng(5)
    for _ in range(500):
        v = rng.normal(size=3) * 10.0 ** rng.uniform(-100, 100)
        u = np.array(sn.unit(tuple(v)))
        assert abs(np.linalg.norm(u) - 1.0) <= 2 * U64
        assert np.linalg.norm(u - v / np.linalg.norm(v)) <= 4 * U64
    assert sn.unit((0.0, 0.0, 0.0)) == (1.0, 0.0, 0.0)
    assert sn.unit((0.0, -3.0, 0.0)) == (0.0, -1.0, 0.0)


@pytest.mark.parametrize("kind", ["random", "axes", "near 0.6"])
def test_tangent_basis_completes_a_right_handed_frame(kind):
    """(t1, t2, n) is orthonormal to 8 u (Gram matrix) and right-handed (t1 x t2 = n), on both branches of the
    construction (|n_x| < 0.6 or not), at the axes and at the switch."""
    rng = np.random.default_rng(7)
    if kind == "random":
        ns = rng.normal(size=(500, 3))
    elif kind == "axes":
        ns = np.concatenate([np.eye(3), -np.eye(3)])
    else:
        x = 0.6 + rng.uniform(-1e-9, 1e-9, 200)
        r = np.sqrt(1 - x * x)
        ph = rng.uniform(0, 2 * np.pi, 200)
        ns = np.stack([x * rng.choice([-1, 1], 200), r * np.cos(ph), r * np.sin(ph)], 1)
    for n in ns:
        n = tuple(map(float, sn.unit(tuple(n))))
        t1, t2 = (np.array(t) for t in sn.tangent_basis(n))
        F = np.stack([t1, t2, np.array(n)])
        assert np.all(np.abs(F @ F.T - np.eye(3)) <= 8 * U64)
        assert np.linalg.norm(np.cross(t1, t2) - np.array(n)) <= 8 * U64


def ellipsoid_q(r, x):
    return np.sum((x / r) ** 2, axis=-1)


def test_rolling_radius_is_the_largest_ball_that_rolls_inside():
    """rolling_radius(r) = r_min^2 / r_max: the ball of that radius tangent inside at 300 boundary points
    (centre p - rho nu, nu the outward normal) stays inside to rounding (2000 points of its sphere), and
    at the end of the longest axis one 1 % larger pokes out (its circle in the longest-shortest plane)."""
    rng = np.random.default_rng(9)
    ball = fibonacci(2000)
    for _ in range(20):
        r = np.array([1.0, 10.0 ** -rng.uniform(0, 3), 10.0 ** -rng.uniform(0, 3)]) * rng.uniform(0.1, 10)
        r = r[rng.permutation(3)]
        rho = sn.rolling_radius(tuple(r))
        assert rho == pytest.approx(r.min() ** 2 / r.max(), rel=2 * U64)
        p = fibonacci(300) * r  # boundary points (not uniform: fine)
        nu = p / r**2
        nu /= np.linalg.norm(nu, axis=1)[:, None]
        for pk, nk in zip(p, nu):
            assert ellipsoid_q(r, pk - rho * nk + rho * ball).max() <= 1 + 1e-9
        i, k = int(np.argmax(r)), int(np.argmin(r))
        th = np.linspace(-0.5, 0.5, 20001)
        big = rho * 1.01
        pts = np.zeros((len(th), 3))
        pts[:, i] = r[i] - big + big * np.cos(th)
        pts[:, k] = big * np.sin(th)
        assert ellipsoid_q(r, pts).max() > 1 + 1e-12


# --- bisector_seed ----------------------------------------------------------------------------------


def test_bisector_seed_bisects_the_normals_on_the_centre_line():
    """The seed is the unit bisector of A's outward normal where the ray c_A -> c_B leaves A (Q_A e) and
    B's where the ray leaves B on the same side (Q_B e, Q = R D^-2 R^T), to 1e-13 rad; spheres: e / |e|."""
    rng = np.random.default_rng(13)
    for _ in range(200):
        P = random_pair(rng)
        rb2 = tuple(float(x) ** 2 for x in P.rb)
        seed = np.array(sn.bisector_seed(P.e, P.a2, P.U, rb2))
        na = unit_np(P.e_np / P.ra**2)
        nb = unit_np(P.U_np @ ((P.U_np.T @ P.e_np) / P.rb**2))
        ref = unit_np(na + nb)
        assert abs(np.linalg.norm(seed) - 1) <= 4 * U64
        assert np.linalg.norm(seed - ref) <= 1e-13, (seed, ref)
    P = Pair([0, 0, 0], np.eye(3), [0.3] * 3, [1.0, -2.0, 0.5], Rot.random(random_state=rng).as_matrix(), [0.7] * 3)
    seed = sn.bisector_seed(P.e, P.a2, P.U, (0.49,) * 3)
    assert np.linalg.norm(np.array(seed) - unit_np(P.e_np)) <= 1e-15


# --- newton: one step against 40-digit differences ---------------------------------------------------


def reference_step(P, n):
    """The Newton step x (2,) in tangent_basis(n)'s coordinates for F(x) = sigma((n + x) / |n + x|), its
    gradient and Hessian by 40-digit central differences (step 1e-12: error ~1e-24 relative), and the
    Hessian (2 x 2)."""
    t1, t2 = (np.array(t) for t in sn.tangent_basis(tuple(map(float, n))))
    with mp.workdps(DPS):
        nm = [mp.mpf(float(x)) for x in n]
        T = [[mp.mpf(float(x)) for x in t1], [mp.mpf(float(x)) for x in t2]]
        h = mp.mpf(10) ** -12

        def F(x1, x2):
            return P.sigma_mp([nm[i] + x1 * T[0][i] + x2 * T[1][i] for i in range(3)])

        f0 = F(0, 0)
        g = [(F(h, 0) - F(-h, 0)) / (2 * h), (F(0, h) - F(0, -h)) / (2 * h)]
        H11 = (F(h, 0) - 2 * f0 + F(-h, 0)) / h**2
        H22 = (F(0, h) - 2 * f0 + F(0, -h)) / h**2
        H12 = (F(h, h) - F(h, -h) - F(-h, h) + F(-h, -h)) / (4 * h * h)
        H = mp.matrix([[H11, H12], [H12, H22]])
        x = mp.lu_solve(H, -mp.matrix(g))
        return np.array([float(x[0]), float(x[1])]), np.array(H.tolist(), dtype=float), t1, t2


def test_newton_step_is_the_riemannian_newton_step():
    """One step (max_iter 1) from 0.003-0.03 rad off a strict maximum, where the tangent Hessian is negative
    definite and the step short of every cap and backtrack: the value returned is sigma at the start, and
    the step taken (read back from the retraction: x_i = n'.t_i / n'.n) is the Newton step of F(x) =
    sigma(unit(n + x)) with F's gradient and Hessian by 40-digit central differences, to the rounding of
    the step (64 u (S + max a^2 / h_A + max b^2 / h_B) |Hess^-1|) relative to the Hessian."""
    rng = np.random.default_rng(17)
    checked = 0
    for _ in range(60):
        P = random_pair(rng, aspect_max=1000.0)
        m, _, status, _ = P.newton(unit_np(rng.normal(size=3)), max_iter=100)
        if status != sn.CONVERGED:
            continue
        off = rng.normal(size=3)
        off -= (off @ np.array(m)) * np.array(m)
        n = unit_np(np.array(m) + unit_np(off) * 10.0 ** rng.uniform(-2.5, -1.5))
        x_ref, H, t1, t2 = reference_step(P, n)
        if not (np.all(np.linalg.eigvalsh(H) < 0) and np.linalg.norm(x_ref) < 0.09):
            continue
        checked += 1
        n2, value, _, steps = P.newton(n, max_iter=1)
        assert steps == 1
        _, ha, hb = P.parts_mp(n)
        assert abs(value - float(P.sigma_mp(n))) <= 32 * U64 * (P.S + P.rb.max() ** 2 / float(hb))
        n2 = np.array(n2)
        x = np.array([n2 @ t1, n2 @ t2]) / (n2 @ n)
        curv = P.S + P.ra.max() ** 2 / float(ha) + P.rb.max() ** 2 / float(hb)
        err = 64 * U64 * curv * np.linalg.norm(np.linalg.inv(H), 2) + 8 * U64
        assert np.linalg.norm(x - x_ref) <= err, (x, x_ref, err)
    assert checked >= 30


# --- newton: where it ends ----------------------------------------------------------------------------


def test_newton_ends_at_a_strict_local_maximum():
    """300 random pairs (aspect up to 1000, deep to apart), random starts: the run converges (all but
    1 %), at a unit n* (to 2 u per step: the retraction divides by sqrt(1 + |x|^2)) where Newton would
    move by less than NEWTON_STEP_TOL / 10 (the run's last step was < NEWTON_STEP_TOL; the step after it
    is quadratically smaller), sigma at 8 directions 1e-3 rad
    around n* is below sigma(n*) (40 digits), sigma(n*) is the 40-digit stationary value from n* to
    |Hess| (NEWTON_STEP_TOL / 10)^2, and the value (sigma before the last step) is at most sigma(n*) and
    within |Hess| NEWTON_STEP_TOL^2 of the stationary value (the module's O(tol^2))."""
    rng = np.random.default_rng(23)
    failed = 0
    for _ in range(300):
        P = random_pair(rng)
        n, value, status, steps = P.newton(unit_np(rng.normal(size=3)), max_iter=100)
        if status != sn.CONVERGED:
            failed += 1
            continue
        n = np.array(n)
        assert abs(np.linalg.norm(n) - 1) <= (2 * steps + 2) * U64  # the retraction's rounding, per step
        assert P.remaining_step(n) <= 0.1 * NEWTON_STEP_TOL, P
        top = P.sigma_mp(n)
        t1, t2 = (np.array(t) for t in sn.tangent_basis(tuple(n)))
        for ang in np.linspace(0, 2 * np.pi, 8, endpoint=False):
            assert P.sigma_mp(n + 1e-3 * (np.cos(ang) * t1 + np.sin(ang) * t2)) < top, P
        _, _, hb = P.parts_mp(n)
        slack = 32 * U64 * (P.S + P.rb.max() ** 2 / float(hb))
        _, H = P.riemannian(n)
        with mp.workdps(DPS):
            hess = float(max(abs(x) for x in mp.eigsy(H)[0]))
        stationary = float(P.polished(n))
        assert stationary - hess * (0.1 * NEWTON_STEP_TOL) ** 2 - slack <= float(top) <= stationary + slack
        assert stationary - hess * NEWTON_STEP_TOL**2 - slack <= value <= float(top) + slack, P
    assert failed <= 3


@pytest.mark.parametrize("gap", [0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.3])
def test_separated_and_touching_pairs_reach_the_distance(gap):
    """Pairs built around a normal m at distance gap (times the larger semi-axis; aspect up to 1000): from
    the bisector seed Newton converges within NEWTON_MAX_ITER steps, to m (1e-6 rad), and its value is
    the distance: between the 40-digit bounds sigma(m) <= dist <= |x_B(m) - x_A(m)| (weak duality), to
    1e-10 S (the value is sigma before a last step < 1e-5 rad: O(|Hess| 1e-10))."""
    rng = np.random.default_rng(int(1 + gap * 1e13) % 2**32)
    for _ in range(40):
        P, m = touching_pair(rng, gap)
        lower = P.sigma_mp(m)
        xa = support_point(P.ca, P.Ra, P.ra, P.Ra @ m)
        xb = support_point(P.cb, P.Rb, P.rb, -(P.Ra @ m))
        with mp.workdps(DPS):
            upper = mp.norm(xb - xa)
            assert upper - lower <= mp.mpf(1e-15) * P.S  # the construction: the bracket is tight
        seed = sn.bisector_seed(P.e, P.a2, P.U, tuple(float(x) ** 2 for x in P.rb))
        n, value, status, steps = P.newton(seed)
        assert status == sn.CONVERGED, (P, steps)
        assert np.linalg.norm(np.array(n) - m) <= 1e-6, P
        assert float(lower) - 1e-10 * P.S <= value <= float(upper) + 32 * U64 * P.S


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.floats(-12.0, 0.0), st.floats(0.0, 3.0))
def test_near_touching_pairs_from_any_start(seed, log_gap, log_aspect):
    """Hypothesis over near-touching pairs (gap 1e-12..1 of the larger semi-axis, aspect 1..1000) and
    starts anywhere on the sphere: a separated pair has a single local maximum of sigma > 0 on the hemisphere
    it lives on, so a converged run from any start ends either there, at the distance (within the
    weak-duality bracket), or at a maximum with sigma <= 0."""
    rng = np.random.default_rng(seed)
    P, m = touching_pair(rng, 10.0**log_gap, 10.0**log_aspect)
    n, value, status, steps = P.newton(unit_np(rng.normal(size=3)), max_iter=100)
    if status == sn.CONVERGED and value > 32 * U64 * P.S:
        xa = support_point(P.ca, P.Ra, P.ra, P.Ra @ m)
        xb = support_point(P.cb, P.Rb, P.rb, -(P.Ra @ m))
        with mp.workdps(DPS):
            upper = float(mp.norm(xb - xa))
        assert float(P.sigma_mp(m)) - 1e-10 * P.S <= value <= upper + 32 * U64 * P.S
        assert np.linalg.norm(np.array(n) - m) <= 1e-5
    else:
        assert status != sn.CONVERGED or value <= 32 * U64 * P.S
        # every run ends where sigma is no more than the distance (weak duality)
        assert float(P.sigma_mp(n)) <= float(P.sigma_mp(m)) + 1e-10 * P.S


# --- newton: the special exits ----------------------------------------------------------------------


def test_newton_escapes_the_minimum_of_spheres():
    """Spheres started exactly at the minimum -e/|e| (zero tangent gradient, positive curvature): the
    escape step leaves it and the run converges to e/|e| with sigma = |e| - r_A - r_B."""
    for e in ([1.0, 0.0, 0.0], [0.3, -0.4, 1.2], [0.0, 0.0, -2.0]):
        P = Pair([0, 0, 0], np.eye(3), [0.2] * 3, e, np.eye(3), [0.5] * 3)
        n, value, status, steps = P.newton(-unit_np(e))
        assert status == sn.CONVERGED
        assert np.linalg.norm(np.array(n) - unit_np(e)) <= 1e-12
        assert value == pytest.approx(np.linalg.norm(e) - 0.7, abs=1e-14)


def test_newton_on_concentric_spheres_is_a_flat_maximum():
    """Concentric spheres: sigma = -(r_A + r_B) everywhere; CONVERGED at the first step, n unchanged."""
    rng = np.random.default_rng(29)
    P = Pair([1, 2, 3], np.eye(3), [0.4] * 3, [1, 2, 3], Rot.random(random_state=rng).as_matrix(), [0.25] * 3)
    for _ in range(10):
        n0 = unit_np(rng.normal(size=3))
        n, value, status, steps = P.newton(n0)
        assert status == sn.CONVERGED and steps == 1
        assert np.array_equal(np.array(n), n0) and value == pytest.approx(-0.65, abs=1e-15)


def test_newton_abandons_only_runs_that_cannot_reach_the_target():
    """From 0.01 rad off a strict maximum, where the tangent Hessian H is negative definite: the run's
    quadratic bound is B = sigma + |g|^2 (-tr H) / (2 det H) (g, H the Riemannian gradient and Hessian,
    here in 40 digits); with a target 1e-9 S above B the run is ABANDONED at its first step, n unchanged,
    with sigma at the start; 1e-9 S below B it is not abandoned there; with a target 1e-6 S below the
    maximum, or -inf, it converges to the maximum (never abandoned)."""
    rng = np.random.default_rng(31)
    done = 0
    for _ in range(40):
        P = random_pair(rng, aspect_max=30.0)
        m, _, status, _ = P.newton(unit_np(rng.normal(size=3)), max_iter=100)
        if status != sn.CONVERGED:
            continue
        top = float(P.polished(m))
        off = rng.normal(size=3)
        n0 = unit_np(np.array(m) + 0.01 * unit_np(off - (off @ np.array(m)) * np.array(m)))
        g, H = P.riemannian(n0)
        t1, t2 = (np.array(t) for t in sn.tangent_basis(tuple(n0)))
        with mp.workdps(DPS):
            T = mp.matrix([list(map(mp.mpf, t1)), list(map(mp.mpf, t2))])
            g2, H2 = T * g, T * H * T.T
            det = H2[0, 0] * H2[1, 1] - H2[0, 1] ** 2
            if not (H2[0, 0] < 0 and det > 0):
                continue
            bound = float(P.sigma_mp(n0) - (g2[0] ** 2 + g2[1] ** 2) * (H2[0, 0] + H2[1, 1]) / (2 * det))
        done += 1
        n, value, status, steps = P.newton(n0, target=bound + 1e-9 * P.S)
        assert status == sn.ABANDONED and steps == 1 and tuple(n) == tuple(n0)
        assert value == pytest.approx(float(P.sigma_mp(n0)), abs=64 * U64 * P.S)
        n, value, status, steps = P.newton(n0, target=bound - 1e-9 * P.S)
        assert not (status == sn.ABANDONED and steps == 1)
        for target in (top - 1e-6 * P.S, NEG_INF):
            n, value, status, steps = P.newton(n0, target=target)
            assert status == sn.CONVERGED
            assert np.linalg.norm(np.array(n) - np.array(m)) <= 1e-6
    assert done >= 25
