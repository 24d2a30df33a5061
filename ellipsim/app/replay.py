"""The animation check: a motion (qpos per frame) played on a model, and which frames bring a pair of
geoms ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, convex mesh or height
field) into contact.

    motion = load_motion("walk.csv", model.nq)          # (frames, nq), .npy or .csv
    result = replay(model, motion, fps=30)              # a ReplayResult

Per frame: qpos, MuJoCo's forward kinematics and its own collision (mj_fwdPosition, for its contacts
on the same frames), then ellipsim's verdict on every candidate pair of every frame, a chunk of frames
at a time (stepping.FrameLoop over a capture.FrameBuffer: sweep and prune per frame, MuJoCo's pair
rules, mujoco.judge's one margin rule: in contact when the signed distance is below the pair's
margin, on both sides), and the penetration depth of the pairs in contact.  Only the touching and
in-contact pairs are kept.  With between=True, also
the contacts that begin and end between two frames (pairs separated at both frames that touch in
between on the interpolated motion: mujoco.between, core.motion.time_of_impact).
"""

import dataclasses
import os

import mujoco
import numpy as np

from . import capture, limits
from .errors import UserError
from .mjcf import make_data
from .stepping import FrameLoop

MOTION_FORMATS = (".npy", ".csv")

_JOINT_NAMES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}
_QPOS_WIDTH = {"free": 7, "ball": 4, "slide": 1, "hinge": 1}


class MotionError(UserError):
    """A motion file that cannot be played on the model; the message names the file (one line)."""


def qpos_layout(model):
    """What the model's qpos holds, e.g. "7 (1 free joint) + 28 (28 hinges)"."""
    kinds = [_JOINT_NAMES.get(int(t), "joint") for t in model.jnt_type]
    parts = []
    for kind in ("free", "ball", "slide", "hinge"):
        n = kinds.count(kind)
        if n:
            noun = (
                f"{kind} joint{'s' if n > 1 else ''}" if kind in ("free", "ball") else f"{kind}{'s' if n > 1 else ''}"
            )
            parts.append(f"{n * _QPOS_WIDTH[kind]} ({n} {noun})")
    return " + ".join(parts) or "nothing (no joints)"


def load_motion(path, nq, *, layout=""):
    """The motion file `path` as qpos per frame, (frames, nq) float64.

    .npy: a 2-D array of real numbers (no pickles).  .csv: one frame per line, comma-separated;
    a first line that is not numbers is taken as a header and skipped.  MotionError names the file
    and what is wrong: the format, the shape (with the expected nq and `layout`, what qpos holds),
    the first value that is not finite.
    """
    text = os.fspath(path)
    ext = os.path.splitext(text)[1].lower()
    if ext not in MOTION_FORMATS:
        raise MotionError(
            f"motion {text!r} must be a {' or '.join(MOTION_FORMATS)} file, got {ext or 'no extension'!r}"
        )
    if not os.path.isfile(text):
        raise MotionError(f"motion {text!r} does not exist or is not a file")
    if ext == ".npy":
        try:
            values = np.load(text, allow_pickle=False, mmap_mode="r")  # the header first: shape and dtype
        except (ValueError, OSError, EOFError) as exc:
            raise MotionError(f"motion {text!r} is not a readable .npy array: {exc}") from None
        if values.dtype == bool or values.dtype.kind not in "iuf":
            raise MotionError(f"motion {text!r} must hold real numbers, got dtype {values.dtype}")
    else:
        values = _read_csv(text)
    expected = f"(frames, nq) with nq = {nq}" + (f": the model's qpos holds {layout}" if layout else "")
    if values.ndim != 2:
        raise MotionError(f"motion {text!r} must have shape {expected}, got shape {values.shape}")
    if values.shape[0] == 0:
        raise MotionError(f"motion {text!r} has no frames")
    if values.shape[1] != nq:
        raise MotionError(f"motion {text!r} has {values.shape[1]} values per frame, expected {expected}")
    try:
        limits.check_fits(2 * 8 * values.size, f"motion {text!r} ({values.shape[0]} frames of {nq} values)")
    except ValueError as exc:
        raise MotionError(str(exc)) from None
    values = np.array(values, dtype=np.float64)  # read in (from a memory map) and owned
    bad = np.argwhere(~np.isfinite(values))
    if len(bad):
        f, q = (int(i) for i in bad[0])
        raise MotionError(f"motion {text!r}: frame {f}, qpos[{q}] must be finite, got {values[f, q]}")
    return values


def _read_csv(path):
    """(frames, values) float64 of a CSV motion, line by line: blank lines and lines starting with
    '#' are skipped, a first line that is not numbers is a header; errors name the line."""
    rows, width, first = [], None, True
    try:
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, start=1):
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                try:
                    row = np.array([float(x) for x in line.split(",")])
                except ValueError:
                    if first:  # a header line of column names
                        first = False
                        continue
                    raise MotionError(
                        f"motion {path!r}, line {number}: expected comma-separated numbers, got {line[:60]!r}"
                    ) from None
                first = False
                if width is not None and len(row) != width:
                    raise MotionError(
                        f"motion {path!r}, line {number}: {len(row)} values, the lines before have {width}"
                    )
                width = len(row)
                rows.append(row)
    except UnicodeDecodeError as exc:
        raise MotionError(f"motion {path!r} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise MotionError(f"motion {path!r} cannot be read: {exc.strerror}") from None
    return np.array(rows).reshape(len(rows), width or 0)


@dataclasses.dataclass
class ReplayResult:
    """What `replay` found, per frame (F,) and per pair (P pairs touching or in contact).

    fps : frames per second of the motion
    touching, in_contact : (F,) int64, ellipsoid pairs ellipsim classifies exactly touching / pairs of
        every judged type in contact (signed distance < the pair's margin)
    in_contact_by_type, mujoco_by_type : (F, T) the pairs in contact per pair type (mujoco.judge.KEYS), by
        ellipsim and by MuJoCo (a contact with dist < margin)
    deepest : (F,) float64, the largest penetration depth of the frame, metres (0 without contact)
    deepest_pair : (F,) int64, index into the pair arrays of that pair (-1 without contact)
    mujoco_contacts : (F,) int64, all of MuJoCo's contacts; mujoco_pairs : (F,) the pairs ellipsim
        judges on which MuJoCo made a contact with dist < margin
    pair_frame : (P,) int64; pair_geoms : (P, 2) int64 MuJoCo geom ids; pair_relation : (P,) int8
        (1 touching, 2 in contact: capture.TOUCHING, CONTACT); pair_depth : (P,) float64 metres, max(0,
        -signed distance) (nan when touching); pair_type : (P,) int8 index into mujoco.judge.KEYS
    geom_names, body_names : MuJoCo's names (or geom{i} / body{i}); geom_body : (ngeom,) int64
    judged_geoms : how many geoms are of a type ellipsim judges; candidates : pairs decided, all frames
    between : mujoco.between.Events, the contacts between frames (pairs index the ellipsoid and sphere
        geoms `ellipsoid_ids`), or None when not looked for; between_candidates : the pairs whose motion
        between two frames time_of_impact decided
    seconds : wall time of kinematics and MuJoCo's collision; analysis_seconds : of ellipsim's verdicts
        (and of waiting for the contacts between frames); between_seconds : the wall time of their
        check, on a thread of its own while the next frames are posed (capture.FrameBuffer's background)
    """

    fps: float
    touching: np.ndarray
    in_contact: np.ndarray
    in_contact_by_type: np.ndarray
    mujoco_by_type: np.ndarray
    deepest: np.ndarray
    deepest_pair: np.ndarray
    mujoco_contacts: np.ndarray
    mujoco_pairs: np.ndarray
    pair_frame: np.ndarray
    pair_geoms: np.ndarray
    pair_relation: np.ndarray
    pair_depth: np.ndarray
    pair_type: np.ndarray
    geom_names: list
    body_names: list
    geom_body: np.ndarray
    judged_geoms: int
    possible: bool
    candidates: int
    seconds: float
    analysis_seconds: float
    record_seconds: float
    ellipsoid_ids: np.ndarray = None
    between: object = None
    between_candidates: int = 0
    between_seconds: float = 0.0

    @property
    def frames(self):
        return len(self.touching)

    @property
    def names(self):
        """geom_names, body_names and geom_body as a capture.ModelNames."""
        return capture.ModelNames(self.geom_names, self.body_names, self.geom_body)

    def body_pairs(self):
        """Per pair of bodies that touch or are in contact in some frame, most frames in contact first:
        list of dicts {bodies, geoms (the deepest pair's), frames_in_contact, frames_touching, first,
        last, deepest (m), deepest_frame, contact_frames}."""
        if len(self.pair_frame) == 0:
            return []
        bodies = np.sort(self.geom_body[self.pair_geoms], axis=1)
        keys, group = np.unique(bodies, axis=0, return_inverse=True)
        group = group.ravel()
        out = []
        for k, (b1, b2) in enumerate(keys):
            mine = np.flatnonzero(group == k)
            over = mine[self.pair_relation[mine] == capture.CONTACT]
            frames_over = np.unique(self.pair_frame[over])
            frames_touch = np.setdiff1d(np.unique(self.pair_frame[mine]), frames_over)
            depth = self.pair_depth[over]
            deepest = over[int(np.argmax(depth))] if len(over) else mine[0]
            out.append(
                {
                    "bodies": [self.body_names[b1], self.body_names[b2]],
                    "geoms": [self.geom_names[g] for g in self.pair_geoms[deepest]],
                    "frames_in_contact": int(len(frames_over)),
                    "frames_touching": int(len(frames_touch)),
                    "first": int(self.pair_frame[mine].min()),
                    "last": int(self.pair_frame[mine].max()),
                    "deepest": float(depth.max()) if len(over) else 0.0,
                    "deepest_frame": int(self.pair_frame[deepest]),
                    "contact_frames": frames_over.tolist(),
                }
            )
        out.sort(key=lambda d: (-d["frames_in_contact"], -d["deepest"], d["first"]))
        return out

    def between_events(self):
        """The contacts between frames as dicts (capture.describe_events), in time order; [] when not
        looked for."""
        if self.between is None:
            return []
        return capture.describe_events(self.between, self.ellipsoid_ids, self.names)

    def summary(self, show):
        """The lines `ellipsim replay` prints after playing: timings, frames in contact, the deepest
        penetration, MuJoCo's contacts, `show` body pairs and contacts between frames at most."""
        from .simulate import contact_lines

        F = self.frames
        over = np.flatnonzero(self.in_contact)
        touch_only = np.flatnonzero((self.touching > 0) & (self.in_contact == 0))
        lines = [
            f"  kinematics and MuJoCo's collision {self.seconds:.2f} s; ellipsim's exact verdicts on "
            f"{self.candidates} candidate pairs of {self.judged_geoms} geoms it judges {self.analysis_seconds:.2f} s"
        ]
        if not self.possible:
            lines.append(
                "  the model has no pair ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, "
                "convex mesh or height field that may collide): nothing to test"
            )
        lines.append(
            f"  frames with pairs in contact (distance < margin): {len(over)} of {F} ({frame_ranges(over)}); "
            f"touching only: {len(touch_only)}"
        )
        if len(over):
            f = int(over[np.argmax(self.deepest[over])])
            g1, g2 = self.pair_geoms[self.deepest_pair[f]]
            b1, b2 = (self.body_names[self.geom_body[g]] for g in (g1, g2))
            lines.append(
                f"  deepest penetration: {length(self.deepest[f])} at frame {f} ({f / self.fps:.3f} s): bodies {b1} / {b2} "
                f"(geoms {self.geom_names[g1]} / {self.geom_names[g2]})"
            )
        lines.append(
            f"  MuJoCo's contacts on the same frames: {int(self.mujoco_contacts.sum())} in all (max "
            f"{int(self.mujoco_contacts.max())} in a frame); on the pairs ellipsim judges, within the margin: MuJoCo "
            f"{int(self.mujoco_pairs.sum())}, ellipsim {int(self.in_contact.sum())} (and {int(self.touching.sum())} "
            "exactly touching)"
        )
        if self.possible:
            lines += contact_lines(_ByType(self.mujoco_by_type, self.in_contact_by_type), F, "frames")[1:]
        body_pairs = self.body_pairs()
        if body_pairs:
            lines.append("  body pairs in contact (most frames in contact first):")
            for bp in body_pairs[:show]:
                frames = frame_ranges(bp["contact_frames"], most=4)
                lines.append(
                    f"    {bp['bodies'][0]} / {bp['bodies'][1]}: in contact in {bp['frames_in_contact']} frames ({frames}), "
                    f"deepest {length(bp['deepest'])} at frame {bp['deepest_frame']}; touching only in {bp['frames_touching']}"
                )
            if len(body_pairs) > show:
                lines.append(f"    ... and {len(body_pairs) - show} more (--show N, or --json)")
        if self.between is not None:
            lines += capture.between_lines(
                self.between_events(), self.between_candidates, self.between_seconds, show, "frames"
            )
        elif self.possible:
            lines.append("  contacts that begin and end between two frames: not looked for (--between-frames)")
        return lines

    def report(self, model_path, motion_path, nq):
        """The JSON report (`ellipsim replay --json`) of the motion file `motion_path` played on the
        model file `model_path` (nq qpos values): totals, per pair type, body pairs,
        contacts between frames, per frame."""
        from ..mujoco.judge import KEYS

        per_pair = [[] for _ in range(self.frames)]
        for p in range(len(self.pair_frame)):
            g1, g2 = (int(g) for g in self.pair_geoms[p])
            contact = self.pair_relation[p] == capture.CONTACT
            per_pair[int(self.pair_frame[p])].append(
                {
                    "geoms": [self.geom_names[g1], self.geom_names[g2]],
                    "bodies": [self.body_names[self.geom_body[g1]], self.body_names[self.geom_body[g2]]],
                    "pair_type": KEYS[int(self.pair_type[p])],
                    "relation": "contact" if contact else "touching",
                    "depth": float(self.pair_depth[p]) if contact else None,
                }
            )
        return {
            "model": os.path.abspath(model_path),
            "motion": os.path.abspath(motion_path),
            "frames": self.frames,
            "fps": self.fps,
            "nq": int(nq),
            "judged_geoms": self.judged_geoms,
            "candidate_pairs": self.candidates,
            "frames_in_contact": int(np.count_nonzero(self.in_contact)),
            "frames_touching_only": int(np.count_nonzero((self.touching > 0) & (self.in_contact == 0))),
            "ellipsim_contacts": int(self.in_contact.sum()),
            "touching_pairs": int(self.touching.sum()),
            "mujoco_contacts": int(self.mujoco_contacts.sum()),
            "mujoco_judged_contacts": int(self.mujoco_pairs.sum()),
            "by_pair_type": {
                key: {
                    "mujoco_contacts": int(self.mujoco_by_type[:, k].sum()),
                    "ellipsim_contacts": int(self.in_contact_by_type[:, k].sum()),
                }
                for k, key in enumerate(KEYS)
            },
            "deepest": float(self.deepest.max()) if self.frames else 0.0,
            "body_pairs": self.body_pairs(),
            "between_frames": self.between_events() if self.between is not None else None,
            "per_frame": {
                "time": (np.arange(self.frames) / self.fps).tolist(),
                "touching": self.touching.tolist(),
                "in_contact": self.in_contact.tolist(),
                "deepest": self.deepest.tolist(),
                "mujoco_contacts": self.mujoco_contacts.tolist(),
                "mujoco_judged_contacts": self.mujoco_pairs.tolist(),
                "pairs": per_pair,
            },
        }


@dataclasses.dataclass
class _ByType:
    """The two (F, T) count arrays simulate.contact_lines reads."""

    builtin_by_type: np.ndarray
    ellipsim_by_type: np.ndarray


def replay(model, motion, *, fps=30.0, progress=None, recorder=None, name="replay", between=False):
    """Pose `model` at every frame of `motion` (F, nq) and decide every candidate pair ellipsim judges.

    fps : frames per second, > 0 (the recording's time line, and the report's times).
    between : also find the contacts that begin and end between two frames, on the interpolated motion
        of each ellipsoid (centre linear, rotation along the shortest arc: core.motion.interpolation), which is not
        the motion of qpos interpolated; the recording gets a marker at each one's first contact.
        It runs on a thread of its own while the frames are posed (FrameBuffer's background): 2-14%
        more wall time with a free core, 15-51% on one (16 figures, 2000 frames; cli.common.BETWEEN_DEFAULT).
    progress : optional callable(frame, F).  recorder : optional record.Recorder, begun with the
    model's geometry (named `name`) and sent every chunk (closing it is the caller's).
    Returns a ReplayResult.  ValueError names a bad motion shape or fps.
    """
    motion = np.asarray(motion, dtype=np.float64)
    if motion.ndim != 2 or motion.shape[1] != model.nq or len(motion) == 0:
        raise ValueError(f"motion must have shape (frames, {model.nq}) (frames >= 1), got {motion.shape}")
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.floating)) or not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive finite number, got {fps!r}")
    from ..mujoco.attachment import ellipsoid_pair_possible
    from ..mujoco.judge import KEYS

    data = make_data(model, name)
    F, T = len(motion), len(KEYS)
    per_frame = {k: np.zeros(F, dtype=np.int64) for k in ("touching", "in_contact", "mujoco_contacts", "mujoco_pairs")}
    ours_by_type, theirs_by_type = np.zeros((F, T), dtype=np.int64), np.zeros((F, T), dtype=np.int64)
    pairs, relations, depths, kinds = [], [], [], []
    candidates = 0

    def on_chunk(chunk):
        nonlocal candidates
        fr = chunk.frames
        at = fr.frame
        per_frame["touching"][at] = fr.touching_counts
        per_frame["in_contact"][at] = fr.ellipsim_counts
        per_frame["mujoco_contacts"][at] = fr.contact_counts
        per_frame["mujoco_pairs"][at] = fr.builtin_counts
        ours_by_type[at], theirs_by_type[at] = fr.ellipsim_by_type, fr.builtin_by_type
        candidates += len(chunk.pairs)
        hit = chunk.contact > 0
        pairs.append(chunk.pairs[hit])
        relations.append(chunk.contact[hit])
        depths.append(chunk.depth[hit])
        kinds.append(chunk.kind[hit])

    loop = FrameLoop(
        model, recorder=recorder, title=name, on_chunk=on_chunk, depth=True, between=between, background=between
    )

    def pose(f):
        data.qpos[:] = motion[f]
        data.time = f / fps
        mujoco.mj_fwdPosition(model, data)

    loop.run(data, F, pose, progress=progress)
    buffer, names = loop.buffer, loop.names
    pairs = np.concatenate(pairs) if pairs else np.zeros((0, 3), dtype=np.int64)
    relation = np.concatenate(relations) if relations else np.zeros(0, dtype=np.int8)
    kind = np.concatenate(kinds) if kinds else np.zeros(0, dtype=np.int8)
    contact = relation == capture.CONTACT
    depth = np.where(contact, np.concatenate(depths), np.nan) if len(relation) else np.zeros(0)
    geoms = np.column_stack([buffer.ids[pairs[:, 1]], buffer.ids[pairs[:, 2]]]).astype(np.int64).reshape(-1, 2)
    deepest, deepest_pair = np.zeros(F), np.full(F, -1, dtype=np.int64)
    over = np.flatnonzero(contact)
    if len(over):
        order = over[np.lexsort((-depth[over], pairs[over, 0]))]  # by frame, deepest first
        first = order[np.r_[True, pairs[order[1:], 0] != pairs[order[:-1], 0]]]
        deepest[pairs[first, 0]] = depth[first]
        deepest_pair[pairs[first, 0]] = first
    return ReplayResult(
        fps=float(fps),
        touching=per_frame["touching"],
        in_contact=per_frame["in_contact"],
        in_contact_by_type=ours_by_type,
        mujoco_by_type=theirs_by_type,
        deepest=deepest,
        deepest_pair=deepest_pair,
        mujoco_contacts=per_frame["mujoco_contacts"],
        mujoco_pairs=per_frame["mujoco_pairs"],
        pair_frame=pairs[:, 0].copy(),
        pair_geoms=geoms,
        pair_relation=relation,
        pair_depth=depth,
        pair_type=kind,
        geom_names=names.geoms,
        body_names=names.bodies,
        geom_body=names.geom_body,
        judged_geoms=len(buffer.ids),
        possible=bool(ellipsoid_pair_possible(model, "narrowphase")),
        candidates=candidates,
        seconds=loop.seconds,
        analysis_seconds=loop.analysis_seconds,
        record_seconds=loop.record_seconds,
        ellipsoid_ids=buffer.ellipsoid_ids.astype(np.int64),
        between=loop.events(),
        between_candidates=buffer.between.candidates if between else 0,
        between_seconds=buffer.between_seconds,
    )


def frame_ranges(frames, most=8):
    """Sorted frame numbers as text: "3-7, 12, 15-16" (the first `most` runs, then "... (n more)")."""
    frames = np.unique(np.asarray(frames, dtype=np.int64))
    if len(frames) == 0:
        return "none"
    breaks = np.flatnonzero(np.diff(frames) != 1)
    starts = np.r_[frames[0], frames[breaks + 1]]
    ends = np.r_[frames[breaks], frames[-1]]
    runs = [f"{a}" if a == b else f"{a}-{b}" for a, b in zip(starts, ends)]
    more = len(runs) - most
    return ", ".join(runs[:most]) + (f", ... ({more} more)" if more > 0 else "")


def length(metres):
    """A length as text: centimetres below a metre ("1.23 cm"), else metres."""
    return f"{metres * 100:.3g} cm" if metres < 1 else f"{metres:.3g} m"
