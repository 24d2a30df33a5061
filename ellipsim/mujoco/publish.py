"""Publishing the context (context.py) to the callbacks' machine code, once per process.

publish_context makes SYMBOL resolve to context.CONTEXT in LLVM's JIT linker, before any object is
linked (nativecache.load) or compiled (callbacks.compile_callback); fill_context writes the words the
callbacks read: struct offsets (structs.checked_layout), the registry's address, and MuJoCo's own
mjCOLLISIONFUNC entry of every row of context.PAIR_TYPES (the fallbacks).
"""

import threading

from . import structs
from .context import CONTEXT, DATA_WORDS, MODEL_WORDS, PAIR_TYPES, REGISTRY, REGISTRY_ADDRESS, REGISTRY_ROWS, SYMBOL

_lock = threading.RLock()
_state = {"published": False, "filled": False}


def publish_context():
    """Make SYMBOL resolve to context.CONTEXT in this process's JIT linker (once; on first use, not
    on import: it is process-wide)."""
    with _lock:
        if _state["published"]:
            return
        import llvmlite.binding as llb

        existing = llb.address_of_symbol(SYMBOL)
        if existing is not None and existing != CONTEXT.ctypes.data:
            raise RuntimeError(
                f"{SYMBOL} is already defined in this process, at {existing:#x}: two copies of ellipsim?"
            )
        llb.add_symbol(SYMBOL, CONTEXT.ctypes.data)
        _state["published"] = True


def fill_context():
    """Write the per-process values the callbacks read (once): struct offsets (verified layout),
    the registry, MuJoCo's collision functions for the pairs ellipsim handles (the fallbacks)."""
    with _lock:
        if _state["filled"]:
            return
        lay = structs.checked_layout()
        table, ntypes = structs.collision_table()
        for name, word in MODEL_WORDS.items():
            CONTEXT[word] = lay["model"][name]
        for name, word in DATA_WORDS.items():
            CONTEXT[word] = lay["data"][name]
        CONTEXT[REGISTRY_ADDRESS], CONTEXT[REGISTRY_ROWS] = REGISTRY.ctypes.data, REGISTRY.shape[0]
        for row in PAIR_TYPES:
            CONTEXT[row.fallback] = table[row.type1 * ntypes + row.type2]
        _state["filled"] = True
