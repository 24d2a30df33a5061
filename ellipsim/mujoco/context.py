"""What the compiled callbacks share with Python: the context words and the registry of attached datas.

The callbacks (callbacks.py) are compiled once per machine and their machine code is cached across
processes (nativecache.py), so they contain no per-process constant.  Everything that changes from
one process to the next they read from CONTEXT, an int64 array whose address publish.py publishes to
LLVM's symbol table under SYMBOL (`llvmlite.binding.add_symbol`); their code declares SYMBOL as an
external global, which the JIT linker resolves each time the code is loaded:

    CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS]       the registry below
    CONTEXT[FALLBACK_ELLIPSOID], CONTEXT[FALLBACK_SPHERE],  MuJoCo's own mjCOLLISIONFUNC entries for
    CONTEXT[FALLBACK_CAPSULE], CONTEXT[FALLBACK_BOX],       ellipsoid x ellipsoid, sphere x ellipsoid,
    CONTEXT[FALLBACK_CYLINDER]                             capsule x ellipsoid, ellipsoid x box,
                                                           ellipsoid x cylinder
    CONTEXT[MODEL_WORDS[field]], CONTEXT[DATA_WORDS[field]] byte offsets of mjModel / mjData fields
                                                           (structs.py)

This module is the compiled code's ABI, so its text is part of the cache keys (nativecache.py hashes
every module callbacks.py imports).  A change of the word layout must also change SYMBOL (`_v2`):
an object built for the old layout then no longer links in a process with the new one.

It also holds MuJoCo's geom type codes and PAIR_TYPES, the geom-type pairs ellipsim handles, for
the whole glue: it imports nothing but mujoco and numpy.
"""

from typing import NamedTuple

import mujoco
import numpy as np

SYMBOL = "ellipsim_ctx_v5"  # v2: word 15 FALLBACK_CAPSULE; v3: registry columns 5, 6 (warm-start table); v4: words 16, 17 FALLBACK_BOX, _CYLINDER; v5: words 18, 19 (data time, opt.timestep), warm-start epochs

REGISTRY_ADDRESS, REGISTRY_ROWS, FALLBACK_ELLIPSOID, FALLBACK_SPHERE = 0, 1, 2, 3
FALLBACK_CAPSULE, FALLBACK_BOX, FALLBACK_CYLINDER = 15, 16, 17
#: pointer fields (the word at the offset holds the array's address) and, dotted, mjOption scalars
MODEL_WORDS = {
    "geom_type": 4,
    "geom_contype": 5,
    "geom_conaffinity": 6,
    "geom_size": 7,
    "geom_margin": 8,
    "geom_gap": 9,
    "opt.ccd_tolerance": 10,
    "opt.o_margin": 11,
    "opt.enableflags": 12,
    "opt.timestep": 19,
}
#: pointer fields, and "time", a scalar (the word at the offset is the float64 itself)
DATA_WORDS = {"geom_xpos": 13, "geom_xmat": 14, "time": 18}
WORDS = 20
CONTEXT = np.zeros(WORDS, dtype=np.int64)  # lives as long as the process: its address is published

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

# Warm-start table of a data attached in mode "narrowphase" (attachment.py owns it, callbacks.py reads
# and writes it): WARM_SLOT_WORDS int64/float64 words per slot, [key << 1 | in contact, normal x, y, z,
# the normal before it x, y, z, epoch] (the key g1 << 32 | g2 as int64, the normals of the pair's last
# two calls, from g1 to g2 in the world frame, as float64, the table's epoch when written, int64);
# slots 2k and 2k + 1 form the set of the keys hashing to k.  Key word 0, or an epoch other than the
# table's: empty.  The epoch advances when the data's time goes back or jumps ahead by more than
# WARM_JUMP timesteps (mj_resetData, mj_setState, a rollout's next initial state): a new trajectory
# then starts cold, as on a fresh data, so identical initial states give bit-identical trajectories.
WARM_SLOT_WORDS = 8

# MuJoCo's enum values, baked into the compiled code (the cache keys hold MuJoCo's version).
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
    #: the kernel the narrow phase calls for it (callbacks.narrowphase)
    kernel: str


#: Every geom-type pair ellipsim handles: the narrow phase replaces MuJoCo's table entry of each
#: (attachment.py), the context holds MuJoCo's function for each (publish.py), the filter covers those
#: marked `filter`, the recorder of candidate pairs (mode "record") and the validation (judge.py) all.  callbacks.py dispatches on geom types in compiled code, written out there;
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
        "core.distance.ellipsoid_pair",
    ),
    PairType(
        "sphere x ellipsoid",
        "ellipsoid-sphere",
        SPHERE,
        ELLIPSOID,
        FALLBACK_SPHERE,
        True,
        True,
        "core.distance.ellipsoid_pair",
    ),
    PairType(
        "capsule x ellipsoid",
        "ellipsoid-capsule",
        CAPSULE,
        ELLIPSOID,
        FALLBACK_CAPSULE,
        False,
        True,
        "core.pairs.capsule",
    ),
    PairType("ellipsoid x box", "ellipsoid-box", ELLIPSOID, BOX, FALLBACK_BOX, False, False, "core.pairs.box"),
    PairType(
        "ellipsoid x cylinder",
        "ellipsoid-cylinder",
        ELLIPSOID,
        CYLINDER,
        FALLBACK_CYLINDER,
        False,
        False,
        "core.pairs.cylinder",
    ),
)
FILTER_PAIR_TYPES = tuple(row for row in PAIR_TYPES if row.filter)

OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
SPECULATIVE = int(mujoco.mjtEnableBit.mjENBL_SPECULATIVE)
#: a call this many timesteps after the table's last read starts a new epoch (RK4 moves by at most 1)
WARM_JUMP = 1.5
#: mjPreContact as the narrow phase writes it: float64 words dist, pos[3], normal[3], tangent[3]
PRECONTACT_WORDS = {"dist": 0, "pos": 1, "normal": 4, "tangent": 7}
