import math

import numpy as np
import pytest
import reference
import strategies as S
from hypothesis import given
from hypothesis import strategies as st

from ellipsim import Ellipsoids, characteristic_polynomial, classify, contact_scale

well_conditioned = st.tuples(
    S.ellipsoid(
        radius=st.tuples(*[st.floats(0.3, 1.5)] * 3).map(np.array),
        center=st.tuples(*[st.floats(-1, 1)] * 3).map(np.array),
    ),
    S.ellipsoid(
        radius=st.tuples(*[st.floats(0.3, 1.5)] * 3).map(np.array),
        center=st.tuples(*[st.floats(-1, 1)] * 3).map(np.array),
    ),
)


@pytest.mark.parametrize("setup", ["rearranged", "cofactor"])
@given(pair=well_conditioned)
def test_characteristic_polynomial_matches_exact_pencil(setup, pair):
    a, b = pair
    exact = np.array(
        [
            float(c)
            for c in reference.pencil(
                reference.quadric(a.centers[0], a.rotations[0], a.radii[0]),
                reference.quadric(b.centers[0], b.rotations[0], b.radii[0]),
            )
        ]
    )
    got = characteristic_polynomial(a, b, setup=setup)[0]
    # Coefficients of well-conditioned pairs (|c| <= 1, radii >= 0.3): a few hundred roundings at most.
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-11 * np.abs(exact).max())


def test_characteristic_polynomial_shape_and_errors():
    a = S.one([0, 0, 0], np.eye(3), [1, 1, 1])
    b = Ellipsoids(np.zeros((4, 3)) + [3, 0, 0], np.stack([np.eye(3)] * 4), np.ones((4, 3)))
    assert characteristic_polynomial(a, b).shape == (4, 5)
    with pytest.raises(ValueError, match="setup must be one of"):
        characteristic_polynomial(a, b, setup="direct")


def pw_reference(a, b):
    """max over s of Perram-Wertheim's s (1 - s) d^T [(1 - s) A^-1 + s B^-1]^-1 d, by golden section."""
    d = b.centers[0] - a.centers[0]
    ia = a.rotations[0] @ np.diag(a.radii[0] ** 2) @ a.rotations[0].T
    ib = b.rotations[0] @ np.diag(b.radii[0] ** 2) @ b.rotations[0].T

    def F(s):
        return s * (1 - s) * d @ np.linalg.solve((1 - s) * ia + s * ib, d)

    lo, hi = 0.0, 1.0
    g = (math.sqrt(5) - 1) / 2
    for _ in range(200):
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        if F(x1) < F(x2):
            lo = x1
        else:
            hi = x2
    return math.sqrt(F(0.5 * (lo + hi)))


@given(well_conditioned)
def test_contact_scale_matches_a_direct_maximisation(pair):
    a, b = pair
    assert contact_scale(a, b)[0] == pytest.approx(pw_reference(a, b), rel=1e-9, abs=1e-12)


@given(S.random_pair(), st.floats(0.25, 4.0))
def test_contact_scale_scales_inversely_with_the_radii(pair, sigma):
    a, b = pair
    s = contact_scale(a, b)[0]
    scaled = [Ellipsoids(e.centers, e.rotations, e.radii * sigma) for e in (a, b)]
    assert contact_scale(*scaled)[0] == pytest.approx(s / sigma, rel=1e-9, abs=1e-15)


@given(S.random_pair())
def test_contact_scale_agrees_with_exact_classify(pair):
    a, b = pair
    s = contact_scale(a, b)[0]
    relation = classify(a, b)[0]
    if s > 1 + 1e-9:
        assert relation == 0
    elif s < 1 - 1e-9:
        assert relation == 2


def test_contact_scale_at_extreme_offsets():
    """Linear in the centre offset down to 1e-200 and up to 1e200 (no underflow of |e|^2)."""
    a = S.one([0, 0, 0], np.diag([1.0, -1.0, -1.0]), [1, 2, 3])
    for k in (1e-200, 1e-100, 1.0, 1e100, 1e200):
        b = S.one([0, 0, 2.0 * k], np.eye(3), [1, 1, 1])
        assert contact_scale(a, b)[0] == pytest.approx(2.0 * k / 4.0, rel=1e-14)


def test_contact_scale_of_spheres_and_concentric_pairs():
    I = np.eye(3)
    a = S.one([0, 0, 0], I, [1, 1, 1])
    assert contact_scale(a, S.one([3, 4, 0], I, [1.5, 1.5, 1.5]))[0] == pytest.approx(2.0, rel=1e-15)
    assert contact_scale(a, S.one([0, 0, 0], I, [2, 3, 4]))[0] == 0.0
