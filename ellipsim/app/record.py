"""Recording: turns a Trajectory into a rerun recording (.rrd) and opens it in the rerun viewer.

Kept apart from the simulation (scenario.py fills a Trajectory, this module only reads it).  Static
data (semi-axes, labels, fill mode, series styling) is logged once; everything that changes per
frame goes out as columns with `RecordingStream.send_columns`, one partition per frame, on two
timelines: "time" (a duration, seconds) and "frame" (a sequence).

What is written (F frames, G geoms, K contacts):

    world                      ViewCoordinates RIGHT_HAND_Z_UP (MuJoCo's world frame), static
    world/figures/f{i}         Ellipsoids3D of the geoms with geom_figure == i:
                                 static: half_sizes, fill_mode (solid), labels (geom names)
                                 per frame: centers, quaternions (x, y, z, w), colors (by state)
    world/ellipsoids           the same for the geoms with geom_figure == -1 (free ellipsoids)
    world/contacts             Points3D: static radii and colour; per frame: positions
    world/contact_normals      Arrows3D: static radii and colour; per frame: origins, vectors
    counts/builtin             Scalars per frame (MuJoCo's contacts); static SeriesLines style
    counts/ellipsim            Scalars per frame (pairs ellipsim finds overlapping); static style

The default blueprint splits the window horizontally: a 3D view of "world" and a time-series view
of "counts".

Speed (2-core Xeon VM of README.md, rerun-sdk 0.41, median of 5): 1000 frames of 400 geoms in 25
figures of 16, with 20 contacts a frame, save in 0.14 s (0.15-0.26 s for the first save in a
process; 0.16-0.18 s as one entity of 400) to a 13 MB file.
"""

import os
import pathlib
import shutil
import subprocess
import sys
import uuid

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from .trajectory import Trajectory

# RGBA colours of a geom by its ellipsim state (Trajectory.state): 0 free, 1 touching, 2 overlapping.
FREE_COLOR = (120, 144, 176, 255)  # grey-blue
TOUCHING_COLOR = (255, 176, 0, 255)  # amber
OVERLAPPING_COLOR = (220, 30, 30, 255)  # red
STATE_COLORS = np.array([FREE_COLOR, TOUCHING_COLOR, OVERLAPPING_COLOR], dtype=np.uint8)  # (3, 4)

CONTACT_COLOR = (20, 200, 60, 255)  # green: stands out against all three state colours
CONTACT_RADIUS = 0.008  # metres, contact point spheres
NORMAL_LENGTH = 0.05  # metres, drawn length of a contact normal (the normals are unit)
NORMAL_RADIUS = 0.002  # metres, arrow shaft radius
BUILTIN_SERIES_COLOR = (60, 120, 220, 255)  # blue line: MuJoCo's contacts
ELLIPSIM_SERIES_COLOR = OVERLAPPING_COLOR  # red line: overlapping pairs, as the overlapping geoms

FIGURES_PATH = "world/figures"
FREE_PATH = "world/ellipsoids"
CONTACTS_PATH = "world/contacts"
NORMALS_PATH = "world/contact_normals"
BUILTIN_PATH = "counts/builtin"
ELLIPSIM_PATH = "counts/ellipsim"

# Namespace of the deterministic recording ids: uuid5(_RECORDING_NAMESPACE, scenario name).
_RECORDING_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://github.com/ellipsim/recording")


def recording_id(scenario):
    """The recording id of a scenario's recordings: a UUID derived from its name, the same every run."""
    return str(uuid.uuid5(_RECORDING_NAMESPACE, str(scenario)))


def blueprint():
    """The default layout: 3D view of "world" beside a time-series view of "counts"."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="world"),
            rrb.TimeSeriesView(origin="counts", name="contacts per frame"),
            column_shares=[3, 2],
        ),
    )


def save(path, trajectory, *, app_id="ellipsim"):
    """Write `trajectory` to the rerun recording file `path` (see the module docstring for the entities).

    path : str or os.PathLike ending in ".rrd", in an existing directory; overwritten if it exists
    trajectory : Trajectory (centres in metres, quaternions in MuJoCo's w, x, y, z order, times in s)
    app_id : rerun application id; the recording id is derived from `trajectory.scenario`, so two
        saves of the same scenario share it.

    Raises ValueError naming `path` or `trajectory` on bad input.  Geometry goes out with
    send_columns, one call per entity (no per-frame loop): 1000 frames x 400 geoms take about
    0.15 s and 13 MB.
    """
    path = _check_save_path(path)
    _check_trajectory(trajectory)
    t = trajectory
    n_frames = len(t.times)

    rec = rr.RecordingStream(app_id, recording_id=recording_id(t.scenario))
    rec.save(path, default_blueprint=blueprint())
    try:
        if t.scenario:
            rec.send_recording_name(t.scenario)
        indexes = _indexes(t.times)
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

        figure = np.asarray(t.geom_figure)
        for fig in np.unique(figure):
            entity = FREE_PATH if fig == -1 else f"{FIGURES_PATH}/f{fig}"
            _send_geoms(rec, entity, t, np.flatnonzero(figure == fig), indexes)

        _send_contacts(rec, t, indexes)

        for entity, counts, name, color in (
            (BUILTIN_PATH, t.builtin_counts, "MuJoCo contacts", BUILTIN_SERIES_COLOR),
            (ELLIPSIM_PATH, t.ellipsim_counts, "ellipsim overlapping pairs", ELLIPSIM_SERIES_COLOR),
        ):
            rec.log(entity, rr.SeriesLines(names=name, colors=color, widths=2.0), static=True)
            if n_frames:
                scalars = np.asarray(counts, dtype=np.float64)
                rec.send_columns(entity, indexes=indexes, columns=rr.Scalars.columns(scalars=scalars))
    finally:
        rec.flush()
        rec.disconnect()


def view(path):
    """Open the rerun viewer on the recording `path` and wait until it is closed.

    Returns the viewer's exit status (0 when it is closed normally).  On Linux without a display
    (neither DISPLAY nor WAYLAND_DISPLAY set) no viewer is started: one line says how to view the
    file elsewhere, and 0 is returned.  A path that is not an existing file raises ValueError.
    """
    text = os.fspath(path)
    if not os.path.isfile(text):
        raise ValueError(f"path must be an existing .rrd file, got {text!r}")
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print(f"no display: view {text} elsewhere with `rerun {text}` (or `python -m rerun {text}`), "
              "or open it at https://app.rerun.io")
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


def _check_trajectory(t):
    if not isinstance(t, Trajectory):
        raise ValueError(f"trajectory must be an ellipsim.app.trajectory.Trajectory, got {type(t).__name__}")
    figure = np.asarray(t.geom_figure)
    bad = np.flatnonzero(figure < -1)
    if len(bad):
        raise ValueError(f"trajectory.geom_figure[{bad[0]}] must be >= -1, got {figure[bad[0]]}")
    state = np.asarray(t.state)
    bad = np.argwhere((state < 0) | (state >= len(STATE_COLORS)))
    if len(bad):
        f, g = bad[0]
        raise ValueError(f"trajectory.state[{f}, {g}] must be 0, 1 or 2, got {state[f, g]}")
    for name in ("times", "half_sizes", "centers", "quaternions", "contact_pos", "contact_normal"):
        values = np.asarray(getattr(t, name), dtype=np.float64)
        bad = np.argwhere(~np.isfinite(values))
        if len(bad):
            index = ", ".join(str(i) for i in bad[0])
            raise ValueError(f"trajectory.{name}[{index}] must be finite, got {values[tuple(bad[0])]}")


def _indexes(times):
    """The two timelines of every per-frame column: "time" (duration) and "frame" (sequence)."""
    times = np.asarray(times, dtype=np.float64)
    # Whole nanoseconds, rounded: rerun's own float conversion truncates (1/60 s -> 16666666 ns).
    nanos = np.round(times * 1e9).astype(np.int64).astype("timedelta64[ns]")
    return [rr.TimeColumn("time", duration=nanos), rr.TimeColumn("frame", sequence=np.arange(len(times)))]


def _send_geoms(rec, entity, t, geoms, indexes):
    """One batched Ellipsoids3D for the geoms `geoms` (indices into the G geoms)."""
    n_frames, n = len(t.times), len(geoms)
    rec.log(
        entity,
        rr.Ellipsoids3D.from_fields(
            half_sizes=np.asarray(t.half_sizes, dtype=np.float64)[geoms],
            fill_mode=rr.components.FillMode.Solid,
            labels=[t.geom_names[g] for g in geoms],
        ),
        static=True,
    )
    if not n_frames:
        return
    centers = np.asarray(t.centers, dtype=np.float64)[:, geoms].reshape(-1, 3)
    wxyz = np.asarray(t.quaternions, dtype=np.float64)[:, geoms].reshape(-1, 4)
    xyzw = wxyz[:, [1, 2, 3, 0]]  # MuJoCo (w, x, y, z) -> rerun (x, y, z, w)
    colors = STATE_COLORS[np.asarray(t.state)[:, geoms].reshape(-1)]
    columns = rr.Ellipsoids3D.columns(centers=centers, quaternions=xyzw, colors=colors)
    rec.send_columns(entity, indexes=indexes, columns=columns.partition(np.full(n_frames, n)))


def _send_contacts(rec, t, indexes):
    """Contact points and normals, one partition per frame (empty for frames without contacts)."""
    n_frames = len(t.times)
    rec.log(CONTACTS_PATH, rr.Points3D.from_fields(radii=CONTACT_RADIUS, colors=CONTACT_COLOR), static=True)
    rec.log(NORMALS_PATH, rr.Arrows3D.from_fields(radii=NORMAL_RADIUS, colors=CONTACT_COLOR), static=True)
    if not n_frames:
        return
    frame = np.asarray(t.contact_frame, dtype=np.int64)
    order = np.argsort(frame, kind="stable")
    lengths = np.bincount(frame, minlength=n_frames)
    pos = np.asarray(t.contact_pos, dtype=np.float64).reshape(-1, 3)[order]
    normal = np.asarray(t.contact_normal, dtype=np.float64).reshape(-1, 3)[order]
    rec.send_columns(CONTACTS_PATH, indexes=indexes, columns=rr.Points3D.columns(positions=pos).partition(lengths))
    arrows = rr.Arrows3D.columns(origins=pos, vectors=NORMAL_LENGTH * normal)
    rec.send_columns(NORMALS_PATH, indexes=indexes, columns=arrows.partition(lengths))
