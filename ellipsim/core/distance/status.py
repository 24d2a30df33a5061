"""What signed_distance reports per pair, by name: `DistanceStatus`, and `DerivativeStatus` for its derivatives.

The kernels return the plain int8 codes ellipsoid_pair.GLOBAL and UNPROVEN (numba compiles them as
constants); the arrays signed_distance returns compare equal to the members of `DistanceStatus`.
The codes are repeated here, not imported, so that `ellipsim.DistanceStatus` loads no kernel
(tests/test_distance.py checks they are the kernel's).
"""

from enum import IntEnum


class DistanceStatus(IntEnum):
    """signed_distance's status, per pair (int8 codes)."""

    GLOBAL = 0  #: the returned maximum is proven global, to ellipsoid_pair's tolerance
    UNPROVEN = 1  #: the proof's budget ran out: the best maximum found, not proven global


class DerivativeStatus(IntEnum):
    """signed_distance(..., derivatives=True)'s derivative status, per pair (int8 codes of derivatives.py)."""

    SMOOTH = 0  #: unique, nondegenerate maximiser: the derivatives
    BRANCH = 1  #: a deep maximum's derivatives; a tie with another maximiser is not excluded
    FLAT = 2  #: a flat maximum (circle of maxima or nearly): NaN
    UNPROVEN = 3  #: the maximum is not proven: NaN
