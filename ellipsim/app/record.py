"""Recording: a model and its frames as a rerun recording (.rrd), and opening one in the viewer.

Kept apart from the simulation (capture.py fills a SceneGeometry and Frames; this module only reads
them).  A Recorder writes while a run goes: the model's shapes once, static (`begin`), then each
chunk of frames as columns with `RecordingStream.send_columns` (`write`), on two timelines, "time"
(a duration, seconds) and "frame" (a sequence).  The file is written under a temporary name in the
same folder and renamed to its own name only when complete (`close`): an interrupted run leaves
no truncated recording behind (or, with keep_partial, a complete recording of the frames so far).  Every recording gets a fresh recording id, so two runs opened
together in one viewer stay two recordings.

What is written (B bodies, G geoms):

    world                          ViewCoordinates RIGHT_HAND_Z_UP (MuJoCo's world frame), static
    world/model                    the world body; its child bodies below it, by the kinematic tree:
    world/model/<body>/<child>/..  Transform3D relative to the parent body: static for bodies that
                                   never move relative to it, a column per frame for bodies with
                                   joints (or mocap)
      <body>/geoms/ellipsoids      Ellipsoids3D of the body's ellipsoid and sphere geoms, in the body
                                   frame, static, solid, names as labels shown only on hover (or
                                   always: labels=True); colours per frame where they change: the
                                   free colour (figure_colors: a hue per kinematic tree; or the MJCF
                                   colour), amber touching, red overlapping (ellipsim's exact
                                   verdict, the worst over its pairs)
      <body>/geoms/capsules        Capsules3D, static, solid, free colours
      <body>/geoms/cylinders       Cylinders3D, static, solid, free colours
      <body>/geoms/boxes           Boxes3D, static, solid, free colours
      <body>/geoms/<geom>          a mesh, height field or plane geom: static Transform3D + Mesh3D
                                   (an infinite plane: logged again at close, a square just larger
                                   than the bodies' bounding box over the run)
    world/contacts                 Points3D of every MuJoCo contact (all pair types) per frame, sized
                                   to the scene (scene_scale): green between two ellipsoids, black
                                   otherwise (floor, boxes, ...); labelled with the geoms and
                                   MuJoCo's distance, shown on hover
    world/contact_normals          Arrows3D, the contact normals, same colours
    world/between_frames           Points3D, magenta, labelled with the geoms: where two ellipsoids,
                                   separated at two consecutive frames, first touch in between (on
                                   the interpolated motion, mujoco.between), from that time until the
                                   next frame (then an empty row); every such contact of the step
                                   begun so far is shown
    events/between_frames          TextLog, a line per such contact at its time (level WARN)
    counts/pairs/builtin           Scalars per frame: MuJoCo's contacts between ellipsoid geoms
    counts/pairs/ellipsim          Scalars per frame: pairs ellipsim finds in contact (signed distance < margin)
    counts/contacts/all            Scalars per frame: all of MuJoCo's contacts
    legend                         TextDocument (markdown): what each colour means

The blueprint, sent at close, puts a 3D view of "world", its camera on the bodies' bounding box over
the run (camera), beside two time-series views: ellipsoid pairs in contact (MuJoCo's as a wide light
line, ellipsim's as a thin dark line over it, so both stay visible where they agree) and all
contacts; then the legend, and a text log of the contacts between frames when there are any.
compare_record.py adds the disagreements of `compare --record`.
"""

import colorsys
import contextlib
import os
import pathlib
import shutil
import subprocess
import sys
import uuid

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ..core.rotations import quaternions_to_rotations
from .errors import STOPS
from .trajectory import GEOM_KINDS, Frames, SceneGeometry

TOUCHING_COLOR = (255, 176, 0, 210)  # amber
OVERLAPPING_COLOR = (220, 30, 30, 210)  # red
CONTACT_COLOR = (20, 200, 60, 255)  # green: contacts between two ellipsoid geoms
OTHER_CONTACT_COLOR = (30, 30, 30, 255)  # black: every other contact (floor, boxes, ...)
BETWEEN_COLOR = (230, 0, 200, 255)  # magenta: a contact between two frames
#: Each kinematic tree with a moving body (a figure, a falling ellipsoid) gets a hue in this range of
#: degrees (cyan to indigo: clear of the state colours amber and red, the contacts' green and black
#: and the markers' magenta), trees spaced by the golden ratio so that trees next in number differ
#: most; its lightness follows the luminance of the MJCF colour, so parts MJCF tells apart stay apart.
#: The world's own geoms (floor, walls) keep their MJCF colours.
FIGURE_HUES = (180.0, 255.0)
FIGURE_SATURATION = 0.5
FIGURE_LIGHTNESS = (0.42, 0.78)
FIGURE_SHADES = (0.0, -0.13, 0.09)  # added to the lightness of trees k = 0, 1, 2 (mod 3): neighbours differ more
#: Figures are drawn a little translucent (alpha out of 255; the state colours too), so that
#: MuJoCo's contact points and normals show where they sit inside the geoms.
FIGURE_ALPHA = 170
#: Marker sizes, as multiples of the scene's typical geom size (scene_scale: the median of the moving
#: geoms' largest half extents), so that contacts show at any scale: a contact point's sphere stands
#: out of the two surfaces it sits between, a normal reaches out of the geom it points into.
CONTACT_RADIUS = 0.2
NORMAL_LENGTH = 1.6
NORMAL_RADIUS = 0.04
BETWEEN_RADIUS = 0.35
# Series styles: MuJoCo's line wide and light, ellipsim's thin and dark on top of it, so that where
# the counts agree the thin line runs inside the wide one and both are seen.
BUILTIN_SERIES = ("MuJoCo (dist < margin)", (110, 160, 240, 255), 6.0)
ELLIPSIM_SERIES = ("ellipsim (exact)", (170, 20, 20, 255), 1.5)
ALL_SERIES = ("MuJoCo contacts (all geoms)", (190, 190, 190, 255), 1.5)  # light: the viewer is dark
#: The 3D view's camera: looking at the centre of the box where the collisions happen (framing()) from
#: this direction (front right, above), as close as keeps the whole box in view (camera()).
CAMERA_DIRECTION = (0.55, -1.0, 0.55)
#: The box framed is that of MuJoCo's contacts over the run, between these percentiles of their
#: positions on each axis (a body flung off does not pull the camera away from the heap), grown by this
#: many scene scales (the geoms around the contacts), at least FRAMING_MIN scene scales across; without a
#: contact, the bodies at the last frame (the settled state).  CONTACT_SAMPLES positions are kept at most
#: (a uniform sample of those recorded).
FRAMING_PERCENTILES = (2.0, 98.0)
FRAMING_PAD = 1.0
FRAMING_MIN = 6.0
CONTACT_SAMPLES = 50_000
#: The 3D view's share of the window's width (per cent; the side panels collapsed): the plots share the rest.
SCENE_SHARE = 64
#: Pairs whose depth over the run is drawn as a series (the deepest), and the rows of depth kept at most
#: (past it, only the deepest pairs' rows are kept).
DEPTH_PAIRS = 6
DEPTH_ROWS = 2_000_000
FLOOR_MARGIN = 3.0  # an infinite plane reaches this many scene scales (or tenths of the bodies' span) beyond them
CAMERA_HALF_FOV = 0.5  # radians, a little under half of the viewer's vertical field of view

MODEL_PATH = "world/model"
CONTACTS_PATH = "world/contacts"
NORMALS_PATH = "world/contact_normals"
BUILTIN_PATH = "counts/pairs/builtin"
ELLIPSIM_PATH = "counts/pairs/ellipsim"
ALL_PATH = "counts/contacts/all"
BETWEEN_PATH = "world/between_frames"
BETWEEN_LOG_PATH = "events/between_frames"
LEGEND_PATH = "legend"
DEPTH_PATH = "depth"
TENDONS_PATH = "world/tendons"
COPY_LABELS_PATH = "world/copy_labels"

COLOR_MODES = ("figure", "mjcf")
#: The colour scheme a recording of each kind of scene gets unless told: ellipsim's own figures and piles
#: a hue per figure, a user's MJCF model its own colours.
DEFAULT_COLORS = {"figures": "figure", "pile": "figure", "mjcf": "mjcf"}

RRD_MAGIC = b"RRF"  # first bytes of an .rrd file ("RRF2" in rerun 0.41)

_KIND = {name: k for k, name in enumerate(GEOM_KINDS)}
_PRIMITIVES = {  # geom kinds drawn as a batch per body: entity name
    _KIND["ellipsoid"]: "ellipsoids",
    _KIND["sphere"]: "ellipsoids",
    _KIND["capsule"]: "capsules",
    _KIND["cylinder"]: "cylinders",
    _KIND["box"]: "boxes",
}


def blueprint(camera=None, panels=None, tabs=()):
    """The default layout: a 3D view of "world" (SCENE_SHARE of the width) beside a column of `panels`,
    (view, share) pairs (default: run_panels()); `tabs`, more views or containers, each a tab beside
    this scene.  The viewer's side panels start collapsed (the 3D view gets the room).  camera : the 3D
    view's rrb.EyeControls3D (record.camera), or None for the viewer's own framing."""
    panels = run_panels() if panels is None else panels
    scene = rrb.Horizontal(
        rrb.Spatial3DView(origin="world", name="model", eye_controls=camera),
        rrb.Vertical(*(view for view, _ in panels), row_shares=[share for _, share in panels]),
        column_shares=[SCENE_SHARE, 100 - SCENE_SHARE],
        name="scene",
    )
    root = rrb.Tabs(scene, *tabs, active_tab=0) if tabs else scene
    return rrb.Blueprint(root, collapse_panels=True)


def plot(origin, name, span=None):
    """A time-series view, its legend top left; span : (start, end) seconds of the run, the time axis
    shown (every plot of a recording then lines up on the same steps, also one whose data cover part
    of the run), or None for the viewer's own."""
    import rerun.blueprint.archetypes as rba
    import rerun.blueprint.components as rbc

    axis = None
    if span is not None:
        start, end = (rr.TimeRangeBoundary.absolute(seconds=float(t)) for t in span)
        axis = rba.TimeAxis(view_range=rr.TimeRange(start=start, end=end))
    return rrb.TimeSeriesView(origin=origin, name=name, axis_x=axis, plot_legend=rba.PlotLegend(rbc.Corner2D.LeftTop))


def run_panels(depth=True, span=None):
    """The column beside a run's 3D view: the contact counts, the depth of the deepest pairs (when any
    penetrated: depth), all contacts, the legend; span : the run's (start, end) seconds (plot)."""
    panels = [(plot("counts/pairs", "pairs in contact (every type ellipsim judges)", span), 3)]
    if depth:
        panels.append((plot(DEPTH_PATH, "depth of the deepest pairs, m", span), 3))
    panels += [
        (plot("counts/contacts", "all MuJoCo contacts", span), 2),
        (rrb.TextDocumentView(origin=LEGEND_PATH, name="what the colours mean"), 3),
    ]
    return panels


def log_view(origin, name):
    """A text log of whole lines: the body only (the frame on its own column; entity path and level,
    which the lines repeat, hidden)."""
    import rerun.blueprint.archetypes as rba
    import rerun.blueprint.encodings as rbe

    columns = rba.TextLogColumns(
        timeline_columns=[rbe.TimelineColumn("frame"), rbe.TimelineColumn("time", visible=False)],
        text_log_columns=[
            rbe.TextLogColumn("EntityPath", visible=False),
            rbe.TextLogColumn("LogLevel", visible=False),
            rbe.TextLogColumn("Body"),
        ],
    )
    return rrb.TextLogView(origin=origin, name=name, columns=columns)


def framing(points, lo_bodies, hi_bodies, scale):
    """(lo, hi) of the box the camera frames: MuJoCo's contact positions (n, 3) between FRAMING_PERCENTILES,
    grown by FRAMING_PAD scene scales, at least FRAMING_MIN across; the bodies' box (lo_bodies, hi_bodies)
    without contacts."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) == 0:
        return np.asarray(lo_bodies, dtype=np.float64), np.asarray(hi_bodies, dtype=np.float64)
    lo, hi = np.percentile(points, FRAMING_PERCENTILES, axis=0)
    lo, hi = lo - FRAMING_PAD * scale, hi + FRAMING_PAD * scale
    grow = np.maximum(FRAMING_MIN * scale - (hi - lo), 0.0) / 2
    return lo - grow, hi + grow


def camera(lo, hi):
    """The 3D view's camera on the box [lo, hi] (metres, world frame): looking at its centre from
    CAMERA_DIRECTION, as close as keeps every corner of the box within CAMERA_HALF_FOV of the view's
    axis, across and up; z up."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    center = (lo + hi) / 2
    back = np.asarray(CAMERA_DIRECTION, dtype=np.float64)
    back /= np.linalg.norm(back)  # from the target to the eye
    right = np.cross(-back, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    corners = _corners(lo, hi) - center
    across = np.maximum(np.abs(corners @ right), np.abs(corners @ up))
    distance = max(float(np.max(corners @ back + across / np.tan(CAMERA_HALF_FOV))), 1e-3)
    return rrb.EyeControls3D(position=center + distance * back, look_target=center, eye_up=(0.0, 0.0, 1.0))


def legend(between=None, extra=(), engine="MuJoCo"):
    """The legend (markdown): what each colour of a recording means.  between : the number of
    contacts between frames found, or None when they were not looked for; extra : more lines;
    engine : whose contacts are drawn."""
    lines = [
        "**Geoms** (hover one for its name)",
        "- in a hue per figure (kinematic tree; ellipsim's scenes) or the model's own colours (an MJCF model; "
        "`--colors` picks)",
        "- **red**: an ellipsoid or sphere in contact with another geom (signed distance below the pair's margin: "
        "ellipsim's exact verdict, every pair type it judges)",
        "- **amber**: touching, tangent exactly (rare in a moving scene)",
        "",
        f"**{engine}'s contacts**: a point and its normal (from the first geom into the second); hover one for the "
        f"geoms and the depth (or the gap, within the margin)",
        "- **green**: on a pair ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, "
        "convex mesh or height field)",
        "- **black**: every other contact (floor, meshes, ...)",
        "",
        "The camera frames where the contacts happen over the run; the depth plot follows the deepest pairs.",
    ]
    if between is None:
        lines += ["", "Contacts between frames: not looked for in this recording"]
    elif between == 0:
        lines += ["", "Contacts between frames: none (looked for on every step)"]
    else:
        lines += ["", f"**magenta** point: one of the {between} contacts between frames (listed in the log)"]
    return "\n".join([*lines, *extra])


def figure_colors(g):
    """(G, 4) uint8: each geom's colour as drawn when free (FIGURE_HUES), from a SceneGeometry."""
    colors = rgba8(g.geom_rgba)
    parent = np.asarray(g.body_parent)
    root = np.arange(len(parent))
    for b in range(1, len(parent)):  # MuJoCo numbers a parent before its children
        if parent[b] != 0:
            root[b] = root[parent[b]]
    root[0] = 0
    trees = np.unique(root[np.asarray(g.moving, dtype=np.int64)])
    trees = trees[trees != 0]
    rgb = np.asarray(g.geom_rgba, dtype=np.float64)[:, :3]
    luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
    lo, hi = FIGURE_HUES
    dark, light = FIGURE_LIGHTNESS
    tree_of_geom = root[np.asarray(g.geom_body, dtype=np.int64)]
    for k, tree in enumerate(trees):
        hue = (lo + (k * 0.6180339887498949 % 1.0) * (hi - lo)) / 360.0
        for i in np.flatnonzero(tree_of_geom == tree):
            lightness = dark + (light - dark) * float(np.clip(luminance[i], 0.0, 1.0)) + FIGURE_SHADES[k % 3]
            lightness = float(np.clip(lightness, 0.3, 0.85))
            r, gr, bl = colorsys.hls_to_rgb(hue, lightness, FIGURE_SATURATION)
            colors[i] = np.round(np.array([r * 255, gr * 255, bl * 255, FIGURE_ALPHA])).astype(np.uint8)
    return colors


def scene_scale(g):
    """The typical size of a SceneGeometry's geoms, metres: the median largest half extent of the
    geoms on moving bodies (of every geom but planes and height fields when none moves), 0.1 when
    there is none; marker sizes are multiples of it."""
    moving = set(int(b) for b in g.moving)
    kind = np.asarray(g.geom_kind)
    size = np.asarray(g.geom_size, dtype=np.float64)
    extents = []
    for i in range(len(kind)):
        name = GEOM_KINDS[int(kind[i])]
        if name in ("plane", "hfield"):
            continue
        if name == "sphere":
            e = size[i, 0]
        elif name in ("capsule", "cylinder"):
            e = max(size[i, 0], size[i, 1] + (size[i, 0] if name == "capsule" else 0.0))
        elif name == "mesh":
            vertices = g.meshes.get(i, (np.zeros((1, 3)),))[0]
            e = float(np.abs(vertices).max()) if len(vertices) else 0.0
        else:
            e = size[i].max()
        extents.append((int(g.geom_body[i]) in moving, float(e)))
    for want in (True, None):
        chosen = [e for m, e in extents if (want is None or m == want) and e > 0 and np.isfinite(e)]
        if chosen:
            return float(np.median(chosen))
    return 0.1


def rgba8(rgba):
    """RGBA floats in [0, 1] (..., 4) as uint8 (..., 4)."""
    return np.clip(np.round(np.asarray(rgba, dtype=np.float64) * 255), 0, 255).astype(np.uint8)


def xyzw(wxyz):
    """MuJoCo's quaternions (..., 4) w x y z in rerun's x y z w order."""
    wxyz = np.asarray(wxyz, dtype=np.float64)
    return np.concatenate([wxyz[..., 1:], wxyz[..., :1]], axis=-1)


class Recorder:
    """Writes one recording while a run goes: `begin(geometry)`, `write(frames)` per chunk, `close()`.

    path : str or os.PathLike ending in ".rrd", in an existing directory; replaced only by `close`.
    labels : draw every geom's name in the 3D view (default: names only on hover and selection).
    colors : "figure" (default), a hue per kinematic tree (figure_colors); "mjcf", the model's colours.
    Used as a context manager, an exception (or Ctrl-C) inside the block removes the partial file
    and leaves `path` as it was; with keep_partial=True, Ctrl-C or SIGTERM (errors.STOPS) instead
    keeps the frames written so far, if any: the file is completed and moved to `path` as `close`
    does, and `kept` is their number (0: nothing kept).  ValueError names a bad path or bad data;
    OSError a file that cannot be created.
    """

    def __init__(self, path, *, app_id="ellipsim", keep_partial=False, labels=False, colors="figure"):
        self.path = _check_save_path(path)
        if colors not in COLOR_MODES:
            raise ValueError(f"colors must be one of {COLOR_MODES}, got {colors!r}")
        if not isinstance(labels, bool):
            raise ValueError(f"labels must be True or False, got {labels!r}")
        self.labels, self.colors = labels, colors
        folder, base = os.path.split(os.path.abspath(self.path))
        self.partial = os.path.join(folder, f".{base}.{uuid.uuid4().hex[:12]}.part")
        self.app_id = app_id
        self.recording_id = str(uuid.uuid4())
        self.rec = None
        self.frames_written = 0
        self.keep_partial = keep_partial
        self.kept = 0
        self.events_written = 0
        self.between_checked = False  # set by whoever looks for contacts between frames (the legend says)
        self.panels = lambda recorder: run_panels(recorder.depth_pairs > 0, recorder.span())  # beside the 3D view
        self.tabs = lambda recorder: (  # more tabs beside the scene
            [log_view("events", "contacts between frames")] if recorder.events_written else []
        )
        self.legend_extra = []  # more legend lines (markdown)
        self.engine = "MuJoCo"  # whose contacts are drawn (the legend says)
        #: (text, offset (3,)) of copies of one model side by side (ellipsim fix: original and fixed): a label
        #: above each copy, the first at the model's own place
        self.copy_labels = []
        self.depth_pairs = 0  # depth series drawn (close)
        self._lo = self._hi = None  # the bodies' bounding box over the frames written
        self._last = None  # and at the last frame
        self._contact_sample = np.zeros((0, 3))  # a uniform sample of MuJoCo's contact positions
        self._contacts_seen = 0
        self._sampler = np.random.default_rng(0)  # fixed: the same run gives the same framing
        self._times = []  # per chunk: the frames' times
        self._depth = []  # per chunk: (frame (k,), pair key (k,), depth (k,)) of judged pairs penetrating
        self._depth_rows = 0

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.close()
        elif self.keep_partial and issubclass(kind, STOPS) and self.rec is not None and self.frames_written:
            try:
                self.close()  # flushed, then renamed in one os.replace: `path` is whole or as it was
            except Exception:  # the stop is what to report; close removed the partial file
                return False
            self.kept = self.frames_written
        else:
            self.abort()
        return False

    def begin(self, geometry):
        """Open the partial file and log the model's static shapes."""
        if not isinstance(geometry, SceneGeometry):
            raise ValueError(
                f"geometry must be an ellipsim.app.trajectory.SceneGeometry, got {type(geometry).__name__}"
            )
        self.geometry = geometry
        self._colors = figure_colors(geometry) if self.colors == "figure" else rgba8(geometry.geom_rgba)
        self.scale = scene_scale(geometry)
        rec = rr.RecordingStream(self.app_id, recording_id=self.recording_id)
        self.rec = rec  # before the file exists: an interruption from here on is cleaned up by abort
        try:
            rec.save(self.partial)  # the layout is sent at close, framed on what was recorded
        except RuntimeError as exc:  # rerun reports a file it cannot create as a RuntimeError
            self.abort()
            raise OSError(f"cannot create {self.partial!r}: {exc}") from None
        if geometry.name:
            rec.send_recording_name(geometry.name)
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._paths = _body_paths(geometry)
        self._log_bodies()
        self._log_geoms()
        rec.log(
            CONTACTS_PATH,
            rr.Points3D.from_fields(radii=CONTACT_RADIUS * self.scale, show_labels=self.labels),
            static=True,
        )
        rec.log(NORMALS_PATH, rr.Arrows3D.from_fields(radii=NORMAL_RADIUS * self.scale), static=True)
        rec.log(BETWEEN_PATH, rr.Points3D.from_fields(show_labels=self.labels), static=True)
        if geometry.tendon_names:
            rec.log(TENDONS_PATH, rr.LineStrips3D.from_fields(show_labels=self.labels), static=True)
        self._log_legend()
        for entity, (name, color, width) in (
            (BUILTIN_PATH, BUILTIN_SERIES),
            (ELLIPSIM_PATH, ELLIPSIM_SERIES),
            (ALL_PATH, ALL_SERIES),
        ):
            rec.log(entity, rr.SeriesLines(names=name, colors=color, widths=width), static=True)
        self._last_state = None

    def write(self, frames):
        """Send one chunk of frames (consecutive, after the previous chunk) as columns."""
        if self.rec is None:
            raise ValueError("Recorder.write before begin")
        if not isinstance(frames, Frames):
            raise ValueError(f"frames must be an ellipsim.app.trajectory.Frames, got {type(frames).__name__}")
        frames.check(self.geometry)
        if len(frames) == 0:
            return
        if frames.frame[0] != self.frames_written:
            raise ValueError(f"frames must continue at frame {self.frames_written}, got frame {frames.frame[0]}")
        rec, g = self.rec, self.geometry
        indexes = _indexes(frames.times, frames.frame)
        for m, body in enumerate(g.moving):
            rec.send_columns(
                self._paths[body],
                indexes=indexes,
                columns=rr.Transform3D.columns(
                    translation=frames.body_pos[:, m], quaternion=xyzw(frames.body_quat[:, m])
                ),
            )
        self._write_states(frames)
        self._write_contacts(frames, indexes)
        self._write_tendons(frames, indexes)
        self._keep_contacts(frames)
        lo, hi = frames.bounds[:, 0].min(axis=0), frames.bounds[:, 1].max(axis=0)
        self._lo = lo if self._lo is None else np.minimum(self._lo, lo)
        self._hi = hi if self._hi is None else np.maximum(self._hi, hi)
        self._last = (frames.bounds[-1, 0].copy(), frames.bounds[-1, 1].copy())
        self._times.append(np.asarray(frames.times, dtype=np.float64).copy())
        for entity, counts in (
            (BUILTIN_PATH, frames.builtin_counts),
            (ELLIPSIM_PATH, frames.ellipsim_counts),
            (ALL_PATH, frames.contact_counts),
        ):
            rec.send_columns(
                entity, indexes=indexes, columns=rr.Scalars.columns(scalars=np.asarray(counts, dtype=np.float64))
            )
        self.frames_written += len(frames)

    def write_events(self, frame, time, until, point, label, text):
        """Markers of E contacts between frames, each at its time: a point at `point` from `time` until
        `until` (the next frame, then cleared) and a text line.

        frame : (E,) int, the frame before the contact (its row on the "frame" timeline); time, until :
        (E,) seconds, time <= until; point : (E, 3) metres; label : E str (drawn by the point); text : E
        str (the log line).  Events of one step (equal frame) are shown together from each one's time.
        """
        if self.rec is None:
            raise ValueError("Recorder.write_events before begin")
        frame = np.asarray(frame, dtype=np.int64).reshape(-1)
        time, until = (np.asarray(x, dtype=np.float64).reshape(-1) for x in (time, until))
        point = np.asarray(point, dtype=np.float64).reshape(-1, 3)
        E = len(frame)
        if not (len(time) == len(until) == len(point) == len(label) == len(text) == E):
            raise ValueError(
                f"frame, time, until, point, label and text must have one row per event, got "
                f"{E}, {len(time)}, {len(until)}, {len(point)}, {len(label)} and {len(text)}"
            )
        if E == 0:
            return
        bad = np.flatnonzero(~(time <= until))
        if len(bad):
            raise ValueError(
                f"time[{int(bad[0])}] must be <= until[{int(bad[0])}], got {float(time[bad[0]])!r} and {float(until[bad[0]])!r}"
            )
        order = np.lexsort((time, frame))
        frame, time, until, point = frame[order], time[order], until[order], point[order]
        label = [label[k] for k in order]
        starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]])  # first event of each step
        group_start = starts[np.searchsorted(starts, np.arange(E), side="right") - 1]
        shown = np.concatenate([np.arange(group_start[e], e + 1) for e in range(E)])  # the step's events so far
        lengths = np.r_[np.arange(E) - group_start + 1, np.zeros(len(starts), dtype=np.int64)]
        row_time = np.r_[time, until[starts]]
        row_frame = np.r_[frame, frame[starts] + 1]
        columns = rr.Points3D.columns(
            positions=point[shown],
            labels=[label[k] for k in shown],
            colors=np.broadcast_to(np.array(BETWEEN_COLOR, dtype=np.uint8), (len(shown), 4)),
            radii=np.full(len(shown), BETWEEN_RADIUS * self.scale, dtype=np.float32),
        )
        self.rec.send_columns(BETWEEN_PATH, indexes=_indexes(row_time, row_frame), columns=columns.partition(lengths))
        self.rec.send_columns(
            BETWEEN_LOG_PATH,
            indexes=_indexes(time, frame),
            columns=rr.TextLog.columns(text=[text[k] for k in order], level=["WARN"] * E),
        )
        self.events_written += E

    def close(self):
        """Finish the file and move it to `path`; returns `path`."""
        if self.rec is None:
            raise ValueError("Recorder.close before begin")
        try:
            self._write_depth()
            self._log_copy_labels()
            self._log_legend()
            self._size_floors()
            self.rec.send_blueprint(self.final_blueprint(), make_active=True, make_default=True)
        except BaseException:
            self.abort()
            raise
        rec, self.rec = self.rec, None
        try:
            rec.flush()
            rec.disconnect()
            os.replace(self.partial, self.path)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                os.remove(self.partial)
            raise
        return self.path

    def final_blueprint(self):
        """The layout `close` sends: the camera on the box where the collisions happened (framing: MuJoCo's
        contacts over the frames written, or the bodies at the last one; the viewer's own framing when no
        frame was written), the column of self.panels(self), the tabs of self.tabs(self)."""
        view = camera(*self.framed()) if self._lo is not None else None
        return blueprint(view, self.panels(self), self.tabs(self))

    def span(self):
        """(first, last) time of the frames written, seconds (None before any)."""
        if not self._times:
            return None
        return float(self._times[0][0]), float(self._times[-1][-1])

    def framed(self):
        """(lo, hi): the box the camera frames (framing)."""
        return framing(self._contact_sample, *self._last, self.scale)

    def _keep_contacts(self, frames):
        """Keep a uniform sample (CONTACT_SAMPLES at most) of MuJoCo's contact positions, and the depth of
        the pairs ellipsim judges that penetrate (each pair once a frame, its deepest contact)."""
        pos = np.asarray(frames.contact_pos, dtype=np.float64).reshape(-1, 3)
        room = CONTACT_SAMPLES - len(self._contact_sample)
        if room > 0:  # the sample not yet full: kept as they come
            self._contact_sample = np.concatenate([self._contact_sample, pos[:room]])
            self._contacts_seen += min(room, len(pos))
            pos = pos[room:]
        if len(pos):  # reservoir sampling (Vitter's algorithm R), vectorised: the i-th position seen is kept
            # with probability CONTACT_SAMPLES / i, in a slot drawn uniformly (a later one overwrites)
            seen = self._contacts_seen + np.arange(1, len(pos) + 1)
            keep = self._sampler.random(len(pos)) < CONTACT_SAMPLES / seen
            slots = self._sampler.integers(0, CONTACT_SAMPLES, size=int(keep.sum()))
            self._contact_sample[slots] = pos[keep]
            self._contacts_seen += len(pos)
        deep = np.flatnonzero(np.asarray(frames.contact_ellipsoids, bool) & (np.asarray(frames.contact_dist) < 0))
        if len(deep):
            geoms = np.sort(np.asarray(frames.contact_geoms)[deep], axis=1)
            key = geoms[:, 0] * len(self.geometry.geom_names) + geoms[:, 1]
            self._depth.append((np.asarray(frames.contact_frame)[deep], key, -np.asarray(frames.contact_dist)[deep]))
            self._depth_rows += len(deep)
            if self._depth_rows > DEPTH_ROWS:  # keep the rows of the deepest pairs only
                frame, key, depth = (np.concatenate(x) for x in zip(*self._depth))
                top = _deepest_keys(key, depth, DEPTH_PAIRS)
                mine = np.isin(key, top)
                self._depth = [(frame[mine], key[mine], depth[mine])]
                self._depth_rows = int(mine.sum())

    def _write_depth(self):
        """A series per pair of the DEPTH_PAIRS deepest (judged pairs, MuJoCo's contact depth, the deepest
        of the pair's contacts in a frame; 0 in the frames between its first and last where it does not
        penetrate), under depth/<geom1> ~ <geom2>."""
        if not self._depth:
            return
        frame, key, depth = (np.concatenate(x) for x in zip(*self._depth))
        times = np.concatenate(self._times)
        names, G = self.geometry.geom_names, len(self.geometry.geom_names)
        top = _deepest_keys(key, depth, DEPTH_PAIRS)
        for k in top:
            mine = key == k
            first, last = int(frame[mine].min()), int(frame[mine].max())
            span = np.arange(max(first - 1, 0), min(last + 2, len(times)))
            values = np.zeros(len(span))
            np.maximum.at(values, frame[mine] - span[0], depth[mine])
            g1, g2 = divmod(int(k), G)
            entity = f"{DEPTH_PATH}/{rr.escape_entity_path_part(f'{names[g1]} ~ {names[g2]}')}"
            self.rec.log(entity, rr.SeriesLines(names=f"{names[g1]} / {names[g2]}", widths=1.5), static=True)
            self.rec.send_columns(
                entity, indexes=_indexes(times[span], span), columns=rr.Scalars.columns(scalars=values)
            )
        self.depth_pairs = len(top)

    def _write_tendons(self, frames, indexes):
        """The spatial tendons' paths per frame, each strip in its tendon's colour and width."""
        g = self.geometry
        if not g.tendon_names:
            return
        cuts = np.cumsum(frames.tendon_strip_points)[:-1]
        strips = np.split(np.asarray(frames.tendon_points, dtype=np.float64).reshape(-1, 3), cuts)
        tendon = np.asarray(frames.tendon_strip, dtype=np.int64)
        columns = rr.LineStrips3D.columns(
            strips=strips if len(tendon) else [],
            colors=rgba8(np.asarray(g.tendon_rgba)[tendon]),
            radii=np.maximum(np.asarray(g.tendon_width)[tendon], 0.01 * self.scale).astype(np.float32),
            labels=[g.tendon_names[t] for t in tendon],
        )
        self.rec.send_columns(TENDONS_PATH, indexes=indexes, columns=columns.partition(frames.tendon_frame_strips))

    def _log_copy_labels(self):
        """Labels above copies of one model side by side (copy_labels), over the box the bodies took."""
        if not self.copy_labels or self._lo is None:
            return
        offsets = np.array([np.asarray(o, dtype=np.float64) for _, o in self.copy_labels])
        span = offsets.max(axis=0) - offsets.min(axis=0)
        center = (self._lo + self._hi - span) / 2 - offsets.min(axis=0)  # the first copy's box's centre
        points = center + offsets
        points[:, 2] = self._hi[2] + 2 * self.scale
        self.rec.log(
            COPY_LABELS_PATH,
            rr.Points3D(
                points,
                labels=[text for text, _ in self.copy_labels],
                radii=0.3 * self.scale,
                colors=[(255, 255, 255, 255)] * len(points),
                show_labels=True,
            ),
            static=True,
        )

    def _size_floors(self):
        """Log the world's infinite planes again, as squares that reach FLOOR_MARGIN beyond the
        bodies' bounding box over the frames written (seen from the plane's centre)."""
        if self._lo is None:
            return
        g, corners = self.geometry, _corners(self._lo, self._hi)
        for entity, i in self._floors:
            rotation = quaternions_to_rotations(g.geom_quat[i])
            local = (corners - g.geom_pos[i]) @ rotation  # R^T (p - c), in the plane's frame
            half = np.abs(local[:, :2]).max(axis=0) + FLOOR_MARGIN * max(
                self.scale, float(np.ptp(local[:, :2], axis=0).max()) / 10
            )
            half = np.where(g.geom_size[i, :2] > 0, g.geom_size[i, :2], half)
            sx, sy = (float(h) for h in half)
            vertices = np.array([[-sx, -sy, 0.0], [sx, -sy, 0.0], [sx, sy, 0.0], [-sx, sy, 0.0]])
            self.rec.log(
                entity,
                rr.Mesh3D(
                    vertex_positions=vertices,
                    triangle_indices=np.array([[0, 1, 2], [0, 2, 3]]),
                    vertex_normals=np.tile([0.0, 0.0, 1.0], (4, 1)),
                    albedo_factor=self._colors[i],
                ),
                static=True,
            )

    def _log_legend(self):
        between = self.events_written if self.between_checked or self.events_written else None
        self.rec.log(
            LEGEND_PATH,
            rr.TextDocument(legend(between, self.legend_extra, self.engine), media_type=rr.MediaType.MARKDOWN),
            static=True,
        )

    def abort(self):
        """Stop writing and remove the partial file; `path` is left untouched."""
        rec, self.rec = self.rec, None
        if rec is not None:
            with contextlib.suppress(Exception):  # the stream may already be broken; the file goes anyway
                rec.disconnect()
        with contextlib.suppress(FileNotFoundError):
            os.remove(self.partial)

    # --- static ----------------------------------------------------------------------------------

    def _log_bodies(self):
        g, moving = self.geometry, set(int(b) for b in self.geometry.moving)
        for b in range(1, len(g.body_names)):
            if b not in moving:
                self.rec.log(
                    self._paths[b],
                    rr.Transform3D(translation=g.body_pos[b], quaternion=xyzw(g.body_quat[b])),
                    static=True,
                )

    def _log_geoms(self):
        g, rec = self.geometry, self.rec
        ellipsoid_ids = np.asarray(g.ellipsoids)
        self._ellipsoid_groups = []  # (entity, indices into g.ellipsoids, free colours (n, 4) uint8)
        self._floors = []  # (entity, geom) of the world's infinite planes
        colors = self._colors
        for body in np.unique(g.geom_body):
            geoms = np.flatnonzero(g.geom_body == body)
            base = self._paths[body] + "/geoms"
            for kind in sorted(set(_PRIMITIVES.values())):
                mine = geoms[[_PRIMITIVES.get(int(k)) == kind for k in g.geom_kind[geoms]]]
                if len(mine) == 0:
                    continue
                entity = f"{base}/{kind}"
                labels = [g.geom_names[i] for i in mine]
                size, pos, quat = g.geom_size[mine], g.geom_pos[mine], xyzw(g.geom_quat[mine])
                if kind == "ellipsoids":
                    sphere = g.geom_kind[mine] == _KIND["sphere"]
                    half = np.where(sphere[:, None], size[:, :1], size)
                    rec.log(
                        entity,
                        rr.Ellipsoids3D.from_fields(
                            half_sizes=half,
                            centers=pos,
                            quaternions=quat,
                            labels=labels,
                            show_labels=self.labels,
                            fill_mode=rr.components.FillMode.Solid,
                        ),
                        static=True,
                    )
                    at = np.searchsorted(ellipsoid_ids, mine)
                    if not np.array_equal(ellipsoid_ids[np.minimum(at, len(ellipsoid_ids) - 1)], mine):
                        raise ValueError("SceneGeometry.ellipsoids must list every ellipsoid and sphere geom")
                    self._ellipsoid_groups.append((entity, at, colors[mine]))
                elif kind == "capsules":
                    axis = _axes_z(g.geom_quat[mine])
                    rec.log(
                        entity,
                        rr.Capsules3D(
                            lengths=2 * size[:, 1],
                            radii=size[:, 0],
                            translations=pos - axis * size[:, 1:2],
                            quaternions=quat,
                            colors=colors[mine],
                            labels=labels,
                            show_labels=self.labels,
                            fill_mode=rr.components.FillMode.Solid,
                        ),
                        static=True,
                    )
                elif kind == "cylinders":
                    rec.log(
                        entity,
                        rr.Cylinders3D(
                            lengths=2 * size[:, 1],
                            radii=size[:, 0],
                            centers=pos,
                            quaternions=quat,
                            colors=colors[mine],
                            labels=labels,
                            show_labels=self.labels,
                            fill_mode=rr.components.FillMode.Solid,
                        ),
                        static=True,
                    )
                else:
                    rec.log(
                        entity,
                        rr.Boxes3D(
                            half_sizes=size,
                            centers=pos,
                            quaternions=quat,
                            colors=colors[mine],
                            labels=labels,
                            show_labels=self.labels,
                            fill_mode=rr.components.FillMode.Solid,
                        ),
                        static=True,
                    )
            for i in geoms:
                if int(i) not in g.meshes:
                    continue
                vertices, triangles = g.meshes[int(i)]
                entity = f"{base}/{rr.escape_entity_path_part(g.geom_names[i])}"
                if g.geom_kind[i] == _KIND["plane"] and body == 0 and (g.geom_size[i, :2] <= 0).any():
                    self._floors.append((entity, int(i)))  # infinite: sized to the bodies at close
                rec.log(entity, rr.Transform3D(translation=g.geom_pos[i], quaternion=xyzw(g.geom_quat[i])), static=True)
                rec.log(
                    entity,
                    rr.Mesh3D(
                        vertex_positions=vertices,
                        triangle_indices=triangles,
                        vertex_normals=_vertex_normals(vertices, triangles),
                        albedo_factor=colors[i],
                    ),
                    static=True,
                )

    # --- per chunk -------------------------------------------------------------------------------

    def _write_states(self, frames):
        """Ellipsoid colours at the frames where a body's states change (and at the first frame)."""
        state = np.asarray(frames.state)
        previous = self._last_state
        for entity, at, free in self._ellipsoid_groups:
            s = state[:, at]
            before = np.concatenate([previous[None, at] if previous is not None else np.full((1, len(at)), -1), s[:-1]])
            changed = np.flatnonzero((s != before).any(axis=1))
            if len(changed) == 0:
                continue
            palette = np.stack(
                [
                    np.broadcast_to(free, (len(at), 4)),
                    np.broadcast_to(TOUCHING_COLOR, (len(at), 4)),
                    np.broadcast_to(OVERLAPPING_COLOR, (len(at), 4)),
                ]
            ).astype(np.uint8)  # (3, n, 4)
            colors = palette[s[changed], np.arange(len(at))[None, :]].reshape(-1, 4)
            columns = rr.Ellipsoids3D.columns(colors=colors).partition(np.full(len(changed), len(at)))
            self.rec.send_columns(
                entity, indexes=_indexes(frames.times[changed], frames.frame[changed]), columns=columns
            )
        self._last_state = state[-1].copy()

    def _write_contacts(self, frames, indexes):
        order = np.argsort(frames.contact_frame, kind="stable")
        lengths = np.bincount(frames.contact_frame - frames.frame[0], minlength=len(frames))
        pos = np.asarray(frames.contact_pos, dtype=np.float64).reshape(-1, 3)[order]
        normal = np.asarray(frames.contact_normal, dtype=np.float64).reshape(-1, 3)[order]
        colors = np.where(np.asarray(frames.contact_ellipsoids)[order][:, None], CONTACT_COLOR, OTHER_CONTACT_COLOR)
        colors = colors.astype(np.uint8).reshape(-1, 4)
        names = self.geometry.geom_names
        geoms = np.asarray(frames.contact_geoms, dtype=np.int64).reshape(-1, 2)[order]
        dist = np.asarray(frames.contact_dist, dtype=np.float64)[order]
        labels = [
            f"{names[g1]} / {names[g2]}: " + (f"depth {-d:.3g} m" if d < 0 else f"apart {d:.3g} m")
            for (g1, g2), d in zip(geoms.tolist(), dist.tolist())
        ]
        self.rec.send_columns(
            CONTACTS_PATH,
            indexes=indexes,
            columns=rr.Points3D.columns(positions=pos, colors=colors, labels=labels).partition(lengths),
        )
        arrows = rr.Arrows3D.columns(origins=pos, vectors=NORMAL_LENGTH * self.scale * normal, colors=colors)
        self.rec.send_columns(NORMALS_PATH, indexes=indexes, columns=arrows.partition(lengths))


def save(path, geometry, frames, *, app_id="ellipsim"):
    """Write `geometry` and `frames` (a Frames or a list of consecutive chunks) to the recording `path`.

    path : str or os.PathLike ending in ".rrd", in an existing directory; written under a temporary
    name and moved into place when complete.  Returns the recording id.
    """
    chunks = [frames] if isinstance(frames, Frames) else list(frames)
    with Recorder(path, app_id=app_id) as recorder:
        recorder.begin(geometry)
        for chunk in chunks:
            recorder.write(chunk)
    return recorder.recording_id


def is_recording(path):
    """True when `path` is a file that starts like a rerun recording (.rrd)."""
    try:
        with open(path, "rb") as f:
            return f.read(len(RRD_MAGIC)) == RRD_MAGIC
    except OSError:
        return False


def view(path):
    """Open the rerun viewer on the recording `path` and wait until it is closed.

    Returns the viewer's exit status (0 when it is closed normally).  On Linux without a display
    (neither DISPLAY nor WAYLAND_DISPLAY set) no viewer is started: one line says how to view the
    file elsewhere, and 0 is returned.  A path that is not an existing rerun recording raises
    ValueError.
    """
    text = os.fspath(path)
    if not os.path.isfile(text):
        raise ValueError(f"path must be an existing .rrd file, got {text!r}")
    if not is_recording(text):
        raise ValueError(f"{text!r} is not a rerun recording (an .rrd file starts with {RRD_MAGIC!r})")
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print(
            f"no display: view {text} elsewhere with `rerun {text}` (or `python -m rerun {text}`), "
            "or open it at https://app.rerun.io"
        )
        return 0
    return subprocess.run([*_viewer_command(), text], check=False).returncode


# --- internals -----------------------------------------------------------------------------------


def _viewer_command():
    """The rerun executable shipped with rerun-sdk: next to this interpreter, on PATH, or `python -m rerun`."""
    beside = pathlib.Path(sys.executable).with_name("rerun.exe" if sys.platform.startswith("win") else "rerun")
    if beside.is_file():
        return [str(beside)]
    on_path = shutil.which("rerun")
    if on_path:
        return [on_path]
    return [sys.executable, "-m", "rerun"]


def _check_save_path(path):
    try:
        text = os.fspath(path)
    except TypeError:
        raise ValueError(f"path must be a str or os.PathLike ending in .rrd, got {path!r}") from None
    if not isinstance(text, str):
        text = os.fsdecode(text)
    if not text.endswith(".rrd"):
        raise ValueError(f"path must end in .rrd, got {text!r}")
    directory = os.path.dirname(text) or "."
    if not os.path.isdir(directory):
        raise ValueError(f"path must be in an existing directory, got {text!r} (no directory {directory!r})")
    if os.path.isdir(text):
        raise ValueError(f"path must be a file, got the directory {text!r}")
    return text


def _body_paths(g):
    """Entity path of each body: MODEL_PATH for the world, then the kinematic tree of escaped names."""
    paths = [MODEL_PATH] + [""] * (len(g.body_names) - 1)
    for b in range(1, len(g.body_names)):  # MuJoCo numbers a parent before its children
        part = rr.escape_entity_path_part(g.body_names[b])
        if part == "geoms":  # not to be confused with the geoms of the parent
            part = f"geoms_{b}"
        paths[b] = f"{paths[g.body_parent[b]]}/{part}"
    return paths


def _deepest_keys(key, depth, k):
    """The k keys with the largest depth (each key's largest), deepest first."""
    keys, at = np.unique(key, return_inverse=True)
    deepest = np.zeros(len(keys))
    np.maximum.at(deepest, at.ravel(), depth)
    return keys[np.argsort(-deepest, kind="stable")[:k]]


def _indexes(times, frames):
    """The two timelines of per-frame columns: "time" (duration) and "frame" (sequence)."""
    times = np.asarray(times, dtype=np.float64)
    # Whole nanoseconds, rounded: rerun's own float conversion truncates (1/60 s -> 16666666 ns).
    nanos = np.round(times * 1e9).astype(np.int64).astype("timedelta64[ns]")
    return [rr.TimeColumn("time", duration=nanos), rr.TimeColumn("frame", sequence=np.asarray(frames, dtype=np.int64))]


def _corners(lo, hi):
    """The 8 corners (8, 3) of the box [lo, hi]."""
    return np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], dtype=np.float64
    )


def _axes_z(quat_wxyz):
    """Third column (local z axis) of the rotations of quaternions (n, 4) w x y z."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=np.float64).T
    return np.column_stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def _vertex_normals(vertices, triangles):
    """Unit vertex normals (n, 3): the area-weighted sum of the adjacent faces' normals."""
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    normals = np.zeros_like(vertices)
    if len(triangles):
        a, b, c = (vertices[triangles[:, k]] for k in range(3))
        face = np.cross(b - a, c - a)
        for k in range(3):
            np.add.at(normals, triangles[:, k], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
