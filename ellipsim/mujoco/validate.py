"""MuJoCo's built-in contacts against ellipsim's exact verdicts, candidate pair by candidate pair, and
the ellipsoid pairs that pass through each other within one step (between.py)."""

import dataclasses

import mujoco
import numpy as np

from ..core.distance.ellipsoid_pair import signed_distance
from ..core.exact.contact_scale import contact_scale
from ..core.relation import Relation
from .attachment import check_model_data
from .between import BetweenFrames, Events
from .geoms import (
    PairRecorder,
    ellipsoid_geoms,
    enclosing,
    explicit_pairs,
    pair_contact_dist,
    pair_gaps,
    pair_margins,
    proof_tolerance,
    within_threshold,
)

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
    mujoco_contact: bool  # MuJoCo has a contact with dist < margin (active: not excluded by the gap)
    mujoco_dist: float  # the smallest dist of its contacts on the pair (nan if none)
    relation: str  # ellipsim's exact relation of the geoms themselves (no margin)
    contact_scale: float  # Perram-Wertheim scale of the geoms themselves
    geom_distance: float  # mujoco.mj_geomDistance (signed; capped at 1)
    right: str  # "ellipsim", "mujoco" or "undetermined", per the exact test
    reason: str
    margin: float = 0.0  # the pair's margin, as MuJoCo applies it (geoms.pair_margins)
    gap: float = 0.0  # the pair's gap (geoms.pair_gaps): contacts below margin + gap, excluded above margin
    signed_distance: float = float("nan")  # ellipsim's signed distance of the geoms (core.distance.ellipsoid_pair)
    explicit: bool = False  # the pair is a <contact><pair> element
    mujoco_pos: tuple = None  # MuJoCo's contact on the pair with the smallest dist: its point (metres)
    mujoco_normal: tuple = None  # and its unit normal, from geom1 to geom2 (None without a contact)
    ellipsim_pos: tuple = (float("nan"),) * 3  # ellipsim's contact point (midpoint of the support points)
    ellipsim_normal: tuple = (float("nan"),) * 3  # and its unit normal, from geom1 to geom2


@dataclasses.dataclass
class Validation:
    """Per-step agreement of MuJoCo's contacts with ellipsim's exact verdicts.

    counts : (steps, 4) int64, columns COLUMNS: candidate ellipsoid pairs per step, dynamic and <pair>
        elements, by MuJoCo's contact (dist < margin) and ellipsim's verdict (signed distance < margin)
    explicit : (steps,) int64, how many of a step's candidates are <contact><pair> elements
    undetermined : (steps,) int64, candidates whose verdict is not proven (within the proof tolerance
        of the margin, or an UNPROVEN maximum): counted in `counts` by ellipsim's float estimate, and
        reported as right = "undetermined" when that disagrees with MuJoCo
    contacts_disabled : the model disables contacts (<option><flag contact="disable"/>: MuJoCo
        collides nothing, so there is no candidate pair and nothing to compare; contacts_disabled())
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
    explicit: np.ndarray = None
    undetermined: np.ndarray = None
    contacts_disabled: bool = False

    def totals(self):
        return {name: int(self.counts[:, k].sum()) for k, name in enumerate(self.COLUMNS)}


def validate(model, data, nstep, *, control=None, advance=True, progress=None, between=False, observer=None):
    """Step plain MuJoCo nstep times and compare, pair by pair, its contacts with ellipsim's verdicts.

    At each step, before mj_step, mj_forward runs collision; every candidate ellipsoid pair (those
    MuJoCo's broad phase produced, recorded by the callback, which otherwise behaves exactly like
    MuJoCo, and the model's <pair> elements MuJoCo collides: geoms.explicit_pairs) is judged with the
    pair's margin (geoms.pair_margins: the <pair> element's, the geoms' sum, or opt.o_margin under
    override): MuJoCo says contact when it made one with dist < margin (an active contact; one in the
    gap, margin <= dist < margin + gap, is excluded); ellipsim says contact when the geoms' signed
    distance is < margin (geoms.within_threshold: exact classification at margin 0 and for
    overlapping pairs; else the proven signed distance, decided unless within the proof tolerance of
    the margin).  Disagreements carry contact_scale, mj_geomDistance, the signed distance and who is
    right by the exact test.

    control : optional callable(model, data, step) run before each mj_forward (set ctrl, or a pose)
    advance : mj_step after each comparison (False for kinematic replays that set every pose)
    progress : optional callable(step, nstep), called after each step
    between : also find the ellipsoid pairs separated at two consecutive steps that touch in between
        (Validation.passed_through; mujoco.between, core.motion.time_of_impact on the interpolated motion)
    observer : optional callable(model, data, step, disagreements), after each step's comparison and
        before mj_step (MuJoCo's contacts of the step in data; disagreements, the step's new ones)
    """
    check_model_data(model, data)
    if not isinstance(nstep, (int, np.integer)) or nstep < 1:
        raise ValueError(f"nstep must be a positive integer, got {nstep!r}")
    counts = np.zeros((nstep, 4), dtype=np.int64)
    ncon, n_explicit, n_open = (np.zeros(nstep, dtype=np.int64) for _ in range(3))
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
            pairs, explicit = _candidates(model, data, recorder.forward())
            ncon[step], n_explicit[step] = data.ncon, int(explicit.sum())
            if checker is not None:
                centers[held], rotations[held], times[held] = data.geom_xpos[ids], data.geom_xmat[ids], data.time
                held += 1
                if held == capacity or step == nstep - 1:
                    events.append(
                        checker.check(np.arange(first, first + held), times[:held], centers[:held], rotations[:held])
                    )
                    first, held = first + held, 0
            if len(pairs):
                margin, gap = pair_margins(model, pairs), pair_gaps(model, pairs)
                el, decided, sd, relation = within_threshold(model, data, pairs, margin)
                dist = pair_contact_dist(model, data, pairs)
                mj = dist < margin
                counts[step] = np.bincount(np.where(mj, np.where(el, 0, 2), np.where(el, 3, 1)), minlength=4)
                n_open[step] = int((~decided).sum())
                found = len(disagreements)
                for i in np.flatnonzero(mj != el):
                    g1, g2 = int(pairs[i, 0]), int(pairs[i, 1])
                    facts = (
                        bool(mj[i]),
                        dist[i],
                        relation[i],
                        margin[i],
                        gap[i],
                        sd[i],
                        bool(decided[i]),
                        bool(explicit[i]),
                    )
                    disagreements.append(_explain(model, data, step, g1, g2, names, *facts))
            else:
                found = len(disagreements)
            if observer is not None:
                observer(model, data, step, disagreements[found:])
            if advance:
                mujoco.mj_step(model, data)
            if progress is not None:
                progress(step + 1, nstep)
    passed = Events.concatenate(events) if checker is not None else None
    return Validation(
        nstep,
        counts,
        ncon,
        disagreements,
        passed,
        ids.astype(np.int64),
        checker.candidates if checker is not None else 0,
        n_explicit,
        n_open,
        contacts_disabled(model),
    )


def contacts_disabled(model):
    """True when the model disables contacts (<option><flag contact="disable"/>, as dm_control's fish
    does): MuJoCo's collision makes no contact and calls no collision callback."""
    return bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)


def _candidates(model, data, dynamic):
    """The step's candidates: (pairs (k, 2), g1 < g2, sorted; explicit (k,) bool), the dynamic pairs the
    recorder saw and the <pair> elements MuJoCo collides, each geom pair once (MuJoCo skips a dynamic
    pair a <pair> element names before the filter sees it; the drop here only guards that)."""
    if model.npair == 0:
        return dynamic, np.zeros(len(dynamic), dtype=bool)
    named = explicit_pairs(model, data)
    dynamic = dynamic[~np.isin(_key(model, dynamic), _key(model, explicit_pairs(model)))]
    pairs = np.concatenate([dynamic, named]).astype(np.int32)
    order = np.argsort(_key(model, pairs), kind="stable")
    return pairs[order], np.concatenate([np.zeros(len(dynamic), dtype=bool), np.ones(len(named), dtype=bool)])[order]


def _key(model, pairs):
    """(k,) int64 g1 * ngeom + g2 of pairs (k, 2) with g1 < g2: their order as pair_contact_dist needs it."""
    return pairs[:, 0].astype(np.int64) * model.ngeom + pairs[:, 1]


def _explain(model, data, step, g1, g2, names, mj, dist, relation, margin, gap, sd, decided, explicit):
    geom_distance = float(mujoco.mj_geomDistance(model, data, g1, g2, 1.0, None))
    zero = np.zeros(1)
    a, b = enclosing(model, data, np.array([g1]), zero), enclosing(model, data, np.array([g2]), zero)
    scale = float(contact_scale(a, b)[0])
    rel = Relation(int(relation)).name.lower()
    measured, normal, point, _ = signed_distance(a, b)
    if sd != sd:  # settled by classify alone: the signed distance is for the report
        sd = measured[0]
    sd = float(sd)
    mujoco_pos = mujoco_normal = None
    if data.ncon:
        con = data.contact
        on = np.flatnonzero(
            ((con.geom[:, 0] == g1) & (con.geom[:, 1] == g2)) | ((con.geom[:, 0] == g2) & (con.geom[:, 1] == g1))
        )
        if len(on):
            k = on[np.argmin(con.dist[on])]
            mujoco_pos = tuple(float(x) for x in con.pos[k])
            sign = 1.0 if con.geom[k, 0] == g1 else -1.0  # MuJoCo's normal points from its geom1 to its geom2
            mujoco_normal = tuple(sign * float(x) for x in con.frame[k, :3])
    tol = float(proof_tolerance(a, b)[0])
    kind = "<pair>" if explicit else "dynamic pair"
    if not decided:
        right = "undetermined"
        why = f"within the proof tolerance {tol:.2g}" if abs(sd - margin) <= tol else "an UNPROVEN maximum"
        reason = f"{kind}: signed distance {sd:.12g} against margin {margin:g}, {why}; MuJoCo's dist {dist:.12g}"
    elif margin == 0:
        right = "ellipsim"
        if mj:  # MuJoCo made a contact the exact test rules out
            reason = f"exact: {rel} at margin 0; MuJoCo's contact is within its ccd tolerance"
        else:
            reason = "exact: overlapping; MuJoCo made no contact"
    else:
        right = "ellipsim"
        if mj:
            reason = (
                f"{kind}: proven signed distance {sd:.12g} >= margin {margin:g} (proof tolerance {tol:.2g}); "
                f"MuJoCo's contact (dist {dist:.12g}) is within its ccd tolerance"
            )
        elif relation == Relation.OVERLAPPING:
            reason = f"{kind}: exact: overlapping, below margin {margin:g}; MuJoCo made no contact"
        else:
            reason = f"{kind}: proven signed distance {sd:.12g} < margin {margin:g} (proof tolerance {tol:.2g}); MuJoCo made no contact"
    return Disagreement(
        step,
        g1,
        g2,
        (names[g1], names[g2]),
        mj,
        float(dist),
        rel,
        scale,
        geom_distance,
        right,
        reason,
        float(margin),
        float(gap),
        sd,
        explicit,
        mujoco_pos,
        mujoco_normal,
        tuple(float(x) for x in point[0]),
        tuple(float(x) for x in normal[0]),
    )
