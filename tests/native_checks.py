"""What the tests of the compiled core (test_native*.py) share: bit-for-bit equality, the float strategies of
their arbitrary-input tests, random proper rotations, and poses as the pair kernels' arguments."""

import numpy as np
from hypothesis import strategies as st

from ellipsim.core.rotations import quaternions_to_rotations

#: any finite float64, and any positive one down to the smallest subnormal
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
positive = st.floats(min_value=5e-324, max_value=1.7e308, allow_nan=False, width=64)
#: a quaternion far enough from 0 to normalise, and a body size from 1e-4 to 10
quaternion = st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(x * x for x in q) > 1e-3)
size = st.one_of(st.floats(0.01, 1.0), st.sampled_from([1e-4, 1e-3, 10.0]))


def rotation(q):
    """The rotation matrix of quaternion q (any length but 0)."""
    q = np.asarray(q, float)
    return quaternions_to_rotations(q / np.linalg.norm(q))


def assert_same_bits(got, want, what=""):
    """Equal shapes, dtypes and bits, NaN for NaN (its sign and payload are the compiler's choice); any dtype."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape and got.dtype == want.dtype, what
    if got.dtype == np.float64:
        differ = (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))
    else:
        differ = got != want
    bad = np.argwhere(differ)
    assert not len(bad), (
        f"{what} at {tuple(bad[0])}: {got[tuple(bad[0])]!r}, expected {want[tuple(bad[0])]!r} ({len(bad)} differ)"
    )


def pose_args(P):
    """Fresh writable float64 copies of the poses P (dict cE, RE, rE, cK, RK, sK): a pair kernel's arguments."""
    return tuple(np.array(P[k], dtype=float) for k in ("cE", "RE", "rE", "cK", "RK", "sK"))


def as_shapes(a, b):
    """A sample set's pair (a, b) as poses: the ellipsoid a, b's centre, rotation and radii the other body's (a
    capsule's and a cylinder's radius r_0, half-length r_1: needles, flat disks and spheres alike)."""
    return dict(cE=a.centers, RE=a.rotations, rE=a.radii, cK=b.centers, RK=b.rotations, sK=b.radii)
