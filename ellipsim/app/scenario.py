"""Scenarios: what to simulate, read from TOML files (scenarios/*.toml, or any path).

A scenario names the scene (oval-limb figures in a layout, or a pile of free ellipsoids), the
control (scripted position targets: hold, sway, walk, reach, dance, flail, or keyframes), the
duration and timestep, the collision mode (builtin, filter, narrowphase) and whether it is
kinematic (poses replayed without physics).  `load` validates every key and raises ScenarioError
naming the file and the key; simulate.py runs it.
"""

import dataclasses
import functools
import math
import os
import tomllib

import mujoco

from .. import shipped
from ..mujoco import scenes

MODES = ("builtin", "filter", "narrowphase")
SCENES = ("figures", "pile")
CONTROLS = ("hold", "sway", "walk", "reach", "dance", "flail", "keyframes")


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
        out["layout"] = c.get("layout", str, "grid", choices=scenes.LAYOUTS)
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


@functools.cache
def _figure_joints():
    """Names of the figure's actuated joints, in actuator order (what keyframes may name)."""
    model = mujoco.MjModel.from_xml_string(scenes.figure_xml())
    return tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[a, 0]) for a in range(model.nu))
