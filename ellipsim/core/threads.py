"""Batch kernels on several cores with threads of our own, no other library's parallel layer.

Every batch kernel is one serial C++ loop over pairs [lo, hi) (ellipsim/native: each binding releases
the GIL while it runs); `run` cuts a batch into chunks and runs them on a pool of Python threads, the
calling thread taking the first chunk.  Each chunk writes a disjoint slice of its call's own output
arrays, so any number of Python threads may call at once and get what one thread gets, to the bit.

Why not OpenMP or a C++ pool: a process-wide pool is shared with every library that uses the same
runtime (numba's workqueue layer aborted the interpreter when two Python threads entered parallel code
at once; OpenMP cost ~8 ms per call on the 2-core benchmark machine).  A pool we own changes nothing
that other libraries share.  It holds no data: a call's arrays travel with its chunks.
"""

import contextlib
import contextvars
import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from .tolerances import CHUNK_MIN_PAIRS, CHUNKS_PER_THREAD

_lock = threading.Lock()
_pool = None
_pool_pid = None
_limit = contextvars.ContextVar("ellipsim_threads", default=None)


def available():
    """The cores this process may run on (its CPU affinity, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def workers():
    """Threads a parallel call uses here: `limit`'s value in this context, else every core."""
    n = _limit.get()
    return available() if n is None else n


@contextlib.contextmanager
def limit(n):
    """At most n threads for the parallel calls made in this block, by this thread (a context
    variable: other threads and other libraries are untouched).  Sweeps use limit(1) in workers
    that already share the cores."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    token = _limit.set(n)
    try:
        yield
    finally:
        _limit.reset(token)


def _executor(size):
    """The shared pool, (re)built in a process that forked after building it (threads do not
    survive fork) or when a call needs more threads than it has."""
    global _pool, _pool_pid
    with _lock:
        if _pool is None or _pool_pid != os.getpid() or _pool._max_workers < size:
            _pool = ThreadPoolExecutor(max_workers=size, thread_name_prefix="ellipsim")
            _pool_pid = os.getpid()
        return _pool


def _drain(kernel, args, bounds, counter):
    """Run chunks until none is left (`next` on an itertools.count is atomic in CPython)."""
    while (k := next(counter)) < len(bounds) - 1:
        kernel(*args, bounds[k], bounds[k + 1])


def run(kernel, n, parallel, *args):
    """kernel(*args, lo, hi) over [0, n): in one piece in this thread, or, when `parallel` and the
    batch has at least 2 * CHUNK_MIN_PAIRS pairs, in chunks on `workers()` threads.  The calling
    thread takes chunks too, so a call progresses even while other calls keep the pool busy."""
    if not parallel or n < 2 * CHUNK_MIN_PAIRS:  # decided before workers(): its affinity query costs a
        kernel(*args, 0, n)  # system call, a quarter of a one-pair call's overhead (issue 20)
        return
    w = workers()
    if w < 2:
        kernel(*args, 0, n)
        return
    chunks = min(w * CHUNKS_PER_THREAD, n // CHUNK_MIN_PAIRS)
    bounds = [n * k // chunks for k in range(chunks + 1)]
    counter = itertools.count()
    pool = _executor(w - 1)
    futures = [pool.submit(_drain, kernel, args, bounds, counter) for _ in range(w - 1)]
    _drain(kernel, args, bounds, counter)
    for f in futures:
        f.result()
