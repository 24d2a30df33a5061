"""contains: float filter and rational fallback against a 60-digit mpmath reference (reference.py:
max of q_A over B by the secular equation) and against constructed cases whose answer is exact."""

import numpy as np
import pytest
import reference
import strategies as S
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation as Rot

from ellipsim import Ellipsoids
from ellipsim.core.exact.containment import INSIDE, UNDECIDED, certify_containment, contains, contains_exact

I = np.eye(3)


def one(c, R, r):
    return Ellipsoids(np.asarray(c, float), np.asarray(R, float), np.asarray(r, float))


def check(a, b, expected=None):
    """contains, its rational fallback and the reference agree (and equal `expected`); returns
    (answer, whether the float filter left it to rationals)."""
    got = bool(contains(a, b)[0])
    undecided = bool(certify_containment(a, b, 1, False)[0] == UNDECIDED)
    args = (a.centers[0], a.rotations[0], a.radii[0], b.centers[0], b.rotations[0], b.radii[0])
    ref, margin = reference.contained(*args)
    assert got == (contains_exact(*args) == INSIDE) == ref, (got, ref, margin)
    if expected is not None:
        assert got == expected
    return got, undecided


@pytest.mark.parametrize(
    "cb, rb, expected",
    [
        ([1, 0, 0], [1, 1, 1], True),  # internally tangent spheres (radius 2 and 1)
        ([1 + 2**-40, 0, 0], [1, 1, 1], False),
        ([1 - 2**-40, 0, 0], [1, 1, 1], True),
        ([0, 0, 0], [2, 2, 2], True),  # identical
        ([0, 0, 0], [1, 1, 1], True),  # concentric, smaller
        ([0, 0, 0], [2, 2, 2 + 2**-40], False),
        ([3, 0, 0], [1, 1, 1], False),  # overlapping, not contained
        ([5, 0, 0], [1, 1, 1], False),  # separated
        ([0, 0, 0], [2.5, 0.1, 0.1], False),  # a needle longer than A
    ],
)
def test_spheres_and_hand_picked(cb, rb, expected):
    check(one([0, 0, 0], I, [2, 2, 2]), one(cb, I, rb), expected)


def test_identical_and_same_frame_pairs_need_no_rationals():
    rng = np.random.default_rng(3)
    n = 40
    a = Ellipsoids(rng.uniform(-3, 3, (n, 3)), Rot.random(n, random_state=rng).as_matrix(), rng.uniform(0.1, 2, (n, 3)))
    assert contains(a, a).all()
    assert np.all(certify_containment(a, a, n, False) == INSIDE)
    smaller = Ellipsoids(a.centers, a.rotations, a.radii * rng.uniform(0.5, 1.0, (n, 3)))
    assert contains(a, smaller).all() and np.all(certify_containment(a, smaller, n, False) == INSIDE)
    for i in range(0, n, 8):
        check(a[i], a[i], True)


def test_concentric_scaled_and_rotated():
    rng = np.random.default_rng(4)
    for k in range(24):
        R = Rot.random(random_state=rng).as_matrix()
        r = rng.uniform(0.1, 2, 3)
        f = [0.5, 0.25, 0.999, 1.0 + 2**-30][k % 4]
        check(
            Ellipsoids(np.zeros(3), R, r),
            Ellipsoids(np.zeros(3), R @ Rot.from_rotvec([0, 0, 1e-3]).as_matrix(), r * f),
            None,
        )
        check(Ellipsoids(np.zeros(3), R, r), Ellipsoids(np.zeros(3), R, r * f), f <= 1)


def test_exactly_internally_tangent_dyadic():
    """A axis-aligned with dyadic semi-axes a; B axis-aligned, b0 <= a0 along x, centred at x = a0 - b0
    and curving more than A at the contact point (b_k^2 / b0 <= a_k^2 / a0): B touches A at (a0, 0, 0)
    from inside.  Everything is exact in floats; a signed permutation and a dyadic shift move the pair."""
    rng = np.random.default_rng(5)
    undecided = 0
    for _ in range(40):
        a = rng.integers(4, 33, 3) / 8.0
        b0 = rng.integers(1, int(a[0] * 8) + 1) / 8.0
        bk = [max(np.floor(min(a[k] * np.sqrt(b0 / a[0]), a[k]) * 8) / 8.0, 1 / 16) for k in (1, 2)]
        P = S.SIGNED_PERMUTATIONS[rng.integers(len(S.SIGNED_PERMUTATIONS))]
        shift = rng.integers(-16, 17, 3) / 4.0
        A = one(shift, P, a)
        rb = [b0, *bk]
        undecided += check(A, one(shift + P @ np.array([a[0] - b0, 0, 0]), P, rb), True)[1]
        check(A, one(shift + P @ np.array([a[0] - b0 + 2.0**-30, 0, 0]), P, rb), False)
    assert undecided > 0  # tangency from inside is what the rational fallback is for


def test_random_near_containment_against_the_reference():
    """B small-ish and centred inside A: a mix of inside and poking out, many close calls; the float
    filter decides almost all of them."""
    rng = np.random.default_rng(6)
    n = 300
    ra = rng.uniform(0.5, 2, (n, 3))
    Ra = Rot.random(n, random_state=rng).as_matrix()
    ca = rng.uniform(-2, 2, (n, 3))
    rb = ra.min(1)[:, None] * rng.uniform(0.1, 1.0, (n, 3))
    cb = ca + np.einsum("nij,nj->ni", Ra, ra * rng.uniform(-0.6, 0.6, (n, 3)))
    a, b = Ellipsoids(ca, Ra, ra), Ellipsoids(cb, Rot.random(n, random_state=rng).as_matrix(), rb)
    got = contains(a, b)
    ref = [
        reference.contained(a.centers[i], a.rotations[i], a.radii[i], b.centers[i], b.rotations[i], b.radii[i])[0]
        for i in range(n)
    ]
    np.testing.assert_array_equal(got, ref)
    assert 30 < got.sum() < n - 30
    assert np.count_nonzero(certify_containment(a, b, n, False) == UNDECIDED) <= 3
    np.testing.assert_array_equal(contains(a, b, parallel=True), got)


def test_shrunk_about_an_interior_point_by_one_minus_or_plus_2_to_the_minus_k():
    """B = p + s (A - p) for p inside A: inside for s = 1 - 2^-k, poking out by ~2^-k for s = 1 + 2^-k."""
    rng = np.random.default_rng(7)
    for k in (10, 20, 30, 40):
        for _ in range(4):
            ra = rng.uniform(0.5, 2, 3)
            R = Rot.random(random_state=rng).as_matrix()
            ca = rng.uniform(-1, 1, 3)
            p = ca + R @ (ra * rng.uniform(-0.3, 0.3, 3))
            for s, expected in ((1 - 2.0**-k, True), (1 + 2.0**-k, False)):
                check(Ellipsoids(ca, R, ra), Ellipsoids(p + s * (ca - p), R, ra * s), expected)


@settings(max_examples=60)
@given(S.random_pair())
def test_random_pairs_against_the_reference(pair):
    a, b = pair
    check(a, b)
    check(b, a)


@given(st.sampled_from([2.0**-20, 2.0**20, 2.0**-300, 2.0**300]), st.integers(0, 10**6))
def test_scaling_by_powers_of_two_changes_nothing(f, seed):
    rng = np.random.default_rng(seed)
    ra = rng.uniform(0.5, 2, 3)
    R = Rot.random(random_state=rng).as_matrix()
    a = Ellipsoids(rng.uniform(-1, 1, 3), R, ra)
    b = Ellipsoids(
        a.centers[0] + R @ (ra * rng.uniform(-0.3, 0.3, 3)),
        Rot.random(random_state=rng).as_matrix(),
        ra.min() * rng.uniform(0.2, 1.0, 3),
    )
    sc = lambda x: Ellipsoids(x.centers * f, x.rotations, x.radii * f)  # noqa: E731
    assert contains(sc(a), sc(b))[0] == contains(a, b)[0]


def test_roles_broadcasting_and_errors():
    big, small = one([0, 0, 0], I, [2, 2, 2]), one([0.5, 0, 0], I, [1, 1, 1])
    assert contains(big, small)[0] and not contains(small, big)[0]
    b = Ellipsoids(np.array([[0, 0, 0], [3, 0, 0]], float), np.stack([I, I]), np.ones((2, 3)))
    assert contains(big, b).tolist() == [True, False] and contains(b, big).tolist() == [False, False]
    assert contains(big, b[:0]).shape == (0,)
    with pytest.raises(ValueError, match="b must be an ellipsim.Ellipsoids batch"):
        contains(big, "b")
    three = Ellipsoids.concatenate([big, big, big])
    with pytest.raises(ValueError, match="a and b must have the same length or one of them length 1, got 3 and 2"):
        contains(three, b)
