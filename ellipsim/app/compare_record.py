"""`ellipsim compare --record`: MuJoCo's contacts against ellipsim's exact verdicts, step by step, as
a rerun recording.

A CompareRecording is mujoco.validate's observer: each compared step becomes a frame of a
record.Recorder (the bodies, MuJoCo's contacts, every candidate ellipsoid pair's exact verdict as
the geoms' colours, capture.FrameBuffer); on top of what `run --record` writes (record.py's module
docstring):

    world/disagreements            Points3D at each disagreement's pair (ellipsim's contact point), at
                                   its step only: magenta, the engine's contact the exact test separates
                                   (compare's missed), yellow, an exact contact the engine did not make
                                   (extra), white within NEAR_TANGENT of touching; labelled with the kind
                                   and the geoms, the
                                   label shown (they are few)
    world/disagreements/mujoco     MuJoCo's contact on the pair (its deepest): Points3D + Arrows3D, blue
    world/disagreements/ellipsim   ellipsim's: Points3D + Arrows3D, dark red
    events/disagreements           TextLog, a line per disagreement at its step: geoms, bodies, MuJoCo's
                                   and ellipsim's distance and normal, who is right and why
    counts/disagreements/<kind>    Scalars per step: missed, extra, near_tangent
    differences/distance           Scalars, at steps with MuJoCo contacts between ellipsoid geoms: the
                                   largest |MuJoCo's dist - ellipsim's signed distance| (metres)
    differences/normal_angle       the largest angle between their normals (degrees)

The Warp compare (warp_compare) records world 0 the same way, with Warp's contacts and its words
for the kinds (kinds()).  The per-step differences are measured a chunk of frames at a time (one batched signed_distance);
the disagreements, already explained by validate, are written as they come.
"""

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ..core.tolerances import NEAR_TANGENT
from ..mujoco.judge import NORMAL_OFF_DEG, verdicts_at
from . import capture, record
from .comparison import line
from .errors import STOPS

DISAGREEMENTS_PATH = "world/disagreements"
MUJOCO_PATH = "world/disagreements/mujoco"
ELLIPSIM_PATH = "world/disagreements/ellipsim"
LOG_PATH = "events/disagreements"
COUNTS_PATH = "counts/disagreements"
DISTANCE_PATH = "differences/distance"
ANGLE_PATH = "differences/normal_angle"

ENGINE_ONLY = (230, 0, 200, 255)  # magenta: the engine's contact, the exact test separates
EXACT_ONLY = (250, 230, 0, 255)  # yellow: the exact test's contact, none from the engine
NEAR = (250, 250, 250, 255)  # white: within NEAR_TANGENT of touching
NORMAL_OFF = (0, 220, 230, 255)  # cyan: both in contact, the engine's normal off
MUJOCO_COLOR = (110, 160, 240, 255)  # as MuJoCo's count series
ELLIPSIM_COLOR = (170, 20, 20, 255)  # as ellipsim's
MARKER_RADIUS = 0.45  # scene scales: a disagreement's marker, larger than a contact's


def kinds(engine):
    """{kind: (colour, series name)} of a compare recording, the same words for every engine
    (mujoco.validate.KINDS)."""
    return {
        "mujoco_extra": (ENGINE_ONLY, f"mujoco_extra ({engine} contact, the exact test separates)"),
        "mujoco_missed": (EXACT_ONLY, f"mujoco_missed (exact contact, none from {engine})"),
        "near_tangent": (NEAR, f"near_tangent (one side only, within {NEAR_TANGENT:g} m of the margin)"),
        "normal_off": (NORMAL_OFF, f"normal_off ({engine}'s normal more than {NORMAL_OFF_DEG:g} deg off)"),
    }


def legend(engine):
    """The legend's lines on the disagreements."""
    return [
        "",
        "**Disagreements** (at their step; listed in the log, whose lines name the step):",
        f"- **magenta** ball: mujoco_extra, {engine} made a contact the exact test separates",
        f"- **yellow** ball: mujoco_missed, the exact test makes a contact {engine} did not",
        f"- **white** ball: near_tangent, one of those within {NEAR_TANGENT:g} m of the margin",
        f"- **cyan** ball: normal_off, both in contact, {engine}'s normal more than {NORMAL_OFF_DEG:g} deg off",
        f"- at each: {engine}'s contact in **blue**, ellipsim's in **dark red**, point and normal",
    ]


def kind_of(d):
    """A mujoco.validate.Disagreement's kind."""
    return d.kind


def panels(engine="MuJoCo", log=True):
    """The column beside a compare recording's 3D view; log : with the log panel (there are
    disagreements or contacts between steps to list)."""
    return [
        (rrb.TimeSeriesView(origin="counts/pairs", name="pairs in contact (every type ellipsim judges)"), 2),
        (rrb.TimeSeriesView(origin=COUNTS_PATH, name="disagreements per step"), 2),
        (rrb.TimeSeriesView(origin=DISTANCE_PATH, name=f"|{engine} dist - ellipsim's| on {engine}'s contacts, m"), 1),
        (rrb.TimeSeriesView(origin=ANGLE_PATH, name=f"normal angle on {engine}'s contacts, deg"), 1),
        *([(rrb.TextLogView(origin="events", name="disagreements"), 2)] if log else []),
        (rrb.TextDocumentView(origin=record.LEGEND_PATH, name="what the colours mean"), 2),
    ]


class CompareRecording:
    """Records `compare`'s steps: call it as validate's observer, then `finish()`.

    recorder : a record.Recorder, begun here with `model`'s geometry called `title`
    engine : whose contacts are compared, as the log lines name it ("MuJoCo", or "Warp")
    """

    def __init__(self, recorder, model, title, engine="MuJoCo"):
        self.engine = engine
        self.recorder = recorder
        self.names = capture.ModelNames.of(model)
        self.model = model
        self.buffer = capture.FrameBuffer(model, record=True)
        recorder.begin(capture.geometry(model, title, self.names))
        recorder.panels = lambda r: panels(engine, self.written > 0 or r.events_written > 0)
        recorder.engine = engine
        recorder.legend_extra = legend(engine)
        self.kinds = kinds(engine)
        self.scale = recorder.scale
        rec = recorder.rec
        rec.log(
            DISAGREEMENTS_PATH, rr.Points3D.from_fields(radii=MARKER_RADIUS * self.scale, show_labels=True), static=True
        )
        for path, color in ((MUJOCO_PATH, MUJOCO_COLOR), (ELLIPSIM_PATH, ELLIPSIM_COLOR)):
            rec.log(path, rr.Points3D.from_fields(radii=record.CONTACT_RADIUS * self.scale, colors=color), static=True)
            rec.log(path, rr.Arrows3D.from_fields(radii=record.NORMAL_RADIUS * self.scale, colors=color), static=True)
        for kind, (color, name) in self.kinds.items():
            rec.log(f"{COUNTS_PATH}/{kind}", rr.SeriesLines(names=name, colors=color, widths=2.0), static=True)
        name, color, width = record.BUILTIN_SERIES
        rec.log(
            record.BUILTIN_PATH,
            rr.SeriesLines(names=f"{engine} contacts (dist < margin)", colors=color, widths=width),
            static=True,
        )
        rec.log(DISTANCE_PATH, rr.SeriesLines(names="largest distance difference, m", widths=1.5), static=True)
        rec.log(ANGLE_PATH, rr.SeriesLines(names="largest normal angle, deg", widths=1.5), static=True)
        self.counts = []  # per step: disagreements of each kind
        self.times = []  # per step: data.time
        self._shown = None  # the step whose markers are on screen (cleared at the next step)
        self.written = 0  # disagreements written

    def __call__(self, model, data, step, disagreements, kinds=None, contacts=None):
        """validate's observer: the step's frame, and its disagreements (mujoco.validate.Disagreement).
        kinds : their kinds (default: kind_of each); contacts : the engine's contacts, when not
        data.contact (capture.FrameBuffer.add)."""
        if self._shown is not None and self._shown != step:
            self._clear(step, data.time)
        self.times.append(float(data.time))
        kinds = [kind_of(d) for d in disagreements] if kinds is None else list(kinds)
        order = list(self.kinds)
        counts = [0] * len(order)
        for kind in kinds:
            counts[order.index(kind)] += 1
        self.counts.append(counts)
        if disagreements:
            self._write_disagreements(step, data.time, disagreements, kinds)
        if self.buffer.add(data, data.time, contacts):
            self._flush()

    def run(self, call):
        """call() (the stepping that calls this observer), then finish(); on Ctrl-C or SIGTERM the
        steps so far are written first when the recorder keeps partial recordings."""
        try:
            result = call()
        except STOPS:
            if self.recorder.keep_partial:
                self.finish()
            raise
        self.finish()
        return result

    def finish(self):
        """Write the frames still held and the count series; the recorder's closing is the caller's."""
        self._flush()
        self.buffer.close()
        if self.written == 0:
            self.recorder.legend_extra = [
                *self.recorder.legend_extra,
                "",
                f"No disagreements in {len(self.counts)} steps.",
            ]
        counts = np.asarray(self.counts, dtype=np.float64).reshape(-1, len(self.kinds))
        if len(counts):
            indexes = record._indexes(np.asarray(self.times), np.arange(len(counts)))
            for k, kind in enumerate(self.kinds):
                self.recorder.rec.send_columns(
                    f"{COUNTS_PATH}/{kind}", indexes=indexes, columns=rr.Scalars.columns(scalars=counts[:, k])
                )

    # --- internals -------------------------------------------------------------------------------

    def _flush(self):
        chunk = self.buffer.flush()
        if chunk is None:
            return
        self.recorder.write(chunk.frames)
        self._differences(chunk)

    def _differences(self, chunk):
        """The largest distance and normal differences per frame over the engine's contacts on pairs
        ellipsim judges, against ellipsim's signed distance on the same poses."""
        f = chunk.frames
        mine = np.flatnonzero(f.contact_ellipsoids)
        if len(mine) == 0:
            return
        ids = self.buffer.ids
        local = f.contact_frame[mine] - f.frame[0]
        geoms = f.contact_geoms[mine]
        i, j = (np.searchsorted(ids, geoms[:, k]) for k in (0, 1))
        xpos = np.stack([chunk.centers[local, i], chunk.centers[local, j]], axis=1)
        xmat = np.stack([chunk.rotations[local, i], chunk.rotations[local, j]], axis=1)
        v = verdicts_at(self.model, geoms, xpos, xmat, np.zeros(len(mine)), measure=np.ones(len(mine), dtype=bool))
        ddist = np.abs(f.contact_dist[mine] - v.dist)
        cos = np.clip(np.einsum("ij,ij->i", v.normal, f.contact_normal[mine]), -1.0, 1.0)
        angle = np.degrees(np.arccos(cos))
        frames = np.unique(local)
        at = np.searchsorted(frames, local)
        worst_dist, worst_angle = np.zeros(len(frames)), np.zeros(len(frames))
        np.fmax.at(worst_dist, at, ddist)
        np.fmax.at(worst_angle, at, angle)
        indexes = record._indexes(f.times[frames], f.frame[frames])
        rec = self.recorder.rec
        rec.send_columns(DISTANCE_PATH, indexes=indexes, columns=rr.Scalars.columns(scalars=worst_dist))
        rec.send_columns(ANGLE_PATH, indexes=indexes, columns=rr.Scalars.columns(scalars=worst_angle))

    def _write_disagreements(self, step, time, ds, kinds):
        rec = self.recorder.rec
        rec.set_time("frame", sequence=step)
        rec.set_time("time", duration=np.timedelta64(int(round(time * 1e9)), "ns"))
        points = np.array([d.ellipsim_pos for d in ds], dtype=np.float64)
        labels = [f"{kind}: {d.names[0]} / {d.names[1]}" for kind, d in zip(kinds, ds)]
        rec.log(DISAGREEMENTS_PATH, rr.Points3D(points, colors=[self.kinds[k][0] for k in kinds], labels=labels))
        length = record.NORMAL_LENGTH * self.scale
        ours = np.array([d.ellipsim_normal for d in ds], dtype=np.float64)
        rec.log(ELLIPSIM_PATH, rr.Points3D(points), rr.Arrows3D(origins=points, vectors=length * ours))
        theirs = [d for d in ds if d.mujoco_pos is not None]
        at = np.array([d.mujoco_pos for d in theirs], dtype=np.float64).reshape(-1, 3)
        normals = np.array([d.mujoco_normal for d in theirs], dtype=np.float64).reshape(-1, 3)
        rec.log(MUJOCO_PATH, rr.Points3D(at), rr.Arrows3D(origins=at, vectors=length * normals))
        for kind, d in zip(kinds, ds):
            text = line(d, self.engine)
            rec.log(LOG_PATH, rr.TextLog(text, level="INFO" if kind == "near_tangent" else "WARN"))
        rec.reset_time()
        self._shown = step
        self.written += len(ds)

    def _clear(self, step, time):
        """Take the markers of the step shown off the screen at `step` (at `time`, seconds)."""
        rec = self.recorder.rec
        rec.set_time("frame", sequence=step)
        rec.set_time("time", duration=np.timedelta64(int(round(time * 1e9)), "ns"))
        empty = np.zeros((0, 3))
        rec.log(DISAGREEMENTS_PATH, rr.Points3D(empty, colors=np.zeros((0, 4), dtype=np.uint8), labels=[]))
        for path in (MUJOCO_PATH, ELLIPSIM_PATH):
            rec.log(path, rr.Points3D(empty), rr.Arrows3D(origins=empty, vectors=empty))
        rec.reset_time()
        self._shown = None
