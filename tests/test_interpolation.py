"""core/motion/interpolation.py on its own: the rigid motion c(t) = c0 + t (c1 - c0), R(t) = R0 exp(t [w]x) with
w = log(R0^T R1), against scipy.spatial.transform.Rotation and 40-digit mpmath (nothing of ellipsim in either).

Checked: rotation_vector (the axis-angle of R0^T R1 against scipy's as_rotvec, and R0 exp([w]x) = R1 in 40
digits) for generic, near-identity (down to 1e-140 rad) and near-half-turn rotations (pi - 1e-3 ... pi - 2e-6);
rotation_vectors (OMEGA_ZERO flushes a negligible turn to exactly 0; the half-turn refusal, a ValueError naming
the arguments, the index and the angle, at HALF_TURN_TOL); rodrigues (the exact zero cases, a unit axis down to
|w| = OMEGA_ZERO, the matrix against scipy); poses_at (the pose at t within DELTA_R, spectral norm, of the exact
motion in 40 digits, on each half as the module defines it; the halves meet; the same motion as scipy's;
centres within rounding of the exact c0 + t (c1 - c0); endpoints exact; the argument checks).
"""

import math
from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot

from ellipsim import Ellipsoids
from ellipsim.core.motion import interpolation as ip
from ellipsim.core.tolerances import DELTA_R, HALF_TURN_TOL, OMEGA_ZERO
from ellipsim.native import ext

U = 2.0**-53
DPS = 40
ANGLES = [0.3, 1.0, 2.0, 3.0, 1e-3, 1e-6, 1e-9, 1e-12, math.pi - 1e-3, math.pi - 1e-4, math.pi - 1e-5, math.pi - 2e-6]


# --- references ----------------------------------------------------------------------------------


def mp_exp(w, phi):
    """exp(phi [w]x) in the current precision (Rodrigues' formula on the exact w)."""
    wv = [mp.mpf(float(x)) for x in w]
    th = mp.sqrt(sum(x * x for x in wv))
    if th == 0:
        return mp.eye(3)
    K = mp.matrix([[0, -wv[2], wv[1]], [wv[2], 0, -wv[0]], [-wv[1], wv[0], 0]]) / th
    al = th * mp.mpf(float(phi))
    return mp.eye(3) + mp.sin(al) * K + (1 - mp.cos(al)) * K * K


def mp_mat(R):
    return mp.matrix(np.asarray(R, dtype=float).tolist())


def spectral(D):
    return float(np.linalg.norm(np.array(D.tolist(), dtype=float), 2))


def turned(rng, n, angle):
    """(R0, R1): n random rotations and the same turned by `angle` about random axes (scipy)."""
    R0 = Rot.random(n, random_state=rng)
    v = rng.normal(size=(n, 3))
    v *= (angle / np.linalg.norm(v, axis=1))[:, None]
    return R0.as_matrix(), (R0 * Rot.from_rotvec(v)).as_matrix()


def batch(C, R, r=None):
    return Ellipsoids(C, R, np.ones((len(C), 3)) if r is None else r)


# --- rotation_vector(s) ----------------------------------------------------------------------------


@pytest.mark.parametrize("angle", ANGLES)
def test_rotation_vector_is_the_logarithm(angle):
    """w against scipy's as_rotvec of R0^T R1 (absolute 1e-12; the axis near a half turn is well defined from
    the symmetric part), theta = |w|, and R0 exp([w]x) reproduces R1 in 40 digits."""
    rng = np.random.default_rng(int(angle * 1e6) % 2**32)
    R0, R1 = turned(rng, 12, angle)
    worst = 0.0
    with mp.workdps(DPS):
        for a, b in zip(R0, R1):
            w0, w1, w2, theta = ext.rotation_vector(a, b)
            w = np.array([w0, w1, w2])
            ref = Rot.from_matrix(a.T @ b).as_rotvec()
            assert np.abs(w - ref).max() <= 1e-12 * max(1.0, angle) + 4 * U * angle, (angle, w, ref)
            assert abs(theta - angle) <= 1e-12 and abs(theta - np.linalg.norm(w)) <= 4 * U * theta
            worst = max(worst, float(mp.mnorm(mp_mat(a) * mp_exp(w, 1.0) - mp_mat(b), 1)))
    assert worst <= 1e-14


def test_rotation_vector_identity_and_negligible_turns():
    """R0 = R1: exactly 0.  A turn about z of 1e-140 rad (sin written into the matrix, R0 a signed permutation so
    that R0 Rz is exact): w = (0, 0, 1e-140) to rounding, kept by rotation_vectors; 1e-160 rad, below
    OMEGA_ZERO = 2^-500: flushed to exactly 0."""
    R0 = Rot.random(3, random_state=np.random.default_rng(1)).as_matrix()
    assert ext.rotation_vector(R0[0], R0[0]) == (0.0, 0.0, 0.0, 0.0)
    R0[0] = [[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]]  # a signed permutation: R0 Rz is exact
    rows = []
    for a in (1e-140, 1e-160):
        Rz = np.array([[1.0, -a, 0.0], [a, 1.0, 0.0], [0.0, 0.0, 1.0]])
        w0, w1, w2, theta = ext.rotation_vector(R0[0], R0[0] @ Rz)
        assert abs(w2 - a) <= 1e-12 * a and abs(w0) <= 1e-15 * a + 1e-300 and abs(w1) <= 1e-15 * a + 1e-300
        rows.append(R0[0] @ Rz)
    x0 = batch(np.zeros((3, 3)), R0[[0, 0, 0]])
    x1 = batch(np.zeros((3, 3)), np.stack([R0[0], rows[0], rows[1]]))
    w = ip.rotation_vectors(x0, x1)
    assert w[0].tolist() == [0.0, 0.0, 0.0] and w[2].tolist() == [0.0, 0.0, 0.0]
    assert abs(w[1, 2] - 1e-140) <= 1e-12 * 1e-140 and 1e-140 > OMEGA_ZERO > 1e-160


def test_rotation_vectors_refuse_a_half_turn_naming_the_arguments():
    """Within HALF_TURN_TOL of pi: ValueError naming both arguments, the index and the angle; just outside: the
    vector, of length the angle."""
    rng = np.random.default_rng(2)
    R0, R1 = turned(rng, 4, 1.0)
    near, _ = turned(rng, 1, 0.0)
    ok = (Rot.from_matrix(near[0]) * Rot.from_rotvec([0.0, math.pi - 3 * HALF_TURN_TOL, 0.0])).as_matrix()
    bad = (Rot.from_matrix(near[0]) * Rot.from_rotvec([0.0, 0.0, math.pi - HALF_TURN_TOL / 3])).as_matrix()
    x0 = batch(np.zeros((4, 3)), np.concatenate([R0[:2], near, R0[3:]]))
    good = batch(np.zeros((4, 3)), np.concatenate([R1[:2], ok[None], R1[3:]]))
    w = ip.rotation_vectors(x0, good, "p", "q")
    assert abs(np.linalg.norm(w[2]) - (math.pi - 3 * HALF_TURN_TOL)) <= 1e-12
    turns = batch(np.zeros((4, 3)), np.concatenate([R1[:2], bad[None], R1[3:]]))
    with pytest.raises(ValueError, match=r"a half turn between p\[2\] and q\[2\] \(angle 3\.14159.*of pi\)"):
        ip.rotation_vectors(x0, turns, "p", "q")
    exact = batch(np.zeros((1, 3)), np.diag([-1.0, -1.0, 1.0])[None])  # exactly pi about z
    with pytest.raises(ValueError, match=r"a half turn between x0\[0\] and x1\[0\] \(angle 3\.141592653589793 rad"):
        ip.rotation_vectors(batch(np.zeros((1, 3)), np.eye(3)[None]), exact)
    with pytest.raises(ValueError, match=r"a half turn between x0\[2\] and x1\[2\]"):
        ip.poses_at(x0, turns, 0.5)


# --- rodrigues -------------------------------------------------------------------------------------


def _rod_stages(w, phi):
    """The motion's Rodrigues stages (interpolation.hpp) on one row: columns 0-6 rodrigues(w, phi) flattened,
    10-18 its rodrigues_matrix."""
    out = np.empty((1, 28))
    ext.testing.rodrigues_stages(np.array([w], float), np.array([phi], float), np.zeros((1, 3)), np.eye(3)[None], out)
    return out[0].tolist()


def _rod(w, phi):
    """rodrigues(w, phi): (cos alpha, sin alpha, 1 - cos alpha, unit axis k, |alpha|)."""
    c, s, om, k0, k1, k2, al = _rod_stages(w, phi)[:7]
    return c, s, om, (k0, k1, k2), al


def _rod_matrix(w, phi):
    return tuple(_rod_stages(w, phi)[10:19])


def test_rodrigues_exact_cases_and_unit_axis_down_to_omega_zero():
    assert _rod((0.0, 0.0, 0.0), 0.3) == (1.0, 0.0, 0.0, (0.0, 0.0, 0.0), 0.0)
    c, s, om, k, al = _rod((0.3, -1.2, 0.5), 0.0)
    assert (c, s, om, al) == (1.0, 0.0, 0.0, 0.0)
    rng = np.random.default_rng(3)
    for scale in (OMEGA_ZERO, OMEGA_ZERO * 7, 1e-100, 1e-8, 1.0):
        for _ in range(20):
            w = rng.normal(size=3)
            w *= scale / np.linalg.norm(w)
            k = np.array(_rod(tuple(w), 0.25)[3])
            assert abs(np.linalg.norm(k) - 1.0) <= 4 * U  # |w|^2 is a normal float from OMEGA_ZERO up


def test_rodrigues_matrix_against_scipy():
    rng = np.random.default_rng(4)
    for angle in ANGLES:
        for _ in range(10):
            w = rng.normal(size=3)
            w *= angle / np.linalg.norm(w)
            phi = float(rng.uniform(-0.5, 0.5))
            E = np.reshape(_rod_matrix(tuple(w), phi), (3, 3))
            np.testing.assert_allclose(E, Rot.from_rotvec(phi * w).as_matrix(), rtol=0, atol=1e-15)
            assert np.abs(E.T @ E - np.eye(3)).max() <= 1e-15


# --- poses_at ------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [1e-9, 1e-4, 0.7, 2.5, math.pi - 1e-4, math.pi - 2e-6])
def test_poses_at_within_delta_r_of_the_exact_motion(angle):
    """The float pose at t against the motion in 40 digits on the module's own w: R0 exp(t [w]x) on [0, 1/2],
    R1 exp((t - 1) [w]x) on (1/2, 1], within DELTA_R (spectral norm); the halves meet to ~1e-15; scipy's motion
    (w from as_rotvec) agrees to 1e-12."""
    rng = np.random.default_rng(int(angle * 1e4))
    n = 8
    R0, R1 = turned(rng, n, angle)
    x0, x1 = batch(rng.uniform(-2, 2, (n, 3)), R0), batch(rng.uniform(-2, 2, (n, 3)), R1)
    w = ip.rotation_vectors(x0, x1)
    ts = np.concatenate([[0.0, 1e-300, 1e-9, 0.25, 0.5, np.nextafter(0.5, 1), 0.75, 1 - 2**-40], rng.uniform(0, 1, 4)])
    wsci = Rot.from_matrix(np.einsum("nji,njk->nik", R0, R1)).as_rotvec()
    worst = 0.0
    with mp.workdps(DPS):
        for t in ts:
            got = ip.poses_at(x0, x1, t).rotations
            for i in range(n):
                exact = mp_mat(R0[i]) * mp_exp(w[i], t) if t <= 0.5 else mp_mat(R1[i]) * mp_exp(w[i], t - 1.0)
                err = spectral(mp_mat(got[i]) - exact)
                assert err <= DELTA_R, (t, i, err)
                worst = max(worst, err)
            ref = np.einsum("nij,njk->nik", R0, Rot.from_rotvec(t * wsci).as_matrix())
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
        for i in range(n):  # the two halves' definitions meet at t = 1/2
            gap = spectral(mp_mat(R0[i]) * mp_exp(w[i], 0.5) - mp_mat(R1[i]) * mp_exp(w[i], -0.5))
            assert gap <= 1e-14
    assert worst <= 1e-14  # rigorous, and in practice far inside


def test_poses_at_centres_and_endpoints():
    """Centres within 2u |c0| + 2u |c1| of the exact c0 + t (c1 - c0) (Fractions); x0 and x1 themselves at 0
    and 1; one t for all or one per body; the radii carried along."""
    rng = np.random.default_rng(5)
    n = 50
    R0, R1 = turned(rng, n, 1.3)
    r = rng.uniform(0.1, 2.0, (n, 3))
    C0 = rng.uniform(-1, 1, (n, 3)) * 10.0 ** rng.integers(-3, 4, (n, 1))
    C1 = C0 + rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-12, 2, (n, 1))
    x0, x1 = Ellipsoids(C0, R0, r), Ellipsoids(C1, R1, r)
    t = rng.uniform(0, 1, n)
    got = ip.poses_at(x0, x1, t)
    for i in range(n):
        for k in range(3):
            exact = Fraction(C0[i, k]) + Fraction(t[i]) * (Fraction(C1[i, k]) - Fraction(C0[i, k]))
            assert abs(Fraction(got.centers[i, k]) - exact) <= Fraction(2 * U) * (abs(C0[i, k]) + abs(C1[i, k]))
    np.testing.assert_array_equal(got.radii, r)
    for tt, x in ((0.0, x0), (1.0, x1), (np.zeros(n), x0), (np.ones(n), x1)):
        end = ip.poses_at(x0, x1, tt)
        np.testing.assert_array_equal(end.centers, x.centers)
        np.testing.assert_array_equal(end.rotations, x.rotations)
    one = ip.poses_at(x0, x1, 0.3)
    np.testing.assert_array_equal(one.rotations, ip.poses_at(x0, x1, np.full(n, 0.3)).rotations)
    near_end = ip.poses_at(x0, x1, np.nextafter(1.0, 0.0))
    assert np.abs(near_end.rotations - R1).max() <= 1e-15 and np.abs(near_end.centers - C1).max() <= 4 * U * 1e3


def test_poses_at_argument_checks():
    rng = np.random.default_rng(6)
    R0, R1 = turned(rng, 2, 0.5)
    x0 = Ellipsoids(np.zeros((2, 3)), R0, np.ones((2, 3)))
    x1 = Ellipsoids(np.zeros((2, 3)), R1, [[1.0, 1.0, 1.0], [1.0, 2.0, 1.0]])
    with pytest.raises(ValueError, match=r"x1.radii\[1\] must equal x0.radii\[1\], got \[1.0, 2.0, 1.0\]"):
        ip.poses_at(x0, x1, 0.5)
    with pytest.raises(ValueError, match="x0 must be an ellipsim.Ellipsoids batch, got list"):
        ip.poses_at([1], x0, 0.5)
    with pytest.raises(ValueError, match="x0 and x1 must have the same length, got 2 and 1"):
        ip.poses_at(x0, x0[0], 0.5)
    with pytest.raises(ValueError, match=r"t\[0\] must lie in \[0, 1\], got nan"):
        ip.poses_at(x0, x0, math.nan)
    with pytest.raises(ValueError, match=r"t\[1\] must lie in \[0, 1\], got -1e-300"):
        ip.poses_at(x0, x0, [0.0, -1e-300])
