"""Running a scenario: build its model, drive it (or pose it, when kinematic), keep the frames.

`run` returns a Run whose Trajectory record.py writes and the CLI summarises; `validation` steps
the scenario under mujoco.validate (MuJoCo's contacts against the exact test, pair by pair).
"""

import contextlib
import dataclasses
import time

import mujoco
import numpy as np

from ..core.broadphase import classify_frames
from ..core.relation import Relation
from ..core.rotations import rotations_to_quaternions
from ..mujoco import scenes
from ..mujoco.attachment import attach
from ..mujoco.geoms import ellipsoid_geoms
from ..mujoco.validate import validate
from .control import Controller
from .scenario import MODES, Scenario, ScenarioError
from .trajectory import Trajectory

RECORD_FPS = 60.0  # frames per simulated second kept for recording and comparison


def build(s):
    """(model, data) of a scenario, with its timestep and gravity, at the initial state.

    A scene the figures module refuses (e.g. a spacing too small for the layout) raises
    ScenarioError naming the file.
    """
    sc = s.scene
    try:
        if sc["kind"] == "figures":
            xml = scenes.scene_xml(
                sc["figures"], layout=sc["layout"], spacing=sc["spacing"], seed=sc["seed"],
                drop_height=sc["drop_height"], floor=sc["floor"], fixed_roots=sc["fixed_roots"],
            )  # fmt: skip
        else:
            xml = scenes.pile_xml(sc["ellipsoids"], seed=sc["seed"], bin_half_width=sc["bin_half_width"])
    except ValueError as exc:
        raise ScenarioError(f"{s.path}: [scene] {exc}") from None
    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.timestep = s.timestep
    if s.gravity:
        model.opt.gravity[:] = s.gravity
    return model, mujoco.MjData(model)


@dataclasses.dataclass
class Run:
    """What `run` returns: the recorded frames and a summary."""

    scenario: Scenario
    mode: str
    steps: int
    seconds: float  # wall time of the stepping loop
    frames: Trajectory
    counters: dict  # ellipsim's per-data counters (filter or narrowphase), or {}
    mujoco_contacts: np.ndarray  # (steps,) all contacts MuJoCo made per step


def _frames(s, model, ids, radii, allowed, times, centers, rotations, contacts, builtin):
    """contacts: (frame (N,) int64, pos (N, 3), normal (N, 3)) of the recorded ellipsoid contacts."""
    pairs, relation = classify_frames(centers, rotations, radii, allowed)
    F, g = centers.shape[:2]
    state = np.zeros((F, g), dtype=np.int8)
    if len(pairs):
        f, i, j = pairs.T
        np.maximum.at(state, (f, i), relation)
        np.maximum.at(state, (f, j), relation)
    overlaps = np.bincount(pairs[relation == Relation.OVERLAPPING, 0], minlength=F) if len(pairs) else np.zeros(F, int)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(k)) or f"geom{k}" for k in ids]
    figure = np.array([int(n.split("_")[0][1:]) if n.startswith("f") and n.split("_")[0][1:].isdigit() else -1 for n in names])
    cf, pos, normal = contacts
    return Trajectory(
        scenario=s.name, times=np.asarray(times), geom_names=names, geom_figure=figure, half_sizes=radii,
        centers=centers, quaternions=rotations_to_quaternions(rotations), state=state,
        contact_frame=cf, contact_pos=pos, contact_normal=normal,
        builtin_counts=np.asarray(builtin, dtype=np.int64), ellipsim_counts=overlaps.astype(np.int64),
    )  # fmt: skip


def _ellipsoid_contacts(data, keep):
    """Positions (m, 3) and normals (m, 3) of MuJoCo's contacts in data between two geoms marked
    in `keep` (ngeom,) bool, in MuJoCo's order; the normal is the first row of the contact frame."""
    con = data.contact
    both = keep[con.geom].all(axis=1)
    return con.pos[both], con.frame[both, :3]


def run(s, *, steps=None, mode=None, progress=None):
    """Simulate a scenario (or replay it, when kinematic); returns a Run.

    steps : number of steps (default: the scenario's duration); mode : overrides the scenario's.
    progress : optional callable(step, steps).
    """
    mode = mode or s.mode
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    steps = s.steps if steps is None else steps
    if not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")
    model, data = build(s)
    ids, radii, allowed = ellipsoid_geoms(model)
    control = Controller(model, s.control)
    keep = np.zeros(model.ngeom, dtype=bool)
    keep[ids] = True
    every = 1 if s.kinematic else max(1, int(round(1.0 / (RECORD_FPS * s.timestep))))
    times, centers, rotations, builtin = [], [], [], []
    contact_frame, contact_pos, contact_normal = [], [], []
    ncon = np.zeros(steps, dtype=np.int64)
    counters = {}
    att = attach(model, data, mode=mode) if mode != "builtin" and not s.kinematic else None
    with att if att else contextlib.nullcontext():
        t0 = time.perf_counter()  # after attaching: the first attach compiles the callback
        for k in range(steps):
            if s.kinematic:  # pose from the keyframes, then forward kinematics and MuJoCo's collision
                t = k * s.timestep
                data.qpos[control.qadr] = control(t)
                data.time = t
                mujoco.mj_forward(model, data)
            else:
                data.ctrl[:] = control(data.time)
                mujoco.mj_step(model, data)
            ncon[k] = data.ncon
            if k % every == 0:
                frame = len(times)
                times.append(data.time)
                centers.append(data.geom_xpos[ids].copy())
                rotations.append(data.geom_xmat[ids].reshape(-1, 3, 3).copy())
                pos, normal = _ellipsoid_contacts(data, keep)
                contact_frame.append(np.full(len(pos), frame, dtype=np.int64))
                contact_pos.append(pos)
                contact_normal.append(normal)
                builtin.append(len(pos))
            if progress is not None:
                progress(k + 1, steps)
        seconds = time.perf_counter() - t0
    if att:
        counters = att.counters
    contacts = (np.concatenate(contact_frame), np.concatenate(contact_pos), np.concatenate(contact_normal))
    frames = _frames(s, model, ids, radii, allowed, times, np.array(centers), np.array(rotations), contacts, builtin)
    return Run(s, mode, steps, seconds, frames, counters, ncon)


def validation(s, steps=None, progress=None):
    """mujoco.validate on the scenario: its model, its controls (or keyframed poses), `steps` steps."""
    model, data = build(s)
    control = Controller(model, s.control)
    steps = s.steps if steps is None else steps
    if s.kinematic:

        def pose(m, d, k):
            d.time = k * s.timestep
            d.qpos[control.qadr] = control(d.time)

        return validate(model, data, steps, control=pose, advance=False, progress=progress), model

    def apply(m, d, k):
        d.ctrl[:] = control(d.time)

    return validate(model, data, steps, control=apply, progress=progress), model

