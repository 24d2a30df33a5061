"""The one place that builds numba decorators, so every kernel compiles the same way.

fastmath stays off: the certified kernels rely on IEEE round-to-nearest for every operation
(no reassociation, no contraction that the error analysis did not count).
"""

import os

import numba

# numba's OpenMP threading layer cost ~8 ms per parallel call on the 2-core VM ellipsim is
# benchmarked on (a parallel classify of 1e5 pairs was no faster than one thread); numba's own
# workqueue layer costs ~0.06 ms.  A layer the user chose (NUMBA_THREADING_LAYER) is respected.
if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

_OPTIONS = dict(cache=True, error_model="numpy", fastmath=False, nogil=True)


def jit(fn=None, *, parallel=False):
    """`numba.njit` with the project's options; `parallel=True` enables `numba.prange`."""
    decorator = numba.njit(parallel=parallel, **_OPTIONS)
    return decorator if fn is None else decorator(fn)


def stage(fn):
    """A per-pair stage of a kernel, inlined into its caller by numba (LLVM's heuristics would
    leave the larger ones as calls inside the pair loop)."""
    return numba.njit(inline="always", **_OPTIONS)(fn)


prange = numba.prange
