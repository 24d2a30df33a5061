"""A user's MJCF model: loaded as MuJoCo loads it, put in its initial state (a keyframe or the
default pose), with controls that hold its actuators.

    model = load_model("fly.xml")                 # includes and assets relative to the file
    data = mujoco.MjData(model)
    key = keyframe(model, "stand")                # a name or an index; None: the default pose
    start(model, data, key, ctrl="hold")          # reset, forward, set data.ctrl (and data.act)

Errors are ModelError (an errors.UserError, a ValueError) with one line naming the file and, for keyframes and
controls, the available choices.
"""

import os

import mujoco
import numpy as np

from .errors import UserError

#: How the actuators are driven when nothing else drives them (`start`'s ctrl).
CTRL_MODES = ("hold", "zero", "keyframe")

_INTEGRATOR = int(mujoco.mjtDyn.mjDYN_INTEGRATOR)
_FIXED_GAIN = int(mujoco.mjtGain.mjGAIN_FIXED)
_AFFINE_BIAS = int(mujoco.mjtBias.mjBIAS_AFFINE)


class ModelError(UserError):
    """A model that cannot be used as asked; the message names the file (one line)."""


def one_line(text):
    """MuJoCo's multi-line error text as one line: its lines joined by '; ', blank ones dropped."""
    return "; ".join(line.strip() for line in str(text).splitlines() if line.strip())


def load_model(path):
    """mujoco.MjModel of the MJCF file `path` (str or os.PathLike), compiled by MuJoCo with
    includes, meshes and other assets resolved relative to the file's folder.

    ModelError when the path is not a file, or MuJoCo refuses the model (its message, one line),
    or cannot allocate the model's memory arena (then with a hint at <size memory>).
    """
    try:
        text = os.fspath(path)
    except TypeError:
        raise ModelError(f"model must be a path to an MJCF .xml file, got {path!r}") from None
    if not os.path.isfile(text):
        raise ModelError(f"model {text!r} does not exist or is not a file")
    try:
        return mujoco.MjModel.from_xml_path(text)
    except ValueError as exc:
        message = one_line(exc)
        if "allocate memory" in message:
            raise ModelError(
                f'{text}: MuJoCo could not allocate the model\'s memory ({message}); set <size memory="..."/> '
                "in the model to what it needs (MuJoCo's default grows with the square of the number of bodies)"
            ) from None
        raise ModelError(f"{text}: MuJoCo cannot load this model: {message}") from None


def make_data(model, label):
    """mujoco.MjData(model); ModelError naming `label` if MuJoCo cannot allocate it."""
    try:
        return mujoco.MjData(model)
    except (ValueError, MemoryError, mujoco.FatalError) as exc:
        raise ModelError(
            f"{label}: MuJoCo could not allocate the model's data ({one_line(exc) or type(exc).__name__}); "
            'set a smaller <size memory="..."/>, or free memory'
        ) from None


def keyframe(model, key, label="model"):
    """Index of keyframe `key` of `model`: None (the default pose: None), an int or a numeric string
    (an index, negative from the end), or a keyframe name.  ModelError naming `label` otherwise."""
    if key is None:
        return None
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"#{k}" for k in range(model.nkey)]
    listing = f"it has {model.nkey}: {', '.join(names)}" if model.nkey else "it has none"
    if isinstance(key, bool):
        raise ModelError(f"{label}: key must be a keyframe name or index, got {key!r}")
    if isinstance(key, (int, np.integer)) or (isinstance(key, str) and key.lstrip("-").isdigit()):
        index = int(key)
        if not -model.nkey <= index < model.nkey:
            raise ModelError(f"{label}: keyframe index {index} is out of range; {listing}")
        return index % model.nkey
    if isinstance(key, str):
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, key)
        if index < 0:
            raise ModelError(f"{label}: no keyframe named {key!r}; {listing}")
        return index
    raise ModelError(f"{label}: key must be a keyframe name or index, got {key!r}")


def held_controls(model, data):
    """(nu,) ctrl that holds each actuator where the current state puts it: the zero-force target of
    position-like actuators (fixed gain, affine bias: ctrl = -(bias0 + bias1 length) / gain, i.e.
    the current joint position of a <position> servo), 0 for motors and velocity servos; clipped
    to ctrlrange where it is limited.  For integrator actuators (<intvelocity>) ctrl is 0 and the
    activation is the one to hold: see `start`.  data must be after mj_forward."""
    gain = model.actuator_gainprm[:, 0]
    bias = model.actuator_biasprm
    position_like = (
        (model.actuator_gaintype == _FIXED_GAIN) & (model.actuator_biastype == _AFFINE_BIAS)
        & (gain != 0) & (bias[:, 1] != 0)
    )  # fmt: skip
    target = np.zeros(model.nu)
    target[position_like] = (
        -(bias[position_like, 0] + bias[position_like, 1] * data.actuator_length[position_like]) / gain[position_like]
    )
    return _clip(model, target), position_like


def _clip(model, ctrl):
    limited = model.actuator_ctrllimited.astype(bool)
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    return np.where(limited, np.clip(ctrl, lo, hi), ctrl)


def start(model, data, key=None, ctrl="hold", label="model"):
    """Reset data to keyframe index `key` (from `keyframe`) or the default pose (None), run
    mj_forward, and set data.ctrl by `ctrl`:

    "hold"      actuators hold the initial pose (held_controls; integrator actuators through act)
    "zero"      every ctrl 0
    "keyframe"  the keyframe's ctrl (needs a key)

    Returns the ctrl (nu,) that was set.  ModelError naming `label` for a bad `ctrl`.
    """
    if ctrl not in CTRL_MODES:
        raise ModelError(f"{label}: ctrl must be one of {CTRL_MODES}, got {ctrl!r}")
    if ctrl == "keyframe" and key is None:
        raise ModelError(f"{label}: ctrl 'keyframe' takes the controls of a keyframe: choose one with key (--key)")
    if key is None:
        mujoco.mj_resetData(model, data)
    else:
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    if ctrl == "zero":
        data.ctrl[:] = 0.0
    elif ctrl == "hold":
        target, position_like = held_controls(model, data)
        integrator = (model.actuator_dyntype == _INTEGRATOR) & (model.actuator_actadr >= 0)
        for a in np.flatnonzero(integrator & position_like):  # <intvelocity>: hold through the activation
            data.act[model.actuator_actadr[a]] = target[a]
        target[integrator] = 0.0
        data.ctrl[:] = target
    return data.ctrl.copy()


def geom_counts(model):
    """{kind: count} of the model's geoms, by MuJoCo's type names (for summaries)."""
    names = {int(v): k[len("mjGEOM_") :].lower() for k, v in mujoco.mjtGeom.__members__.items()}
    kinds, counts = np.unique(model.geom_type, return_counts=True)
    return {names.get(int(k), str(k)): int(c) for k, c in zip(kinds, counts)}
