"""What the compiled callbacks share with Python: the context words and the registry of attached datas.

The callbacks (C++, ellipsim/native/mujoco/: context.hpp is this module's other half, with the same numbers)
are MuJoCo's process-global hooks, so what changes from one process or one attached data to the next they
read from CONTEXT, an int64 array whose address publish.fill_context hands them (ext.mujoco.set_context):

    CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS]       the registry below
    CONTEXT[FALLBACK_ELLIPSOID], CONTEXT[FALLBACK_SPHERE],  MuJoCo's own mjCOLLISIONFUNC entries for
    CONTEXT[FALLBACK_CAPSULE], CONTEXT[FALLBACK_BOX],       ellipsoid x ellipsoid, sphere x ellipsoid,
    CONTEXT[FALLBACK_CYLINDER], CONTEXT[FALLBACK_MESH],    capsule x ellipsoid, ellipsoid x box,
    CONTEXT[FALLBACK_HFIELD]                               ellipsoid x cylinder, ellipsoid x mesh,
                                                           height field x ellipsoid
    CONTEXT[MARK_STACK], CONTEXT[FREE_STACK],               MuJoCo's mj_markStack, mj_freeStack and
    CONTEXT[STACK_ALLOC_NUM]                               mj_stackAllocNum (a mesh pair's scratch comes
                                                           from the data's own arena)

mjModel and mjData they read through MuJoCo's own structs (the headers the extension was built against).

It also hands the glue the pair table (ellipsim/pair_table.py: MuJoCo's geom type codes and PAIR_TYPES, the
geom-type pairs ellipsim handles) and says which word holds each row's MuJoCo function (FALLBACK_WORDS): it
imports nothing but mujoco, numpy and that table.
"""

import mujoco
import numpy as np

from ..pair_table import (  # noqa: F401
    BOX,
    CAPSULE,
    CYLINDER,
    ELLIPSOID,
    FILTER_PAIR_TYPES,
    HFIELD,
    MESH,
    PAIR_TYPES,
    SPHERE,
    PairType,
)

REGISTRY_ADDRESS, REGISTRY_ROWS, FALLBACK_ELLIPSOID, FALLBACK_SPHERE = 0, 1, 2, 3
MARK_STACK, FREE_STACK, STACK_ALLOC_NUM = 4, 5, 6
FALLBACK_CAPSULE, FALLBACK_BOX, FALLBACK_CYLINDER, FALLBACK_MESH, FALLBACK_HFIELD = 15, 16, 17, 18, 19
#: words 7-14 are unused (the numba callbacks' struct offsets, before the C++ glue)
WORDS = 20
CONTEXT = np.zeros(WORDS, dtype=np.int64)  # lives as long as the process: the callbacks hold its address

# Registry of attached datas.  Row 0: [highest slot ever used, ...]; slots 1..: [mjData address
# (0: free), counters address, mode, pair buffer address, capacity, warm-start table address,
# warm-start table slots - 1 (0: no table, every pair starts cold), hull table address (0: none)].  A slot's other fields are
# written before its address and only change while that data is detached, and slots never move, so
# a callback stepping one data never sees another's fields half-written (attachment.py writes them
# under a lock).
MAX_ATTACHED = 256
REGISTRY_COLUMNS = 8
WARM_ADDRESS, WARM_MASK, HULLS = 5, 6, 7
FILTER, RECORD, NARROW = 1, 2, 3
REGISTRY = np.zeros((MAX_ATTACHED + 1, REGISTRY_COLUMNS), dtype=np.int64)

# Per-data counters (int64): filter: seen, discarded, passed; narrowphase: -, separated, contacts,
# apart (measured apart beyond the margin), fallbacks: every call adds 1 to exactly one of words
# 1-4, so the number of calls is their sum (one atomic add per call, not two); record: the number
# of recorded pairs in word RECORDED.  Narrowphase words 0 and 5 are the warm-start table's clock:
# the data's time at the last call that read the table (float64 bits) and the table's epoch; word
# CAPPED counts the height-field calls that made mjMAXCONPAIR contacts (a call of contacts besides).
NCOUNTERS = 7
SEEN, DISCARDED, PASSED, RECORDED = 0, 1, 2, 3
SEPARATED, CONTACTS, APART, FALLBACKS = 1, 2, 3, 4
WARM_TIME, WARM_EPOCH, CAPPED = 0, 5, 6

# Warm-start table of a data attached in mode "narrowphase" (attachment.py owns it, the narrow phase reads
# and writes it): WARM_SLOT_WORDS int64/float64 words per slot, [key << 1 | in contact, normal x, y, z,
# the normal before it x, y, z, epoch] (the key g1 << 32 | g2 as int64, the normals of the pair's last
# two calls, from g1 to g2 in the world frame, as float64, the table's epoch when written, int64);
# slots 2k and 2k + 1 form the set of the keys hashing to k.  Key word 0, or an epoch other than the
# table's: empty.  The epoch advances when the data's time goes back or jumps ahead by more than
# WARM_JUMP timesteps (mj_resetData, mj_setState, a rollout's next initial state): a new trajectory
# then starts cold, as on a fresh data, so identical initial states give bit-identical trajectories.
WARM_SLOT_WORDS = 8

# Hull table of a data attached in mode "narrowphase" whose model has meshes (attachment.py builds it from
# mujoco/hull.py, the narrow phase's mesh row reads it): HULL_WORDS int64 words per mesh of the model, [nv, ne, nf,
# vertices address (float64 (nv, 3), the geom's frame), edges address (int32 (ne, 2)), outward normals address
# (float64 (nf, 3)), triangles address (int32 (nf, 3)), its adjacency's addresses (int32 adj_start (nv + 1), adj
# (2 ne), vface_start (nv + 1), vface (3 nf): ext.hull_adjacency, polytope.hpp's build_adjacency), 0]; nv 0: the
# mesh has no hull (MuJoCo's own function).
HULL_WORDS = 12

# The pair table both engines' glues read (ellipsim/pair_table.py), its geom codes MuJoCo's (the C++ glue uses
# MuJoCo's own enum, mjtGeom).
assert (HFIELD, SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX, MESH) == tuple(
    int(getattr(mujoco.mjtGeom, f"mjGEOM_{name.upper()}"))
    for name in ("hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh")
)

#: The CONTEXT word holding MuJoCo's own mjCOLLISIONFUNC entry for each row of PAIR_TYPES (publish.fill_context),
#: by the row's key.
FALLBACK_WORDS = {
    "ellipsoid-ellipsoid": FALLBACK_ELLIPSOID,
    "ellipsoid-sphere": FALLBACK_SPHERE,
    "ellipsoid-capsule": FALLBACK_CAPSULE,
    "ellipsoid-box": FALLBACK_BOX,
    "ellipsoid-cylinder": FALLBACK_CYLINDER,
    "ellipsoid-mesh": FALLBACK_MESH,
    "ellipsoid-hfield": FALLBACK_HFIELD,
}
assert set(FALLBACK_WORDS) == {row.key for row in PAIR_TYPES}

OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
SPECULATIVE = int(mujoco.mjtEnableBit.mjENBL_SPECULATIVE)
#: a call this many timesteps after the table's last read starts a new epoch (RK4 moves by at most 1)
WARM_JUMP = 1.5
