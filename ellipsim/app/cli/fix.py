"""`ellipsim fix`: a motion corrected until no two ellipsoid limbs come closer than a clearance (fix.fix_motion),
verified frame by frame and between frames (replay.replay), optionally recorded beside the original."""

import argparse
import os

import numpy as np

from .common import (
    bar,
    check_output,
    made_parents,
    model_and_motion,
    non_negative_int,
    positive_real,
    record_options,
    recorded,
    recorder_for,
    write_error,
    write_json,
)


def _clearance(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of metres >= 0, got {text!r}") from None
    if not (0.0 <= value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a number of metres >= 0, got {text!r}")
    return value


def side_by_side(path, original, fixed):
    """(model, motion, offset (3,)): the MJCF at `path` twice, the second copy's bodies prefixed "fixed/" and set
    beside the first (along x or y, whichever the motion's bodies span more, clear of it over the whole motion
    with a gap: the recording's camera, framed on all bodies, then shows two groups apart), and the two motions
    as one qpos per frame."""
    import mujoco

    from .. import mjcf

    model = mjcf.load_model(path)
    data = mujoco.MjData(model)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    moving = model.body_rootid[model.geom_bodyid] != 0
    for f in np.unique(np.linspace(0, len(original) - 1, min(len(original), 200)).astype(int)):
        data.qpos[:] = original[f]
        mujoco.mj_kinematics(model, data)
        if moving.any():
            x, r = data.geom_xpos[moving], model.geom_rbound[moving, None]
            lo, hi = np.minimum(lo, (x - r).min(axis=0)), np.maximum(hi, (x + r).max(axis=0))
    extent = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    axis = int(np.argmax(extent[:2]))
    offset = np.zeros(3)
    offset[axis] = 1.25 * extent[axis] + 0.5
    parent, child = mujoco.MjSpec.from_file(path), mujoco.MjSpec.from_file(path)
    for spec in (parent, child):  # keyframes: not needed to draw, and copied once per attached root they clash
        for key in list(spec.keys):
            spec.delete(key)
    frame = parent.worldbody.add_frame(pos=offset)
    for body in list(child.worldbody.bodies):
        frame.attach_body(body, "fixed/", "")
    both = parent.compile()
    moved = fixed.copy()
    for j in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE):  # a free joint's qpos is in the world
        a = model.jnt_qposadr[j]
        moved[:, a : a + 3] += offset
    return both, np.concatenate([original, moved], axis=1), offset


def fix(args):
    """Correct a motion (qpos per frame) so that no two ellipsoid limbs come closer than --clearance."""
    from .. import capture, mjcf
    from .. import fix as fx
    from .. import replay as rp

    outputs = ((args.out, ".npy", "--out"), (args.record, ".rrd", "--record"), (args.json, ".json", "--json"))
    for path, suffix, option in outputs:
        if path:
            check_output(path, suffix, option)
    model = mjcf.load_model(args.model)
    layout = rp.qpos_layout(model)
    motion = rp.load_motion(args.motion, model.nq, layout=layout)
    name = os.path.splitext(os.path.basename(args.model))[0]
    F = len(motion)
    print(f"{name}: {F} frames of qpos (nq = {model.nq}: {layout}) from {args.motion}; clearance {args.clearance:g} m")
    result = fx.fix_motion(
        model,
        motion,
        clearance=args.clearance,
        metric=args.metric,
        smooth=args.smooth,
        progress=bar(f"  {name}: fix", 2 * F, unit="frame passes"),
    )
    print("\n".join(result.summary(args.show)))
    check = rp.replay(model, result.motion, fps=args.fps, name=name, between=True)
    # the pairs fix keeps apart (ellipsoid and sphere limbs), overlapping: in contact with a positive depth
    limbs = np.isin(check.pair_type, fx.PAIR_TYPES) & (check.pair_relation == capture.CONTACT) & (check.pair_depth > 0)
    overlapping = len(np.unique(check.pair_frame[limbs]))
    events = len(check.between_events())
    print(
        f"  verified: {overlapping} frames with overlapping limbs, {events} contacts between frames "
        f"(exact test, time of impact on the interpolated motion)"
    )
    report = result.report()
    report["verification"] = {"frames_overlapping": overlapping, "contacts_between_frames": events}
    if args.out:
        made_parents(args.out, "--out")
        try:
            np.save(args.out, result.motion)
        except OSError as exc:
            raise write_error("--out", args.out, exc) from None
        print(f"  corrected motion: {args.out}")
    if args.json:
        report.update(model=args.model, motion=args.motion)
        write_json(args.json, report)
        print(f"  report: {args.json}")
    if args.record:
        both, motion2, offset = side_by_side(args.model, motion, result.motion)
        recorder = recorder_for(args.record, args)
        axis = "xy"[int(np.flatnonzero(offset)[0])]
        recorder.legend_extra.append(
            f"**Original and fixed**: the original motion at the model's own place, labelled *original*; the "
            f"corrected one beside it, {offset.max():.2f} m along +{axis}, labelled *fixed* (its bodies and geoms "
            "named `fixed/...`)."
        )
        recorder.copy_labels = [("original", np.zeros(3)), ("fixed", offset)]
        _, size = recorded(
            recorder, rp.replay, both, motion2, fps=args.fps, name=f"{name}: original | fixed", between=False
        )
        print(
            f"  recording: {args.record} (original, and the fixed copy beside it; {size / 1e6:.1f} MB); "
            f"view it with: ellipsim view {args.record}"
        )
    if result.unfreed or overlapping or events:
        return 1
    return 0


def add_parser(sub):
    """The `fix` subcommand and its arguments."""
    p = sub.add_parser(
        "fix",
        help="correct a motion (qpos per frame) so that no two ellipsoid limbs come closer than a clearance",
        epilog="example: ellipsim fix figure.xml dance.npy --clearance 0.005 --out fixed.npy --record fixed.rrd",
    )
    model_and_motion(p)
    p.add_argument(
        "--clearance", type=_clearance, default=0.0, help="least distance in metres between two limbs (default 0)"
    )
    p.add_argument("--out", metavar="FILE.npy", help="write the corrected motion (frames, nq)")
    p.add_argument(
        "--metric",
        choices=("mass", "identity"),
        default="mass",
        help="what 'smallest change' measures: the model's joint-space inertia (default) or plain qpos",
    )
    p.add_argument(
        "--smooth",
        type=non_negative_int,
        default=4,
        help="frames on either side over which a correction ramps in and out (default 4; 0: per frame)",
    )
    p.add_argument("--fps", type=positive_real, default=30.0, help="frames per second, for the recording (default 30)")
    record_options(p, help="save a rerun recording of the original and the fixed motion side by side")
    p.add_argument("--json", metavar="FILE.json", help="write what moved per frame and the pairs not freed")
    p.add_argument("--show", type=non_negative_int, default=10, help="pairs not freed to print (default 10)")
    p.set_defaults(run=fix)
