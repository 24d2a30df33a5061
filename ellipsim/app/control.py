"""Scripted controls: position targets of every actuator as a function of time.

hold, sway, walk, dance (periodic patterns per joint), flail (random sines within the joint
ranges), reach (one arm to a pose) and keyframes (smoothstep between keys), as a scenario's
[control] table names them.
"""

import math

import mujoco
import numpy as np


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
