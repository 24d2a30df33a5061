"""The relation of two ellipsoids, as every query reports it: one set of int8 codes for the package.

The C++ kernels return the plain ints (include/ellipsim/relation.hpp); public functions return arrays of
them, which compare equal to the members of `Relation`.
"""

from enum import IntEnum

SEPARATED, TOUCHING, OVERLAPPING = 0, 1, 2

#: What the certified float path returns for a pair it cannot prove (exact arithmetic decides it).
UNDECIDED = -1


class Relation(IntEnum):
    """What classify returns, per pair (int8 codes)."""

    SEPARATED = SEPARATED  #: closed ellipsoids disjoint
    TOUCHING = TOUCHING  #: boundaries meet, interiors disjoint
    OVERLAPPING = OVERLAPPING  #: interiors intersect (includes containment)
