"""MuJoCo's built-in contacts against ellipsim's exact verdicts, candidate pair by candidate pair, and
the ellipsoid pairs that pass through each other within one step (between.py)."""

import dataclasses

import mujoco
import numpy as np

from ..core.classify import classify
from ..core.perram_wertheim import contact_scale
from ..core.relation import Relation
from .attachment import check_model_data
from .between import BetweenFrames, Events
from .geoms import PairRecorder, ellipsoid_geoms, enclosing, pair_contact_dist, pair_margins

#: Values (float64) of ellipsoid poses `validate` holds before looking between the steps: 2^22 = 32 MB
#: (12 per ellipsoid and step; at most 1024 steps at a time).
STEP_VALUES = 2**22


@dataclasses.dataclass
class Disagreement:
    """A candidate pair on which MuJoCo's contact and ellipsim's verdict differ."""

    step: int
    geom1: int
    geom2: int
    names: tuple
    mujoco_contact: bool  # MuJoCo has a contact with dist < margin
    mujoco_dist: float  # that contact's dist (nan if none)
    relation: str  # ellipsim's exact relation of the margin-enclosing ellipsoids
    contact_scale: float  # Perram-Wertheim scale of the margin-enclosing ellipsoids
    geom_distance: float  # mujoco.mj_geomDistance (signed; capped at 1)
    right: str  # "ellipsim", "mujoco" or "undetermined", per the exact test
    reason: str


@dataclasses.dataclass
class Validation:
    """Per-step agreement of MuJoCo's contacts with ellipsim's exact verdicts.

    counts : (steps, 4) int64, columns COLUMNS: candidate ellipsoid pairs per step
    passed_through : between.Events, ellipsoid pairs separated at step k and at step k + 1 that touch in
        between on the interpolated motion (pairs index `ellipsoid_ids`; the geoms themselves, margins
        not included); None when not looked for.  mj_step's motion between two steps is not that
        interpolation (centre linear, rotation along the shortest arc): an event says the two poses
        are consistent with passing through each other within the step, not that MuJoCo's did.
    """

    COLUMNS = ("both", "neither", "mujoco_only", "ellipsim_only")
    steps: int
    counts: np.ndarray
    mujoco_contacts: np.ndarray  # (steps,) all contacts MuJoCo made (every geom type)
    disagreements: list
    passed_through: Events = None
    ellipsoid_ids: np.ndarray = None
    between_candidates: int = 0

    def totals(self):
        return {name: int(self.counts[:, k].sum()) for k, name in enumerate(self.COLUMNS)}


def validate(model, data, nstep, *, control=None, advance=True, progress=None, between=False):
    """Step plain MuJoCo nstep times and compare, pair by pair, its contacts with ellipsim's verdicts.

    At each step, before mj_step, mj_forward runs collision; every candidate ellipsoid pair MuJoCo's
    broad phase produced (recorded by the callback, which otherwise behaves exactly like MuJoCo) is
    classified: MuJoCo says contact when it made one with dist < margin; ellipsim says contact when
    the ellipsoids grown by margin/2 each (enclosing the margin bodies; exact when margin = 0)
    overlap.  Disagreements carry contact_scale, mj_geomDistance and who is right by the exact test.

    control : optional callable(model, data, step) run before each mj_forward (set ctrl, or a pose)
    advance : mj_step after each comparison (False for kinematic replays that set every pose)
    progress : optional callable(step, nstep), called after each step
    between : also find the ellipsoid pairs separated at two consecutive steps that touch in between
        (Validation.passed_through; mujoco.between, core.time_of_impact on the interpolated motion)
    """
    check_model_data(model, data)
    if not isinstance(nstep, (int, np.integer)) or nstep < 1:
        raise ValueError(f"nstep must be a positive integer, got {nstep!r}")
    counts = np.zeros((nstep, 4), dtype=np.int64)
    ncon = np.zeros(nstep, dtype=np.int64)
    disagreements = []
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(model.ngeom)]
    ids, radii, rules = ellipsoid_geoms(model)
    checker = BetweenFrames(radii, rules) if between else None
    capacity = int(min(1024, max(2, STEP_VALUES // max(12 * len(ids), 1))))
    centers, rotations, times = np.empty((capacity, len(ids), 3)), np.empty((capacity, len(ids), 9)), np.empty(capacity)
    events, held, first = [], 0, 0
    with PairRecorder(model, data) as recorder:
        for step in range(nstep):
            if control is not None:
                control(model, data, step)
            pairs = recorder.forward()
            ncon[step] = data.ncon
            if checker is not None:
                centers[held], rotations[held], times[held] = data.geom_xpos[ids], data.geom_xmat[ids], data.time
                held += 1
                if held == capacity or step == nstep - 1:
                    events.append(checker.check(np.arange(first, first + held), times[:held], centers[:held], rotations[:held]))
                    first, held = first + held, 0
            if len(pairs):
                margin = pair_margins(model, pairs)
                a = enclosing(model, data, pairs[:, 0], np.maximum(margin, 0) / 2)
                b = enclosing(model, data, pairs[:, 1], np.maximum(margin, 0) / 2)
                relation = classify(a, b)
                dist = pair_contact_dist(model, data, pairs)
                mj = dist < margin
                el = relation == Relation.OVERLAPPING
                counts[step] = np.bincount(np.where(mj, np.where(el, 0, 2), np.where(el, 3, 1)), minlength=4)
                for i in np.flatnonzero(mj != el):
                    g1, g2 = int(pairs[i, 0]), int(pairs[i, 1])
                    disagreements.append(_explain(model, data, step, g1, g2, names, bool(mj[i]), dist[i], relation[i], margin[i], a[i], b[i]))
            if advance:
                mujoco.mj_step(model, data)
            if progress is not None:
                progress(step + 1, nstep)
    passed = Events.concatenate(events) if checker is not None else None
    return Validation(nstep, counts, ncon, disagreements, passed, ids.astype(np.int64),
                      checker.candidates if checker is not None else 0)  # fmt: skip


def _explain(model, data, step, g1, g2, names, mj, dist, relation, margin, a, b):
    geom_distance = float(mujoco.mj_geomDistance(model, data, g1, g2, 1.0, None))
    scale = float(contact_scale(a, b)[0])
    rel = Relation(int(relation)).name.lower()
    if mj:  # MuJoCo made a contact the exact test rules out
        right, reason = "ellipsim", f"exact: {rel} at margin {margin:g}; MuJoCo's contact is within its ccd tolerance"
    elif margin <= 0 or _bare_overlap(model, data, g1, g2):
        right, reason = "ellipsim", "exact: overlapping; MuJoCo made no contact"
    else:
        right = "undetermined"
        reason = f"ellipsim tested an ellipsoid enclosing the margin body; mj_geomDistance {geom_distance:.3g} vs margin {margin:g}"
    return Disagreement(step, g1, g2, (names[g1], names[g2]), mj, float(dist), rel, scale, geom_distance, right, reason)


def _bare_overlap(model, data, g1, g2):
    zero = np.zeros(1)
    a = enclosing(model, data, np.array([g1]), zero)
    b = enclosing(model, data, np.array([g2]), zero)
    return classify(a, b)[0] == Relation.OVERLAPPING
