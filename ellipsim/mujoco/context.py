"""What the compiled callbacks share with Python: the context words and the registry of attached datas.

The callbacks (C++, ellipsim/native/mujoco/: context.hpp is this module's other half, with the same numbers)
are MuJoCo's process-global hooks, so what changes from one process or one attached data to the next they
read from CONTEXT, an int64 array whose address publish.fill_context hands them (ext.mujoco.set_context):

    CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS]       the registry below
    CONTEXT[FALLBACK_ELLIPSOID], CONTEXT[FALLBACK_SPHERE],  MuJoCo's own mjCOLLISIONFUNC entries for
    CONTEXT[FALLBACK_CAPSULE], CONTEXT[FALLBACK_BOX],       ellipsoid x ellipsoid, sphere x ellipsoid,
    CONTEXT[FALLBACK_CYLINDER]                             capsule x ellipsoid, ellipsoid x box,
                                                           ellipsoid x cylinder

mjModel and mjData they read through MuJoCo's own structs (the headers the extension was built against).

It also holds MuJoCo's geom type codes and PAIR_TYPES, the geom-type pairs ellipsim handles, for
the whole glue: it imports nothing but mujoco and numpy.
"""

from typing import NamedTuple

import mujoco
import numpy as np

REGISTRY_ADDRESS, REGISTRY_ROWS, FALLBACK_ELLIPSOID, FALLBACK_SPHERE = 0, 1, 2, 3
FALLBACK_CAPSULE, FALLBACK_BOX, FALLBACK_CYLINDER = 15, 16, 17
#: words 4-14 and 18-19 are unused (the numba callbacks' struct offsets, before the C++ glue)
WORDS = 20
CONTEXT = np.zeros(WORDS, dtype=np.int64)  # lives as long as the process: the callbacks hold its address

# Registry of attached datas.  Row 0: [highest slot ever used, ...]; slots 1..: [mjData address
# (0: free), counters address, mode, pair buffer address, capacity, warm-start table address,
# warm-start table slots - 1 (0: no table, every pair starts cold)].  A slot's other fields are
# written before its address and only change while that data is detached, and slots never move, so
# a callback stepping one data never sees another's fields half-written (attachment.py writes them
# under a lock).
MAX_ATTACHED = 256
REGISTRY_COLUMNS = 7
WARM_ADDRESS, WARM_MASK = 5, 6
FILTER, RECORD, NARROW = 1, 2, 3
REGISTRY = np.zeros((MAX_ATTACHED + 1, REGISTRY_COLUMNS), dtype=np.int64)

# Per-data counters (int64): filter: seen, discarded, passed; narrowphase: -, separated, contacts,
# apart (measured apart beyond the margin), fallbacks: every call adds 1 to exactly one of words
# 1-4, so the number of calls is their sum (one atomic add per call, not two); record: the number
# of recorded pairs in word RECORDED.  Narrowphase words 0 and 5 are the warm-start table's clock:
# the data's time at the last call that read the table (float64 bits) and the table's epoch.
NCOUNTERS = 6
SEEN, DISCARDED, PASSED, RECORDED = 0, 1, 2, 3
SEPARATED, CONTACTS, APART, FALLBACKS = 1, 2, 3, 4
WARM_TIME, WARM_EPOCH = 0, 5

# Warm-start table of a data attached in mode "narrowphase" (attachment.py owns it, the narrow phase reads
# and writes it): WARM_SLOT_WORDS int64/float64 words per slot, [key << 1 | in contact, normal x, y, z,
# the normal before it x, y, z, epoch] (the key g1 << 32 | g2 as int64, the normals of the pair's last
# two calls, from g1 to g2 in the world frame, as float64, the table's epoch when written, int64);
# slots 2k and 2k + 1 form the set of the keys hashing to k.  Key word 0, or an epoch other than the
# table's: empty.  The epoch advances when the data's time goes back or jumps ahead by more than
# WARM_JUMP timesteps (mj_resetData, mj_setState, a rollout's next initial state): a new trajectory
# then starts cold, as on a fresh data, so identical initial states give bit-identical trajectories.
WARM_SLOT_WORDS = 8

# MuJoCo's geom type codes (the C++ glue uses MuJoCo's own enum, mjtGeom).
SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = (
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
)


class PairType(NamedTuple):
    """A geom-type pair ellipsim handles, as a row of PAIR_TYPES."""

    name: str
    #: the pair type as reports name it (validate, compare, replay, run: `by_pair_type`), the ellipsoid first
    key: str
    #: MuJoCo's table order, type1 <= type2 (engine_collision_driver.c swaps a pair by type)
    type1: int
    type2: int
    #: the CONTEXT word holding MuJoCo's own mjCOLLISIONFUNC entry for the pair (publish.fill_context)
    fallback: int
    #: the contact filter (modes "filter", "record"; geoms.candidate_pairs, validate, compare) covers it
    filter: bool
    #: its geoms count towards the warm-start table's size (attachment.warm_slots)
    warm: bool
    #: the core's header the narrow phase calls for it (ellipsim/native/include/ellipsim/<kernel>.hpp)
    kernel: str


#: Every geom-type pair ellipsim handles: the narrow phase replaces MuJoCo's table entry of each
#: (attachment.py), the context holds MuJoCo's function for each (publish.py), the filter covers those
#: marked `filter`, the recorder of candidate pairs (mode "record") and the validation (judge.py) all.  The C++
#: narrow phase (ellipsim/native/mujoco/narrowphase.hpp) dispatches on geom types, written out there;
#: tests/test_pair_table.py checks that code against these rows.  Capsule geoms size the warm-start
#: table though capsule pairs start cold: kept, as the table's size decides which pairs share a set,
#: and so the trajectories.
PAIR_TYPES = (
    PairType(
        "ellipsoid x ellipsoid",
        "ellipsoid-ellipsoid",
        ELLIPSOID,
        ELLIPSOID,
        FALLBACK_ELLIPSOID,
        True,
        True,
        "distance/ellipsoid_pair",
    ),
    PairType(
        "sphere x ellipsoid",
        "ellipsoid-sphere",
        SPHERE,
        ELLIPSOID,
        FALLBACK_SPHERE,
        True,
        True,
        "distance/ellipsoid_pair",
    ),
    PairType(
        "capsule x ellipsoid",
        "ellipsoid-capsule",
        CAPSULE,
        ELLIPSOID,
        FALLBACK_CAPSULE,
        False,
        True,
        "pairs/capsule",
    ),
    PairType("ellipsoid x box", "ellipsoid-box", ELLIPSOID, BOX, FALLBACK_BOX, False, False, "pairs/box"),
    PairType(
        "ellipsoid x cylinder",
        "ellipsoid-cylinder",
        ELLIPSOID,
        CYLINDER,
        FALLBACK_CYLINDER,
        False,
        False,
        "pairs/cylinder",
    ),
)
FILTER_PAIR_TYPES = tuple(row for row in PAIR_TYPES if row.filter)

OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
SPECULATIVE = int(mujoco.mjtEnableBit.mjENBL_SPECULATIVE)
#: a call this many timesteps after the table's last read starts a new epoch (RK4 moves by at most 1)
WARM_JUMP = 1.5
