"""Python threads calling ellipsim at once get what one thread gets, to the bit; ellipsim changes no
process-wide threading setting (issue 10, part 2): its kernels are C++ run on threads of its own
(ellipsim.core.threads)."""

import multiprocessing
import subprocess
import sys
import threading

import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot

import ellipsim as es
from ellipsim.core import threads
from ellipsim.core.samples import generic_pairs, stress_pairs
from ellipsim.core.tolerances import CHUNK_MIN_PAIRS

N = 6 * CHUNK_MIN_PAIRS  # several chunks per parallel call


def batch():
    """Generic pairs with exactly tangent and near-tangent ones mixed in (the rational fallback runs
    in the calling thread), shuffled so that every chunk holds some."""
    a, b = generic_pairs(N, seed=11)
    ta, tb = stress_pairs("exactly tangent", 40, seed=1)
    na, nb = stress_pairs("near-tangent 1e-15", 40, seed=2)
    pick = np.random.default_rng(5).permutation(N + 80)
    cat = lambda *xs: es.Ellipsoids(
        *(np.concatenate([getattr(x, f) for x in xs])[pick] for f in ("centers", "rotations", "radii"))
    )  # noqa: E731
    return cat(a, ta, na), cat(b, tb, nb)


def moved(x, seed):
    rng = np.random.default_rng(seed)
    turn = Rot.from_rotvec(rng.normal(scale=0.3, size=(len(x), 3)))
    return es.Ellipsoids(x.centers + rng.normal(scale=0.2, size=(len(x), 3)), x.rotations @ turn.as_matrix(), x.radii)


A, B = batch()
A1, B1 = moved(A, 1), moved(B, 2)
AB = es.Ellipsoids.concatenate([A, B])
IDX = np.random.default_rng(7).integers(0, 2 * len(A), (2, len(A)))
CALLS = {
    "classify": lambda p: es.classify(A, B, parallel=p),
    "classify sturm": lambda p: es.classify(A, B, method="sturm", parallel=p),
    "classify descartes float32": lambda p: es.classify(A, B, method="descartes", dtype="float32", parallel=p),
    "classify_pairs": lambda p: es.classify_pairs(AB, IDX[0], IDX[1], parallel=p),
    "contact_scale": lambda p: es.contact_scale(A, B, parallel=p),
    "characteristic_polynomial": lambda p: es.characteristic_polynomial(A, B, parallel=p),
    "signed_distance": lambda p: es.signed_distance(A[:3000], B[:3000], parallel=p),
    "contains": lambda p: es.contains(A, B, parallel=p),
    "time_of_impact": lambda p: es.time_of_impact(
        A[:3000], A1[:3000], B[:3000], B1[:3000], parallel=p, return_status=True
    ),
    "shape_distance with derivatives": lambda p: es.shape_distance(
        A[:1000], "box", B.centers[:1000], B.rotations[:1000], B.radii[:1000], parallel=p, derivatives=True
    ),
}


def same(x, y):
    if isinstance(x, tuple):
        return all(same(u, v) for u, v in zip(x, y, strict=True))
    return x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)


@pytest.fixture(scope="module")
def alone():
    return {name: fn(False) for name, fn in CALLS.items()}


@pytest.mark.parametrize("callers", [4, 16])
def test_threads_calling_every_public_function_at_once_get_one_threads_results(alone, callers):
    start = threading.Barrier(callers)
    failures = []

    def work(k):
        start.wait()
        names = list(CALLS)
        for j in range(len(names)):
            name = names[(j + k) % len(names)]  # callers start on different functions
            for parallel in (True, None, False):
                if not same(CALLS[name](parallel), alone[name]):
                    failures.append((k, name, parallel))

    pool = [threading.Thread(target=work, args=(k,)) for k in range(callers)]
    for t in pool:
        t.start()
    for t in pool:
        t.join()
    assert failures == []


def test_the_parallel_results_are_the_serial_ones(alone):
    for name, fn in CALLS.items():
        assert same(fn(True), alone[name]), name


SCRIPT = """
import sys, threading, numpy as np
import ellipsim as es
from ellipsim.core.samples import generic_pairs
a, b = generic_pairs(300_000, seed=3)
ref = es.classify(a, b, parallel=False)
out = []
ts = [threading.Thread(target=lambda: out.append(es.classify(a, b, parallel=True))) for _ in range(4)]
[t.start() for t in ts]; [t.join() for t in ts]
assert len(out) == 4 and all(np.array_equal(o, ref) for o in out)
print(" ".join(sorted(m for m in sys.modules if m.split(".")[0] in ("numba", "llvmlite", "threadpoolctl"))) or "none")
"""


def test_four_threads_classifying_300000_pairs_at_once_in_a_fresh_process():
    """Issue 10's reproduction (four threads in parallel calls at once aborted numba's workqueue layer): the
    process lives, every thread gets the serial answer, and ellipsim loads no process-wide parallel runtime
    (numba, llvmlite): its kernels are C++ on its own pool."""
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["none"]


def test_chunks_cover_the_batch_once_and_limit_holds_the_caller_to_its_own_thread():
    seen, lock = [], threading.Lock()

    def kernel(tag, lo, hi):
        with lock:
            seen.append((lo, hi, threading.get_ident()))

    n = 10 * CHUNK_MIN_PAIRS + 7
    threads.run(kernel, n, True, "x")
    spans = sorted((lo, hi) for lo, hi, _ in seen)
    assert spans[0][0] == 0 and spans[-1][1] == n and all(p[1] == q[0] for p, q in zip(spans, spans[1:]))
    assert len(spans) > 1 or threads.available() < 2
    seen.clear()
    with threads.limit(1):
        threads.run(kernel, n, True, "x")
    assert seen == [(0, n, threading.get_ident())]
    seen.clear()
    threads.run(kernel, CHUNK_MIN_PAIRS, True, "x")  # too small to cut
    assert seen == [(0, CHUNK_MIN_PAIRS, threading.get_ident())]
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match=r"n must be a positive integer, got"), threads.limit(bad):
            pass


def _child(q):
    q.put(bool(np.array_equal(es.classify(A, B, parallel=True), es.classify(A, B, parallel=False))))


@pytest.mark.skipif(sys.platform != "linux", reason="fork start method")
def test_a_forked_child_runs_parallel_calls():
    """Threads do not survive fork: the child of a process whose pool exists must build its own."""
    es.classify(A, B, parallel=True)  # the parent's pool exists
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_child, args=(q,))
    p.start()
    p.join(120)
    assert p.exitcode == 0 and q.get(timeout=1) is True
