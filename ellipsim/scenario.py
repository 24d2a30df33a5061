"""Scenarios: what to simulate, read from TOML files (scenarios/*.toml, or any path).

A scenario names the scene (oval-limb figures in a layout, or a pile of free ellipsoids), the
control (scripted position targets: hold, sway, walk, reach, dance, flail, or keyframes), the
duration and timestep, the collision mode (builtin, filter, narrowphase) and whether it is
kinematic (poses replayed without physics).  `load` validates every key and raises ScenarioError
naming the file and the key; `run` simulates and returns the Trajectory that record.py writes and the
CLI summarises.
"""

import contextlib
import dataclasses
import functools
import math
import os
import time
import tomllib

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from . import figures, plugin, shipped
from ._jit import jit
from .classify import Relation, classify
from .ellipsoids import Ellipsoids
from .trajectory import Trajectory

MODES = ("builtin", "filter", "narrowphase")
SCENES = ("figures", "pile")
CONTROLS = ("hold", "sway", "walk", "reach", "dance", "flail", "keyframes")
RECORD_FPS = 60.0  # frames per simulated second kept for recording and comparison


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message names the file and the key."""


@dataclasses.dataclass(frozen=True)
class Scenario:
    name: str
    path: str
    description: str
    duration: float  # seconds
    timestep: float  # seconds per step (per frame when kinematic)
    mode: str
    kinematic: bool
    gravity: tuple  # (3,) m/s^2, or () for the model's default
    scene: dict
    control: dict

    @property
    def steps(self):
        return max(1, int(round(self.duration / self.timestep)))


# --- files ---------------------------------------------------------------------------------------


def _directory():
    return shipped.folder("scenarios")


def available():
    """Names of the scenarios shipped in scenarios/."""
    return sorted(p.name[:-5] for p in _directory().iterdir() if p.name.endswith(".toml"))


def resolve(name_or_path):
    """The file of a scenario given by name (in scenarios/) or by path; ScenarioError if neither."""
    text = os.fspath(name_or_path)
    if os.path.isfile(text):
        return text
    if not text.endswith(".toml") and text in available():
        return str(_directory() / f"{text}.toml")
    raise ScenarioError(f"unknown scenario {text!r}; available: {', '.join(available())} (or a path to a .toml file)")


class _Checker:
    """Reads typed values out of a TOML table; errors name the file and the dotted key."""

    def __init__(self, path, table, prefix=""):
        self.path, self.table, self.prefix = path, table, prefix
        self.used = set()

    def error(self, key, problem, value):
        return ScenarioError(f"{self.path}: key '{self.prefix}{key}' {problem}, got {value!r}")

    def get(self, key, kind, default=None, *, choices=None, positive=False, required=False):
        self.used.add(key)
        if key not in self.table:
            if required:
                raise ScenarioError(f"{self.path}: missing key '{self.prefix}{key}'")
            return default
        value = self.table[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if kind is bool and not isinstance(value, bool) or kind is not bool and isinstance(value, bool):
            raise self.error(key, f"must be a {kind.__name__}", value)
        if not isinstance(value, kind):
            raise self.error(key, f"must be a {kind.__name__}", value)
        if kind is float and not math.isfinite(value):
            raise self.error(key, "must be finite", value)
        if choices is not None and value not in choices:
            raise self.error(key, f"must be one of {choices}", value)
        if positive and value <= 0:
            raise self.error(key, "must be positive", value)
        return value

    def table_of(self, key, required=True):
        self.used.add(key)
        value = self.table.get(key, {} if not required else None)
        if value is None:
            raise ScenarioError(f"{self.path}: missing table [{self.prefix}{key}]")
        if not isinstance(value, dict):
            raise self.error(key, "must be a table", value)
        return _Checker(self.path, value, f"{self.prefix}{key}.")

    def done(self):
        unknown = sorted(set(self.table) - self.used)
        if unknown:
            raise ScenarioError(
                f"{self.path}: unknown key '{self.prefix}{unknown[0]}' (known here: {', '.join(sorted(self.used))})"
            )


def load(name_or_path):
    """The Scenario of a name in scenarios/ or of a .toml path, validated."""
    path = resolve(name_or_path)
    try:
        with open(path, "rb") as f:
            table = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror}") from None
    top = _Checker(path, table)
    description = top.get("description", str, "")
    duration = top.get("duration", float, required=True, positive=True)
    timestep = top.get("timestep", float, required=True, positive=True)
    if timestep > duration:
        raise top.error("timestep", f"must not exceed the duration {duration}", timestep)
    mode = top.get("mode", str, "narrowphase", choices=MODES)
    kinematic = top.get("kinematic", bool, False)
    gravity = top.get("gravity", list, [])
    if gravity and (len(gravity) != 3 or not all(isinstance(g, (int, float)) and not isinstance(g, bool) for g in gravity)):
        raise top.error("gravity", "must be a list of three numbers (m/s^2)", gravity)
    scene = _scene(top.table_of("scene"))
    if scene["kind"] == "pile" and kinematic:
        raise top.error("kinematic", "must be false for a pile scene (free ellipsoids have no joints to pose)", kinematic)
    control = _control(top.table_of("control"), kinematic, scene["kind"])
    top.done()
    name = os.path.basename(path)[:-5] if path.endswith(".toml") else os.path.basename(path)
    return Scenario(name, path, description, duration, timestep, mode, kinematic, tuple(float(g) for g in gravity), scene, control)


def _scene(c):
    kind = c.get("kind", str, "figures", choices=SCENES)
    out = {"kind": kind, "seed": c.get("seed", int, 0)}
    if out["seed"] < 0:
        raise c.error("seed", "must be non-negative", out["seed"])
    if kind == "figures":
        out["figures"] = c.get("figures", int, required=True, positive=True)
        out["layout"] = c.get("layout", str, "grid", choices=figures.LAYOUTS)
        out["spacing"] = c.get("spacing", float, 0.8, positive=True)
        out["drop_height"] = c.get("drop_height", float, 0.0)
        out["floor"] = c.get("floor", bool, True)
        out["fixed_roots"] = c.get("fixed_roots", bool, False)
    else:
        out["ellipsoids"] = c.get("ellipsoids", int, required=True, positive=True)
        out["bin_half_width"] = c.get("bin_half_width", float, 0.5, positive=True)
    c.done()
    return out


def _control(c, kinematic, scene_kind):
    kind = c.get("kind", str, "hold", choices=CONTROLS)
    if kinematic and kind != "keyframes":
        raise c.error("kind", "must be 'keyframes' for a kinematic scenario", kind)
    if scene_kind == "pile" and kind != "hold":
        raise c.error("kind", "must be 'hold' for a pile scene (free ellipsoids have no joints to drive)", kind)
    out = {"kind": kind}
    if kind in ("sway", "walk", "dance", "flail"):
        out["amplitude"] = c.get("amplitude", float, 20.0 if kind != "flail" else 0.5, positive=True)
        out["period"] = c.get("period", float, 2.0, positive=True)
        out["phase_step"] = c.get("phase_step", float, 0.0)
        out["seed"] = c.get("seed", int, 0)
    elif kind == "reach":
        out["arm"] = c.get("arm", str, "right", choices=("right", "left"))
        out["shoulder_flex"] = c.get("shoulder_flex", float, 80.0)
        out["shoulder_abd"] = c.get("shoulder_abd", float, 10.0)
        out["shoulder_rot"] = c.get("shoulder_rot", float, 0.0)
        out["elbow"] = c.get("elbow", float, 20.0)
        out["ramp"] = c.get("ramp", float, 1.0, positive=True)
    elif kind == "keyframes":
        out["stagger"] = c.get("stagger", float, 0.0)
        keys = c.get("keys", list, required=True)
        frames = []
        for i, k in enumerate(keys):
            if not isinstance(k, dict) or "t" not in k:
                raise c.error(f"keys[{i}]", "must be a table with a time 't'", k)
            t = k["t"]
            joints = k.get("joints", {})
            if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
                raise c.error(f"keys[{i}].t", "must be a number of seconds", t)
            if not isinstance(joints, dict) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in joints.values()
            ):
                raise c.error(f"keys[{i}].joints", "must map joint names to angles in degrees", joints)
            unknown = set(k) - {"t", "joints"}
            if unknown:
                raise c.error(f"keys[{i}]", f"has unknown key {sorted(unknown)[0]!r}", k)
            for j in joints:
                if j not in _figure_joints():
                    raise ScenarioError(
                        f"{c.path}: key '{c.prefix}keys[{i}].joints' names unknown joint {j!r}; "
                        f"the figure's joints are {', '.join(_figure_joints())}"
                    )
            frames.append((float(t), {str(j): float(v) for j, v in joints.items()}))
        if len(frames) < 2 or any(b[0] <= a[0] for a, b in zip(frames, frames[1:])):
            raise c.error("keys", "must be at least two keyframes with increasing times", [f[0] for f in frames])
        out["keys"] = frames
    c.done()
    return out


# --- models --------------------------------------------------------------------------------------


@functools.cache
def _figure_joints():
    """Names of the figure's actuated joints, in actuator order (what keyframes may name)."""
    model = mujoco.MjModel.from_xml_string(figures.figure_xml())
    return tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[a, 0]) for a in range(model.nu))


def build(s):
    """(model, data) of a scenario, with its timestep and gravity, at the initial state.

    A scene the figures module refuses (e.g. a spacing too small for the layout) raises
    ScenarioError naming the file.
    """
    sc = s.scene
    try:
        if sc["kind"] == "figures":
            xml = figures.scene_xml(
                sc["figures"], layout=sc["layout"], spacing=sc["spacing"], seed=sc["seed"],
                drop_height=sc["drop_height"], floor=sc["floor"], fixed_roots=sc["fixed_roots"],
            )  # fmt: skip
        else:
            xml = figures.pile_xml(sc["ellipsoids"], seed=sc["seed"], bin_half_width=sc["bin_half_width"])
    except ValueError as exc:
        raise ScenarioError(f"{s.path}: [scene] {exc}") from None
    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.timestep = s.timestep
    if s.gravity:
        model.opt.gravity[:] = s.gravity
    return model, mujoco.MjData(model)


def _actuated_joints(model):
    """For each actuator: (figure index, joint name without the "f{i}_" prefix, qpos address)."""
    out = []
    for a in range(model.nu):
        j = model.actuator_trnid[a, 0]
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
        fig, _, base = name.partition("_")
        out.append((int(fig[1:]) if fig.startswith("f") and fig[1:].isdigit() else 0, base, int(model.jnt_qposadr[j])))
    return out


# Joint targets of the periodic controls, in units of the amplitude, as
# (constant, sin, max(0, cos), max(0, -cos)) of the phase w t + figure phase.
_PATTERNS = {
    "sway": {
        "waist_bend": (0, 1, 0, 0), "hip_abd_l": (0, 0.5, 0, 0), "hip_abd_r": (0, -0.5, 0, 0),
        "ankle_inv_l": (0, -0.3, 0, 0), "ankle_inv_r": (0, 0.3, 0, 0),
        "shoulder_abd_l": (0.5, 0.5, 0, 0), "shoulder_abd_r": (0.5, -0.5, 0, 0),
    },
    "walk": {
        "hip_flex_l": (0, 1, 0, 0), "hip_flex_r": (0, -1, 0, 0), "knee_l": (0, 0, 0, 1), "knee_r": (0, 0, 1, 0),
        "shoulder_flex_l": (0, -0.6, 0, 0), "shoulder_flex_r": (0, 0.6, 0, 0), "elbow_l": (0.5, 0, 0, 0),
        "elbow_r": (0.5, 0, 0, 0),
    },
    "dance": {
        "shoulder_abd_l": (1.5, 1.5, 0, 0), "shoulder_abd_r": (1.5, -1.5, 0, 0), "elbow_l": (1, 1, 0, 0),
        "elbow_r": (1, -1, 0, 0), "waist_bend": (0, 1, 0, 0), "neck_turn": (0, 1, 0, 0),
        "knee_l": (0.5, 0.5, 0, 0), "knee_r": (0.5, -0.5, 0, 0), "hip_flex_l": (0.25, 0.25, 0, 0),
        "hip_flex_r": (0.25, -0.25, 0, 0),
    },
}  # fmt: skip


class Controller:
    """Position targets (radians) of every actuator as a function of time, for a scenario's control.

    Each kind is precomputed into per-actuator arrays, so a call is a few numpy operations.
    """

    def __init__(self, model, control):
        self.kind, self.c = control["kind"], control
        self.joints = _actuated_joints(model)
        self.qadr = np.array([adr for _, _, adr in self.joints], dtype=np.intp)  # qpos address per actuator
        nu = len(self.joints)
        self.lo, self.hi = model.actuator_ctrlrange[:, 0].copy(), model.actuator_ctrlrange[:, 1].copy()
        deg = math.pi / 180
        fig = np.array([f for f, _, _ in self.joints], dtype=float)
        names = [j for _, j, _ in self.joints]
        if self.kind in _PATTERNS:
            table = _PATTERNS[self.kind]
            self.coef = np.array([table.get(j, (0, 0, 0, 0)) for j in names], dtype=float).T * control["amplitude"] * deg
            self.phase = fig * control["phase_step"]
            self.w = 2 * math.pi / control["period"]
        elif self.kind == "flail":
            rng = np.random.default_rng(control["seed"])
            self.w = 2 * math.pi / control["period"] * rng.uniform(0.6, 1.6, nu)
            self.phase = rng.uniform(0, 2 * math.pi, nu)
            self.mid, self.half = 0.5 * (self.lo + self.hi), 0.5 * (self.hi - self.lo) * control["amplitude"]
        elif self.kind == "reach":
            side = "_r" if control["arm"] == "right" else "_l"
            goal = {f"shoulder_flex{side}": control["shoulder_flex"], f"shoulder_abd{side}": control["shoulder_abd"],
                    f"shoulder_rot{side}": control["shoulder_rot"], f"elbow{side}": control["elbow"]}  # fmt: skip
            self.goal = np.array([goal.get(j, 0.0) for j in names]) * deg
        elif self.kind == "keyframes":
            keys = control["keys"]
            self.key_t = np.array([t for t, _ in keys])
            self.key_q = np.array([[k.get(j, 0.0) for j in names] for _, k in keys]) * deg  # (K, nu)
            self.shift = fig * control["stagger"]

    def __call__(self, t):
        if self.kind == "hold":
            out = np.zeros(len(self.joints))
        elif self.kind in _PATTERNS:
            x = self.w * t + self.phase
            c = np.cos(x)
            out = self.coef[0] + self.coef[1] * np.sin(x) + self.coef[2] * np.maximum(c, 0) + self.coef[3] * np.maximum(-c, 0)
        elif self.kind == "flail":
            out = self.mid + self.half * np.sin(self.w * t + self.phase)
        elif self.kind == "reach":
            out = _smoothstep(t / self.c["ramp"]) * self.goal
        else:  # keyframes: smoothstep between the keys around each actuator's (staggered) time
            tt = np.clip(t - self.shift, self.key_t[0], self.key_t[-1])
            k = np.clip(np.searchsorted(self.key_t, tt, side="right") - 1, 0, len(self.key_t) - 2)
            x = np.clip((tt - self.key_t[k]) / (self.key_t[k + 1] - self.key_t[k]), 0.0, 1.0)
            s = x * x * (3 - 2 * x)
            cols = np.arange(len(self.joints))
            out = (1 - s) * self.key_q[k, cols] + s * self.key_q[k + 1, cols]
        return np.clip(out, self.lo, self.hi)


def _smoothstep(x):
    x = min(max(x, 0.0), 1.0)
    return x * x * (3 - 2 * x)


# --- candidate pairs ------------------------------------------------------------------------------


def _geoms(model):
    """Ellipsoid and sphere geoms, their semi-axes (g, 3), and which pairs may collide (g, g) bool:
    MuJoCo's own rules (contype/conaffinity, not the same body, not parent and child, <exclude>)."""
    ids = np.flatnonzero((model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID) | (model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE))
    radii = model.geom_size[ids].copy()
    sphere = model.geom_type[ids] == mujoco.mjtGeom.mjGEOM_SPHERE
    radii[sphere] = radii[sphere, :1]
    body = model.geom_bodyid[ids]
    ct, ca = model.geom_contype[ids], model.geom_conaffinity[ids]
    allowed = ((ct[:, None] & ca[None, :]) != 0) | ((ct[None, :] & ca[:, None]) != 0)
    weld = model.body_weldid[body]
    parent = model.body_weldid[model.body_parentid[model.body_weldid[body]]]
    allowed &= weld[:, None] != weld[None, :]
    allowed &= ~((weld[:, None] == parent[None, :]) | (parent[:, None] == weld[None, :])) | (weld[:, None] == 0) | (weld[None, :] == 0)
    for k in range(model.nexclude):
        sig = model.exclude_signature[k]
        b1, b2 = sig >> 16, sig & 0xFFFF
        allowed &= ~(((body[:, None] == b1) & (body[None, :] == b2)) | ((body[:, None] == b2) & (body[None, :] == b1)))
    np.fill_diagonal(allowed, False)
    return ids, radii, allowed


@jit
def sweep_and_prune(centers, rho, allowed):
    """Pairs (frame, i, j), i < j, whose bounding spheres overlap in each frame: sort by c - rho along
    the frame's axis of widest spread (figures in a line along y must not be swept along x), sweep.

    centers : (F, g, 3), rho : (g,) bounding radii, allowed : (g, g) bool.  Returns (P, 3) int64.
    """
    F, g = centers.shape[0], centers.shape[1]
    cap = 1024
    out = np.empty((cap, 3), dtype=np.int64)
    n = 0
    for f in range(F):
        axis, widest = 0, -1.0
        for k in range(3):
            spread = centers[f, :, k].max() - centers[f, :, k].min() if g else 0.0
            if spread > widest:
                axis, widest = k, spread
        lo = centers[f, :, axis] - rho
        order = np.argsort(lo)
        for a in range(g):
            i = order[a]
            hi = centers[f, i, axis] + rho[i]
            for b in range(a + 1, g):
                j = order[b]
                if lo[j] > hi:
                    break
                if not allowed[i, j]:
                    continue
                dx = centers[f, i, 0] - centers[f, j, 0]
                dy = centers[f, i, 1] - centers[f, j, 1]
                dz = centers[f, i, 2] - centers[f, j, 2]
                r = rho[i] + rho[j]
                if dx * dx + dy * dy + dz * dz <= r * r:
                    if n == cap:
                        bigger = np.empty((2 * cap, 3), dtype=np.int64)
                        bigger[:n] = out[:n]
                        out, cap = bigger, 2 * cap
                    out[n, 0], out[n, 1], out[n, 2] = f, min(i, j), max(i, j)
                    n += 1
    return out[:n]


def classify_frames(centers, rotations, radii, allowed):
    """Exact relation of every candidate pair of every frame, in one batched classify call.

    centers (F, g, 3), rotations (F, g, 3, 3), radii (g, 3), allowed (g, g).
    Returns pairs (P, 3) (frame, i, j) and relations (P,) int8.
    """
    rho = radii.max(axis=1) * (1 + 1e-9)
    pairs = sweep_and_prune(np.ascontiguousarray(centers), rho, allowed)
    if len(pairs) == 0:
        return pairs, np.zeros(0, dtype=np.int8)
    f, i, j = pairs.T
    a = Ellipsoids(centers[f, i], rotations[f, i], radii[i])
    b = Ellipsoids(centers[f, j], rotations[f, j], radii[j])
    return pairs, classify(a, b)


# --- running ----------------------------------------------------------------------------------------


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


def _quaternions(mats):
    """Unit quaternions (..., 4) w x y z of rotation matrices (..., 3, 3)."""
    if mats.size == 0:
        return np.zeros(mats.shape[:-2] + (4,))
    xyzw = Rotation.from_matrix(mats.reshape(-1, 3, 3)).as_quat()
    return np.roll(xyzw, 1, axis=-1).reshape(mats.shape[:-2] + (4,))


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
        centers=centers, quaternions=_quaternions(rotations), state=state,
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
    ids, radii, allowed = _geoms(model)
    control = Controller(model, s.control)
    keep = np.zeros(model.ngeom, dtype=bool)
    keep[ids] = True
    every = 1 if s.kinematic else max(1, int(round(1.0 / (RECORD_FPS * s.timestep))))
    times, centers, rotations, builtin = [], [], [], []
    contact_frame, contact_pos, contact_normal = [], [], []
    ncon = np.zeros(steps, dtype=np.int64)
    counters = {}
    att = plugin.attach(model, data, mode=mode) if mode != "builtin" and not s.kinematic else None
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
    """plugin.validate on the scenario: its model, its controls (or keyframed poses), `steps` steps."""
    model, data = build(s)
    control = Controller(model, s.control)
    steps = s.steps if steps is None else steps
    if s.kinematic:

        def pose(m, d, k):
            d.time = k * s.timestep
            d.qpos[control.qadr] = control(d.time)

        return plugin.validate(model, data, steps, control=pose, advance=False, progress=progress), model

    def apply(m, d, k):
        d.ctrl[:] = control(d.time)

    return plugin.validate(model, data, steps, control=apply, progress=progress), model
