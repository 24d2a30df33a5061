"""Scripted controls: position targets of every actuator as a function of time.

hold, sway, walk, dance (periodic patterns per joint), flail (random sines within the joint
ranges), reach (one arm to a pose) and keyframes (smoothstep between keys), as a scenario's
[control] table names them.  Actuators are named by their joint (without a figure's "f{i}_"
prefix) or by their own name, so the same controls drive the figure and a user's MJCF model.
"""

import math

import mujoco
import numpy as np

_JOINT_TRANSMISSIONS = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))
_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)


def _split_figure(name):
    """(figure index, name without it) of "f{i}_name"; (0, name) for a name without the prefix."""
    fig, sep, base = name.partition("_")
    if sep and fig.startswith("f") and fig[1:].isdigit():
        return int(fig[1:]), base
    return 0, name


def _actuated_joints(model):
    """For each actuator: (figure index, joint name without the "f{i}_" prefix, qpos address), with
    the actuator's own name in place of the joint's and qpos address -1 when it drives no joint."""
    out = []
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) in _JOINT_TRANSMISSIONS:
            j = model.actuator_trnid[a, 0]
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
            adr = int(model.jnt_qposadr[j])
        else:
            name, adr = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or "", -1
        fig, base = _split_figure(name)
        out.append((fig, base, adr))
    return out


def _actuator_names(model):
    """Each actuator's own name without a figure prefix ("" when unnamed)."""
    return [_split_figure(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or "")[1] for a in range(model.nu)]


def _angular(model):
    """(nu,) bool: the actuator drives a hinge joint (its targets are angles, given in degrees)."""
    joint = np.isin(model.actuator_trntype, _JOINT_TRANSMISSIONS)
    jnt = np.where(joint, model.actuator_trnid[:, 0], 0)
    return joint & (model.jnt_type[jnt] == _HINGE) if model.njnt else np.zeros(model.nu, dtype=bool)


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


#: Joints the reach control moves (either arm).
_REACH_JOINTS = {f"{j}_{side}" for j in ("shoulder_flex", "shoulder_abd", "shoulder_rot", "elbow") for side in "lr"}


class Controller:
    """Controls (position targets, radians for hinges) of every actuator as a function of time, for
    a scenario's control, added to `base`.

    base : (nu,) the controls that hold the initial pose (a user's model: mjcf.start's ctrl);
        default zeros, the figure's standing pose.  Periodic patterns, reach and flail move about
        it; keyframes set the actuators they name and leave the others at it.
    Each kind is precomputed into per-actuator arrays, so a call is a few numpy operations.
    ValueError when the control names actuators the model does not have, or moves none of them.
    """

    def __init__(self, model, control, base=None):
        self.kind, self.c = control["kind"], control
        self.joints = _actuated_joints(model)
        self.qadr = np.array([adr for _, _, adr in self.joints], dtype=np.intp)  # qpos address per actuator
        nu = len(self.joints)
        self.base = np.zeros(nu) if base is None else np.asarray(base, dtype=np.float64).copy()
        if self.base.shape != (nu,):
            raise ValueError(f"base must have shape ({nu},) (one control per actuator), got {self.base.shape}")
        limited = model.actuator_ctrllimited.astype(bool)
        self.lo = np.where(limited, model.actuator_ctrlrange[:, 0], -np.inf)
        self.hi = np.where(limited, model.actuator_ctrlrange[:, 1], np.inf)
        deg = math.pi / 180
        fig = np.array([f for f, _, _ in self.joints], dtype=float)
        names = [j for _, j, _ in self.joints]
        aliases = _actuator_names(model)
        if self.kind in _PATTERNS or self.kind == "reach":
            known = set(_PATTERNS[self.kind]) if self.kind in _PATTERNS else _REACH_JOINTS
            if nu and not any(j in known or a in known for j, a in zip(names, aliases)):
                raise ValueError(
                    f"control {self.kind!r} moves the figure's joints ({', '.join(sorted(known))}); "
                    f"none of the model's {nu} actuators drives one of them"
                )
        if self.kind in _PATTERNS:
            table = _PATTERNS[self.kind]
            rows = [table.get(j, table.get(a, (0, 0, 0, 0))) for j, a in zip(names, aliases)]
            self.coef = np.array(rows, dtype=float).reshape(nu, 4).T * control["amplitude"] * deg
            self.phase = fig * control["phase_step"]
            self.w = 2 * math.pi / control["period"]
        elif self.kind == "flail":
            rng = np.random.default_rng(control["seed"])
            self.w = 2 * math.pi / control["period"] * rng.uniform(0.6, 1.6, nu)
            self.phase = rng.uniform(0, 2 * math.pi, nu)
            if nu and not limited.any():
                raise ValueError(
                    "control 'flail' swings actuators across their ctrlrange; none of the model's actuators has one"
                )
            self.mid = np.where(limited, 0.5 * (self.lo + self.hi), self.base) if nu else np.zeros(0)
            self.half = np.where(limited, 0.5 * (self.hi - self.lo) * control["amplitude"], 0.0) if nu else np.zeros(0)
        elif self.kind == "reach":
            side = "_r" if control["arm"] == "right" else "_l"
            goal = {
                f"shoulder_flex{side}": control["shoulder_flex"],
                f"shoulder_abd{side}": control["shoulder_abd"],
                f"shoulder_rot{side}": control["shoulder_rot"],
                f"elbow{side}": control["elbow"],
            }
            self.goal = np.array([goal.get(j, goal.get(a, 0.0)) for j, a in zip(names, aliases)]) * deg
        elif self.kind == "keyframes":
            keys = control["keys"]
            valid = set(names) | set(aliases)
            for i, (_, k) in enumerate(keys):
                unknown = sorted(set(k) - valid)
                if unknown:
                    raise ValueError(
                        f"keys[{i}].joints names {unknown[0]!r}, which no actuator drives; the model's actuators "
                        f"are {', '.join(sorted(n for n in valid if n)) or 'none'}"
                    )
            unit = np.where(_angular(model), deg, 1.0)  # degrees for hinges, the actuator's own units otherwise
            self.key_t = np.array([t for t, _ in keys])
            self.key_q = np.array(
                [
                    [
                        k[j] * unit[a] if j in k else k[n] * unit[a] if n in k else self.base[a]
                        for a, (j, n) in enumerate(zip(names, aliases))
                    ]
                    for _, k in keys
                ]
            ).reshape(len(keys), nu)  # (K, nu)
            self.shift = fig * control["stagger"]

    def __call__(self, t):
        if self.kind == "hold":
            out = self.base
        elif self.kind in _PATTERNS:
            x = self.w * t + self.phase
            c = np.cos(x)
            out = (
                self.base
                + self.coef[0]
                + self.coef[1] * np.sin(x)
                + self.coef[2] * np.maximum(c, 0)
                + self.coef[3] * np.maximum(-c, 0)
            )
        elif self.kind == "flail":
            out = self.mid + self.half * np.sin(self.w * t + self.phase)
        elif self.kind == "reach":
            out = self.base + _smoothstep(t / self.c["ramp"]) * self.goal
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
