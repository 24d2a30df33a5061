import numpy as np
import pytest
import reference
import strategies as S
from hypothesis import given
from hypothesis import strategies as st

from ellipsim import (
    Ellipsoids,
    Relation,
    characteristic_polynomial,
    classify,
    classify_pairs,
    contact_scale,
    signed_distance,
)
from ellipsim.core.exact.certified_filter import certify
from ellipsim.core.relation import UNDECIDED
from ellipsim.core.samples import generic_pairs, near_contact_pairs, stress_pairs

SEP, TOUCH, OVER = Relation.SEPARATED, Relation.TOUCHING, Relation.OVERLAPPING
I = np.eye(3)


def exact(a, b):
    return int(classify(a, b)[0])


def ref(a, b):
    return reference.relations(a, b)[0]


def test_relation_codes():
    assert [int(r) for r in Relation] == [0, 1, 2]
    assert classify(S.one([0, 0, 0], I, [1, 1, 1]), S.one([3, 0, 0], I, [1, 1, 1])).dtype == np.int8


@pytest.mark.parametrize(
    "cb, rb, expected",
    [
        ([2, 0, 0], [1, 1, 1], TOUCH),  # unit spheres 2 apart
        ([2 + 2**-51, 0, 0], [1, 1, 1], SEP),  # one ulp apart
        ([2 - 2**-52, 0, 0], [1, 1, 1], OVER),
        ([0, 0, 0], [1, 1, 1], OVER),  # identical
        ([0.5, 0, 0], [0.5, 0.5, 0.5], OVER),  # internally tangent: interiors meet
        ([0, 0, 0], [0.5, 0.5, 0.5], OVER),  # contained
        ([1.5, 0, 0], [0.5, 2, 0.25], TOUCH),  # axis-aligned, dyadic, meeting at x = 1
        ([0, 0, 1.25], [3, 3, 0.25], TOUCH),
    ],
)
def test_hand_picked_cases(cb, rb, expected):
    a, b = S.one([0, 0, 0], I, [1, 1, 1]), S.one(cb, I, rb)
    assert exact(a, b) == expected == ref(a, b)
    assert exact(b, a) == expected


@given(S.random_pair())
def test_exact_matches_reference_on_random_pairs(pair):
    a, b = pair
    assert exact(a, b) == ref(a, b)


@given(S.hard_pair)
def test_exact_matches_reference_on_hard_pairs(pair):
    a, b = pair
    assert exact(a, b) == ref(a, b)


@given(S.exact_tangent_pair())
def test_exactly_tangent_pairs_touch(pair):
    assert exact(*pair) == TOUCH


@given(S.pythagorean_spheres())
def test_pythagorean_spheres(pair):
    a, b = pair
    gap = np.linalg.norm(b.centers[0] - a.centers[0]) - a.radii[0, 0] - b.radii[0, 0]
    expected = TOUCH if gap == 0 else (SEP if gap > 0 else OVER)
    assert exact(a, b) == expected == ref(a, b)


@given(S.hard_pair)
def test_symmetry(pair):
    a, b = pair
    assert exact(a, b) == exact(b, a)


@given(S.hard_pair, st.integers(-30, 30))
def test_invariant_under_dyadic_scaling(pair, k):
    a, b = pair
    f = 2.0**k

    def scale(e):
        return Ellipsoids(e.centers * f, e.rotations, e.radii * f)

    assert exact(scale(a), scale(b)) == exact(a, b)


@given(S.exact_tangent_pair() | S.spheroid_pair() | S.pythagorean_spheres(), st.integers(0, 47), st.integers(-64, 64))
def test_invariant_under_exact_rigid_motions(pair, p, t):
    """Signed permutations and dyadic translations are exact in floats: the relation cannot change."""
    a, b = pair
    P = S.SIGNED_PERMUTATIONS[p]
    shift = np.array([t, -t, 2 * t]) / 4.0

    def move(e):
        return Ellipsoids(e.centers @ P.T + shift, P @ e.rotations, e.radii)

    assert exact(move(a), move(b)) == exact(a, b)


@given(S.random_pair(), S.quaternions, S.centers)
def test_invariant_under_rigid_motions_away_from_tangency(pair, q, shift):
    a, b = pair
    if abs(contact_scale(a, b)[0] - 1) < 1e-6:
        return
    R = Ellipsoids.from_quaternions(shift, q, [1, 1, 1]).rotations[0]

    def move(e):
        return Ellipsoids(e.centers @ R.T + shift, R @ e.rotations, e.radii)

    assert exact(move(a), move(b)) == exact(a, b)


@given(S.near_tangent_pair(gaps=(1e-3, 1e-6, 1e-9)))
def test_certified_path_decides_pairs_a_billionth_from_touching(pair):
    """Escalation is for the last few digits only: a 1e-9 relative gap is decided in float64."""
    a, b = pair
    assert certify(a, b, 1, False)[0] != UNDECIDED


def test_broadcasting_and_parallel_agree_with_serial():
    rng = np.random.default_rng(1)
    n = 3000
    a = Ellipsoids.from_quaternions(rng.uniform(-2, 2, (n, 3)), rng.normal(size=(n, 4)), rng.uniform(0.1, 1, (n, 3)))
    b = Ellipsoids.from_quaternions(rng.uniform(-2, 2, (n, 3)), rng.normal(size=(n, 4)), rng.uniform(0.1, 1, (n, 3)))
    serial = classify(a, b, parallel=False)
    np.testing.assert_array_equal(classify(a, b, parallel=True), serial)
    assert set(np.unique(serial)) == {0, 2}
    one = classify(a[0], b)
    np.testing.assert_array_equal(one[::300], [classify(a[0], b[i])[0] for i in range(0, n, 300)])
    np.testing.assert_array_equal(classify(b, a[0]), one)
    assert classify(a[:0], b[:0]).shape == (0,)


def _generic(pair):
    """Pencil roots 1% apart (spheres, spheroids and parallel twins have repeated roots), 5% from touching."""
    a, b = pair
    A = reference.quadric(a.centers[0], a.rotations[0], a.radii[0])
    B = reference.quadric(b.centers[0], b.rotations[0], b.radii[0])
    roots = np.roots([float(c) for c in reference.pencil(A, B)])
    gaps = np.abs(roots[:, None] - roots[None, :])[np.triu_indices(4, 1)]
    return gaps.min() > 1e-2 * np.abs(roots).max() and abs(contact_scale(a, b)[0] - 1) > 0.05


easy_pair = S.random_pair().filter(_generic)


@given(pair=easy_pair)
def test_thesis_methods_agree_with_exact_on_generic_pairs(pair):
    """Generic pairs in float64, each checked with all four method and set-up pairs (one draw and one
    generic-ness filter per pair for the four; the thesis methods' weak cases are measured in bench/)."""
    a, b = pair
    want = exact(a, b)
    for method in ("sturm", "descartes"):
        for setup in ("rearranged", "cofactor"):
            assert classify(a, b, method=method, setup=setup)[0] == want, (method, setup)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(method="gjk"), r"method must be one of \('exact', 'sturm', 'descartes'\), got 'gjk'"),
        (dict(method="sturm", setup="direct"), r"setup must be one of \('rearranged', 'cofactor'\), got 'direct'"),
        (dict(method="sturm", dtype="float16"), r"dtype must be one of \('float64', 'float32'\), got 'float16'"),
        (dict(setup="cofactor"), "setup and dtype apply to the 'sturm' and 'descartes' methods"),
        (dict(method=np.array(["exact"])), r"method must be one of .*, got array\(\['exact'\]"),
        (dict(method="sturm", dtype=None), r"dtype must be one of .*, got None"),
        (dict(parallel="no"), r"parallel must be True, False or None, got 'no'"),
        (dict(parallel=0.5), r"parallel must be True, False or None, got 0.5"),
    ],
)
def test_bad_arguments(kwargs, message):
    a = S.one([0, 0, 0], I, [1, 1, 1])
    with pytest.raises(ValueError, match=message):
        classify(a, a, **kwargs)


def test_dtype_accepts_numpy_types():
    a = S.one([0, 0, 0], I, [1, 1, 1])
    b = S.one([3, 0, 0], I, [1, 1, 1])
    for dtype in (np.float32, np.dtype("float32"), "float32"):
        assert classify(a, b, method="sturm", dtype=dtype)[0] == Relation.SEPARATED


def test_other_queries_name_their_bad_arguments():
    a = S.one([0, 0, 0], I, [1, 1, 1])
    with pytest.raises(ValueError, match=r"setup must be one of .*, got array"):
        characteristic_polynomial(a, a, setup=np.array(["cofactor"]))
    with pytest.raises(ValueError, match=r"max_iter must be an integer from 1 to 1000000, got 1180591620717411303424"):
        signed_distance(a, a, max_iter=2**70)
    with pytest.raises(ValueError, match=r"band must be a positive finite number, got 0"):
        near_contact_pairs(5, band=0)
    with pytest.raises(ValueError, match=r"band must be a positive finite number, got nan"):
        near_contact_pairs(5, band=float("nan"))


def test_serial_and_parallel_queries_agree():
    a, b = near_contact_pairs(300, seed=4)
    np.testing.assert_array_equal(contact_scale(a, b, parallel=True), contact_scale(a, b, parallel=False))
    for x, y in zip(signed_distance(a, b, parallel=True), signed_distance(a, b, parallel=False)):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError, match="parallel must be True, False or None, got 'yes'"):
        contact_scale(a, b, parallel="yes")


def test_bad_batches():
    a = Ellipsoids(np.zeros((2, 3)), np.stack([I, I]), np.ones((2, 3)))
    b = Ellipsoids(np.zeros((3, 3)), np.stack([I, I, I]), np.ones((3, 3)))
    with pytest.raises(ValueError, match="same length or one of them length 1, got 2 and 3"):
        classify(a, b)
    with pytest.raises(ValueError, match="b must be an ellipsim.Ellipsoids batch, got ndarray"):
        classify(a, np.zeros(3))


def test_classify_pairs_indexes_one_batch_as_classify_does_on_copies():
    n = 6000  # several chunks when parallel
    a, b = generic_pairs(n, seed=21)
    ta, tb = stress_pairs("exactly tangent", 20, seed=3)  # rationals decide these
    batch = Ellipsoids.concatenate([a, b, ta, tb])
    rng = np.random.default_rng(0)
    first = np.r_[np.arange(n), 2 * n + np.arange(20), rng.integers(0, len(batch), 500)]
    second = np.r_[n + np.arange(n), 2 * n + 20 + np.arange(20), rng.integers(0, len(batch), 500)]
    want = classify(batch[first], batch[second])
    for parallel in (False, True):
        assert np.array_equal(classify_pairs(batch, first, second, parallel=parallel), want)
    assert (want[n : n + 20] == Relation.TOUCHING).all()
    assert classify_pairs(batch, [], []).shape == (0,)


@pytest.mark.parametrize(
    "first, second, match",
    [
        ([0, 5], [1, 2], r"first\[1\] must index the batch of 4 ellipsoids, got 5"),
        ([0], [-1], r"second\[0\] must index the batch of 4 ellipsoids, got -1"),
        ([0.5], [1], r"first must be a 1-D array of integer indices"),
        ([[0]], [1], r"first must be a 1-D array of integer indices, got shape \(1, 1\)"),
        ([0, 1], [1], r"first and second must have the same length, got 2 and 1"),
    ],
)
def test_classify_pairs_names_bad_indices(first, second, match):
    a, _ = generic_pairs(4, seed=1)
    with pytest.raises(ValueError, match=match):
        classify_pairs(a, first, second)
    with pytest.raises(ValueError, match=r"batch must be an ellipsim.Ellipsoids batch, got list"):
        classify_pairs([1], [0], [0])


@pytest.mark.parametrize("method", ["sturm", "descartes"])
@pytest.mark.parametrize("setup", ["rearranged", "cofactor"])
def test_the_thesis_tests_in_float32_are_right_away_from_tangency_and_float32_near_it(method, setup):
    """dtype="float32" computes the quartic and its root test in float32 (the C++ kernel's float instance):
    on generic pairs whose contact scale is 0.3 or more from 1 it answers as the exact test (Descartes on the
    cofactor set-up, the thesis's weakest, on all but 0.5% of them: the stress section of `ellipsim bench`
    measures where), and within 1e-4 of tangency it parts from the float64 run on some pair."""
    a, b = generic_pairs(6000, seed=5)
    far = np.flatnonzero(np.abs(contact_scale(a, b) - 1.0) > 0.3)
    a, b = a[far], b[far]
    wrong = np.count_nonzero(classify(a, b, method=method, setup=setup, dtype="float32") != classify(a, b))
    assert wrong <= (0.005 * len(far) if (method, setup) == ("descartes", "cofactor") else 0), wrong
    a, b = near_contact_pairs(4000, band=1e-4, seed=5)
    f32 = classify(a, b, method=method, setup=setup, dtype="float32")
    f64 = classify(a, b, method=method, setup=setup, dtype="float64")
    assert np.count_nonzero(f32 != f64) > 0
