"""The context (context.py) handed to the compiled callbacks, once per process.

The callbacks are C++ (ellipsim/native/mujoco/: contact_filter.hpp, narrowphase.hpp), compiled against the
headers of the mujoco the extension was built with (ellipsim.native refuses another at import); they read
mjModel and mjData through MuJoCo's own structs.  What they cannot know at compile time they read from
context.CONTEXT: the registry of attached datas and MuJoCo's own mjCOLLISIONFUNC entry of every row of
context.PAIR_TYPES (the fallbacks).  `fill_context` writes those words and gives the callbacks CONTEXT's
address (ext.mujoco.set_context) before the first callback is installed.
"""

import ctypes
import functools
import glob
import os
import threading

import mujoco

from ..native import ext
from .context import (
    CONTEXT,
    FALLBACK_WORDS,
    FREE_STACK,
    MARK_STACK,
    PAIR_TYPES,
    REGISTRY,
    REGISTRY_ADDRESS,
    REGISTRY_ROWS,
    STACK_ALLOC_NUM,
)

_lock = threading.Lock()
_state = {"filled": False}


@functools.cache
def mujoco_library():
    """The libmujoco the bindings loaded (dlopen of the same path returns the same handle)."""
    paths = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    if not paths:
        raise RuntimeError(f"libmujoco not found next to {mujoco.__file__}")
    return ctypes.CDLL(paths[0])


def collision_table():
    """MuJoCo's mjCOLLISIONFUNC[type1][type2] (exported by libmujoco, declared in engine_collision_driver.h) as a
    flat ctypes array of function pointers, and mjNGEOMTYPES."""
    n = int(mujoco.mjtGeom.mjNGEOMTYPES)
    return (ctypes.c_void_p * (n * n)).in_dll(mujoco_library(), "mjCOLLISIONFUNC"), n


def fill_context():
    """Write the per-process words the callbacks read (once): the registry, MuJoCo's collision functions for
    the pairs ellipsim handles (read before ellipsim replaces any), its arena functions, and hand CONTEXT to
    the callbacks."""
    with _lock:
        if _state["filled"]:
            return
        table, ntypes = collision_table()
        CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS] = REGISTRY.ctypes.data, REGISTRY.shape[0]
        for row in PAIR_TYPES:
            CONTEXT[FALLBACK_WORDS[row.key]] = table[row.type1 * ntypes + row.type2]
        library = mujoco_library()
        for word, name in (
            (MARK_STACK, "mj_markStack"),
            (FREE_STACK, "mj_freeStack"),
            (STACK_ALLOC_NUM, "mj_stackAllocNum"),
        ):
            CONTEXT[word] = ctypes.cast(getattr(library, name), ctypes.c_void_p).value
        ext.mujoco.set_context(CONTEXT.ctypes.data)
        _state["filled"] = True
