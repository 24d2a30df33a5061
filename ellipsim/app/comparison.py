"""A scenario's MuJoCo contacts against the exact test, step by step (a mujoco.Validation): the
counts per step and in total, the disagreements split into missed / extra / near-tangent (as sweep's
columns are), and their summary and JSON report (`ellipsim compare`).
"""

import dataclasses

import numpy as np

from ..core.tolerances import NEAR_TANGENT


def split_disagreements(validation):
    """(missed, extra, near_tangent) lists of a mujoco.Validation's disagreements: within
    NEAR_TANGENT metres of touching (mj_geomDistance), else MuJoCo's contact the exact test
    separates (missed), else an overlap MuJoCo made no contact for (extra)."""
    missed, extra, near = [], [], []
    for d in validation.disagreements:
        if abs(d.geom_distance) < NEAR_TANGENT:
            near.append(d)
        elif d.mujoco_contact:
            missed.append(d)
        else:
            extra.append(d)
    return missed, extra, near


@dataclasses.dataclass
class Comparison:
    """What `ellipsim compare` reports of a scenario's validation.

    builtin, ours : (steps,) int64, ellipsoid pairs in contact per step by MuJoCo and by ellipsim
    missed, extra, near : mujoco.validate.Disagreement lists (split_disagreements)
    passed_through : the pairs that passed through each other within one step, as capture.describe_events
        dicts with "step" for "frame" (None when not looked for)
    """

    scenario: str
    steps: int
    validation: object  # mujoco.Validation
    builtin: np.ndarray
    ours: np.ndarray
    missed: list
    extra: list
    near: list
    passed_through: list = None

    @classmethod
    def of(cls, name, validation, model):
        """The Comparison of scenario `name`'s validation on `model`."""
        from . import capture  # MuJoCo and the kernels: sweep imports this module in its parent process

        counts = validation.counts
        passed = None
        if validation.passed_through is not None:
            names = capture.ModelNames.of(model)
            events = capture.describe_events(validation.passed_through, validation.ellipsoid_ids, names)
            passed = [{("step" if k == "frame" else k): value for k, value in d.items()} for d in events]
        missed, extra, near = split_disagreements(validation)
        builtin, ours = counts[:, 0] + counts[:, 2], counts[:, 0] + counts[:, 3]
        return cls(name, validation.steps, validation, builtin, ours, missed, extra, near, passed)

    @property
    def pairs(self):
        return int(self.validation.counts.sum())

    @property
    def agree(self):
        return int(self.validation.counts[:, 0].sum() + self.validation.counts[:, 1].sum())

    def summary(self, show):
        """The lines `ellipsim compare` prints, `show` disagreements and passed-through pairs at most."""
        agree, pairs, builtin, ours = self.agree, self.pairs, self.builtin, self.ours
        if self.validation.contacts_disabled and pairs == 0:
            agreement = 'none to compare: the model disables contacts (<option><flag contact="disable"/>)'
        else:
            agreement = f"agreement {agree}/{pairs} ({agree / max(pairs, 1):.4%})"
        lines = [
            f"  candidate ellipsoid pairs: {pairs} over {self.steps} steps; {agreement}",
            f"  in contact per frame: MuJoCo mean {builtin.mean():.2f} (max {builtin.max()}), ellipsim mean {ours.mean():.2f} (max {ours.max()})",
            f"  totals: MuJoCo {builtin.sum()}, ellipsim {ours.sum()}",
            f"  disagreements: {len(self.missed)} missed (MuJoCo contact, ellipsim separated), {len(self.extra)} extra "
            f"(ellipsim overlapping, no MuJoCo contact), {len(self.near)} within {NEAR_TANGENT:g} m of touching",
        ]
        disagreements = self.missed + self.extra + self.near
        for d in disagreements[:show]:
            lines.append(
                f"    step {d.step}: {d.names[0]} / {d.names[1]}: MuJoCo {'contact' if d.mujoco_contact else 'none'}, "
                f"ellipsim {d.relation}, contact_scale {d.contact_scale:.9f}, mj_geomDistance {d.geom_distance:.3g}; "
                f"right: {d.right} ({d.reason})"
            )
        if len(disagreements) > show:
            lines.append(f"    ... and {len(disagreements) - show} more (--show N, or --json)")
        if self.passed_through is not None:
            from .capture import between_lines

            lines += between_lines(self.passed_through, self.validation.between_candidates, None, show, "steps")
        else:
            lines.append(
                "  ellipsoid pairs passing through each other within one step: not looked for (--between-frames)"
            )
        return lines

    def report(self):
        """The JSON report (`ellipsim compare --json`): totals, per-step counts, every disagreement."""
        counts = self.validation.counts
        return {
            "scenario": self.scenario,
            "steps": self.steps,
            "builtin_contacts": int(self.builtin.sum()),
            "ellipsim_overlaps": int(self.ours.sum()),
            "missed": len(self.missed),
            "extra": len(self.extra),
            "near_tangent": len(self.near),
            "agreement": self.agree,
            "pairs": self.pairs,
            "contacts_disabled": self.validation.contacts_disabled,
            "per_frame": {
                "builtin_contacts": self.builtin.tolist(),
                "ellipsim_overlaps": self.ours.tolist(),
                "both": counts[:, 0].tolist(),
                "neither": counts[:, 1].tolist(),
                "mujoco_only": counts[:, 2].tolist(),
                "ellipsim_only": counts[:, 3].tolist(),
            },
            "disagreements": [
                {
                    "step": d.step,
                    "geoms": list(d.names),
                    "kind": kind,
                    "mujoco_contact": d.mujoco_contact,
                    "mujoco_dist": None if d.mujoco_dist != d.mujoco_dist else d.mujoco_dist,
                    "relation": d.relation,
                    "contact_scale": d.contact_scale,
                    "geom_distance": d.geom_distance,
                    "signed_distance": _number(d.signed_distance),
                    "mujoco_pos": _vector(d.mujoco_pos),
                    "mujoco_normal": _vector(d.mujoco_normal),
                    "ellipsim_pos": _vector(d.ellipsim_pos),
                    "ellipsim_normal": _vector(d.ellipsim_normal),
                    "right": d.right,
                    "reason": d.reason,
                }
                for kind, ds in (("missed", self.missed), ("extra", self.extra), ("near_tangent", self.near))
                for d in ds
            ],
            "passed_through": self.passed_through,
        }


def _number(x):
    """A float for JSON: None for nan."""
    return None if x != x else float(x)


def _vector(v):
    """A 3-vector for JSON: None when absent."""
    return None if v is None else [_number(x) for x in v]
