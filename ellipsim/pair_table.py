"""The geom-type pairs ellipsim handles: one table both engines' glues read (ellipsim.mujoco: the narrow phase's
table entries, the filter, the warm-start table, the validation's keys; ellipsim.warp: the pairs it takes from
MuJoCo Warp and which core function each runs).

Types are MuJoCo's geom codes (mjtGeom; MuJoCo Warp's GeomType has the same numbers): written here, as the core
imports no engine, and checked against both enums by tests/test_pair_table.py.  A row's geoms are in MuJoCo's
order, type1 <= type2 (engine_collision_driver.c swaps a pair by type, MuJoCo Warp's NXN table likewise).
"""

from typing import NamedTuple

#: MuJoCo's mjtGeom codes of the types ellipsim reads.
HFIELD, SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX, MESH = 1, 2, 3, 4, 5, 6, 7
TYPE_NAMES = {
    HFIELD: "hfield",
    SPHERE: "sphere",
    CAPSULE: "capsule",
    ELLIPSOID: "ellipsoid",
    CYLINDER: "cylinder",
    BOX: "box",
    MESH: "mesh",
}

#: Which core function a pair runs (ellipsim/native/warp/narrowphase.hpp's ROW_*; the MuJoCo C narrow phase
#: dispatches on the same rows by geom type, ellipsim/native/mujoco/narrowphase.hpp).
ROW_ELLIPSOID, ROW_CAPSULE, ROW_BOX, ROW_CYLINDER, ROW_MESH, ROW_HFIELD = 0, 1, 2, 3, 4, 5


class PairType(NamedTuple):
    """A geom-type pair ellipsim handles, as a row of PAIR_TYPES."""

    name: str
    #: the pair type as reports name it (validate, compare, replay, run: `by_pair_type`), the ellipsoid first
    key: str
    #: MuJoCo's table order, type1 <= type2
    type1: int
    type2: int
    #: the contact filter (MuJoCo C modes "filter", "record"; geoms.candidate_pairs, validate, compare) covers it
    filter: bool
    #: its geoms count towards MuJoCo C's warm-start table's size (mujoco/attachment.warm_slots)
    warm: bool
    #: the core's header the narrow phase calls for it (ellipsim/native/include/ellipsim/<kernel>.hpp)
    kernel: str
    #: the narrow phase's row: which function of that header, the capsule's normal flipped (ROW_*)
    row: int
    #: ellipsim.warp takes it from MuJoCo Warp (its kernel has the row); the others stay with Warp's GJK/EPA
    warp: bool


#: Every geom-type pair ellipsim handles.  Capsule geoms size MuJoCo C's warm-start table though capsule pairs
#: start cold: kept, as the table's size decides which pairs share a set, and so the trajectories.
PAIR_TYPES = (
    PairType("ellipsoid x ellipsoid", "ellipsoid-ellipsoid", ELLIPSOID, ELLIPSOID, True, True, "distance/ellipsoid_pair", ROW_ELLIPSOID, True),
    PairType("sphere x ellipsoid", "ellipsoid-sphere", SPHERE, ELLIPSOID, True, True, "distance/ellipsoid_pair", ROW_ELLIPSOID, True),
    PairType("capsule x ellipsoid", "ellipsoid-capsule", CAPSULE, ELLIPSOID, False, True, "pairs/capsule", ROW_CAPSULE, True),
    PairType("ellipsoid x box", "ellipsoid-box", ELLIPSOID, BOX, False, False, "pairs/box", ROW_BOX, True),
    PairType("ellipsoid x cylinder", "ellipsoid-cylinder", ELLIPSOID, CYLINDER, False, False, "pairs/cylinder", ROW_CYLINDER, True),
    PairType("ellipsoid x mesh", "ellipsoid-mesh", ELLIPSOID, MESH, False, False, "pairs/polytope", ROW_MESH, True),
    PairType("hfield x ellipsoid", "ellipsoid-hfield", HFIELD, ELLIPSOID, False, False, "pairs/height_field", ROW_HFIELD, True),
)  # fmt: skip
FILTER_PAIR_TYPES = tuple(row for row in PAIR_TYPES if row.filter)
#: the rows ellipsim.warp takes from MuJoCo Warp (all; a mesh's hull over the mesh row's size stays with Warp)
WARP_PAIR_TYPES = tuple(row for row in PAIR_TYPES if row.warp)
