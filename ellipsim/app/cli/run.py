"""`ellipsim run`: simulate a scenario or an MJCF model (simulate.run), print its summary (simulate.Run.summary)."""

import time

from .common import (
    bar,
    between,
    between_option,
    check_output,
    header,
    load_scenario,
    model_options,
    positive_int,
    recorded,
    recorder_for,
    steps_of,
)


def run(args):
    """Simulate a scenario or model, print a summary, optionally save a rerun recording."""
    from .. import simulate

    s = load_scenario(args)
    if args.record:
        check_output(args.record, ".rrd", "--record")
    steps = steps_of(s, args, simulate.check_steps)
    mode = args.mode or s.mode
    what = "kinematic replay" if s.kinematic else f"mode {mode}"
    header(s)
    print(f"  {steps} steps of {s.timestep:g} s ({steps * s.timestep:g} s simulated), {what}", flush=True)
    recorder = recorder_for(args.record) if args.record else None
    t0 = time.perf_counter()
    result, size = recorded(
        recorder, simulate.run, s, steps=steps, mode=mode, progress=bar(f"  {s.name}", steps), between=between(args)
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
    p.add_argument("--record", metavar="FILE.rrd", help="save a rerun recording")
    between_option(
        p,
        "a kinematic scenario: also find pairs separated at two consecutive frames that touch in "
        "between, on the interpolated motion",
    )
    model_options(p)
    p.set_defaults(run=run)
