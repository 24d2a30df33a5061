"""The one place that builds numba decorators, so every kernel compiles the same way.

fastmath stays off: the certified kernels rely on IEEE round-to-nearest for every operation
(no reassociation, no contraction that the error analysis did not count).  nogil is on: batches
run on threads of our own (threads.py); no kernel uses numba's process-wide parallel layer.
Every kernel is cached by kernel_cache.py (a stamp over the core's sources, shipped objects).
"""

import numba

from . import kernel_cache

_OPTIONS = dict(cache=False, error_model="numpy", fastmath=False, nogil=True)


def jit(fn=None):
    """`numba.njit` with the project's options and ellipsim's kernel cache."""

    def decorate(f):
        return kernel_cache.enable(numba.njit(**_OPTIONS)(f))

    return decorate if fn is None else decorate(fn)


def stage(fn):
    """A per-pair stage of a kernel, inlined into its caller by numba (LLVM's heuristics would
    leave the larger ones as calls inside the pair loop).  Not cached: only a test calls a stage
    from Python; kernels carry their stages inlined."""
    return numba.njit(inline="always", **_OPTIONS)(fn)
