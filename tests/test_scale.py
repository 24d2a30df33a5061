"""Results do not depend on the unit of length, up to float64's range.

Scaling a pair by a power of two is exact, so contact_scale must not change and the signed
distance must scale with it, also where a semi-axis is 1e-160 or 1e160 (frame.unit_scale).
2^+-49 is where the kernels still run unscaled.
"""

import numpy as np
import pytest

import ellipsim as es
from ellipsim.core.samples import generic_pairs, near_contact_pairs

SCALES = [2.0**-530, 2.0**-333, 2.0**-101, 2.0**-49, 2.0**-7, 2.0**11, 2.0**49, 2.0**101, 2.0**333, 2.0**530]


def _scaled(e, k):
    return es.Ellipsoids(e.centers * k, e.rotations, e.radii * k)


@pytest.fixture(scope="module")
def pairs():
    a, b = generic_pairs(200, seed=7)
    c, d = near_contact_pairs(200, seed=8)
    return (
        es.Ellipsoids(np.r_[a.centers, c.centers], np.r_[a.rotations, c.rotations], np.r_[a.radii, c.radii]),
        es.Ellipsoids(np.r_[b.centers, d.centers], np.r_[b.rotations, d.rotations], np.r_[b.radii, d.radii]),
    )


@pytest.mark.parametrize("k", SCALES)
def test_contact_scale_is_unitless(pairs, k):
    a, b = pairs
    s = es.contact_scale(_scaled(a, k), _scaled(b, k))
    assert np.all(np.isfinite(s))
    np.testing.assert_allclose(s, es.contact_scale(a, b), rtol=1e-14, atol=0)


@pytest.mark.parametrize("k", SCALES)
def test_signed_distance_scales_with_the_pair(pairs, k):
    a, b = pairs
    dist0, normal0, pos0, status0 = es.signed_distance(a, b)
    dist, normal, pos, status = es.signed_distance(_scaled(a, k), _scaled(b, k))
    np.testing.assert_array_equal(status, status0)
    rmin = np.minimum(a.radii.min(1), b.radii.min(1))
    assert np.max(np.abs(dist / k - dist0) / rmin) < 1e-13
    assert np.max(np.abs(pos / k - pos0) / rmin[:, None]) < 1e-13
    np.testing.assert_allclose(normal, normal0, rtol=0, atol=1e-13)


@pytest.mark.parametrize("k", [1e-160, 1e160])
def test_classify_agrees_at_extreme_scales(pairs, k):
    a, b = pairs
    np.testing.assert_array_equal(es.classify(_scaled(a, k), _scaled(b, k)), es.classify(a, b))
