"""Relation of two ellipsoids: separated, touching or overlapping.

Two ellipsoids X^T A X <= 0 and X^T B X <= 0 are separated iff det(lambda A + B) = 0 has two
distinct positive roots and externally touching iff it has a positive double root (Wang, Wang &
Kim; thesis ch. 4, Theorem 1).  "exact" decides this on the float64 inputs with a certified float
path (certified_filter.py) and exact integer arithmetic where that path is unsure (exact/rational_fallback.hpp;
rational_fallback.py is the same decision in Fractions, the tests' reference); "sturm" and
"descartes" are the thesis's uncertified tests (exact/root_tests.hpp) on either set-up (characteristic.py).
"""

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import Ellipsoids, check_choice, check_pair, check_parallel, indices_of
from ..relation import UNDECIDED
from ..tolerances import SMALL_BATCH_PAIRS
from .certified_filter import certify
from .characteristic import SETUPS

METHODS = ("exact", "sturm", "descartes")
DTYPES = ("float64", "float32")
_DEFAULTS = ("exact", "rearranged", "float64")  # classify's method, setup and dtype


def resolve_undecided(a, b, out):
    """Replace every UNDECIDED entry of `out` by the exact relation (integer arithmetic,
    include/ellipsim/exact/rational_fallback.hpp; rational_fallback.py is the same in Fractions)."""
    ext.resolve(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out, 0, len(out))
    return out


def classify(a, b, *, method="exact", setup="rearranged", dtype="float64", parallel=None):
    """Relation of each pair (a[i], b[i]) as int8 codes of `Relation`.

    a, b : Ellipsoids; a batch of length 1 broadcasts against the other.
    method : "exact" (default; certified, right on every float64 input), or the thesis's
        uncertified "sturm" (4.2.1) and "descartes" (4.2.2), which exist to be measured.
    setup : "rearranged" (4.1.3) or "cofactor" (4.1.2), for "sturm" and "descartes" only.
    dtype : "float64" or "float32" working precision, for "sturm" and "descartes" only.
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (n,) int8
    """
    n = check_pair(a, b)
    if not (type(method) is type(setup) is type(dtype) is str and _DEFAULTS == (method, setup, dtype)):
        # (the defaults pass every check below: ~0.2 us a call saved, issue 20)
        check_choice("method", method, METHODS)
        check_choice("setup", setup, SETUPS)
        if isinstance(dtype, type) or isinstance(dtype, np.dtype):
            dtype = np.dtype(dtype).name  # np.float32, np.dtype("float32")
        check_choice("dtype", dtype, DTYPES)
        if method == "exact" and (setup != "rearranged" or dtype != "float64"):
            raise ValueError("setup and dtype apply to the 'sturm' and 'descartes' methods; 'exact' has neither")
    parallel = check_parallel(parallel, n)
    if method == "exact":
        if n > SMALL_BATCH_PAIRS:
            return resolve_undecided(a, b, certify(a, b, n, parallel))
        out = np.empty(n, dtype=np.int8)  # certify's kernel in one piece, as threads.run would run it
        ext.certify(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out, 0, n)
        return resolve_undecided(a, b, out)
    arrays = [a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii]
    if dtype == "float32":
        arrays = [x.astype(np.float32) for x in arrays]
    out = np.empty(n, dtype=np.int8)
    threads.run(ext.classify_float, n, parallel, *arrays, setup == "cofactor", method == "sturm", out)
    return out


def check_indices(name, value, n):
    """`value` as a 1-D int64 array of indices into a batch of n; ValueError naming `name`."""
    arr = np.asarray(value)
    if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
        raise ValueError(f"{name} must be a 1-D array of integer indices, got shape {arr.shape} and dtype {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    bad = np.flatnonzero((arr < 0) | (arr >= n))
    if len(bad):
        raise ValueError(f"{name}[{int(bad[0])}] must index the batch of {n} ellipsoids, got {int(arr[bad[0]])}")
    return arr


def classify_pairs(batch, first, second, *, parallel=None):
    """Exact relation of each pair (batch[first[k]], batch[second[k]]), as int8 codes of `Relation`.

    The same answers as classify(batch[first], batch[second]) without copying the ellipsoids: for the
    pairs a broad phase found among one validated batch (e.g. every ellipsoid of every frame).
    batch : Ellipsoids; first, second : (k,) integer indices into it.
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (k,) int8
    """
    if not isinstance(batch, Ellipsoids):
        raise ValueError(f"batch must be an ellipsim.Ellipsoids batch, got {type(batch).__name__}")
    first, second = check_indices("first", first, len(batch)), check_indices("second", second, len(batch))
    if len(first) != len(second):
        raise ValueError(f"first and second must have the same length, got {len(first)} and {len(second)}")
    k = len(first)
    out = np.empty(k, dtype=np.int8)
    threads.run(
        ext.certify_indexed,
        k,
        check_parallel(parallel, k),
        batch.centers,
        batch.rotations,
        batch.radii,
        first,
        second,
        out,
    )
    undecided = indices_of(out, UNDECIDED)
    if len(undecided):
        a, b = batch[first[undecided]], batch[second[undecided]]
        out[undecided] = resolve_undecided(a, b, out[undecided])
    return out
