"""What the compiled callbacks share with Python: the context words and the registry of attached datas.

The callbacks (callbacks.py) are compiled once per machine and their machine code is cached across
processes (nativecache.py), so they contain no per-process constant.  Everything that changes from
one process to the next they read from CONTEXT, an int64 array whose address the loader publishes to
LLVM's symbol table under SYMBOL (`llvmlite.binding.add_symbol`); their code declares SYMBOL as an
external global, which the JIT linker resolves each time the code is loaded:

    CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS]       the registry below
    CONTEXT[FALLBACK_ELLIPSOID], CONTEXT[FALLBACK_SPHERE],  MuJoCo's own mjCOLLISIONFUNC entries for
    CONTEXT[FALLBACK_CAPSULE]                              ellipsoid x ellipsoid, sphere x ellipsoid,
                                                           capsule x ellipsoid
    CONTEXT[MODEL_WORDS[field]], CONTEXT[DATA_WORDS[field]] byte offsets of mjModel / mjData fields
                                                           (structs.py)

This module is the compiled code's ABI, so its text is part of the cache keys (nativecache.py hashes
every module callbacks.py imports).  A change of the word layout must also change SYMBOL (`_v2`):
an object built for the old layout then no longer links in a process with the new one.
"""

import mujoco
import numpy as np

SYMBOL = "ellipsim_ctx_v2"  # v2: word 15 FALLBACK_CAPSULE

REGISTRY_ADDRESS, REGISTRY_ROWS, FALLBACK_ELLIPSOID, FALLBACK_SPHERE = 0, 1, 2, 3
FALLBACK_CAPSULE = 15
#: pointer fields (the word at the offset holds the array's address) and, dotted, mjOption scalars
MODEL_WORDS = {
    "geom_type": 4, "geom_contype": 5, "geom_conaffinity": 6, "geom_size": 7, "geom_margin": 8, "geom_gap": 9,
    "opt.ccd_tolerance": 10, "opt.o_margin": 11, "opt.enableflags": 12,
}  # fmt: skip
DATA_WORDS = {"geom_xpos": 13, "geom_xmat": 14}
WORDS = 16
CONTEXT = np.zeros(WORDS, dtype=np.int64)  # lives as long as the process: its address is published

# Registry of attached datas.  Row 0: [highest slot ever used, ...]; slots 1..: [mjData address
# (0: free), counters address, mode, pair buffer address, capacity].  A slot's other fields are
# written before its address and only change while that data is detached, and slots never move, so
# a callback stepping one data never sees another's fields half-written (attachment.py writes them
# under a lock).
MAX_ATTACHED = 256
REGISTRY_COLUMNS = 5
FILTER, RECORD, NARROW = 1, 2, 3
REGISTRY = np.zeros((MAX_ATTACHED + 1, REGISTRY_COLUMNS), dtype=np.int64)

# Per-data counters (int64): filter: seen, discarded, passed; narrowphase: calls, separated,
# contacts, -, fallbacks; record: the number of recorded pairs in word RECORDED.
NCOUNTERS = 6
SEEN, DISCARDED, PASSED, RECORDED = 0, 1, 2, 3
CALLS, SEPARATED, CONTACTS, FALLBACKS = 0, 1, 2, 4

# MuJoCo's enum values, baked into the compiled code (the cache keys hold MuJoCo's version).
SPHERE, CAPSULE, ELLIPSOID = (int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CAPSULE),
                             int(mujoco.mjtGeom.mjGEOM_ELLIPSOID))  # fmt: skip
OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
#: mjPreContact as the narrow phase writes it: float64 words dist, pos[3], normal[3], tangent[3]
PRECONTACT_WORDS = {"dist": 0, "pos": 1, "normal": 4, "tangent": 7}
