"""What signed_distance reports per pair, by name: `DistanceStatus`, and `DerivativeStatus` for its derivatives.

The kernels return the plain int8 codes ellipsoid_pair.GLOBAL and UNPROVEN (distance/status.hpp); the arrays signed_distance returns compare equal to the members of `DistanceStatus`.
The codes are repeated here, not imported, so that `ellipsim.DistanceStatus` loads no kernel
(tests/test_native_distance.py checks they are the kernel's).
"""

from enum import IntEnum


class DistanceStatus(IntEnum):
    """signed_distance's status, per pair (int8 codes)."""

    GLOBAL = 0  #: the returned maximum is proven global, to ellipsoid_pair's tolerance
    UNPROVEN = 1  #: the proof's budget ran out: the best maximum found, not proven global


class DerivativeStatus(IntEnum):
    """signed_distance(..., derivatives=True)'s derivative status, per pair (int8 codes of derivatives.py and,
    for ONE_SIDED, of pairs/derivatives.py)."""

    SMOOTH = 0  #: unique, nondegenerate maximiser: the derivatives
    BRANCH = 1  #: a deep maximum's derivatives; a tie with another maximiser is not excluded
    FLAT = 2  #: a flat maximum (circle of maxima or nearly): NaN
    UNPROVEN = 3  #: the maximum is not proven: NaN
    ONE_SIDED = 4  #: shape_distance: the contact where two features of the other body meet: the named one's


class ContactFeature(IntEnum):
    """shape_distance(..., derivatives=True)'s feature of the capsule, box, cylinder or mesh that carries the
    contact."""

    FACE = 0  #: a box's or a mesh's face
    EDGE = 1  #: a box's or a mesh's edge
    VERTEX = 2  #: a box's or a mesh's vertex
    SIDE = 3  #: a capsule's or a cylinder's side
    END = 4  #: a capsule's hemispherical end
    CAP = 5  #: a cylinder's flat cap
    RIM = 6  #: a cylinder's rim circle
