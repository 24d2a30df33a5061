"""`ellipsim demo`: a random batch of generic pairs classified by every method; relations, disagreements, timing."""

from ..errors import UserError
from .common import non_negative_int, positive_int

#: Memory `demo` needs per pair: two validated batches, the generator's draws and the relations
#: (measured: 1.16 GB peak for 1e6 pairs, 0.37 GB for 2e5: 990 bytes per pair).
DEMO_BYTES_PER_PAIR = 1000


def demo(args):
    """Classify a batch of generic pairs with every method; print relations, disagreements, timing."""
    from .. import limits

    try:
        limits.check_fits(args.pairs * DEMO_BYTES_PER_PAIR, f"--pairs {args.pairs}")
    except ValueError as exc:
        raise UserError(f"{exc} (about {DEMO_BYTES_PER_PAIR} bytes a pair)") from None

    from ..demo import run_demo

    result = run_demo(args.pairs, args.seed, say=lambda line: print(line, flush=True))
    print("\n".join(result.summary_lines()))
    return 0


def add_parser(sub):
    """The `demo` subcommand and its arguments."""
    p = sub.add_parser("demo", help="classify a random batch of pairs, print a summary table and timing")
    p.add_argument("--pairs", type=positive_int, default=100_000, help="number of pairs (default 100000)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed, >= 0 (default 0)")
    p.set_defaults(run=demo)
