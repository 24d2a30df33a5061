"""`ellipsim demo`: a random batch of generic pairs classified by every method; relations, disagreements, timing."""

import time

import numpy as np

from ..errors import UserError
from .common import non_negative_int, positive_int


#: Memory `demo` needs per pair: two validated batches, the generator's draws and the relations
#: (measured: 1.16 GB peak for 1e6 pairs, 0.37 GB for 2e5: 990 bytes per pair).
DEMO_BYTES_PER_PAIR = 1000


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def demo(args):
    """Classify a batch of generic pairs with every method; print relations, disagreements, timing."""
    from .. import limits

    try:
        limits.check_fits(args.pairs * DEMO_BYTES_PER_PAIR, f"--pairs {args.pairs}")
    except ValueError as exc:
        raise UserError(f"{exc} (about {DEMO_BYTES_PER_PAIR} bytes a pair)") from None

    import ellipsim as es
    from ellipsim.core.certified import certify
    from ellipsim.core.relation import UNDECIDED
    from ellipsim.core.samples import generic_pairs

    methods = [("exact", {})] + [
        (f"{m} {s}", dict(method=m, setup=s)) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor")
    ]
    print(f"ellipsim demo: {args.pairs} random ellipsoid pairs (half colliding, thesis 5.1.1), seed {args.seed}")
    print("  loading kernels (compiled on first use, ~15 s; cached afterwards) ...", flush=True)
    warm = generic_pairs(4, seed=1)
    _, t_compile = _timed(lambda: [es.classify(*warm, parallel=p, **kw) for _, kw in methods for p in (False, True)])
    (a, b), t_gen = _timed(lambda: generic_pairs(args.pairs, seed=args.seed))
    print(f"  kernels ready in {t_compile:.1f} s; pairs generated in {t_gen:.1f} s")
    truth, rows = None, []
    for name, kw in methods:
        rel, seconds = _timed(lambda: es.classify(a, b, parallel=False, **kw))
        truth = rel if truth is None else truth
        counts = np.bincount(rel, minlength=3)
        rows.append((name, *counts, int(np.count_nonzero(rel != truth)), seconds / len(rel) * 1e9))
    header = ("method", "separated", "touching", "overlapping", "wrong", "ns/pair")
    width = max(len(r[0]) for r in rows)
    print()
    print(f"  {header[0]:<{width}}  " + "  ".join(f"{h:>11}" for h in header[1:]))
    for name, sep, touch, over, wrong, ns in rows:
        print(f"  {name:<{width}}  {sep:>11}  {touch:>11}  {over:>11}  {wrong:>11}  {ns:>11.1f}")
    escalated = int(np.count_nonzero(certify(a, b, len(a), False) == UNDECIDED))
    scale = es.contact_scale(a, b)
    print()
    print(f"  exact: {escalated} pairs needed rational arithmetic; 'wrong' counts disagreements with exact")
    print(f"  contact_scale: min {scale.min():.3f}, median {np.median(scale):.3f}, max {scale.max():.3f}")
    print("  timings are single-threaded; `ellipsim bench` measures them properly")
    return 0


def add_parser(sub):
    """The `demo` subcommand and its arguments."""
    p = sub.add_parser("demo", help="classify a random batch of pairs, print a summary table and timing")
    p.add_argument("--pairs", type=positive_int, default=100_000, help="number of pairs (default 100000)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed, >= 0 (default 0)")
    p.set_defaults(run=demo)
