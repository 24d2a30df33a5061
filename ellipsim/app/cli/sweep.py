"""`ellipsim sweep`: many variants of a scenario (sweep.sweep), their table (sweep.rows_table)."""

import os
import sys

from ..errors import UserError
from .common import bar, end_lines, header, install_hint, positive_int, write_error


def sweep(args):
    """Many variants of a scenario: DIR/results.csv (a row each), DIR/sweep.png, optional recordings."""
    from .. import scenario
    from .. import sweep as sw

    vary = {}
    for text in args.vary:
        key, values = sw.parse_vary(text)
        if key in vary:
            raise UserError(f"--vary {key}: given twice; put all its values in one --vary")
        vary[key] = values
    sw.check_out(args.out)
    if args.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise UserError(f"--backend ray needs Ray: {install_hint('ray')}") from None
    variants = sw.plan(
        args.scenario,
        vary,
        seeds=args.seeds,
        steps=args.steps,
        mode=args.mode,
        record_dir=args.out if args.record else None,
    )
    done = sw.already_done(variants, args.out)
    plot = sw.plot_available()
    s = scenario.from_table(variants[0].table, variants[0].path)
    header(s)()  # the variants are built in their workers: an error there is the variant's row
    shape = " x ".join([f"{len(v)} {k}" for k, v in vary.items()] + ([f"{args.seeds} seeds"] if args.seeds else []))
    steps = sorted({v.steps for v in variants})
    todo = len(variants) - len(done)
    where = (
        f"{min(args.workers or os.cpu_count() or 1, todo)} local processes"
        if args.backend == "local"
        else f"Ray at {os.environ['RAY_ADDRESS']}"
        if os.environ.get("RAY_ADDRESS")
        else "a local Ray instance"
    )
    print(
        f"  sweep: {len(variants)} variants ({shape or 'the scenario alone'}), "
        f"{steps[0] if len(steps) == 1 else f'{steps[0]}-{steps[-1]}'} steps each (twice: plain MuJoCo validated, then the mode)"
        + (f"; {len(done)} already in {os.path.join(args.out, sw.RESULTS)}" if done else "")
        + (f"; running {todo} on {where}" if todo else ""),
        flush=True,
    )
    progress = bar("  variants", max(todo, 1), unit="variants")
    try:
        rows = sw.sweep(
            args.scenario,
            vary,
            seeds=args.seeds,
            steps=args.steps,
            mode=args.mode,
            out=args.out,
            backend=args.backend,
            workers=args.workers,
            record=args.record,
            plot=plot,
            progress=progress,
        )
    except OSError as exc:
        raise write_error("--out", args.out, exc) from None
    print("\n".join(sw.rows_table(rows, list(variants[0].values))))
    print(f"  results: {os.path.join(args.out, sw.RESULTS)} (columns: {os.path.join(args.out, 'columns.json')})")
    if plot:
        print(f"  plot: {os.path.join(args.out, sw.PLOT)}")
    else:
        print(f"  no plot: it needs matplotlib: {install_hint('plot')}")
    if args.record:
        first = os.path.relpath(variants[0].record) if not os.path.isabs(args.out) else variants[0].record
        print(
            f"  recordings: one a variant in {args.out}, named by scenario, values and id; view one with: "
            f"ellipsim view {first}"
        )
    failed = [r for r in rows if r["error"]]
    if failed:
        end_lines()
        print(
            f"ellipsim: {len(failed)} of {len(rows)} variants failed (their rows hold the error), "
            f"e.g. {failed[0]['variant']}: {failed[0]['error']}",
            file=sys.stderr,
        )
        return 1
    return 0


def add_parser(sub):
    """The `sweep` subcommand and its arguments."""
    p = sub.add_parser(
        "sweep",
        help="many variants of a scenario (cartesian product of --vary lists, seeds): a CSV row each, a plot",
        epilog="example: ellipsim sweep pile --vary scene.figures=2,4,8 --vary mode=builtin,narrowphase --seeds 3 "
        "--steps 500 --out sweeps/pile ; on a Ray cluster: RAY_ADDRESS=head:6379 ellipsim sweep ... --backend ray. "
        "Each variant steps plain MuJoCo validated against the exact test (contacts, mujoco_extra, mujoco_missed, near_tangent, normal_off), then its mode "
        "(steps/s, fallbacks, deepest penetration); DIR/columns.json says what each column holds. A re-run into the "
        "same DIR skips the variants already in results.csv. Exit status 1 when a variant failed (its row says why).",
    )
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="KEY=V1,V2,...",
        help="a TOML key of the scenario (scene.figures, timestep, mode, control.amplitude, ...) and its values; "
        'repeat for more keys (values are TOML: 2, 0.001, true, "text", [0, 0, -9.81]; bare words are text)',
    )
    p.add_argument(
        "--seeds", type=positive_int, metavar="N", help="run each variant with scene.seed (and control.seed) = 0 .. N-1"
    )
    p.add_argument(
        "--steps", type=positive_int, metavar="N", help="steps of each pass (default: each variant's duration)"
    )
    p.add_argument("--mode", choices=("builtin", "filter", "narrowphase"), help="collision detection of every variant")
    p.add_argument("--record", action="store_true", help="write DIR/<variant>.rrd per variant (its recording id)")
    p.add_argument(
        "--out", required=True, metavar="DIR", help="output directory (made if missing; a re-run resumes it)"
    )
    p.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local: processes on this machine (default); ray: RAY_ADDRESS's cluster or a local Ray instance",
    )
    p.add_argument(
        "--workers",
        type=positive_int,
        metavar="N",
        help="processes (local, default: the CPUs; 1 runs in this process) or Ray tasks at a time",
    )
    p.set_defaults(run=sweep)
