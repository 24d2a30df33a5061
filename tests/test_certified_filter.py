"""core/exact/certified_filter.py on its own: the certified float64 filter never decides against the exact
relation, and leaves a pair UNDECIDED only near tangency.

References: the exact relation of tests/test_rational_fallback.py (`exact_relation`: world quadrics in
Fractions, det(lambda M_A + M_B) by the Leibniz formula, distinct positive roots by Descartes' rule of signs on
bisected intervals; nothing of ellipsim), and, for many random pairs far from tangency, the Perram-Wertheim
contact scale computed with scipy (`contact_scale`: > 1 separated, < 1 overlapping; trusted only 1e-3 away
from 1, where its float error cannot matter).

Checked: certify and separated_by_axes on random pairs, on pairs moved along the centre line to within
1e-15 ... 1e-5 of touching (decided and right from 1e-9 on, the relative gap test_classify.py names; never wrong
below it), on exactly tangent dyadic pairs (spheres, axis-aligned ellipsoids in signed permutations: UNDECIDED is
the only right answer) and their 2^-40 hairs, concentric pairs of any shapes, shapes outside the float range
(RATIO_MAX: UNDECIDED unless the bounding spheres are apart), power-of-two scalings, broadcasting and threads.
"""

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot
from test_rational_fallback import contact_scale, exact_relation, near_tangent, random_pair

from ellipsim import Ellipsoids
from ellipsim.core.exact import certified_filter as cf
from ellipsim.core.relation import OVERLAPPING, SEPARATED, TOUCHING, UNDECIDED
from ellipsim.core.tolerances import RATIO_MAX
from ellipsim.native import ext

I3 = np.eye(3)
PROPER = [P for P in (np.eye(3)[list(p)] * s for p in itertools.permutations(range(3))
                      for s in ([1, 1, 1], [-1, 1, -1])) if np.linalg.det(P) > 0]  # fmt: skip
DECIDED_FROM = 1e-9  # relative gap beyond which the float path must decide


def batches(pairs):
    cols = list(zip(*pairs))
    return Ellipsoids(*(np.array(c, dtype=float) for c in cols[:3])), Ellipsoids(
        *(np.array(c, dtype=float) for c in cols[3:])
    )


def certify(pairs, parallel=False):
    a, b = batches(pairs)
    return cf.certify(a, b, len(pairs), parallel)


def by_axes(pair):
    a, b = batches([pair])
    out = np.empty(1, dtype=bool)
    ext.testing.separated_by_axes(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out, 0, 1)
    return bool(out[0])


def check_never_wrong(pairs, got):
    """Every decision is the exact relation; returns the exact relations."""
    exact = [exact_relation(*p) for p in pairs]
    for k, (g, e) in enumerate(zip(got.tolist(), exact)):
        assert g in (UNDECIDED, e), (k, g, e, pairs[k])
        assert g != TOUCHING  # the float path never claims a touch
    for p, e in zip(pairs, exact):
        if by_axes(p):
            assert e == SEPARATED, p
    return exact


# --- random pairs ---------------------------------------------------------------------------------


def test_random_pairs_far_from_tangency_are_decided_right():
    """2000 random pairs against the contact scale: wherever it is 1e-3 from 1 the filter decides, and right."""
    rng = np.random.default_rng(1)
    pairs = [random_pair(rng) for _ in range(2000)]
    got = certify(pairs)
    s = np.array([contact_scale(*p) for p in pairs])
    far = np.abs(s - 1) > 1e-3
    want = np.where(s > 1, SEPARATED, OVERLAPPING)
    np.testing.assert_array_equal(got[far], want[far])
    assert far.sum() > 1900 and {SEPARATED, OVERLAPPING} <= set(got[far].tolist())
    axes = np.array([by_axes(p) for p in pairs])
    assert not np.any(axes & (want == OVERLAPPING) & far)  # an axis separates separated pairs only
    assert np.all(got[axes] == SEPARATED)


@pytest.mark.parametrize("seed", range(3))
def test_random_pairs_against_the_exact_relation(seed):
    rng = np.random.default_rng(10 + seed)
    pairs = [random_pair(rng) for _ in range(25)]
    got = certify(pairs)
    check_never_wrong(pairs, got)
    assert np.all(got != UNDECIDED)


# --- near tangency ----------------------------------------------------------------------------------

DELTAS = [0.0, 1e-15, -1e-15, 1e-13, -1e-13, 1e-11, -1e-11, 1e-9, -1e-9, 1e-7, -1e-7, 1e-5, -1e-5]


@pytest.mark.parametrize("seed", range(4))
def test_near_tangent_pairs_never_wrong_and_decided_from_a_billionth(seed):
    """B moved along the centre line to touching (to rounding), then by a relative delta: never a wrong
    decision; from |delta| = 1e-9 on, decided (and then, by the exact relation, separated for delta > 0)."""
    rng = np.random.default_rng(20 + seed)
    pairs = [near_tangent(rng, d) for _ in range(2) for d in DELTAS]
    got = certify(pairs)
    exact = check_never_wrong(pairs, got)
    deltas = np.array(DELTAS * 2)
    big = np.abs(deltas) >= DECIDED_FROM
    assert np.all(got[big] != UNDECIDED), got[big]
    assert [e for e, d in zip(exact, deltas) if abs(d) >= DECIDED_FROM] == [
        SEPARATED if d > 0 else OVERLAPPING for d in deltas if abs(d) >= DECIDED_FROM
    ]


# --- pairs built exactly ----------------------------------------------------------------------------

HAIR = 2.0**-40


def tangent_pairs():
    """(pair, direction of B's centre) touching exactly: spheres along an axis and along (3, 4, 12) / 13, and
    axis-aligned ellipsoids touching at the tip of an axis of A, B in each proper signed permutation."""
    out = [
        (((0.0, 0, 0), I3, (1.0, 1, 1)), ((2.0, 0, 0), I3, (1.0, 1, 1))),
        (((0.0, 0, 0), I3, (1.0, 1, 1)), ((3 / 8, 4 / 8, 12 / 8), PROPER[1], (0.625, 0.625, 0.625))),
        (((1.0, -2, 0.5), I3, (0.5, 0.5, 0.5)), ((1.0, -2 + 0.75, 0.5), I3, (0.25, 0.25, 0.25))),
    ]
    ra, rb = np.array([2.0, 1.0, 0.5]), np.array([0.75, 0.25, 1.5])
    for P in PROPER:
        rbw = np.abs(P) @ rb
        for axis in range(3):
            e = np.zeros(3)
            e[axis] = 1.0 if axis != 1 else -1.0
            out.append((((0.0, 0, 0), I3, tuple(ra)), (tuple(e * (ra[axis] + rbw[axis])), P, tuple(rb))))
    return [(A[0], A[1], A[2], B[0], B[1], B[2]) for A, B in out]


def moved(pair, factor):
    ca, Ra, ra, cb, Rb, rb = pair
    ca, cb = np.array(ca), np.array(cb)
    return ca, Ra, ra, ca + (cb - ca) * factor, Rb, rb


def test_exactly_tangent_pairs_are_undecided_and_hairs_never_wrong():
    pairs = tangent_pairs()
    assert [exact_relation(*p) for p in pairs] == [TOUCHING] * len(pairs)
    assert np.all(certify(pairs) == UNDECIDED)
    assert not any(by_axes(p) for p in pairs)
    hairs = [moved(p, 1 + HAIR) for p in pairs] + [moved(p, 1 - HAIR) for p in pairs]
    exact = check_never_wrong(hairs, certify(hairs))
    assert exact == [SEPARATED] * len(pairs) + [OVERLAPPING] * len(pairs)
    wide = [moved(p, 1 + 1e-6) for p in pairs] + [moved(p, 1 - 1e-6) for p in pairs]
    assert certify(wide).tolist() == [SEPARATED] * len(pairs) + [OVERLAPPING] * len(pairs)


def test_concentric_pairs_overlap_whatever_their_shapes():
    rng = np.random.default_rng(3)
    c = rng.uniform(-5, 5, 3)
    Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
    pairs = [
        (c, Ra, (1.0, 1.0, 1.0), c, Rb, (2.0**-60, 1.0, 2.0**60)),  # far outside the float range
        (c, Ra, (1e-200, 1e-200, 1e-200), c, Rb, (1e200, 1e200, 1e200)),
        (c, Ra, (0.3, 0.2, 0.1), c, Ra, (0.3, 0.2, 0.1)),
    ]
    assert certify(pairs).tolist() == [OVERLAPPING] * 3
    assert not any(by_axes(p) for p in pairs)


def test_shapes_outside_the_float_range():
    """A radius ratio beyond RATIO_MAX: undecided unless the bounding spheres are apart, never wrong."""
    rng = np.random.default_rng(4)
    Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
    thin = (1.0, 1.0, 1.0 / (4 * RATIO_MAX))
    pairs = [
        ((0.0, 0, 0), Ra, (1.0, 1.0, 1.0), (0.5, 0.2, 0.1), Rb, thin),  # overlapping: the thin centre is inside
        ((0.0, 0, 0), Ra, (1.0, 1.0, 1.0), (1.5, 0.0, 0.0), Rb, thin),
        ((0.0, 0, 0), Ra, (1.0, 1.0, 1.0), (2.5, 0.0, 0.0), Rb, thin),  # bounding spheres apart
    ]
    got = certify(pairs)
    check_never_wrong(pairs, got)
    assert got.tolist()[0] == UNDECIDED and got.tolist()[2] == SEPARATED


@pytest.mark.parametrize("scale", [2.0**-100, 2.0**100])
def test_power_of_two_scalings_decide_alike(scale):
    """Scaling a pair by 2^k is exact, the bounds relative: the same decisions, near tangency included."""
    rng = np.random.default_rng(5)
    pairs = [random_pair(rng) for _ in range(200)] + [near_tangent(rng, d) for d in DELTAS]
    scaled = [(np.array(ca) * scale, Ra, np.array(ra) * scale, np.array(cb) * scale, Rb, np.array(rb) * scale)
              for ca, Ra, ra, cb, Rb, rb in pairs]  # fmt: skip
    np.testing.assert_array_equal(certify(scaled), certify(pairs))


def test_broadcasting_and_threads_agree_with_one_pair_at_a_time():
    rng = np.random.default_rng(6)
    n = 4000
    a = Ellipsoids(rng.uniform(-2, 2, (n, 3)), Rot.random(n, random_state=rng).as_matrix(), rng.uniform(0.1, 1, (n, 3)))
    b = Ellipsoids(rng.uniform(-2, 2, (n, 3)), Rot.random(n, random_state=rng).as_matrix(), rng.uniform(0.1, 1, (n, 3)))
    serial = cf.certify(a, b, n, False)
    np.testing.assert_array_equal(cf.certify(a, b, n, True), serial)
    one = cf.certify(a[0], b, n, False)
    for i in range(0, n, 397):
        assert one[i] == cf.certify(a[0], b[i], 1, False)[0] and serial[i] == cf.certify(a[i], b[i], 1, False)[0]
