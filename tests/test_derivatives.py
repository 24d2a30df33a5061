"""signed_distance(..., derivatives=True) against central differences of the exact distance in 40 digits.

The reference (reference.contact_mp) is independent of the library: the stationary point of sigma on the
sphere by Newton on the Lagrange system in mpmath, from the definitions (support functions, the midpoint
of the support points), at parameters perturbed by +-h in mpmath (the rotation by expm of the rotation
vector's skew matrix, in mpmath).  With 40 digits and h = 1e-15 the central difference errs by
~h^2 ~ 1e-30 (truncation) plus ~1e-40 / h = 1e-25 (rounding): exact for a float64 comparison.  The bound
is the issue's: relative error <= 1e-8 per quantity and parameter block (centre, rotation, semi-axes of
each body), relative to the block's largest reference entry.
"""

import mpmath as mp
import numpy as np
import pytest
from reference import contact_mp, mp_body, perturbed, relative_errors

import ellipsim as es
from ellipsim.core.distance import derivatives as dv
from ellipsim.core.samples import generic_pairs, random_ellipsoids
from ellipsim.native import ext

H = mp.mpf("1e-15")
H_TOI = mp.mpf("1e-12")
BOUND = 1e-8


def reference_derivatives(a, b, i, n0):
    """(d dist (18,), d normal (3, 18), d pos (3, 18)) of pair i by 40-digit central differences."""
    with mp.workdps(40):
        A, B = mp_body(a, i), mp_body(b, i)
        g, jn, jp = np.empty(18), np.empty((3, 18)), np.empty((3, 18))
        for j in range(18):
            body, kind, axis = j // 9, (j % 9) // 3, j % 3
            out = []
            for h in (H, -H):
                Ap, Bp = (perturbed(A, kind, axis, h), B) if body == 0 else (A, perturbed(B, kind, axis, h))
                out.append(contact_mp(*Ap, *Bp, n0))
            (sp, np_, pp), (sm, nm, pm) = out
            g[j] = float((sp - sm) / (2 * H))
            jn[:, j] = [float((np_[k] - nm[k]) / (2 * H)) for k in range(3)]
            jp[:, j] = [float((pp[k] - pm[k]) / (2 * H)) for k in range(3)]
    return g, jn, jp


def _pairs(category, n, seed):
    rng = np.random.default_rng(seed)
    if category == "random":
        return generic_pairs(n, seed=seed)
    if category == "elongated":  # aspect up to 20
        a, b = random_ellipsoids(rng, n, radii=(0.05, 1.0)), random_ellipsoids(rng, n, radii=(0.05, 1.0))
        return a, b
    if category in ("nearly touching", "nearly touching, penetrating"):
        a, b = generic_pairs(n, seed=seed)
        dist, normal, _, _ = es.signed_distance(a, b)
        gap = 1e-10 if category == "nearly touching" else -1e-10
        return a, es.Ellipsoids(b.centers + (gap - dist)[:, None] * normal, b.rotations, b.radii)
    if category == "deep":  # centres 0.1 apart, elongated: deeper than the rolling radii
        a = random_ellipsoids(rng, n, box=0.05, radii=(0.15, 1.0))
        b = random_ellipsoids(rng, n, box=0.05, radii=(0.15, 1.0))
        return a, b
    raise AssertionError(category)


@pytest.mark.parametrize(
    "category, status",
    [
        ("random", dv.SMOOTH),
        ("elongated", dv.SMOOTH),
        ("nearly touching", dv.SMOOTH),
        ("nearly touching, penetrating", dv.SMOOTH),
        ("deep", dv.BRANCH),
    ],
)
def test_against_mpmath_central_differences(category, status):
    a, b = _pairs(category, 40, seed=11)
    dist, normal, pos, st, der = es.signed_distance(a, b, derivatives=True)
    assert (st == es.DistanceStatus.GLOBAL).all()
    if category != "deep":  # random and elongated pairs: separated or shallow, so unique maximisers
        keep = np.flatnonzero(der.status == dv.SMOOTH)
        assert len(keep) >= 30, np.bincount(der.status)
    else:
        keep = np.flatnonzero(der.status == status)
        assert len(keep) >= 20, np.bincount(der.status)
    if category.startswith("nearly touching"):
        assert np.abs(dist).max() < 2e-10
    checked = 0
    for i in keep[:6]:
        g, jn, jp = reference_derivatives(a, b, i, normal[i])
        for got, ref, name in ((der.dist[i], g, "dist"), (der.normal[i], jn, "normal"), (der.pos[i], jp, "pos")):
            err = relative_errors(got, ref)
            assert err.max() <= BOUND, (category, i, name, err)
        checked += 1
    assert checked == 6


def test_flat_maximum_is_reported_not_differentiated():
    """Two coaxial needles crossing along their axis: sigma is symmetric about it, so the maxima form a circle."""
    a = es.Ellipsoids([[0, 0, 0]], [np.eye(3)], [[0.1, 0.1, 1.0]])
    b = es.Ellipsoids([[0, 0, 0.3]], [np.eye(3)], [[0.1, 0.1, 1.0]])
    dist, _, _, st, der = es.signed_distance(a, b, derivatives=True)
    assert st[0] == es.DistanceStatus.GLOBAL and -0.2 < dist[0] < -0.19
    assert der.status[0] == es.DerivativeStatus.FLAT
    assert np.isnan(der.dist).all() and np.isnan(der.normal).all() and np.isnan(der.pos).all()


def test_concentric_pairs_are_a_branch():
    """sigma(n) = sigma(-n) when the centres coincide: two maximisers, so never SMOOTH."""
    a = es.Ellipsoids([[0.5, 0, 0]], [np.eye(3)], [[0.3, 0.2, 0.1]])
    b = es.Ellipsoids.from_quaternions([[0.5, 0, 0]], [[0.9, 0.1, 0.3, 0.2]], [[0.35, 0.25, 0.15]])
    *_, der = es.signed_distance(a, b, derivatives=True)
    assert der.status[0] == dv.BRANCH
    assert np.isfinite(der.dist).all()


def test_unproven_maximum_gives_nan():
    a, b = generic_pairs(4, seed=2)
    dist, normal, pos, st = es.signed_distance(a, b)
    st = np.array([0, 1, 0, 1], dtype=np.int8)  # as if the last proof had run out
    out = (np.empty((4, 18)), np.empty((4, 3, 18)), np.empty((4, 3, 18)), np.empty(4, np.int8))
    arrays = (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    ext.derivatives(*arrays, normal, st, *out, 0, 4)
    assert list(out[3][[1, 3]]) == [dv.UNPROVEN, dv.UNPROVEN]
    assert np.isnan(out[0][[1, 3]]).all() and np.isfinite(out[0][[0, 2]]).all()


def test_scaling_by_a_power_of_two_is_exact():
    """The pair times 2^60 (the kernels' unit-scale path): each block scales by its units, to the bit."""
    a, b = generic_pairs(50, seed=4)
    s = 2.0**60
    big = [es.Ellipsoids(e.centers * s, e.rotations, e.radii * s) for e in (a, b)]
    *_, d1 = es.signed_distance(a, b, derivatives=True)
    *_, d2 = es.signed_distance(*big, derivatives=True)
    assert (d1.status == d2.status).all()
    unit = np.tile(np.repeat([1.0, s, 1.0], 3), 2)  # d dist / d rotation is a length
    np.testing.assert_array_equal(d2.dist, d1.dist * unit)
    np.testing.assert_array_equal(d2.normal, d1.normal * (unit / s))
    np.testing.assert_array_equal(d2.pos, d1.pos * unit)


def test_threads_and_broadcast_give_the_same_bits():
    a, b = generic_pairs(20_000, seed=5)
    *_, serial = es.signed_distance(a, b, derivatives=True, parallel=False)
    *_, threaded = es.signed_distance(a, b, derivatives=True, parallel=True)
    for x, y in zip(serial, threaded):
        np.testing.assert_array_equal(x, y)
    one = a[:1]
    *_, broadcast = es.signed_distance(one, b[:10], derivatives=True)
    *_, repeated = es.signed_distance(es.Ellipsoids.concatenate([one] * 10), b[:10], derivatives=True)
    for x, y in zip(broadcast, repeated):
        np.testing.assert_array_equal(x, y)


def test_the_columns_follow_parameters():
    """Translating both bodies together changes nothing; so does turning both about A's centre (for the
    distance): the centre columns cancel, and the rotation columns with the moment of the centres."""
    a, b = generic_pairs(100, seed=6)
    *_, der = es.signed_distance(a, b, derivatives=True)
    ok = der.status == dv.SMOOTH
    g = der.dist[ok]
    np.testing.assert_allclose(g[:, 0:3] + g[:, 9:12], 0.0, atol=1e-15)
    # a rigid turn of the pair by omega about the origin moves each centre by omega x c
    ca, cb = a.centers[ok], b.centers[ok]
    total = g[:, 3:6] + g[:, 12:15] + np.cross(ca, g[:, 0:3]) + np.cross(cb, g[:, 9:12])
    np.testing.assert_allclose(total, 0.0, atol=1e-13)
    assert dv.PARAMETERS == ("center_a", "rotation_a", "radii_a", "center_b", "rotation_b", "radii_b")


@pytest.mark.parametrize("bad", ["yes", 1, None])
def test_derivatives_flag_is_checked(bad):
    a, b = generic_pairs(2, seed=1)
    with pytest.raises(ValueError, match="derivatives must be True or False"):
        es.signed_distance(a, b, derivatives=bad)


# --- time_of_impact(..., derivatives=True) ---------------------------------------------------------


def _log_mp(R):
    """The rotation vector of the rotation R (angle below pi), in mpmath: theta / (2 sin theta) vee(R - R^T)."""
    theta = mp.acos((R[0, 0] + R[1, 1] + R[2, 2] - 1) / 2)
    k = theta / (2 * mp.sin(theta)) if theta > 0 else mp.mpf(0.5)
    return mp.matrix([(R[2, 1] - R[1, 2]) * k, (R[0, 2] - R[2, 0]) * k, (R[1, 0] - R[0, 1]) * k])


def _exp_mp(w):
    """Rodrigues' formula in mpmath."""
    theta = mp.norm(w)
    W = mp.matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    if theta == 0:
        return mp.eye(3)
    return mp.eye(3) + mp.sin(theta) / theta * W + (1 - mp.cos(theta)) / theta**2 * W * W


def _first_contact_mp(A0, A1, B0, B1, t0, n0):
    """t* of the motion (centres linear, R0 Exp(t Log(R0^T R1))) in mpmath: the secant root of the local
    signed distance near the float toi."""
    wa, wb = _log_mp(A0[1].T * A1[1]), _log_mp(B0[1].T * B1[1])

    def f(t):
        ca, Ra = A0[0] + t * (A1[0] - A0[0]), A0[1] * _exp_mp(t * wa)
        cb, Rb = B0[0] + t * (B1[0] - B0[0]), B0[1] * _exp_mp(t * wb)
        return contact_mp(ca, Ra, A0[2], cb, Rb, B0[2], n0)[0]

    return mp.findroot(f, (mp.mpf(t0) - mp.mpf("1e-6"), mp.mpf(t0) + mp.mpf("1e-6")), solver="secant")


def _impact_case(seed, n=12):
    """Pairs approaching head on while turning: A near the origin, B 2 m along x, crossing paths."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)

    def body(centers):
        return es.Ellipsoids.from_quaternions(centers, rng.normal(size=(n, 4)), rng.uniform(0.1, 0.5, (n, 3)))

    def moved(E, step, turn):
        R = Rotation.from_rotvec(rng.normal(size=(n, 3)) * turn).as_matrix() @ E.rotations
        return es.Ellipsoids(E.centers + step, R, E.radii)

    a0 = body(rng.uniform(-0.2, 0.2, (n, 3)))
    b0 = body(a0.centers + [2.0, 0.0, 0.0])
    a1 = moved(a0, rng.normal(size=(n, 3)) * 0.3, 0.8)
    b1 = moved(b0, rng.normal(size=(n, 3)) * 0.3 - [2.0, 0.0, 0.0], 0.8)
    return a0, a1, b0, b1


def test_time_of_impact_derivatives_against_mpmath():
    """d t* / d (poses) against central differences of t* found in mpmath (a secant root of the local
    distance along the motion, every pose in mpmath), two transversal first contacts x 24 parameters."""
    from ellipsim.core.motion import impact_derivatives as im
    from ellipsim.core.motion.interpolation import poses_at

    a0, a1, b0, b1 = _impact_case(1)
    toi, status, der = es.time_of_impact(a0, a1, b0, b1, return_status=True, derivatives=True)
    defined = np.flatnonzero(der.status == im.DEFINED)
    assert len(defined) >= 6, np.bincount(der.status)
    assert np.isnan(der.toi[der.status != im.DEFINED]).all()
    assert (der.status[np.isinf(toi)] == im.NO_CONTACT).all()
    for i in defined[:2]:  # (the float normal at toi seeds the stationary point in mpmath)
        Pa, Pb = poses_at(a0[i : i + 1], a1[i : i + 1], toi[i]), poses_at(b0[i : i + 1], b1[i : i + 1], toi[i])
        n0 = es.signed_distance(Pa, Pb)[1][0]
        with mp.workdps(30):  # h = 1e-12: truncation ~1e-24, rounding ~1e-18
            bodies = [mp_body(E, i) for E in (a0, a1, b0, b1)]
            ref = np.empty(24)
            for j in range(24):
                block, axis = j // 3, j % 3  # blocks: a0 c, a0 w, a1 c, a1 w, b0 c, b0 w, b1 c, b1 w
                which, kind = block // 2, block % 2
                roots = []
                for h in (H_TOI, -H_TOI):
                    bs = list(bodies)
                    bs[which] = perturbed(bs[which], kind, axis, h)
                    roots.append(_first_contact_mp(*bs, toi[i], n0))
                ref[j] = float((roots[0] - roots[1]) / (2 * H_TOI))
        err = relative_errors(der.toi[i], ref)
        assert err.max() <= BOUND, (i, err)


def test_time_of_impact_derivatives_say_why_not():
    """No contact, in contact from the start, and a grazing first contact get a status and NaN."""
    from ellipsim.core.motion import impact_derivatives as im

    eye = np.eye(3)
    a = es.Ellipsoids([[0, 0, 0]] * 3, [eye] * 3, [[0.5, 0.5, 0.5]] * 3)
    b0 = es.Ellipsoids([[3, 2, 0], [0.5, 0, 0], [-3, 1, 0]], [eye] * 3, [[0.5, 0.5, 0.5]] * 3)
    b1 = es.Ellipsoids([[-3, 2, 0], [0.6, 0, 0], [3, 1, 0]], [eye] * 3, [[0.5, 0.5, 0.5]] * 3)
    toi, status, der = es.time_of_impact(a, a, b0, b1, return_status=True, derivatives=True)
    assert np.isinf(toi[0]) and der.status[0] == im.NO_CONTACT
    assert toi[1] == 0.0 and der.status[1] == im.AT_START
    # two unit balls grazing at t = 1/2: the distance is quadratic in t there, so float64 sees it only to ~sqrt(u)
    assert toi[2] == pytest.approx(0.5, abs=1e-7)
    assert der.status[2] in (im.GRAZING, im.UNRESOLVED)
    assert np.isnan(der.toi).all()
    toi2, der2 = es.time_of_impact(a, a, b0, b1, derivatives=True)  # without the Impact codes
    np.testing.assert_array_equal(toi2, toi)
    np.testing.assert_array_equal(der2.status, der.status)
    with pytest.raises(ValueError, match="derivatives must be True or False"):
        es.time_of_impact(a, a, b0, b1, derivatives="no")


def test_status_names_are_the_kernel_codes():
    from ellipsim.core.distance.status import DerivativeStatus

    assert [int(DerivativeStatus[k]) for k in ("SMOOTH", "BRANCH", "FLAT", "UNPROVEN")] == [
        dv.SMOOTH,
        dv.BRANCH,
        dv.FLAT,
        dv.UNPROVEN,
    ]
    assert es.DerivativeStatus is DerivativeStatus
