"""time_of_impact against independent references.

References: analytic contact times of spheres (mpmath); dense sampling (up to 2000 instants) with the
exact classify on poses built independently (scipy's rotation vector and matrix exponential);
bisection from the first sampled hit; the EXACT motion (60-digit mpmath poses, converted exactly to
Fractions) classified by reference.py's rational pencil, inside the proven range and at toi; mpmath
checks of the motion's sin/cos and Rodrigues error bounds.
"""

import math
from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest
import reference
from scipy.linalg import expm
from scipy.spatial.transform import Rotation as Rot

from ellipsim import Ellipsoids, classify, contact_scale
from ellipsim.core.motion import interpolation as motion
from ellipsim.core.motion import time_of_impact as T
from ellipsim.core.motion.time_of_impact import Impact, time_of_impact
from ellipsim.core.tolerances import DELTA_R, RODRIGUES_ERR, SINCOS_ERR, TOI_TOL, U
from ellipsim.native import ext

I = np.eye(3)
SEP = 0
CONTACTS = (Impact.CONTACT, Impact.CONTACT_AT_FLOAT_POSE)


def one(c, R, r):
    return Ellipsoids(np.asarray(c, float), np.asarray(R, float), np.asarray(r, float))


def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def random_motion(rng, n, box=1.5, turn=3.0, radii=(0.1, 1.0)):
    """One body per row: random pose, random end pose turned by up to `turn` rad."""
    R0 = Rot.random(n, random_state=rng)
    rv = rng.normal(size=(n, 3))
    rv *= (rng.uniform(0, turn, n) / np.linalg.norm(rv, axis=1))[:, None]
    r = rng.uniform(*radii, (n, 3))
    return (
        Ellipsoids(rng.uniform(-box, box, (n, 3)), R0.as_matrix(), r),
        Ellipsoids(rng.uniform(-box, box, (n, 3)), (R0 * Rot.from_rotvec(rv)).as_matrix(), r),
    )


def smallstep_motion(rng, n):
    """A simulation step: pairs near contact at t = 0 (|contact_scale - 1| < 0.1), each body moving by
    <= 0.05 and turning by <= 0.1 rad."""
    a0, _ = random_motion(rng, 8 * n, box=0.75)
    b0, _ = random_motion(rng, 8 * n, box=0.75)
    keep = np.flatnonzero(np.abs(contact_scale(a0, b0) - 1) < 0.1)[:n]
    a0, b0 = a0[keep], b0[keep]

    def step(x):
        m = len(x)
        rv = rng.normal(size=(m, 3))
        rv *= (rng.uniform(0, 0.1, m) / np.linalg.norm(rv, axis=1))[:, None]
        dc = rng.normal(size=(m, 3))
        dc *= (rng.uniform(0, 0.05, m) / np.linalg.norm(dc, axis=1))[:, None]
        return Ellipsoids(x.centers + dc, (Rot.from_matrix(x.rotations) * Rot.from_rotvec(rv)).as_matrix(), x.radii)

    return a0, step(a0), b0, step(b0)


def wvec(x0, x1):
    return motion.rotation_vectors(x0, x1)


def independent_poses(x0, x1, ts):
    """Every body at every instant of ts (pair-major), by scipy: c0 + t (c1 - c0), R0 expm(t log(R0^T R1))."""
    n, N = len(x0), len(ts)
    w = Rot.from_matrix(np.einsum("nji,njk->nik", x0.rotations, x1.rotations)).as_rotvec()
    E = Rot.from_rotvec((ts[None, :, None] * w[:, None, :]).reshape(-1, 3)).as_matrix().reshape(n, N, 3, 3)
    R = np.einsum("nij,nkjl->nkil", x0.rotations, E)
    c = x0.centers[:, None, :] + ts[None, :, None] * (x1.centers - x0.centers)[:, None, :]
    return Ellipsoids(c.reshape(-1, 3), R.reshape(-1, 3, 3), np.repeat(x0.radii, N, axis=0))


def first_hits(a0, a1, b0, b1, ts):
    """Index of the first instant of ts at which the independent poses are not separated (len(ts) if none)."""
    rel = classify(independent_poses(a0, a1, ts), independent_poses(b0, b1, ts)).reshape(len(a0), len(ts))
    hit = rel != SEP
    return np.where(hit.any(axis=1), hit.argmax(axis=1), len(ts))


def own_relation(a0, a1, b0, b1, t, i=0):
    """Exact classify of the float pose the kernel evaluates at t."""
    arrays, _ = T._check(a0[i], a1[i], b0[i], b1[i])
    ca, Ra, ra, cb, Rb, rb = T.float_poses(arrays, [0], [t])
    return int(classify(Ellipsoids(ca, Ra, ra), Ellipsoids(cb, Rb, rb))[0])


def motion_relation(a0, a1, b0, b1, t, i=0):
    """Relation of the EXACT motion at t (reference.py: 60-digit poses, rational pencil)."""
    return reference.motion_relation(a0, a1, wvec(a0, a1), b0, b1, wvec(b0, b1), t, i)


def check_contract(a0, a1, b0, b1, toi, st, N, label):
    """toi against dense sampling of the independent motion: no sampled contact before toi - TOI_TOL, a
    sampled contact implies toi at or before it, and every claimed contact is one (exact classify)."""
    ts = np.linspace(0, 1, N)
    first = first_hits(a0, a1, b0, b1, ts)
    found = first < N
    tf = np.where(found, ts[np.minimum(first, N - 1)], np.inf)
    early = np.flatnonzero(tf < toi - TOI_TOL)
    assert not len(early), (label, early[:5], tf[early[:5]], toi[early[:5]])
    late = np.flatnonzero(found & (toi > tf + TOI_TOL))
    assert not len(late), (label, late[:5], tf[late[:5]], toi[late[:5]])
    assert np.all(np.isfinite(toi) == (st != Impact.NO_CONTACT)), label
    for i in np.flatnonzero(np.isin(st, CONTACTS))[:150]:
        assert own_relation(a0, a1, b0, b1, float(toi[i]), i) != SEP, (label, i)
    return found


# --- analytic and sampled references ------------------------------------------------------------


def sphere_contact_time(c0, v, rsum):
    """First t in [0, 1] with |c0 + t v| = rsum in 60-digit mpmath, or None (inputs exact floats)."""
    with mp.workdps(60):
        c0 = [mp.mpf(float(x)) for x in c0]
        v = [mp.mpf(float(x)) for x in v]
        a = sum(x * x for x in v)
        b = 2 * sum(x * y for x, y in zip(c0, v))
        c = sum(x * x for x in c0) - mp.mpf(float(rsum)) ** 2
        if c <= 0:
            return 0.0
        disc = b * b - 4 * a * c
        if a == 0 or disc < 0:
            return None
        t = (-b - mp.sqrt(disc)) / (2 * a)
        return float(t) if 0 <= t <= 1 else None


def test_spheres_against_the_analytic_contact_time():
    """Spheres on random straight paths, turning at random (which must not matter): where the motion
    itself is proven in contact (CONTACT), toi is in [t*, t* + TOI_TOL]."""
    rng = np.random.default_rng(11)
    n = 2000
    ca0, ca1, cb0, cb1 = (rng.uniform(-2, 2, (n, 3)) for _ in range(4))
    ra, rb = rng.uniform(0.1, 1, n), rng.uniform(0.1, 1, n)
    R = [Rot.random(n, random_state=rng).as_matrix() for _ in range(2)]
    sa, sb = np.repeat(ra[:, None], 3, 1), np.repeat(rb[:, None], 3, 1)
    toi, st = time_of_impact(
        Ellipsoids(ca0, R[0], sa),
        Ellipsoids(ca1, R[1], sa),
        Ellipsoids(cb0, R[1], sb),
        Ellipsoids(cb1, R[0], sb),
        return_status=True,
    )
    hits = 0
    for i in range(n):
        t = sphere_contact_time(cb0[i] - ca0[i], (cb1[i] - cb0[i]) - (ca1[i] - ca0[i]), ra[i] + rb[i])
        if t is None:
            assert toi[i] == math.inf and st[i] == Impact.NO_CONTACT, (i, toi[i])
            continue
        hits += 1
        assert st[i] == Impact.CONTACT, (i, st[i])
        assert t - 1e-15 <= toi[i] <= t + TOI_TOL, (i, toi[i], t)
    assert hits > 300


def test_random_pairs_against_dense_sampling():
    rng = np.random.default_rng(12)
    a0, a1 = random_motion(rng, 400)
    b0, b1 = random_motion(rng, 400)
    toi, st = time_of_impact(a0, a1, b0, b1, return_status=True)
    found = check_contract(a0, a1, b0, b1, toi, st, 2000, "random")
    assert found.sum() > 100
    assert np.count_nonzero(st == Impact.UNRESOLVED) == 0
    # the serial and parallel kernels agree bit for bit, and a batch agrees with its pairs one by one
    toi_p, st_p = time_of_impact(a0, a1, b0, b1, return_status=True, parallel=True)
    np.testing.assert_array_equal(toi_p, toi)
    np.testing.assert_array_equal(st_p, st)
    for i in (0, 7, 123):
        assert time_of_impact(a0[i], a1[i], b0[i], b1[i])[0] == toi[i]


def test_small_simulation_steps_against_dense_sampling():
    rng = np.random.default_rng(21)
    a0, a1, b0, b1 = smallstep_motion(rng, 1000)
    toi, st = time_of_impact(a0, a1, b0, b1, return_status=True)
    found = check_contract(a0, a1, b0, b1, toi, st, 1000, "small steps")
    assert found.sum() > 300 and np.count_nonzero(st == Impact.UNRESOLVED) == 0


def test_exact_motion_is_separated_inside_the_proven_range_and_not_at_contact():
    """The strong claims, on the EXACT motion: separated up to toi - TOI_TOL (and just below it), and not
    separated at toi where the status is CONTACT."""
    rng = np.random.default_rng(13)
    n = 70
    a0, a1 = random_motion(rng, n, box=1.0)
    b0, b1 = random_motion(rng, n, box=1.0)
    toi, st = time_of_impact(a0, a1, b0, b1, return_status=True)
    checked = contacts = 0
    for i in range(n):
        if not 0 < toi[i] < math.inf:
            continue
        end = toi[i] - TOI_TOL if st[i] != Impact.UNRESOLVED else toi[i]
        for t in (end, np.nextafter(end, 0), end - 3e-10, end * 0.5, rng.uniform(0, end)):
            if t >= 0:
                assert motion_relation(a0, a1, b0, b1, float(t), i) == SEP, (i, t, toi[i])
                checked += 1
        if st[i] == Impact.CONTACT:
            assert motion_relation(a0, a1, b0, b1, float(toi[i]), i) != SEP, (i, toi[i])
            contacts += 1
    assert checked > 100 and contacts > 20


# --- hard cases -----------------------------------------------------------------------------------


def test_tunnelling_is_found():
    """Thin plates sweep through small balls at speed 6: contacts 1e-3 long, between 64 samples."""
    rng = np.random.default_rng(14)
    n = 200
    R = Rot.random(n, random_state=rng).as_matrix()
    normal = R[:, :, 2]
    plate = np.tile([1.0, 1.0, 0.002], (n, 1))
    a0, a1 = Ellipsoids(-3 * normal, R, plate), Ellipsoids(3 * normal, R, plate)
    b = Ellipsoids(rng.uniform(-0.3, 0.3, (n, 3)), Rot.random(n, random_state=rng).as_matrix(), np.full((n, 3), 0.005))
    toi, st = time_of_impact(a0, a1, b, b, return_status=True)
    assert np.all(st == Impact.CONTACT) and np.all((0.4 < toi) & (toi < 0.6))
    missed = first_hits(a0, a1, b, b, np.linspace(0, 1, 64)) == 64
    assert missed.sum() > n // 2  # most of these contacts are invisible to 64 samples
    check_contract(a0, a1, b, b, toi, st, 2000, "tunnel")
    # the plate's exact motion crosses the ball's centre plane at t = 1/2 + n.c_b / 6
    for i in range(0, n, 20):
        t_centre = 0.5 + normal[i] @ b.centers[i] / 6
        assert t_centre - (0.002 + 0.005) / 6 - 1e-12 <= toi[i] <= t_centre


def test_grazing_and_near_miss_spheres():
    """Unit sphere B passes unit sphere A at a distance 2 + g between centres: a miss for g > 0, a brief
    overlap for g < 0; exactly grazing for g = 0."""
    A = one([0, 0, 0], I, [1, 1, 1])
    for g in (1e-3, 1e-6, 1e-9, 1e-12):
        for sign in (1, -1):
            y = 2 + sign * g
            toi, st = time_of_impact(
                A, A, one([3, y, 0], I, [1, 1, 1]), one([-3, y, 0], I, [1, 1, 1]), return_status=True
            )
            if sign > 0:
                assert st[0] in (Impact.NO_CONTACT, Impact.UNRESOLVED), (g, toi, st)
                if g >= 1e-9:
                    assert st[0] == Impact.NO_CONTACT
                else:  # UNRESOLVED: the proven range reaches at least to the closest approach's neighbourhood
                    assert toi[0] == math.inf or toi[0] > 0.49
            else:
                t_star = float((3 - mp.sqrt(4 - mp.mpf(y) ** 2)) / 6)
                if st[0] == Impact.CONTACT:  # the motion is in contact at toi
                    assert t_star - 1e-15 <= toi[0] <= t_star + TOI_TOL
                else:  # UNRESOLVED at g = 1e-12: approaching at 6e-6 size per unit time
                    assert st[0] == Impact.UNRESOLVED and g < 1e-9 and toi[0] <= t_star
    # exact grazing (touching at t = 1/2 only): UNRESOLVED, or a contact found within TOI_TOL of 1/2
    toi, st = time_of_impact(A, A, one([3, 2, 0], I, [1, 1, 1]), one([-3, 2, 0], I, [1, 1, 1]), return_status=True)
    assert st[0] in (Impact.UNRESOLVED, Impact.CONTACT_AT_FLOAT_POSE) and 0.5 - 1e-6 < toi[0] <= 0.5 + TOI_TOL
    assert (
        reference.motion_relation(
            A,
            A,
            np.zeros((1, 3)),
            one([3, 2, 0], I, [1, 1, 1]),
            one([-3, 2, 0], I, [1, 1, 1]),
            np.zeros((1, 3)),
            Fraction(1, 2),
        )
        == 1
    )


def test_pure_rotation_needle_against_bisection():
    """A needle spinning about its centre sweeps into a ball: toi against the first sampled hit, refined by
    bisection on the independent poses."""
    rng = np.random.default_rng(15)
    hits = 0
    for _ in range(40):
        axis = rng.normal(size=3)
        R0 = Rot.random(random_state=rng)
        R1 = Rot.from_rotvec(axis / np.linalg.norm(axis) * rng.uniform(0.5, 3.0)) * R0
        a0, a1 = one([0, 0, 0], R0.as_matrix(), [2.0, 0.1, 0.15]), one([0, 0, 0], R1.as_matrix(), [2.0, 0.1, 0.15])
        # the ball sits near where the needle's axis points at a random instant t_c
        t_c = rng.uniform(0.1, 1.0)
        axis_at = (R0.as_matrix() @ expm(t_c * skew((R0.inv() * R1).as_rotvec())))[:, 0]
        b = one(axis_at * rng.uniform(0.8, 1.9) + rng.uniform(-0.2, 0.2, 3), I, [0.3, 0.3, 0.3])
        toi, st = time_of_impact(a0, a1, b, b, return_status=True)
        ts = np.linspace(0, 1, 400)
        k = first_hits(a0, a1, b, b, ts)[0]
        if k == len(ts):
            assert toi[0] == math.inf or toi[0] > 0
            continue
        assert toi[0] <= ts[k] + TOI_TOL
        if k > 0:
            hits += 1
            lo, hi = ts[k - 1], ts[k]

            def rel(t):
                return int(
                    classify(independent_poses(a0, a1, np.array([t])), independent_poses(b, b, np.array([t])))[0]
                )

            for _ in range(40):
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if rel(mid) != SEP else (mid, hi)
            assert st[0] == Impact.CONTACT
            assert toi[0] < lo or abs(toi[0] - hi) < 2 * TOI_TOL  # a contact between earlier samples, or this one
    assert hits > 20


def test_identical_concentric_touching_at_the_ends_and_at_rest():
    rng = np.random.default_rng(16)
    a0, a1 = random_motion(rng, 20)
    toi, st = time_of_impact(a0, a1, a0, a1, return_status=True)
    assert np.all(toi == 0) and np.all(st == Impact.CONTACT)  # identical at t = 0
    b0 = Ellipsoids(a0.centers, Rot.random(20, random_state=rng).as_matrix(), a0.radii * 0.3)
    b1 = Ellipsoids(a1.centers, b0.rotations, b0.radii)
    assert np.all(time_of_impact(a0, a1, b0, b1) == 0)  # concentric throughout
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1, C0 = one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3)
    # exactly touching at t = 0 (dyadic), moving apart: 0, decided in rationals
    assert time_of_impact(A, A, B0, B1, return_status=True) == (0.0, Impact.CONTACT)
    # exactly touching only at t = 1, approaching: within TOI_TOL of 1
    toi, st = time_of_impact(A, A, C0, B0, return_status=True)
    assert 1 - TOI_TOL <= toi[0] <= 1 and st[0] in CONTACTS
    # separated throughout, at rest; and a sphere rotating in place next to it
    assert time_of_impact(A, A, C0, C0)[0] == math.inf
    spin = one([3, 0, 0], Rot.from_rotvec([0, 0, 3.0]).as_matrix(), [0.5] * 3)
    assert time_of_impact(A, A, C0, spin)[0] == math.inf


def test_reversed_motion_gives_the_last_contact():
    """Running the motion backwards is the same motion (w reverses exactly): 1 - toi(reversed) is the end
    of the last contact, and a contact that begins and ends between the two instants has both."""
    A = one([0, 0, 0], I, [1, 1, 1])
    b0, b1 = one([3, 0.5, 0], I, [0.5] * 3), one([-3, 0.5, 0], I, [0.5] * 3)
    t_in, t_out = time_of_impact(A, A, b0, b1)[0], 1 - time_of_impact(A, A, b1, b0)[0]
    half = math.sqrt(1.5**2 - 0.5**2) / 6
    assert abs(t_in - (0.5 - half)) <= TOI_TOL and abs(t_out - (0.5 + half)) <= TOI_TOL
    rng = np.random.default_rng(18)
    x0, x1 = random_motion(rng, 50)
    np.testing.assert_array_equal(wvec(x1, x0), -wvec(x0, x1))


def test_elongated_tiny_huge_and_far_off():
    rng = np.random.default_rng(22)
    n = 300
    a0, a1 = random_motion(rng, n, radii=(0.001, 1.0))
    b0, b1 = random_motion(rng, n, radii=(0.001, 1.0))
    toi, st = time_of_impact(a0, a1, b0, b1, return_status=True)
    check_contract(a0, a1, b0, b1, toi, st, 1000, "elongated")
    # the same pairs scaled by powers of two give the same answers (the pair is scaled exactly to unit size)
    for f in (2.0**-20, 2.0**20, 2.0**-200, 2.0**200):
        sc = lambda x: Ellipsoids(x.centers * f, x.rotations, x.radii * f)  # noqa: E731
        toi_f, st_f = time_of_impact(sc(a0), sc(a1), sc(b0), sc(b1), return_status=True)
        np.testing.assert_array_equal(toi_f, toi)
        np.testing.assert_array_equal(st_f, st)
    # 1e7 from the origin: the proven claims still hold against sampling
    shift = np.array([1e7, -3e6, 5e6])
    sh = lambda x: Ellipsoids(x.centers + shift, x.rotations, x.radii)  # noqa: E731
    toi_s, st_s = time_of_impact(sh(a0), sh(a1), sh(b0), sh(b1), return_status=True)
    check_contract(sh(a0), sh(a1), sh(b0), sh(b1), toi_s, st_s, 1000, "far off")


def test_rotations_orthonormal_only_to_1e7():
    """The motion R_p exp(phi [w]x) and the certificates hold for any invertible R_p: checked on the float
    poses the kernel classifies (the independent builder assumes orthonormal inputs)."""
    rng = np.random.default_rng(23)
    n = 150
    noisy = lambda x: Ellipsoids(x.centers, x.rotations + rng.uniform(-1e-7, 1e-7, x.rotations.shape), x.radii)  # noqa: E731
    a0, a1 = (noisy(x) for x in random_motion(rng, n))
    b0, b1 = (noisy(x) for x in random_motion(rng, n))
    toi, st = time_of_impact(a0, a1, b0, b1, return_status=True)
    for i in range(n):
        if toi[i] > TOI_TOL:
            for t in np.linspace(0, min(1.0, toi[i] - TOI_TOL), 8):
                assert own_relation(a0, a1, b0, b1, float(t), i) == SEP
        if st[i] in CONTACTS:
            assert own_relation(a0, a1, b0, b1, float(toi[i]), i) != SEP
    ends = np.flatnonzero(classify(a1, b1) != SEP)  # the end poses are the inputs exactly
    assert len(ends) and np.all(toi[ends] < math.inf)


def test_slow_approach_is_conservative():
    """The certificates resolve margins to ~1e-14 of the size, so approaches slower than ~1e-5 size per
    unit time cannot locate contact within TOI_TOL: UNRESOLVED then, with the proven range still right."""
    A = one([0, 0, 0], I, [1, 1, 1])
    for speed in (1e-3, 1e-4, 1e-5, 1e-7):
        b0, b1 = one([2 + 0.5 * speed, 0, 0], I, [1, 1, 1]), one([2 - 0.5 * speed, 0, 0], I, [1, 1, 1])
        toi, st = time_of_impact(A, A, b0, b1, return_status=True)
        assert toi[0] <= 0.5 + TOI_TOL
        end = toi[0] - TOI_TOL if st[0] in CONTACTS else toi[0]
        assert reference.motion_relation(A, A, np.zeros((1, 3)), b0, b1, np.zeros((1, 3)), max(end, 0.0)) == SEP
        if speed >= 1e-4:
            assert st[0] in CONTACTS


def test_rational_fallback_runs_batched():
    """Exactly touching poses make the certified filter unsure: the kernel asks for the exact relation
    (NEED_EXACT at t = 0 here) and time_of_impact supplies it from rationals, for a whole batch."""
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1 = one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3)
    arrays, n = T._check(A, A, B0, B1)
    out, status, t_exact = np.empty(1), np.empty(1, np.int8), np.empty(1)
    OT, OR, OC = np.zeros((1, 16)), np.zeros((1, 16), np.int8), np.zeros(1, np.int64)
    ext.toi(*arrays, np.arange(1), OT, OR, OC, out, status, t_exact, np.empty(1, np.int64), 0, 1)
    assert status[0] == T.NEED_EXACT and t_exact[0] == 0.0
    far = one([5, 0, 0], I, [0.5] * 3)
    toi, st = time_of_impact(
        A, A, Ellipsoids.concatenate([B0, far, B0]), Ellipsoids.concatenate([B1, far, B1]), return_status=True
    )
    assert toi.tolist() == [0.0, math.inf, 0.0] and st.tolist() == [Impact.CONTACT, Impact.NO_CONTACT, Impact.CONTACT]


def test_broadcasting_and_empty_batches():
    rng = np.random.default_rng(24)
    b0, b1 = random_motion(rng, 30)
    A = one([0, 0, 0], I, [0.5, 0.4, 0.3])
    toi = time_of_impact(A, A, b0, b1)
    assert toi.shape == (30,) and toi.dtype == np.float64
    for i in (0, 11):
        assert time_of_impact(A, A, b0[i], b1[i])[0] == toi[i]
    many = Ellipsoids.concatenate([A] * 30)
    np.testing.assert_array_equal(time_of_impact(b0, b1, A, A), time_of_impact(b0, b1, many, many))
    assert time_of_impact(A, A, b0[:0], b1[:0]).shape == (0,)


def test_value_errors_name_the_argument_index_and_value():
    A = one([0, 0, 0], I, [1, 1, 1])
    two = Ellipsoids(np.zeros((2, 3)), np.stack([I, I]), np.ones((2, 3)))
    wide = Ellipsoids(np.zeros((2, 3)), np.stack([I, I]), [[1, 1, 1], [1, 1, 2]])
    with pytest.raises(ValueError, match=r"a1.radii\[1\] must equal a0.radii\[1\] .*got \[1.0, 1.0, 2.0\]"):
        time_of_impact(two, wide, A, A)
    half = np.diag([1.0, -1.0, -1.0])  # a half turn about x
    turns = Ellipsoids(np.zeros((2, 3)), np.stack([I, half]), np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"a half turn between b0\[1\] and b1\[1\] \(angle 3.14"):
        time_of_impact(A, A, two, turns)
    with pytest.raises(ValueError, match="b1 must be an ellipsim.Ellipsoids batch, got str"):
        time_of_impact(A, A, A, "x")
    with pytest.raises(ValueError, match="a0 and a1 must have the same length"):
        time_of_impact(two, A, A, A)
    three = Ellipsoids.concatenate([A, A, A])
    with pytest.raises(ValueError, match="a0 and b0 must have the same length or one of them length 1, got 2 and 3"):
        time_of_impact(two, two, three, three)
    with pytest.raises(ValueError, match="parallel must be True, False or None"):
        time_of_impact(A, A, A, A, parallel="yes")


# --- the motion and its error bounds -----------------------------------------------------------------


def test_motion_reaches_the_end_pose_and_its_halves_meet():
    rng = np.random.default_rng(17)
    a0, a1 = random_motion(rng, 200)
    w = wvec(a0, a1)
    for i in range(200):
        assert np.abs(a0.rotations[i] @ expm(skew(w[i])) - a1.rotations[i]).max() < 1e-13
    arrays, _ = T._check(a0, a1, a0, a1)
    idx = np.arange(200)
    below = T.float_poses(arrays, idx, np.full(200, 0.5))
    above = T.float_poses(arrays, idx, np.full(200, np.nextafter(0.5, 1)))
    assert np.abs(below[1] - above[1]).max() < 1e-13
    ends = T.float_poses(arrays, idx, np.ones(200))
    np.testing.assert_array_equal(ends[1], a1.rotations)


def test_sincos_within_its_proven_bound():
    xs = np.concatenate([np.linspace(-1.6, 1.6, 4001), 10.0 ** np.random.default_rng(19).uniform(-17, 0.2, 1000)])
    sc = np.empty((len(xs), 2))
    ext.testing.sincos(xs, sc)  # the motion's sincos (interpolation.hpp), one row per x
    worst = 0.0
    with mp.workdps(40):
        for x, (s, c) in zip(xs, sc.tolist()):
            worst = max(worst, float(abs(s - mp.sin(mp.mpf(float(x))))), float(abs(c - mp.cos(mp.mpf(float(x))))))
    assert worst <= SINCOS_ERR
    assert worst <= 2 * U  # in practice far inside the proven bound


def _rodrigues_pair(w, phi, p, Rp):
    """rodrigues(w, phi)'s rodrigues_apply(., p), matmul(Rp, rodrigues_matrix(.)) and |alpha|, as the motion
    computes them (interpolation.hpp's stages: columns 0-6 the rod, 7-9 the applied E^T p, 19-27 Rp E)."""
    out = np.empty((1, 28))
    ext.testing.rodrigues_stages(
        np.array([w], float), np.array([phi], float), np.array([p], float), np.reshape(Rp, (1, 3, 3)).astype(float), out
    )
    o = out[0].tolist()
    return o[7:10], o[19:28], o[6]


def test_rodrigues_error_bounds_against_mpmath():
    """|fl(E(phi)^T p) - E(phi)^T p| <= (RODRIGUES_ERR + 12 |alpha|) u |p| and ||fl(R_p E~) - R_p E||_2 <= DELTA_R."""
    rng = np.random.default_rng(18)
    used_v = used_m = 0.0
    with mp.workdps(40):
        for k in range(300):
            w = rng.normal(size=3)
            w *= rng.uniform(0, math.pi - 1e-3) / np.linalg.norm(w)
            if k % 5 == 0:
                w *= 10.0 ** rng.integers(-12, -3)
            phi = float(rng.uniform(-0.5, 0.5))
            p, Rp = rng.normal(size=3), Rot.random(random_state=rng).as_matrix()
            got, R, alpha = _rodrigues_pair(tuple(w), phi, tuple(p), tuple(Rp.ravel()))
            wv = [mp.mpf(float(x)) for x in w]
            th = mp.sqrt(sum(x * x for x in wv))
            kx = mp.matrix([[0, -wv[2], wv[1]], [wv[2], 0, -wv[0]], [-wv[1], wv[0], 0]]) / th
            al = th * mp.mpf(phi)
            E = mp.eye(3) + mp.sin(al) * kx + (1 - mp.cos(al)) * kx * kx
            exact = E.T * mp.matrix([mp.mpf(float(x)) for x in p])
            err = math.sqrt(sum(float(got[j] - exact[j]) ** 2 for j in range(3)))
            bound = (RODRIGUES_ERR + 12 * alpha) * U * np.linalg.norm(p)
            assert err <= bound
            used_v = max(used_v, err / bound)
            D = np.array((mp.matrix(np.reshape(R, (3, 3)).tolist()) - mp.matrix(Rp.tolist()) * E).tolist(), dtype=float)
            assert np.linalg.norm(D, 2) <= DELTA_R
            used_m = max(used_m, np.linalg.norm(D, 2) / DELTA_R)
    assert used_v < 0.1 and used_m < 0.1  # the bounds are rigorous, not tight


def test_poses_at_follows_the_motion():
    rng = np.random.default_rng(25)
    x0, x1 = random_motion(rng, 60)
    ts = rng.uniform(0, 1, 60)
    got = motion.poses_at(x0, x1, ts)
    ref = [independent_poses(x0[i], x1[i], ts[i : i + 1]) for i in range(60)]
    assert max(np.abs(got.rotations[i] - ref[i].rotations[0]).max() for i in range(60)) < 1e-13
    assert max(np.abs(got.centers[i] - ref[i].centers[0]).max() for i in range(60)) < 1e-14
    np.testing.assert_array_equal(got.radii, x0.radii)
    for t, x in ((0.0, x0), (1.0, x1)):  # the inputs themselves at the ends
        ends = motion.poses_at(x0, x1, t)
        np.testing.assert_array_equal(ends.centers, x.centers)
        np.testing.assert_array_equal(ends.rotations, x.rotations)
    # the rotations time_of_impact classifies are these
    arrays, _ = T._check(x0, x1, x0, x1)
    np.testing.assert_array_equal(T.float_poses(arrays, np.arange(60), ts)[1], got.rotations)
    with pytest.raises(ValueError, match=r"t\[1\] must lie in \[0, 1\], got 1.5"):
        motion.poses_at(x0[:2], x1[:2], [0.5, 1.5])
    with pytest.raises(ValueError, match=r"t must be a number or have shape \(2,\)"):
        motion.poses_at(x0[:2], x1[:2], [0.5, 0.5, 0.5])
