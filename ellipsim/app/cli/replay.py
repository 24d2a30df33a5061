"""`ellipsim replay`: a motion (qpos per frame) played on a model (replay.replay, replay.ReplayResult's summary and report)."""

import os

from .common import (
    bar,
    between,
    between_option,
    check_output,
    model_and_motion,
    non_negative_int,
    positive_real,
    record_options,
    recorded,
    recorder_for,
    write_json,
)


def replay(args):
    """Play a motion (qpos per frame) on a model: which frames make its ellipsoid geoms touch or overlap."""
    from .. import mjcf
    from .. import replay as rp

    for path, option in ((args.record, "--record"), (args.json, "--json")):
        if path:
            check_output(path, ".rrd" if option == "--record" else ".json", option)
    model = mjcf.load_model(args.model)
    layout = rp.qpos_layout(model)
    motion = rp.load_motion(args.motion, model.nq, layout=layout)
    name = os.path.splitext(os.path.basename(args.model))[0]
    F = len(motion)
    print(
        f"{name}: {F} frames of qpos (nq = {model.nq}: {layout}) at {args.fps:g} fps ({F / args.fps:.2f} s) from {args.motion}"
    )
    recorder = recorder_for(args.record, args) if args.record else None
    result, size = recorded(
        recorder,
        rp.replay,
        model,
        motion,
        fps=args.fps,
        name=name,
        progress=bar(f"  {name}", F, unit="frames"),
        between=between(args),
    )
    print("\n".join(result.summary(args.show)))
    if args.json:
        write_json(args.json, result.report(args.model, args.motion, model.nq))
        print(f"  report: {args.json}")
    if recorder:
        print(
            f"  recording: {args.record} ({F} frames, {size / 1e6:.1f} MB); view it with: ellipsim view {args.record}"
        )
    return 0


def add_parser(sub):
    """The `replay` subcommand and its arguments."""
    p = sub.add_parser(
        "replay",
        help="play a motion (qpos per frame) on a model: which frames make limbs intersect",
        epilog="example: ellipsim replay fly.xml flight.npy --fps 60 --record flight.rrd --json flight.json",
    )
    model_and_motion(p)
    p.add_argument("--fps", type=positive_real, default=30.0, help="frames per second of the motion (default 30)")
    record_options(p)
    p.add_argument("--json", metavar="FILE.json", help="write per-frame counts and every touching or overlapping pair")
    p.add_argument(
        "--show", type=non_negative_int, default=10, help="body pairs and contacts between frames to print (default 10)"
    )
    between_option(
        p, "also find pairs separated at two consecutive frames that touch in between, on the interpolated motion"
    )
    p.set_defaults(run=replay)
