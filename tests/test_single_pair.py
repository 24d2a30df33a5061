"""One pair per call (issue 20): the small-batch paths of classify, signed_distance and time_of_impact
give, bit for bit, what the same pair gets inside a batch (which takes the general path), and bad
single-pair input raises the general path's ValueError."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot

from ellipsim import Ellipsoids, classify, signed_distance, time_of_impact
from ellipsim.core.ellipsoids import indices_of
from ellipsim.core.motion.time_of_impact import Impact
from ellipsim.core.samples import generic_pairs, stress_pairs
from ellipsim.core.tolerances import CHUNK_MIN_PAIRS, SMALL_BATCH_PAIRS

I = np.eye(3)
BIG = 3 * SMALL_BATCH_PAIRS  # a batch past the small-batch paths


def bits(x):
    """The bytes of an array, for bit-for-bit comparison (-0.0 and NaN payloads included)."""
    return np.ascontiguousarray(x).tobytes()


def pairs():
    """BIG pairs: generic ones with exactly tangent and near-tangent ones (the rational fallback) mixed in."""
    parts = [generic_pairs(BIG - 12, seed=7), stress_pairs("exactly tangent", 6, seed=1)]
    parts.append(stress_pairs("near-tangent 1e-15", 6, seed=2))
    cat = lambda k: Ellipsoids.concatenate([p[k] for p in parts])
    return cat(0), cat(1)


def motions(rng, n):
    """n random motions of A and of B, turned by up to 3 rad, moving across each other."""
    out = []
    for _ in range(2):
        R0 = Rot.random(n, random_state=rng)
        rv = rng.normal(size=(n, 3))
        rv *= (rng.uniform(0, 3.0, n) / np.linalg.norm(rv, axis=1))[:, None]
        r = rng.uniform(0.1, 1.0, (n, 3))
        out.append(Ellipsoids(rng.uniform(-1.5, 1.5, (n, 3)), R0.as_matrix(), r))
        out.append(Ellipsoids(rng.uniform(-1.5, 1.5, (n, 3)), (R0 * Rot.from_rotvec(rv)).as_matrix(), r))
    return out


def test_classify_one_pair_is_the_pair_in_a_batch():
    a, b = pairs()
    full = classify(a, b)
    assert full.dtype == np.int8 and len(full) == BIG
    for i in range(BIG):
        one = classify(a[i], b[i])
        assert one.dtype == np.int8 and one.shape == (1,) and bits(one) == bits(full[i : i + 1])
        assert bits(classify(a[i], b[i], parallel=True)) == bits(one)
    # a small batch, and one ellipsoid broadcast against a small and a big batch
    assert bits(classify(a[:SMALL_BATCH_PAIRS], b[:SMALL_BATCH_PAIRS])) == bits(full[:SMALL_BATCH_PAIRS])
    many = Ellipsoids.concatenate([a[3]] * BIG)
    assert bits(classify(a[3], b)) == bits(classify(many, b))
    assert bits(classify(a[3], b[:4])) == bits(classify(many[:4], b[:4]))
    assert bits(classify(b, a[3])) == bits(classify(b, many))
    assert classify(a[3], b[:0]).shape == classify(a[:0], b[3]).shape == (0,)
    # the thesis's methods keep theirs
    for method in ("sturm", "descartes"):
        one = classify(a[5], b[5], method=method, setup="cofactor", dtype=np.float32)
        assert bits(one) == bits(classify(a, b, method=method, setup="cofactor", dtype="float32")[5:6])


def test_signed_distance_one_pair_is_the_pair_in_a_batch():
    a, b = pairs()
    full = signed_distance(a, b)
    for i in range(BIG):
        one = signed_distance(a[i], b[i])
        for x, y in zip(one, full):
            assert x.dtype == y.dtype and x.shape == (1, *y.shape[1:]) and bits(x) == bits(y[i : i + 1])
    assert [x.shape for x in signed_distance(a[3], b[:0])] == [(0,), (0, 3), (0, 3), (0,)]
    capped = signed_distance(a, b, max_iter=2)
    for x, y in zip(signed_distance(a[4], b[4], max_iter=np.int64(2)), capped):
        assert bits(x) == bits(y[4:5])
    many = Ellipsoids.concatenate([a[3]] * BIG)
    for x, y in zip(signed_distance(a[3], b), signed_distance(many, b)):
        assert bits(x) == bits(y)


def test_time_of_impact_one_pair_is_the_pair_in_a_batch():
    rng = np.random.default_rng(20)
    a0, a1, b0, b1 = motions(rng, BIG)
    # pair 0: exactly touching at t = 0, so the kernel asks for the exact relation (the general path)
    A = Ellipsoids([0.0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1 = Ellipsoids([1.5, 0, 0], I, [0.5] * 3), Ellipsoids([3.0, 0, 0], I, [0.5] * 3)
    a0, a1 = Ellipsoids.concatenate([A, a0[1:]]), Ellipsoids.concatenate([A, a1[1:]])
    b0, b1 = Ellipsoids.concatenate([B0, b0[1:]]), Ellipsoids.concatenate([B1, b1[1:]])
    toi, status = time_of_impact(a0, a1, b0, b1, return_status=True)
    assert toi[0] == 0.0 and status[0] == Impact.CONTACT
    assert np.isfinite(toi).sum() > 3 and np.isinf(toi).sum() > 3  # contacts and misses both
    for i in range(BIG):
        t, s = time_of_impact(a0[i], a1[i], b0[i], b1[i], return_status=True)
        assert t.dtype == np.float64 and s.dtype == np.int8 and t.shape == s.shape == (1,)
        assert bits(t) == bits(toi[i : i + 1]) and bits(s) == bits(status[i : i + 1])
        assert bits(time_of_impact(a0[i], a1[i], b0[i], b1[i], parallel=True)) == bits(t)
    assert time_of_impact(a0[0], a1[0], b0[:0], b1[:0]).shape == (0,)
    assert time_of_impact(a0[:0], a1[:0], b0[0], b1[0], return_status=True)[1].shape == (0,)
    k = SMALL_BATCH_PAIRS
    assert bits(time_of_impact(a0[:k], a1[:k], b0[:k], b1[:k])) == bits(toi[:k])
    many0, many1 = Ellipsoids.concatenate([a0[5]] * BIG), Ellipsoids.concatenate([a1[5]] * BIG)
    assert bits(time_of_impact(a0[5], a1[5], b0, b1)) == bits(time_of_impact(many0, many1, b0, b1))
    assert bits(time_of_impact(b0[:3], b1[:3], a0[5], a1[5])) == bits(
        time_of_impact(b0[:3], b1[:3], many0[:3], many1[:3])
    )


def test_bad_single_pair_input_raises_the_general_error():
    A = Ellipsoids([0.0, 0, 0], I, [1, 1, 1])
    with pytest.raises(ValueError, match=r"centers\[0, 1\] must be finite, got nan"):
        Ellipsoids([0.0, math.nan, 0], I, [1, 1, 1])
    with pytest.raises(ValueError, match=r"radii\[0, 2\] must be positive, got 0.0"):
        Ellipsoids([0.0, 0, 0], I, [1, 1, 0])
    with pytest.raises(ValueError, match=r"rotations\[0\] must be orthonormal"):
        Ellipsoids([0.0, 0, 0], I * (1 + 2e-6), [1, 1, 1])
    for fn in (classify, signed_distance):
        with pytest.raises(ValueError, match="b must be an ellipsim.Ellipsoids batch, got ndarray"):
            fn(A, np.zeros(3))
        with pytest.raises(ValueError, match="parallel must be True, False or None, got 'yes'"):
            fn(A, A, parallel="yes")
    with pytest.raises(ValueError, match="method must be one of"):
        classify(A, A, method="Exact")
    with pytest.raises(ValueError, match="method must be one of"):
        classify(A, A, method=np.array(["exact"]))
    with pytest.raises(ValueError, match="setup and dtype apply to the 'sturm' and 'descartes' methods"):
        classify(A, A, dtype=np.float32)
    for bad in (True, 0, 1.5, 1_000_001):
        with pytest.raises(ValueError, match=f"max_iter must be an integer from 1 to 1000000, got {bad!r}"):
            signed_distance(A, A, max_iter=bad)
    wide = Ellipsoids([0.0, 0, 0], I, [1, 1, 2])
    with pytest.raises(ValueError, match=r"a1.radii\[0\] must equal a0.radii\[0\] .*got \[1.0, 1.0, 2.0\]"):
        time_of_impact(A, wide, A, A)
    with pytest.raises(ValueError, match=r"b1.radii\[0\] must equal b0.radii\[0\]"):
        time_of_impact(A, A, A, wide)
    half = Ellipsoids([0.0, 0, 0], np.diag([1.0, -1.0, -1.0]), [1, 1, 1])  # a half turn about x
    with pytest.raises(ValueError, match=r"a half turn between a0\[0\] and a1\[0\] \(angle 3.14"):
        time_of_impact(A, half, A, half)
    with pytest.raises(ValueError, match=r"a half turn between b0\[0\] and b1\[0\] \(angle 3.14"):
        time_of_impact(A, A, A, half)
    with pytest.raises(ValueError, match="a0 and a1 must have the same length"):
        time_of_impact(A, Ellipsoids.concatenate([A, A]), A, A)
    with pytest.raises(ValueError, match="a0 must be an ellipsim.Ellipsoids batch, got list"):
        time_of_impact([A], A, A, A)
    with pytest.raises(ValueError, match="parallel must be True, False or None, got 'yes'"):
        time_of_impact(A, A, A, A, parallel="yes")


def test_indices_of_matches_flatnonzero_on_both_sides_of_the_small_batch_size():
    rng = np.random.default_rng(3)
    for n in (0, 1, SMALL_BATCH_PAIRS, SMALL_BATCH_PAIRS + 1, 200):
        codes = rng.integers(-1, 3, n).astype(np.int8)
        assert list(indices_of(codes, -1)) == np.flatnonzero(codes == -1).tolist()


def test_small_batches_are_below_threads_splitting():
    """The small-batch paths run serially: threads.run would not split them either, parallel=True or not."""
    assert 1 <= SMALL_BATCH_PAIRS < 2 * CHUNK_MIN_PAIRS
