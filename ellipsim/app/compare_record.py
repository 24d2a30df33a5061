"""`ellipsim compare --record`: MuJoCo's contacts against ellipsim's exact verdicts, step by step, as
a rerun recording.

A CompareRecording is mujoco.validate's observer: each compared step becomes a frame of a
record.Recorder (the bodies, MuJoCo's contacts, every candidate pair's exact verdict as the geoms'
colours, capture.FrameBuffer); on top of what `run --record` writes (record.py's module docstring):

    world/disagreements            Points3D at each disagreement, at its step only, at the top of a pole
                                   that rises from the pair's contact point above the bodies (so the
                                   geoms of a dense heap do not hide it), coloured by kind (KIND_COLORS:
                                   none of the verdict, contact or figure colours), labelled with the
                                   kind and the geoms (shown: they are few)
    world/disagreements/poles      LineStrips3D, the poles
    world/disagreements/mujoco     the engine's contact on the pair (its deepest): Points3D + Arrows3D, blue
    world/disagreements/ellipsim   ellipsim's: Points3D + Arrows3D, white
    events/disagreements           TextLog, a line per disagreement at its step: kind, pair type, geoms
                                   (bodies), both distances, the normals' angle, who is right and why
    events/differences             TextLog, at the steps where the difference plots peak: the pair
    counts/disagreements/<kind>    Scalars per step: mujoco_extra, mujoco_missed, near_tangent, normal_off
    differences/distance           Scalars, at steps with the engine's contacts on pairs ellipsim judges:
                                   the largest |engine's dist - ellipsim's signed distance| (metres)
    differences/normal_angle       the largest angle between their normals (degrees)
    overview                       TextDocument (markdown): every disagreement of the run, counted by kind
                                   and pair type, the first OVERVIEW_ROWS listed

Everything on the timelines goes as columns (send_columns): the recording has the "time" and "frame"
timelines only.  The layout: the scene (the 3D view beside the plots and the legend) and a tab of the
disagreements (the overview above the log, the whole window wide, so the lines show whole).

The Warp compare (warp_compare) records world 0 the same way, with Warp's contacts.  The per-step
differences are measured a chunk of frames at a time (judge.verdicts_at); the disagreements, already
explained by validate, are written a chunk at a time.
"""

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ..core.tolerances import NEAR_TANGENT
from ..mujoco.judge import KEYS, NORMAL_OFF_DEG, verdicts_at
from ..mujoco.validate import KINDS
from . import capture, record
from .errors import STOPS

DISAGREEMENTS_PATH = "world/disagreements"
POLES_PATH = "world/disagreements/poles"
MUJOCO_PATH = "world/disagreements/mujoco"
ELLIPSIM_PATH = "world/disagreements/ellipsim"
LOG_PATH = "events/disagreements"
PEAKS_PATH = "events/differences"
COUNTS_PATH = "counts/disagreements"
DISTANCE_PATH = "differences/distance"
ANGLE_PATH = "differences/normal_angle"
OVERVIEW_PATH = "overview"

#: A disagreement's colour by kind: hues the recording uses for nothing else (the figures are cyan to
#: indigo, a geom in contact red, touching amber, contacts green and black, contacts between frames magenta).
KIND_COLORS = {
    "mujoco_extra": (255, 105, 180, 255),  # pink: the engine's contact, the exact test separates
    "mujoco_missed": (255, 240, 0, 255),  # yellow: an exact contact, none from the engine
    "near_tangent": (235, 235, 235, 255),  # white: within NEAR_TANGENT of the margin
    "normal_off": (255, 120, 0, 255),  # orange: the engine's normal off
}
MUJOCO_COLOR = (40, 110, 255, 255)  # blue, saturated (the figures' blues are pale): the engine's contact
ELLIPSIM_COLOR = (255, 255, 255, 255)  # white: ellipsim's contact (red is a geom in contact)
MARKER_RADIUS = 0.45  # scene scales: a disagreement's marker, larger than a contact's
POLE_RADIUS = 0.06  # scene scales
POLE_ABOVE = 1.5  # scene scales above the highest geom around the pair
#: Peaks of each difference plot named in the log (the largest of the run first).
PEAKS = 3
#: Disagreements listed one by one in the overview (all are in the log and the JSON).
OVERVIEW_ROWS = 40


def kinds(engine):
    """{kind: (colour, series name)} of a compare recording, the same words for every engine
    (mujoco.validate.KINDS; the legend says what each means)."""
    return {kind: (KIND_COLORS[kind], kind) for kind in KINDS}


def legend(engine):
    """The legend's lines on the disagreements."""
    return [
        "",
        "**Disagreements** (at their step, a ball on a pole rising from the pair; all in the *disagreements* tab):",
        f"- **pink**: mujoco_extra, {engine} made a contact the exact test separates",
        f"- **yellow**: mujoco_missed, the exact test makes a contact {engine} did not",
        f"- **white**: near_tangent, one of those within {NEAR_TANGENT:g} m of the margin",
        f"- **orange**: normal_off, {engine}'s normal beyond {NORMAL_OFF_DEG:g} deg of the exact one",
        f"- at each: {engine}'s contact in **blue**, ellipsim's in **white**, point and normal",
    ]


def kind_of(d):
    """A mujoco.validate.Disagreement's kind."""
    return d.kind


def panels(engine="MuJoCo", span=None):
    """The column beside a compare recording's 3D view: the counts, the disagreements, the differences,
    the depth of the deepest pairs, the legend; span : the run's (start, end) seconds (record.plot)."""
    return [
        (record.plot("counts/pairs", "pairs in contact (every type ellipsim judges)", span), 3),
        (record.plot(COUNTS_PATH, "disagreements per step", span), 3),
        (record.plot(DISTANCE_PATH, f"|{engine} dist - exact| on {engine}'s contacts, m (peaks in the log)", span), 2),
        (record.plot(ANGLE_PATH, f"normal angle on {engine}'s contacts, deg (peaks in the log)", span), 2),
        (record.plot(record.DEPTH_PATH, "depth of the deepest pairs, m", span), 2),
        (rrb.TextDocumentView(origin=record.LEGEND_PATH, name="what the colours mean"), 3),
    ]


def tabs():
    """The disagreements' tab: the overview above the log of every disagreement and difference peak."""
    return [
        rrb.Vertical(
            rrb.TextDocumentView(origin=OVERVIEW_PATH, name="overview"),
            record.log_view("events", "log: disagreements and the difference plots' peaks"),
            row_shares=[2, 3],
            name="disagreements",
        )
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
        recorder.panels = lambda r: panels(engine, r.span())
        recorder.tabs = lambda r: tabs()
        recorder.engine = engine
        recorder.legend_extra = legend(engine)
        self.kinds = kinds(engine)
        self.scale = recorder.scale
        solid = model.geom_rbound > 0  # not planes, height fields
        self._solid, self._rbound = np.flatnonzero(solid), model.geom_rbound[solid]
        rec = recorder.rec
        rec.log(
            DISAGREEMENTS_PATH, rr.Points3D.from_fields(radii=MARKER_RADIUS * self.scale, show_labels=True), static=True
        )
        rec.log(POLES_PATH, rr.LineStrips3D.from_fields(radii=POLE_RADIUS * self.scale), static=True)
        for path, color in ((MUJOCO_PATH, MUJOCO_COLOR), (ELLIPSIM_PATH, ELLIPSIM_COLOR)):
            rec.log(path, rr.Points3D.from_fields(radii=record.CONTACT_RADIUS * self.scale, colors=color), static=True)
            rec.log(path, rr.Arrows3D.from_fields(radii=record.NORMAL_RADIUS * self.scale, colors=color), static=True)
        for kind, (color, name) in self.kinds.items():
            rec.log(f"{COUNTS_PATH}/{kind}", rr.SeriesLines(names=name, colors=color, widths=2.0), static=True)
        name, color, width = record.BUILTIN_SERIES
        rec.log(
            record.BUILTIN_PATH,
            rr.SeriesLines(names=f"{engine} (dist < margin)", colors=color, widths=width),
            static=True,
        )
        rec.log(DISTANCE_PATH, rr.SeriesLines(names="largest of the step", widths=1.5), static=True)
        rec.log(ANGLE_PATH, rr.SeriesLines(names="largest of the step", widths=1.5), static=True)
        self.counts = []  # per step: disagreements of each kind
        self.times = []  # per step: data.time
        self.found = []  # every disagreement, in step order (the overview)
        self._pending = []  # (step, time, top of the bodies, disagreements, kinds) not yet sent
        self._to_clear = []  # steps at which markers are to be taken off, once their time is known
        self._peaks = {"distance": [], "angle": []}  # (value, step, time, g1, g2) of each plot's peaks
        self.written = 0  # disagreements written

    def __call__(self, model, data, step, disagreements, kinds=None, contacts=None):
        """validate's observer: the step's frame, and its disagreements (mujoco.validate.Disagreement).
        kinds : their kinds (default: each one's own); contacts : the engine's contacts, when not
        data.contact (capture.FrameBuffer.add)."""
        self.times.append(float(data.time))
        kinds = [kind_of(d) for d in disagreements] if kinds is None else list(kinds)
        order = list(self.kinds)
        counts = [0] * len(order)
        for kind in kinds:
            counts[order.index(kind)] += 1
        self.counts.append(counts)
        if disagreements:
            tops = [self._top(data, d.ellipsim_pos) for d in disagreements]
            self._pending.append((step, float(data.time), tops, list(disagreements), kinds))
            self.found += disagreements
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
        """Write the frames still held, the count series, the peaks and the overview; the recorder's
        closing is the caller's."""
        self._flush(final=True)
        self.buffer.close()
        if self.written == 0:
            self.recorder.legend_extra = [
                *self.recorder.legend_extra,
                "",
                f"No disagreements in {len(self.counts)} steps.",
            ]
        counts = np.asarray(self.counts, dtype=np.float64).reshape(-1, len(self.kinds))
        rec = self.recorder.rec
        if len(counts):
            indexes = record._indexes(np.asarray(self.times), np.arange(len(counts)))
            for k, kind in enumerate(self.kinds):
                rec.send_columns(
                    f"{COUNTS_PATH}/{kind}", indexes=indexes, columns=rr.Scalars.columns(scalars=counts[:, k])
                )
        self._write_peaks()
        rec.log(OVERVIEW_PATH, rr.TextDocument(self.overview(), media_type=rr.MediaType.MARKDOWN), static=True)

    def overview(self):
        """The markdown overview of every disagreement of the run: counts by kind and pair type, then the
        first OVERVIEW_ROWS one by one."""
        engine, ds = self.engine, self.found
        lines = [f"**{len(ds)} disagreements in {len(self.counts)} steps** ({engine} against the exact test)", ""]
        if not ds:
            return "\n".join([*lines, "None: every contact of every step agrees, normals included."])
        lines += ["| pair type | " + " | ".join(KINDS) + " |", "|---|" + "---:|" * len(KINDS)]
        for key in KEYS:
            row = [sum(d.pair_type == key and d.kind == kind for d in ds) for kind in KINDS]
            if any(row):
                lines.append(f"| {key} | " + " | ".join(str(n) for n in row) + " |")
        lines += [
            "",
            f"| step | kind | geoms | {engine} dist | exact | normals apart | right |",
            "|---:|---|---|---:|---:|---:|---|",
        ]
        for d in ds[:OVERVIEW_ROWS]:
            theirs = f"{d.mujoco_dist:.3g}" if d.mujoco_contact else "no contact"
            angle = f"{d.angle:.3g} deg" if d.angle == d.angle else ""
            lines.append(
                f"| {d.step} | {d.kind} | {d.names[0]} / {d.names[1]} | {theirs} | {d.signed_distance:.3g} | {angle} "
                f"| {d.right} |"
            )
        if len(ds) > OVERVIEW_ROWS:
            lines.append(f"\n... and {len(ds) - OVERVIEW_ROWS} more: the log lists them all, `--json` too.")
        return "\n".join(lines)

    # --- internals -------------------------------------------------------------------------------

    def _flush(self, final=False):
        chunk = self.buffer.flush()
        if chunk is not None:
            self.recorder.write(chunk.frames)
            self._differences(chunk)
        self._write_disagreements(final)

    def _differences(self, chunk):
        """The largest distance and normal differences per frame over the engine's contacts on pairs
        ellipsim judges, against ellipsim's signed distance on the same poses; the run's peaks kept."""
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
        indexes = record._indexes(f.times[frames], f.frame[frames])
        rec = self.recorder.rec
        for name, path, values in (("distance", DISTANCE_PATH, ddist), ("angle", ANGLE_PATH, angle)):
            worst = np.full(len(frames), -np.inf)
            np.fmax.at(worst, at, values)
            rec.send_columns(path, indexes=indexes, columns=rr.Scalars.columns(scalars=np.maximum(worst, 0.0)))
            top = np.argsort(-np.nan_to_num(values, nan=-np.inf), kind="stable")[:PEAKS]
            for k in top:  # this chunk's largest, kept if among the run's
                if np.isfinite(values[k]):
                    step = int(f.frame[local[k]])
                    self._peaks[name].append((float(values[k]), step, float(f.times[local[k]]), *geoms[k]))
            self._peaks[name] = sorted(self._peaks[name], key=lambda p: -p[0])[:PEAKS]

    def _write_peaks(self):
        """A log line at each of the PEAKS largest values of each difference plot, naming the pair."""
        names, rows = self.names, []
        for name, what, unit in (("distance", f"|{self.engine} dist - exact|", "m"), ("angle", "normal angle", "deg")):
            for rank, (value, step, time, g1, g2) in enumerate(self._peaks[name], start=1):
                b1, b2 = (names.bodies[names.geom_body[g]] for g in (g1, g2))
                bodies = f" (bodies {b1} / {b2})" if (b1, b2) != (names.geoms[g1], names.geoms[g2]) else ""
                text = (
                    f"step {step}: peak {rank} of the run's {what}: {value:.3g} {unit} on "
                    f"{names.geoms[g1]} / {names.geoms[g2]}{bodies}"
                )
                rows.append((step, time, text))
        if rows:
            rows.sort()
            step, time, text = zip(*rows)
            self.recorder.rec.send_columns(
                PEAKS_PATH,
                indexes=record._indexes(np.array(time), np.array(step)),
                columns=rr.TextLog.columns(text=list(text), level=["INFO"] * len(text)),
            )

    def _top(self, data, at):
        """The height a pole from point `at` rises to: above the geoms stacked on it (bounding spheres within
        one scene scale of the vertical through it, each starting no more than a scene scale above the top
        so far: a dense heap does not hide the pole's head, a body falling well above does not lengthen it)."""
        at = np.asarray(at, dtype=np.float64)
        if not np.isfinite(at).all() or len(self._solid) == 0:
            return float(at[2]) if np.isfinite(at[2]) else 0.0
        xy = np.linalg.norm(data.geom_xpos[self._solid, :2] - at[:2], axis=1)
        near = np.flatnonzero(xy < self._rbound + self.scale)
        z, r = data.geom_xpos[self._solid[near], 2], self._rbound[near]
        top = float(at[2])
        for k in np.argsort(z - r, kind="stable"):
            if z[k] - r[k] > top + self.scale:
                break
            top = max(top, float(z[k] + r[k]))
        return top

    def _write_disagreements(self, final=False):
        """The pending steps' disagreements as columns: the markers at each step, taken off at the next
        step (unless it has its own: cleared once that step's time is known, or at the end), the log lines."""
        rows = []  # (step, time, [(disagreement, kind, top of the bodies)])
        marked = {step for step, *_ in self._pending}
        for step, time, tops, ds, kinds in self._pending:
            rows.append((step, time, list(zip(ds, kinds, tops))))
            if step + 1 not in marked:
                self._to_clear.append(step + 1)
        clear, later = [], []
        for step in self._to_clear:
            (clear if step < len(self.times) else later).append(step)
        rows += [(step, self.times[step], []) for step in clear if step not in marked]
        self._to_clear = [] if final else later
        self._pending = []
        if not rows:
            return
        rows.sort(key=lambda r: r[0])
        rec, scale = self.recorder.rec, self.scale
        length = record.NORMAL_LENGTH * scale
        indexes = record._indexes(np.array([r[1] for r in rows]), np.array([r[0] for r in rows]))
        lengths = [len(r[2]) for r in rows]
        markers = [m for r in rows for m in r[2]]
        at = np.array([d.ellipsim_pos for d, _, _ in markers], dtype=np.float64).reshape(-1, 3)
        heads = at.copy()
        heads[:, 2] = np.array([top for *_, top in markers]).reshape(-1) + POLE_ABOVE * scale
        colors = np.array([self.kinds[kind][0] for _, kind, _ in markers], dtype=np.uint8).reshape(-1, 4)
        labels = [f"{kind}: {d.names[0]} / {d.names[1]}" for d, kind, _ in markers]
        rec.send_columns(
            DISAGREEMENTS_PATH,
            indexes=indexes,
            columns=rr.Points3D.columns(positions=heads, colors=colors, labels=labels).partition(lengths),
        )
        poles = [np.array([a, h]) for a, h in zip(at, heads)]
        rec.send_columns(
            POLES_PATH, indexes=indexes, columns=rr.LineStrips3D.columns(strips=poles, colors=colors).partition(lengths)
        )
        ours = np.nan_to_num(np.array([d.ellipsim_normal for d, _, _ in markers], dtype=np.float64).reshape(-1, 3))
        rec.send_columns(ELLIPSIM_PATH, indexes=indexes, columns=rr.Points3D.columns(positions=at).partition(lengths))
        rec.send_columns(
            ELLIPSIM_PATH,
            indexes=indexes,
            columns=rr.Arrows3D.columns(origins=at, vectors=length * ours).partition(lengths),
        )
        theirs = [[d for d, _, _ in r[2] if d.mujoco_pos is not None] for r in rows]
        where = np.array([d.mujoco_pos for ds in theirs for d in ds], dtype=np.float64).reshape(-1, 3)
        normal = np.array([d.mujoco_normal for ds in theirs for d in ds], dtype=np.float64).reshape(-1, 3)
        split = [len(ds) for ds in theirs]
        rec.send_columns(MUJOCO_PATH, indexes=indexes, columns=rr.Points3D.columns(positions=where).partition(split))
        rec.send_columns(
            MUJOCO_PATH,
            indexes=indexes,
            columns=rr.Arrows3D.columns(origins=where, vectors=length * normal).partition(split),
        )
        logged = [(r[0], r[1], d, kind) for r in rows for d, kind, _ in r[2]]
        if logged:
            rec.send_columns(
                LOG_PATH,
                indexes=record._indexes(np.array([x[1] for x in logged]), np.array([x[0] for x in logged])),
                columns=rr.TextLog.columns(
                    text=[line(d, self.engine) for _, _, d, _ in logged],
                    level=["INFO" if kind == "near_tangent" else "WARN" for *_, kind in logged],
                ),
            )
        self.written += len(markers)


def line(d, engine="MuJoCo"):
    """The log line of a disagreement, short enough to show whole: step, kind, pair type, geoms (bodies when
    they differ), both distances, the normals' angle, who is right and why in a few words (the whole reason
    is in the JSON)."""
    bodies = f" (bodies {d.bodies[0]} / {d.bodies[1]})" if d.bodies and tuple(d.bodies) != tuple(d.names) else ""
    theirs = f"{engine} {d.mujoco_dist:.4g} m" if d.mujoco_contact else f"{engine} no contact"
    angle = f", normals {d.angle:.3g} deg apart" if d.angle == d.angle else ""
    if d.right == "undetermined":
        why = "not proven: " + ("within the proof tolerance" if "tolerance" in d.reason else "an unproven maximum")
    elif d.kind == "normal_off":
        why = f"sigma at {engine}'s normal {d.signed_distance - d.sigma_mujoco:.3g} m below the exact distance"
    elif d.mujoco_contact:
        why = f"the exact distance is >= margin {d.margin:g}" + (
            f", {engine}'s contact within its tolerance" if d.kind == "near_tangent" else ""
        )
    else:
        why = f"the exact distance is < margin {d.margin:g}"
    return (
        f"step {d.step}: {d.kind}: {d.pair_type} {d.names[0]} / {d.names[1]}{bodies}: {theirs}, exact "
        f"{d.signed_distance:.4g} m{angle}; right: {d.right}, {why}"
    )
