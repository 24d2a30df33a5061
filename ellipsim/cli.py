"""The `ellipsim` command line.

    ellipsim demo [--pairs N] [--seed S]      classify a random batch, print a summary and timing
"""

import argparse
import sys
import time

import numpy as np


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit status 2 (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class UserError(Exception):
    """A mistake in what the user asked for: reported in one line, exit status 2."""


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _time(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def demo(args):
    """Classify a batch of generic pairs with every method; print relations, disagreements, timing."""
    import ellipsim as es
    from ellipsim.certified import UNDECIDED, certify
    from ellipsim.samples import generic_pairs

    methods = [("exact", {})] + [
        (f"{m} {s}", dict(method=m, setup=s)) for m in ("descartes", "sturm") for s in ("rearranged", "cofactor")
    ]
    print(f"ellipsim demo: {args.pairs} random ellipsoid pairs (half colliding, thesis 5.1.1), seed {args.seed}")
    print("  loading kernels (compiled on first use, ~15 s; cached afterwards) ...", flush=True)
    warm = generic_pairs(4, seed=1)
    _, t_compile = _time(lambda: [es.classify(*warm, parallel=p, **kw) for _, kw in methods for p in (False, True)])
    (a, b), t_gen = _time(lambda: generic_pairs(args.pairs, seed=args.seed))
    print(f"  kernels ready in {t_compile:.1f} s; pairs generated in {t_gen:.1f} s")
    truth, rows = None, []
    for name, kw in methods:
        rel, seconds = _time(lambda: es.classify(a, b, parallel=False, **kw))
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
    print("  timings are single-threaded; bench/bench_classify.py measures them properly")
    return 0


def main(argv=None):
    parser = _Parser(
        prog="ellipsim",
        description="Exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.",
        epilog="example: ellipsim demo --pairs 100000",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    p = sub.add_parser("demo", help="classify a random batch of pairs, print a summary table and timing")
    p.add_argument("--pairs", type=_positive_int, default=100_000, help="number of pairs (default 100000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.set_defaults(run=demo)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except UserError as exc:
        print(f"ellipsim: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `ellipsim ... | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
