"""`ellipsim bench`: the benchmark suite (ellipsim/app/bench/)."""

import argparse
import os

from ..errors import UserError
from .common import existing_ancestor, install_hint

#: The suite's sections (ellipsim/app/bench SECTIONS, in its order; tests/test_bench.py checks they agree),
#: listed here for --help without importing the suite.
SECTIONS = {
    "accuracy": "time against error of every method (classify, contact_scale, the narrow phase, mj_geomDistance)",
    "stress": "misclassified pairs per numerically hard category and method",
    "scaling": "classify against batch size; the kinematic replay against the number of figures",
    "table1": "the thesis's Table 1 re-run",
    "mujoco": "mj_step per mode, cost per pair, contacts against MuJoCo's, the other pair types",
    "startup": "import to the first narrow-phase mj_step in fresh interpreters",
    "motion": "time_of_impact against sampled instants; contains",
    "speculative": "MuJoCo's speculative contacts against time_of_impact on fast ellipsoids",
    "warp": "ellipsim on MuJoCo Warp against Warp's GJK/EPA (the warp extra)",
    "gradients": "exact derivatives against without; `ellipsim fix` on the replay dance",
    "pairs": "section mujoco's pair-type table measured ten times: median, lowest, highest",
    "validation": "MuJoCo's contacts judged against the exact test: disagreements by kind, normals, cost",
    "baseline": "this build against another install (--baseline PYTHON), function by function, step by step",
    "meshes": "ellipsoid x convex mesh and x height field against MuJoCo's functions; mj_step on the terrain",
}


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
    if args.baseline is not None:
        from ellipsim.app.bench.baseline import check_baseline

        reason = check_baseline(args.baseline)
        if reason:
            raise UserError(f"--baseline: {reason}")
    from ellipsim.app import bench as suite

    print(f"ellipsim bench{' --quick' if args.quick else ''}: writing {args.out}/report.md and plots", flush=True)
    path, seconds = suite.run(args.out, quick=args.quick, only=args.only, baseline=args.baseline)
    print(f"  done in {seconds:.0f} s: {path}")
    return 0


def add_parser(sub):
    """The `bench` subcommand and its arguments."""
    p = sub.add_parser(
        "bench",
        help="time against error, numerical stress, scaling, thesis Table 1: report + plots",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="sections (all by default; --only picks some):\n"
        + "\n".join(f"  {name:<12} {what}" for name, what in SECTIONS.items())
        + "\n\nexample: ellipsim bench --quick --only accuracy mujoco --out bench-report",
    )
    p.add_argument("--quick", action="store_true", help="smaller sets: about 1 minute on 2 cores")
    p.add_argument(
        "--out", default="bench-report", metavar="DIR", help="output directory (made if missing; default bench-report)"
    )
    p.add_argument(
        "--only",
        nargs="+",
        choices=list(SECTIONS),
        metavar="SECTION",
        help="run only these sections of the suite (listed below)",
    )
    p.add_argument(
        "--baseline",
        metavar="PYTHON",
        help="section baseline: the interpreter of another ellipsim install to measure against (a venv's python)",
    )
    p.set_defaults(run=bench)
