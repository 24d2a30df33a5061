"""A scenario's MuJoCo contacts against the exact test, step by step (a mujoco.Validation): the
counts per step, per pair type and in total, the disagreements by kind (mujoco_extra, mujoco_missed,
near_tangent, normal_off: mujoco.validate's words, the Warp compare's too), and their summary and JSON
report (`ellipsim compare`).
"""

import dataclasses

import numpy as np

from ..mujoco.judge import KEYS, NORMAL_OFF_DEG
from ..mujoco.validate import KIND_MEANINGS, KINDS

#: the counters of the totals and of each pair type in the JSON report (and the sweep's columns)
COUNTERS = (
    "pairs",
    "agreement",
    "mujoco_contacts",
    "ellipsim_contacts",
    "mujoco_extra",
    "mujoco_missed",
    "near_tangent",
    "normal_off",
    "undetermined",
)


def by_kind(disagreements):
    """{kind: [Disagreement, ...]} for every kind of mujoco.validate.KINDS, in their order."""
    out = {kind: [] for kind in KINDS}
    for d in disagreements:
        out[d.kind].append(d)
    return out


def counters(validation, column=None):
    """The COUNTERS of pair-type index `column` (None: all types) of a Validation, as a dict of ints."""
    disagreements = validation.disagreements
    counts = validation.by_type.sum(axis=0)  # (T, 4)
    rows = counts if column is None else counts[column : column + 1]
    both, neither, mujoco_only, ellipsim_only = (int(x) for x in rows.sum(axis=0))
    mine = [d for d in disagreements if column is None or d.pair_type == KEYS[column]]
    kinds = by_kind(mine)
    return {
        "pairs": both + neither + mujoco_only + ellipsim_only,
        "agreement": both + neither,
        "mujoco_contacts": both + mujoco_only,
        "ellipsim_contacts": both + ellipsim_only,
        **{kind: len(kinds[kind]) for kind in KINDS},
        "undetermined": sum(d.right == "undetermined" for d in mine),
    }


@dataclasses.dataclass
class Comparison:
    """What `ellipsim compare` reports of a scenario's validation.

    builtin, ours : (steps,) int64, candidate pairs in contact per step (dist < margin) by MuJoCo and by ellipsim
    kinds : {kind: [mujoco.validate.Disagreement]} (by_kind), every kind present
    passed_through : the pairs that passed through each other within one step, as capture.describe_events
        dicts with "step" for "frame" (None when not looked for)
    no_candidates : why there was no candidate pair (None when there were some)
    """

    scenario: str
    steps: int
    validation: object  # mujoco.Validation
    builtin: np.ndarray
    ours: np.ndarray
    kinds: dict
    passed_through: list = None
    no_candidates: str = None

    @classmethod
    def of(cls, name, validation, model):
        """The Comparison of scenario `name`'s validation on `model`."""
        from ..mujoco.validate import no_candidates_reason
        from . import capture  # MuJoCo and the kernels: sweep imports this module in its parent process

        counts = validation.counts
        passed = None
        if validation.passed_through is not None:
            names = capture.ModelNames.of(model)
            events = capture.describe_events(validation.passed_through, validation.ellipsoid_ids, names)
            passed = [{("step" if k == "frame" else k): value for k, value in d.items()} for d in events]
        builtin, ours = counts[:, 0] + counts[:, 2], counts[:, 0] + counts[:, 3]
        none = no_candidates_reason(model, validation) if int(counts.sum()) == 0 else None
        return cls(name, validation.steps, validation, builtin, ours, by_kind(validation.disagreements), passed, none)

    @property
    def disagreements(self):
        """Every disagreement, in step order."""
        return self.validation.disagreements

    @property
    def pairs(self):
        return int(self.validation.counts.sum())

    @property
    def agree(self):
        return int(self.validation.counts[:, 0].sum() + self.validation.counts[:, 1].sum())

    def totals(self):
        """The COUNTERS over every pair type."""
        return counters(self.validation)

    def by_pair_type(self):
        """{pair type key: COUNTERS} for every pair type ellipsim judges (judge.KEYS), in their order."""
        return {key: counters(self.validation, k) for k, key in enumerate(KEYS)}

    def summary(self, show):
        """The lines `ellipsim compare` prints, `show` disagreements and passed-through pairs at most."""
        pairs, builtin, ours = self.pairs, self.builtin, self.ours
        lines = []
        if self.no_candidates is not None:
            lines.append(f"  no candidate pairs in {self.steps} steps: {self.no_candidates}")
        else:
            t = self.totals()
            lines += [
                f"  candidate pairs (every type ellipsim judges, MuJoCo's broad phase and <pair> elements): {pairs} over "
                f"{self.steps} steps; MuJoCo and the exact test agree on contact (distance < margin) in "
                f"{t['agreement']} ({t['agreement'] / pairs:.4%})",
                f"  in contact per step: MuJoCo mean {builtin.mean():.2f} (max {builtin.max()}), ellipsim mean "
                f"{ours.mean():.2f} (max {ours.max()}); in all MuJoCo {builtin.sum()}, ellipsim {ours.sum()}",
                "  " + _kinds_line(t),
                "  by pair type:",
            ]
            none = []
            for key, c in self.by_pair_type().items():
                if c["pairs"] == 0:
                    none.append(key)
                    continue
                lines.append(
                    f"    {key}: {c['pairs']} pairs, contacts MuJoCo {c['mujoco_contacts']} / ellipsim "
                    f"{c['ellipsim_contacts']}; " + _kinds_line(c)
                )
            if none:
                lines.append(f"    no candidate pairs: {', '.join(none)}")
        disagreements = self.disagreements
        if disagreements:
            lines.append("  disagreements (" + "; ".join(f"{k}: {m}" for k, m in KIND_MEANINGS.items()) + "):")
        for d in disagreements[:show]:
            lines.append("    " + line(d))
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
        """The JSON report (`ellipsim compare --json`): totals and the same per pair type, per-step
        counts, every disagreement."""
        counts = self.validation.counts
        return {
            "scenario": self.scenario,
            "engine": "mujoco",
            "steps": self.steps,
            **self.totals(),
            "no_candidates": self.no_candidates,
            "contacts_disabled": self.validation.contacts_disabled,
            "normal_off_deg": NORMAL_OFF_DEG,
            "by_pair_type": self.by_pair_type(),
            "per_step": {
                "mujoco_contacts": self.builtin.tolist(),
                "ellipsim_contacts": self.ours.tolist(),
                "both": counts[:, 0].tolist(),
                "neither": counts[:, 1].tolist(),
                "mujoco_only": counts[:, 2].tolist(),
                "ellipsim_only": counts[:, 3].tolist(),
            },
            "disagreements": [disagreement_json(d) for d in self.disagreements],
            "passed_through": self.passed_through,
        }


def _kinds_line(c):
    return ", ".join(f"{c[kind]} {kind}" for kind in KINDS) + (
        f" ({c['undetermined']} undetermined)" if c["undetermined"] else ""
    )


def line(d, engine="MuJoCo", world=None):
    """One line of text for a disagreement: step, kind, pair type, geoms and bodies, both distances and
    normals, who is right and why."""
    where = f"step {d.step}" + (f", world {world}" if world is not None else "")
    theirs = (
        f"{engine} dist {d.mujoco_dist:.6g} m, normal {_vector(d.mujoco_normal)}"
        if d.mujoco_contact
        else f"{engine}: no contact"
    )
    angle = f", {d.angle:.3g} deg apart" if d.angle == d.angle else ""
    bodies = f" (bodies {d.bodies[0]} / {d.bodies[1]})" if d.bodies else ""
    return (
        f"{where}: {d.kind}: {d.pair_type} {d.names[0]} / {d.names[1]}{bodies}; {theirs}; ellipsim "
        f"{d.relation}, signed distance {d.signed_distance:.6g} m, normal {_vector(d.ellipsim_normal)}{angle}; "
        f"margin {d.margin:g}; right: {d.right} ({d.reason})"
    )


def _vector(v):
    return "none" if v is None else "(" + ", ".join(f"{x:.4f}" for x in v) + ")"


def disagreement_json(d, **extra):
    """A disagreement as a JSON object (the same keys for every engine; `extra` adds e.g. the world)."""
    return {
        "step": d.step,
        **extra,
        "kind": d.kind,
        "pair_type": d.pair_type,
        "geoms": list(d.names),
        "bodies": list(d.bodies),
        "explicit": d.explicit,
        "margin": d.margin,
        "mujoco": {
            "contact": d.mujoco_contact,
            "dist": _number(d.mujoco_dist),
            "pos": _vector_json(d.mujoco_pos),
            "normal": _vector_json(d.mujoco_normal),
        },
        "ellipsim": {
            "relation": d.relation,
            "signed_distance": _number(d.signed_distance),
            "pos": _vector_json(d.ellipsim_pos),
            "normal": _vector_json(d.ellipsim_normal),
        },
        "angle_deg": _number(d.angle),
        "contact_scale": _number(d.contact_scale),
        "geom_distance": _number(d.geom_distance),
        "right": d.right,
        "reason": d.reason,
    }


def _number(x):
    """A float for JSON: None for nan."""
    return None if x != x else float(x)


def _vector_json(v):
    """A 3-vector for JSON: None when absent."""
    return None if v is None else [_number(x) for x in v]
