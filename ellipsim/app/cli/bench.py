"""`ellipsim bench`: the benchmark suite (ellipsim/app/bench/)."""

import os

from ..errors import UserError
from .common import existing_ancestor, install_hint


def bench(args):
    """The benchmark suite (ellipsim/app/bench/): writes DIR/report.md and PNG plots."""
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UserError(f"--out {args.out!r} exists and is not a directory")
    existing = existing_ancestor(os.path.abspath(args.out))  # the suite makes the missing folders
    if not os.path.isdir(existing):
        raise UserError(f"--out: {existing!r} is not a directory (in {args.out!r})")
    try:
        __import__("matplotlib")
        __import__("mpmath")
    except ImportError:
        raise UserError(f"ellipsim bench needs matplotlib and mpmath: {install_hint('bench')}") from None
    from ellipsim.app import bench as suite

    unknown = [name for name in args.only or () if name not in suite.SECTIONS]
    if unknown:
        raise UserError(f"--only: unknown section {unknown[0]!r}; the sections are {', '.join(suite.SECTIONS)}")
    print(f"ellipsim bench{' --quick' if args.quick else ''}: writing {args.out}/report.md and plots", flush=True)
    path, seconds = suite.run(args.out, quick=args.quick, only=args.only)
    print(f"  done in {seconds:.0f} s: {path}")
    return 0


def add_parser(sub):
    """The `bench` subcommand and its arguments."""
    p = sub.add_parser("bench", help="time against error, numerical stress, scaling, thesis Table 1: report + plots")
    p.add_argument("--quick", action="store_true", help="smaller sets: about 1 minute on 2 cores")
    p.add_argument(
        "--out", default="bench-report", metavar="DIR", help="output directory (made if missing; default bench-report)"
    )
    # the sections are ellipsim/app/bench's SECTIONS, checked once the suite is imported (not at start-up)
    p.add_argument(
        "--only",
        nargs="+",
        metavar="SECTION",
        help="run only these sections of the suite (accuracy, stress, ...: a name it does not have lists them)",
    )
    p.set_defaults(run=bench)
