"""`ellipsim compare --record`: MuJoCo's contacts against ellipsim's exact verdicts, step by step, as
a rerun recording.

A CompareRecording is mujoco.validate's observer: each compared step becomes a frame of a
record.Recorder (the bodies, MuJoCo's contacts, every candidate ellipsoid pair's exact verdict as
the geoms' colours, capture.FrameBuffer); on top of what `run --record` writes (record.py's module
docstring):

    world/disagreements            Points3D at each disagreement's pair (ellipsim's contact point), at
                                   its step only: magenta missed (MuJoCo's contact, ellipsim separated),
                                   yellow extra (ellipsim's overlap, no MuJoCo contact), white within
                                   NEAR_TANGENT of touching; labelled with the kind and the geoms, the
                                   label shown (they are few)
    world/disagreements/mujoco     MuJoCo's contact on the pair (its deepest): Points3D + Arrows3D, blue
    world/disagreements/ellipsim   ellipsim's: Points3D + Arrows3D, dark red
    events/disagreements           TextLog, a line per disagreement at its step: geoms, bodies, MuJoCo's
                                   and ellipsim's distance and normal, who is right and why
    counts/disagreements/<kind>    Scalars per step: missed, extra, near_tangent
    differences/distance           Scalars, at steps with MuJoCo contacts between ellipsoid geoms: the
                                   largest |MuJoCo's dist - ellipsim's signed distance| (metres)
    differences/normal_angle       the largest angle between their normals (degrees)

The per-step differences are measured a chunk of frames at a time (one batched signed_distance);
the disagreements, already explained by validate, are written as they come.
"""

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ..core.distance.ellipsoid_pair import signed_distance
from ..core.ellipsoids import Ellipsoids
from ..core.tolerances import NEAR_TANGENT
from . import capture, record

DISAGREEMENTS_PATH = "world/disagreements"
MUJOCO_PATH = "world/disagreements/mujoco"
ELLIPSIM_PATH = "world/disagreements/ellipsim"
LOG_PATH = "events/disagreements"
COUNTS_PATH = "counts/disagreements"
DISTANCE_PATH = "differences/distance"
ANGLE_PATH = "differences/normal_angle"

KIND_COLORS = {
    "missed": (230, 0, 200, 255),  # magenta
    "extra": (250, 230, 0, 255),  # yellow
    "near_tangent": (250, 250, 250, 255),  # white
}
MUJOCO_COLOR = (110, 160, 240, 255)  # as MuJoCo's count series
ELLIPSIM_COLOR = (170, 20, 20, 255)  # as ellipsim's
MARKER_RADIUS = 0.45  # scene scales: a disagreement's marker, larger than a contact's
SERIES = {
    "missed": ("missed (MuJoCo contact, ellipsim separated)", KIND_COLORS["missed"]),
    "extra": ("extra (ellipsim overlapping, no MuJoCo contact)", (200, 170, 0, 255)),
    "near_tangent": (f"within {NEAR_TANGENT:g} m of touching", (120, 120, 120, 255)),
}


def kind_of(d):
    """A mujoco.validate.Disagreement's kind, as comparison.split_disagreements sorts it."""
    if abs(d.geom_distance) < NEAR_TANGENT:
        return "near_tangent"
    return "missed" if d.mujoco_contact else "extra"


def panels(recorder):
    """The column beside a compare recording's 3D view."""
    return [
        (rrb.TimeSeriesView(origin="counts/pairs", name="ellipsoid pairs in contact"), 2),
        (rrb.TimeSeriesView(origin=COUNTS_PATH, name="disagreements per step"), 2),
        (rrb.TimeSeriesView(origin=DISTANCE_PATH, name="|MuJoCo dist - ellipsim's| on MuJoCo's contacts, m"), 1),
        (rrb.TimeSeriesView(origin=ANGLE_PATH, name="normal angle on MuJoCo's contacts, deg"), 1),
        (rrb.TextLogView(origin="events", name="disagreements"), 2),
        (rrb.TextDocumentView(origin=record.LEGEND_PATH, name="what the colours mean"), 2),
    ]


LEGEND = [
    "",
    "**Disagreements** (at their step; listed in the log, whose lines name the step):",
    "- **magenta** ball: missed, MuJoCo made a contact the exact test separates",
    "- **yellow** ball: extra, the exact test overlaps and MuJoCo made no contact",
    f"- **white** ball: within {NEAR_TANGENT:g} m of touching (mj_geomDistance)",
    "- at each: MuJoCo's contact in **blue**, ellipsim's in **dark red**, point and normal",
]


class CompareRecording:
    """Records `compare`'s steps: call it as validate's observer, then `finish()`.

    recorder : a record.Recorder, begun here with `model`'s geometry called `title`
    """

    def __init__(self, recorder, model, title):
        self.recorder = recorder
        self.names = capture.ModelNames.of(model)
        self.buffer = capture.FrameBuffer(model, record=True)
        recorder.begin(capture.geometry(model, title, self.names))
        recorder.panels = panels
        recorder.legend_extra = LEGEND
        self.scale = recorder.scale
        rec = recorder.rec
        rec.log(
            DISAGREEMENTS_PATH, rr.Points3D.from_fields(radii=MARKER_RADIUS * self.scale, show_labels=True), static=True
        )
        for path, color in ((MUJOCO_PATH, MUJOCO_COLOR), (ELLIPSIM_PATH, ELLIPSIM_COLOR)):
            rec.log(path, rr.Points3D.from_fields(radii=record.CONTACT_RADIUS * self.scale, colors=color), static=True)
            rec.log(path, rr.Arrows3D.from_fields(radii=record.NORMAL_RADIUS * self.scale, colors=color), static=True)
        for kind, (name, color) in SERIES.items():
            rec.log(f"{COUNTS_PATH}/{kind}", rr.SeriesLines(names=name, colors=color, widths=2.0), static=True)
        rec.log(DISTANCE_PATH, rr.SeriesLines(names="largest distance difference, m", widths=1.5), static=True)
        rec.log(ANGLE_PATH, rr.SeriesLines(names="largest normal angle, deg", widths=1.5), static=True)
        self.counts = []  # per step: (missed, extra, near_tangent)
        self.times = []  # per step: data.time
        self._shown = None  # the step whose markers are on screen (cleared at the next step)
        self.written = 0  # disagreements written

    def __call__(self, model, data, step, disagreements):
        """validate's observer: the step's frame, and its disagreements."""
        if self._shown is not None and self._shown != step:
            self._clear(step, data.time)
        self.times.append(float(data.time))
        counts = [0, 0, 0]
        for d in disagreements:
            counts[("missed", "extra", "near_tangent").index(kind_of(d))] += 1
        self.counts.append(counts)
        if disagreements:
            self._write_disagreements(step, data.time, disagreements)
        if self.buffer.add(data, data.time):
            self._flush()

    def finish(self):
        """Write the frames still held and the count series; the recorder's closing is the caller's."""
        self._flush()
        self.buffer.close()
        counts = np.asarray(self.counts, dtype=np.float64).reshape(-1, 3)
        if len(counts):
            indexes = record._indexes(np.asarray(self.times), np.arange(len(counts)))
            for k, kind in enumerate(("missed", "extra", "near_tangent")):
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
        """The largest distance and normal differences per frame over MuJoCo's contacts between two
        tested geoms, against ellipsim's signed distance on the same poses."""
        f = chunk.frames
        mine = np.flatnonzero(f.contact_ellipsoids)
        if len(mine) == 0:
            return
        ids = self.buffer.ids
        local = f.contact_frame[mine] - f.frame[0]
        i, j = (np.searchsorted(ids, f.contact_geoms[mine, k]) for k in (0, 1))
        radii = self.buffer.radii
        a = Ellipsoids(chunk.centers[local, i], chunk.rotations[local, i], radii[i])
        b = Ellipsoids(chunk.centers[local, j], chunk.rotations[local, j], radii[j])
        dist, normal = signed_distance(a, b)[:2]
        ddist = np.abs(f.contact_dist[mine] - dist)
        cos = np.clip(np.einsum("ij,ij->i", normal, f.contact_normal[mine]), -1.0, 1.0)
        angle = np.degrees(np.arccos(cos))
        frames = np.unique(local)
        at = np.searchsorted(frames, local)
        worst_dist, worst_angle = np.zeros(len(frames)), np.zeros(len(frames))
        np.maximum.at(worst_dist, at, ddist)
        np.maximum.at(worst_angle, at, angle)
        indexes = record._indexes(f.times[frames], f.frame[frames])
        rec = self.recorder.rec
        rec.send_columns(DISTANCE_PATH, indexes=indexes, columns=rr.Scalars.columns(scalars=worst_dist))
        rec.send_columns(ANGLE_PATH, indexes=indexes, columns=rr.Scalars.columns(scalars=worst_angle))

    def _write_disagreements(self, step, time, ds):
        rec, names = self.recorder.rec, self.names
        rec.set_time("frame", sequence=step)
        rec.set_time("time", duration=np.timedelta64(int(round(time * 1e9)), "ns"))
        kinds = [kind_of(d) for d in ds]
        points = np.array([d.ellipsim_pos for d in ds], dtype=np.float64)
        labels = [f"{kind.replace('_', ' ')}: {d.names[0]} / {d.names[1]}" for kind, d in zip(kinds, ds)]
        rec.log(DISAGREEMENTS_PATH, rr.Points3D(points, colors=[KIND_COLORS[k] for k in kinds], labels=labels))
        length = record.NORMAL_LENGTH * self.scale
        ours = np.array([d.ellipsim_normal for d in ds], dtype=np.float64)
        rec.log(ELLIPSIM_PATH, rr.Points3D(points), rr.Arrows3D(origins=points, vectors=length * ours))
        theirs = [d for d in ds if d.mujoco_pos is not None]
        at = np.array([d.mujoco_pos for d in theirs], dtype=np.float64).reshape(-1, 3)
        normals = np.array([d.mujoco_normal for d in theirs], dtype=np.float64).reshape(-1, 3)
        rec.log(MUJOCO_PATH, rr.Points3D(at), rr.Arrows3D(origins=at, vectors=length * normals))
        for kind, d in zip(kinds, ds):
            rec.log(
                LOG_PATH, rr.TextLog(line(step, kind, d, names), level="INFO" if kind == "near_tangent" else "WARN")
            )
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


def _vector(v):
    return "none" if v is None else "(" + ", ".join(f"{x:.4f}" for x in v) + ")"


def line(step, kind, d, names):
    """The log line of one disagreement."""
    bodies = [names.bodies[names.geom_body[g]] for g in (d.geom1, d.geom2)]
    mujoco = f"dist {d.mujoco_dist:.6g} m, normal {_vector(d.mujoco_normal)}" if d.mujoco_contact else "no contact"
    return (
        f"step {step}: {kind.replace('_', ' ')}: geoms {d.names[0]} / {d.names[1]} (bodies {bodies[0]} / {bodies[1]}); "
        f"MuJoCo {mujoco}; ellipsim {d.relation}, signed distance {d.signed_distance:.6g} m, normal "
        f"{_vector(d.ellipsim_normal)}; right: {d.right} ({d.reason})"
    )
