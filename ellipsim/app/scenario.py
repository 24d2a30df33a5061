"""Scenarios: what to simulate, read from TOML files (scenarios/*.toml, or any path), or a user's
MJCF model given by its path.

A scenario names the scene (oval-limb figures in a layout, a pile of free ellipsoids, or an MJCF
model: `[scene] kind = "mjcf"`, `path` relative to the TOML file), the control (scripted targets:
hold, sway, walk, reach, dance, flail, or keyframes; they drive actuators by name), the duration and
timestep, the collision mode (builtin, filter, narrowphase) and whether it is kinematic (poses
replayed without physics).  `load` validates every key and raises ScenarioError naming the file
and the key (an unknown key is named as unknown, with the nearest known one); simulate.py runs it.
An .xml path loads as a scenario of that model: MJCF_DURATION seconds at the model's own timestep,
from its default pose (or a keyframe), actuators held.
"""

import dataclasses
import difflib
import functools
import math
import os
import tomllib

import mujoco

from .. import shipped
from . import scenes
from .errors import UserError
from .mjcf import CTRL_MODES, one_line

MODES = ("builtin", "filter", "narrowphase")
SCENES = ("figures", "pile", "mjcf")
CONTROLS = ("hold", "sway", "walk", "reach", "dance", "flail", "keyframes")
#: Controls that draw from a random seed (key control.seed).
SEEDED_CONTROLS = ("sway", "walk", "dance", "flail")

#: Simulated seconds of `ellipsim run MODEL.xml` without --steps.
MJCF_DURATION = 2.0

#: Most steps a scenario may ask for (duration / timestep): beyond 2^53 a step count is no longer
#: an exact float64, and at a microsecond a step it would run for 285 years.
MAX_STEPS = 2**53

# Keys each table may hold, to name a misspelt one before anything else is checked.
_TOP_KEYS = ("description", "duration", "timestep", "mode", "kinematic", "gravity", "scene", "control")
_SCENE_KEYS = {
    "figures": (
        "kind",
        "seed",
        "figures",
        "layout",
        "spacing",
        "drop_height",
        "floor",
        "fixed_roots",
        "terrain",
        "props",
    ),
    "pile": ("kind", "seed", "ellipsoids", "bin_half_width"),
    "mjcf": ("kind", "path", "key", "ctrl"),
}
_CONTROL_KEYS = (
    "kind",
    "amplitude",
    "period",
    "phase_step",
    "seed",
    "arm",
    "shoulder_flex",
    "shoulder_abd",
    "shoulder_rot",
    "elbow",
    "ramp",
    "stagger",
    "keys",
)


class ScenarioError(UserError):
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
    scene: dict  # kind "mjcf": path (absolute), key (None, int or str), ctrl (one of CTRL_MODES)
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
    if not text.endswith((".toml", ".xml")) and text in available():
        return str(_directory() / f"{text}.toml")
    if text.endswith(".xml"):
        raise ScenarioError(f"model {text!r} does not exist or is not a file")
    if text.endswith(".toml"):
        raise ScenarioError(f"scenario file {text!r} does not exist or is not a file")
    raise ScenarioError(
        f"unknown scenario {text!r}; available: {', '.join(available())} (or a path to a .toml or MJCF .xml file)"
    )


def _unknown(path, prefix, table, known):
    """ScenarioError naming the first key of `table` not in `known`, and the nearest known key."""
    unknown = sorted(set(table) - set(known))
    if unknown:
        near = difflib.get_close_matches(unknown[0], known, n=1)
        hint = f"did you mean '{prefix}{near[0]}'? " if near else ""
        raise ScenarioError(f"{path}: unknown key '{prefix}{unknown[0]}' ({hint}known here: {', '.join(known)})")


#: The key each kind of scene, and of control, cannot do without.
_SCENE_REQUIRED = {"figures": "figures", "pile": "ellipsoids", "mjcf": "path"}
_CONTROL_REQUIRED = {"keyframes": "keys"}


def _missing(path, table):
    """ScenarioError naming every required key and table the scenario `table` lacks, in one message
    (a table whose kind or keys are wrong is left to the checks that name those)."""
    missing = [f"key '{k}'" for k in ("duration",) if k not in table]
    scene, control = table.get("scene"), table.get("control")
    if scene is None:
        missing.append("table [scene]")
    elif isinstance(scene, dict) and scene.get("kind", "figures") in _SCENE_REQUIRED:
        kind = scene.get("kind", "figures")
        if kind != "mjcf" and "timestep" not in table:
            missing.append("key 'timestep'")
        if not set(scene) - set(_SCENE_KEYS[kind]) and _SCENE_REQUIRED[kind] not in scene:
            missing.append(f"key 'scene.{_SCENE_REQUIRED[kind]}'")
    if control is None:
        missing.append("table [control]")
    elif isinstance(control, dict) and not set(control) - set(_CONTROL_KEYS):
        need = _CONTROL_REQUIRED.get(control.get("kind", "hold"))
        if need is not None and need not in control:
            missing.append(f"key 'control.{need}'")
    if missing:
        listed = missing[0] if len(missing) == 1 else ", ".join(missing[:-1]) + " and " + missing[-1]
        raise ScenarioError(f"{path}: missing {listed}")


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
        what = " or ".join(k.__name__ for k in kind) if isinstance(kind, tuple) else kind.__name__
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        what = ("an " if what[0] in "aeiou" else "a ") + what  # an int, a float
        if kind is bool and not isinstance(value, bool) or kind is not bool and isinstance(value, bool):
            raise self.error(key, f"must be {what}", value)
        if not isinstance(value, kind):
            raise self.error(key, f"must be {what}", value)
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
    """The Scenario of a name in scenarios/, of a .toml path, or of an MJCF .xml path, validated."""
    path = resolve(name_or_path)
    if _is_mjcf(path):
        return model_scenario(path)
    return from_table(read_table(path), path)


def read_table(path):
    """The TOML table of the scenario file at `path` (not validated); ScenarioError naming the file
    when it cannot be read or is not TOML."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror}") from None


def source_table(name_or_path):
    """(table, path): the TOML table of a scenario given as `load` takes it (an MJCF model: the
    table that loads as `model_scenario` does), for a caller to change before `from_table`."""
    path = resolve(name_or_path)
    if not _is_mjcf(path):
        return read_table(path), path
    s = model_scenario(path)
    return {
        "description": s.description,
        "duration": s.duration,
        "mode": s.mode,
        "scene": {"kind": "mjcf", "path": s.scene["path"]},
        "control": {"kind": "hold"},
    }, s.path


def from_table(table, path):
    """The Scenario of a TOML `table` validated as if it were the file at `path` (errors name that
    file; an mjcf scene's path is relative to its folder).  Its name is the file's, without .toml
    or .xml."""
    if not isinstance(table, dict):
        raise ScenarioError(f"{path}: a scenario must be a table, got {table!r}")
    _unknown(path, "", table, _TOP_KEYS)
    _missing(path, table)
    top = _Checker(path, table)
    description = top.get("description", str, "")
    duration = top.get("duration", float, required=True, positive=True)
    mode = top.get("mode", str, "narrowphase", choices=MODES)
    kinematic = top.get("kinematic", bool, False)
    gravity = top.get("gravity", list, [])
    if gravity and (
        len(gravity) != 3 or not all(isinstance(g, (int, float)) and not isinstance(g, bool) for g in gravity)
    ):
        raise top.error("gravity", "must be a list of three numbers (m/s^2)", gravity)
    scene = _scene(top.table_of("scene"), path)
    if scene["kind"] == "mjcf":
        timestep = top.get("timestep", float, None, positive=True)
        if timestep is None:
            timestep = _model_timestep(scene["path"], f"{path}: [scene] path")
    else:
        timestep = top.get("timestep", float, required=True, positive=True)
    if timestep > duration:
        raise top.error("timestep", f"must not exceed the duration {duration}", timestep)
    if duration / timestep > MAX_STEPS:
        raise top.error(
            "duration", f"is {duration / timestep:.3g} steps of {timestep:g} s; at most {MAX_STEPS:.3g}", duration
        )
    if scene["kind"] == "pile" and kinematic:
        raise top.error(
            "kinematic", "must be false for a pile scene (free ellipsoids have no joints to pose)", kinematic
        )
    if scene["kind"] == "mjcf" and kinematic:
        raise top.error(
            "kinematic",
            "must be false for an mjcf scene (to pose a model frame by frame: ellipsim replay MODEL MOTION)",
            kinematic,
        )
    control = _control(top.table_of("control"), kinematic, scene["kind"])
    top.done()
    base = os.path.basename(path)
    name = os.path.splitext(base)[0] if base.endswith((".toml", ".xml")) else base
    return Scenario(
        name, path, description, duration, timestep, mode, kinematic, tuple(float(g) for g in gravity), scene, control
    )


def _is_mjcf(path):
    """An .xml file, or a file that starts with '<' (XML), is an MJCF model rather than a TOML scenario."""
    if path.endswith(".xml"):
        return True
    if path.endswith(".toml"):
        return False
    try:
        with open(path, "rb") as f:
            return f.read(64).lstrip().startswith(b"<")
    except OSError:
        return False


def _model_timestep(path, label):
    """The timestep of the MJCF model at `path` (parsed, not compiled); ScenarioError naming `label`."""
    if not os.path.isfile(path):
        raise ScenarioError(f"{label}: model {path!r} does not exist or is not a file")
    try:
        return float(mujoco.MjSpec.from_file(path).option.timestep)
    except ValueError as exc:
        same = os.path.abspath(label) == path
        model = "this model" if same else f"the model {path!r}"  # the path once, where label names it
        raise ScenarioError(f"{label}: MuJoCo cannot read {model}: {one_line(exc)}") from None


def model_scenario(path, *, key=None, ctrl="hold"):
    """The Scenario of an MJCF model file: MJCF_DURATION seconds at the model's timestep, from
    keyframe `key` (None: the default pose), actuators held by `ctrl` (mjcf.CTRL_MODES), mode
    narrowphase.  ScenarioError naming the file when MuJoCo cannot read it.  The Scenario's path is the
    file as given (what messages show), its scene's path the absolute one (what is loaded)."""
    shown = os.fspath(path)
    path = os.path.abspath(shown)
    timestep = _model_timestep(path, shown)
    if not (math.isfinite(timestep) and timestep > 0):
        raise ScenarioError(f"{shown}: the model's timestep must be positive, got {timestep!r}")
    name = os.path.splitext(os.path.basename(path))[0]
    scene = {"kind": "mjcf", "path": path, "key": key, "ctrl": ctrl}
    return Scenario(
        name,
        shown,
        f"MJCF model {shown}",
        max(MJCF_DURATION, timestep),
        timestep,
        "narrowphase",
        False,
        (),
        scene,
        {"kind": "hold"},
    )


def with_model_options(s, *, key=None, ctrl=None):
    """Scenario `s` with the keyframe and the held controls of its model replaced (those given);
    ScenarioError when `s` is not of an MJCF model or `ctrl` is not one of CTRL_MODES."""
    if key is None and ctrl is None:
        return s
    if s.scene["kind"] != "mjcf":
        option = "--key" if key is not None else "--ctrl"
        raise ScenarioError(f"{option} applies to MJCF models; scenario {s.name!r} builds a {s.scene['kind']} scene")
    if ctrl is not None and ctrl not in CTRL_MODES:
        raise ScenarioError(f"ctrl must be one of {CTRL_MODES}, got {ctrl!r}")
    scene = dict(s.scene)
    if key is not None:
        scene["key"] = key
    if ctrl is not None:
        scene["ctrl"] = ctrl
    return dataclasses.replace(s, scene=scene)


def _scene(c, path):
    kind = c.get("kind", str, "figures", choices=SCENES)
    _unknown(c.path, c.prefix, c.table, _SCENE_KEYS[kind])
    if kind == "mjcf":
        model = c.get("path", str, required=True)
        model = os.path.join(os.path.dirname(os.path.abspath(path)), os.path.expanduser(model))
        key = c.get("key", (int, str), None)
        out = {
            "kind": kind,
            "path": os.path.normpath(model),
            "key": key,
            "ctrl": c.get("ctrl", str, "hold", choices=CTRL_MODES),
        }
        c.done()
        return out
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
        out["terrain"] = c.get("terrain", bool, False)
        out["props"] = c.get("props", int, 0)
        if out["props"] < 0 or (out["props"] and not out["terrain"]):
            raise c.error("props", "must be a non-negative count, and needs terrain = true", out["props"])
    else:
        out["ellipsoids"] = c.get("ellipsoids", int, required=True, positive=True)
        out["bin_half_width"] = c.get("bin_half_width", float, 0.5, positive=True)
    c.done()
    return out


def _control(c, kinematic, scene_kind):
    _unknown(c.path, c.prefix, c.table, _CONTROL_KEYS)
    kind = c.get("kind", str, "hold", choices=CONTROLS)
    if kinematic and kind != "keyframes":
        raise c.error("kind", "must be 'keyframes' for a kinematic scenario", kind)
    if scene_kind == "pile" and kind != "hold":
        raise c.error("kind", "must be 'hold' for a pile scene (free ellipsoids have no joints to drive)", kind)
    out = {"kind": kind}
    if kind in SEEDED_CONTROLS:
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
            for j in joints if scene_kind == "figures" else ():  # a model's actuators: checked when built
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
    return tuple(
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[a, 0]) for a in range(model.nu)
    )
