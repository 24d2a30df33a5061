"""`ellipsim compare`: MuJoCo's built-in contacts against ellipsim's exact verdicts (comparison.Comparison), and their plot."""

import numpy as np

from ..errors import UserError
from .common import (
    bar,
    between,
    between_option,
    check_engine,
    check_output,
    engine_options,
    header,
    install_hint,
    load_scenario,
    made_parents,
    model_options,
    non_negative_int,
    positive_int,
    record_options,
    recorded,
    recorder_for,
    steps_of,
    write_error,
    write_json,
)


def compare(args):
    """MuJoCo's built-in contacts against ellipsim's exact verdicts, per frame and in total."""
    from .. import simulate
    from ..comparison import Comparison

    check_engine(args)
    if args.engine == "warp" and (args.plot or args.between_frames):
        raise UserError("--plot and --between-frames are for --engine mujoco (not yet for --engine warp)")
    s = load_scenario(args)
    if args.engine == "warp":
        return _compare_warp(args, s)
    if args.json:
        check_output(args.json, ".json", "--json")
    if args.plot:
        check_output(args.plot, ".png", "--plot")
        _pyplot()
    if args.record:
        check_output(args.record, ".rrd", "--record")
    steps = steps_of(s, args, _check_validation)
    started = header(s, f"  comparing MuJoCo's built-in detection with ellipsim over {steps} steps")
    recorder = recorder_for(args.record, args, s.scene["kind"]) if args.record else None
    (v, model), size = recorded(
        recorder,
        simulate.validation,
        s,
        steps,
        progress=bar(f"  {s.name}", steps),
        between=between(args),
        started=started,
    )
    result = Comparison.of(s.name, v, model)
    print("\n".join(result.summary(args.show)))
    if args.json:
        write_json(args.json, result.report())
        print(f"  report: {args.json}")
    if args.plot:
        _plot_compare(args.plot, s, result.builtin, result.ours, result.kinds)
        print(f"  plot: {args.plot}")
    if recorder:
        print(
            f"  recording: {args.record} ({steps} steps, {size / 1e6:.1f} MB; the disagreements under world/disagreements "
            f"and in the log); view it with: ellipsim view {args.record}"
        )
    return 0


def _compare_warp(args, s):
    """`compare --engine warp`: plain Warp's contacts in every world against the exact test (app/warp_compare.py)."""
    from .. import simulate, warp_compare, warp_run

    if args.json:
        check_output(args.json, ".json", "--json")
    if args.record:
        check_output(args.record, ".rrd", "--record")
    warp_run.quiet()
    device = warp_run.check_device(args.device or "cpu")
    steps = steps_of(s, args, simulate.check_steps)
    nworld = args.worlds or 1
    started = header(
        s,
        f"  comparing MuJoCo Warp's contacts ({device}, {nworld} worlds) with ellipsim over {steps} steps; the first "
        "run on a machine compiles Warp's kernels (minutes on CPU, then cached)",
    )
    recorder = recorder_for(args.record, args, s.scene["kind"]) if args.record else None
    result, size = recorded(
        recorder,
        warp_compare.compare,
        s,
        steps=steps,
        nworld=nworld,
        device=device,
        progress=bar(f"  {s.name}", steps),
        nconmax=args.nconmax,
        njmax=args.njmax,
        started=started,
    )
    print("\n".join(result.summary(args.show)))
    if args.json:
        write_json(args.json, result.report())
        print(f"  report: {args.json}")
    if recorder:
        print(
            f"  recording (world 0): {args.record} ({steps} steps, {size / 1e6:.1f} MB; the disagreements under "
            f"world/disagreements and in the log); view it with: ellipsim view {args.record}"
        )
    return 0


def _check_validation(s, steps):
    """ValueError when the counts `validation` keeps for `steps` steps would not fit in memory."""
    from .. import limits, simulate

    limits.check_fits(steps * simulate.BYTES_PER_VALIDATED_STEP, f"{steps} steps of pair counts")


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UserError(f"plots need matplotlib: {install_hint('plot')}") from None
    return plt


def _plot_compare(path, s, builtin, ours, kinds):
    plt = _pyplot()
    t = np.arange(len(builtin)) * s.timestep
    fig, ax = plt.subplots(figsize=(9, 3.6), constrained_layout=True)
    ax.step(t, builtin, where="post", label="MuJoCo contacts (dist < margin)", lw=1.4)
    ax.step(t, ours, where="post", label="ellipsim contacts (exact: signed distance < margin)", lw=1.0, ls="--")
    for kind, marker in (("mujoco_extra", "x"), ("mujoco_missed", "+"), ("near_tangent", "."), ("normal_off", "^")):
        ds = kinds[kind]
        if ds:
            ax.plot([d.step * s.timestep for d in ds], [builtin[d.step] for d in ds], marker, ls="none", label=kind)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("pairs in contact")
    ax.set_title(f"{s.name}: MuJoCo vs ellipsim, per step (every pair type ellipsim judges)")
    ax.legend(loc="best", fontsize=8)
    made_parents(path, "--plot")
    try:
        fig.savefig(path, dpi=120)
    except OSError as exc:
        raise write_error("--plot", path, exc) from None
    finally:
        plt.close(fig)


def add_parser(sub):
    """The `compare` subcommand and its arguments."""
    p = sub.add_parser(
        "compare", help="MuJoCo's built-in contacts vs ellipsim's exact verdicts, per frame and in total"
    )
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument("--steps", type=positive_int, help="steps to compare (default: the scenario's duration)")
    p.add_argument("--json", metavar="FILE.json", help="write the counts and every disagreement as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot the per-frame counts (needs the 'plot' extra)")
    p.add_argument(
        "--show",
        type=non_negative_int,
        default=10,
        help="disagreements (and pairs passed through each other) to print (default 10)",
    )
    between_option(
        p,
        "also find ellipsoid pairs separated at two consecutive steps that touch in between (passed "
        "through each other within one step), on the interpolated motion",
    )
    record_options(
        p, "save a rerun recording: every step, MuJoCo's contacts, the exact verdicts and the disagreements marked"
    )
    model_options(p)
    engine_options(p, "MuJoCo Warp's contacts (the warp extra), every world")
    p.set_defaults(run=compare)
