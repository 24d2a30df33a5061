"""The one place that builds numba decorators, so every kernel compiles the same way.

fastmath stays off: the certified kernels rely on IEEE round-to-nearest for every operation
(no reassociation, no contraction that the error analysis did not count).  nogil is on: batches
run on threads of our own (threads.py); no kernel uses numba's process-wide parallel layer.
"""

import numba

_OPTIONS = dict(cache=True, error_model="numpy", fastmath=False, nogil=True)


def jit(fn=None):
    """`numba.njit` with the project's options."""
    decorator = numba.njit(**_OPTIONS)
    return decorator if fn is None else decorator(fn)


def stage(fn):
    """A per-pair stage of a kernel, inlined into its caller by numba (LLVM's heuristics would
    leave the larger ones as calls inside the pair loop)."""
    return numba.njit(inline="always", **_OPTIONS)(fn)
