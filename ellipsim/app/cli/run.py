"""`ellipsim run`: simulate a scenario or an MJCF model (simulate.run), print its summary (simulate.Run.summary)."""

import time

from ..errors import UserError
from .common import (
    bar,
    between,
    between_option,
    check_engine,
    check_output,
    engine_options,
    header,
    load_scenario,
    model_options,
    positive_int,
    record_options,
    recorded,
    recorder_for,
    steps_of,
)


def run(args):
    """Simulate a scenario or model, print a summary, optionally save a rerun recording."""
    from .. import simulate

    check_engine(args)
    if args.engine == "warp" and args.mode == "filter":
        raise UserError("--mode filter is MuJoCo C's; on Warp, --mode narrowphase (ellipsim attached) or builtin")
    if args.engine == "warp" and args.between_frames:
        raise UserError("--between-frames is for --engine mujoco (not yet for --engine warp)")
    s = load_scenario(args)
    if args.engine == "warp" and (args.mode or s.mode) == "filter":  # the scenario file's mode, no --mode given
        raise UserError(
            f'{s.name}: its mode "filter" is MuJoCo C\'s; on Warp, --mode narrowphase (ellipsim attached) or builtin'
        )
    if args.engine == "warp":
        return _run_warp(args, s)
    if args.record:
        check_output(args.record, ".rrd", "--record")
    steps = steps_of(s, args, simulate.check_steps)
    mode = args.mode or s.mode
    what = "kinematic replay" if s.kinematic else f"mode {mode}"
    started = header(s, f"  {steps} steps of {s.timestep:g} s ({steps * s.timestep:g} s simulated), {what}")
    recorder = recorder_for(args.record, args, s.scene["kind"]) if args.record else None
    t0 = time.perf_counter()
    result, size = recorded(
        recorder,
        simulate.run,
        s,
        steps=steps,
        mode=mode,
        progress=bar(f"  {s.name}", steps),
        between=between(args),
        started=started,
    )
    wall = time.perf_counter() - t0
    lines = result.summary(
        wall, recording=recorder is not None, between_asked=bool(args.between_frames), show=BETWEEN_SHOWN
    )
    print("\n".join(lines))
    if recorder:
        print(
            f"  recording: {args.record} ({len(result.frames.times)} frames, {size / 1e6:.1f} MB); view it with: ellipsim view {args.record}"
        )
    return 0


def _run_warp(args, s):
    """`run --engine warp`: the scenario in --worlds worlds on MuJoCo Warp (app/warp_run.py)."""
    from .. import simulate, warp_run

    if args.record:
        check_output(args.record, ".rrd", "--record")
    warp_run.quiet()
    device = warp_run.check_device(args.device or "cpu")
    steps = steps_of(s, args, simulate.check_steps)
    nworld = args.worlds or 1
    mode = args.mode or s.mode
    started = header(
        s,
        f"  {steps} steps of {s.timestep:g} s in {nworld} worlds on MuJoCo Warp ({device}), "
        f"{'plain Warp' if mode == 'builtin' else 'ellipsim attached'}; the first run on a machine compiles "
        "Warp's kernels (minutes on CPU, then cached)",
    )
    recorder = recorder_for(args.record, args, s.scene["kind"]) if args.record else None
    result, size = recorded(
        recorder,
        warp_run.run,
        s,
        steps=steps,
        nworld=nworld,
        device=device,
        mode=mode,
        progress=bar(f"  {s.name}", steps),
        nconmax=args.nconmax,
        njmax=args.njmax,
        started=started,
    )
    print("\n".join(result.summary()))
    if recorder:
        print(f"  recording (world 0): {args.record} ({size / 1e6:.1f} MB); view it with: ellipsim view {args.record}")
    return 0


#: Contacts between frames `ellipsim run` prints at most.
BETWEEN_SHOWN = 10


def add_parser(sub):
    """The `run` subcommand and its arguments."""
    p = sub.add_parser(
        "run", help="simulate a scenario or an MJCF model; print steps/s, contacts, pairs tested/skipped"
    )
    p.add_argument("scenario", help="a name from `ellipsim list`, a path to a .toml file, or an MJCF .xml model")
    p.add_argument("--steps", type=positive_int, help="steps to run (default: the scenario's duration; a model: 2 s)")
    p.add_argument(
        "--mode", choices=("builtin", "filter", "narrowphase"), help="collision detection (default: the scenario's)"
    )
    record_options(p)
    between_option(
        p,
        "a kinematic scenario: also find pairs separated at two consecutive frames that touch in "
        "between, on the interpolated motion",
    )
    model_options(p)
    engine_options(p, "MuJoCo Warp (the warp extra), ellipsim attached unless --mode builtin")
    p.set_defaults(run=run)
