"""MuJoCo's built-in contacts against ellipsim's exact verdicts, candidate pair by candidate pair, for
every pair type ellipsim handles (judge.py), and the ellipsoid pairs that pass through each other within
one step (between.py).

One margin rule (judge.py): a pair is a contact when its distance is below its margin, on both sides.
Each pair where the two differ is a disagreement of one kind, the same words for every engine (the Warp
compare's too, app/warp_compare.py):

    mujoco_extra   the engine made a contact the exact test separates (signed distance >= margin)
    mujoco_missed  an exact contact (signed distance < margin) the engine did not make
    near_tangent   either of those within NEAR_TANGENT of the margin: the engine's ccd_tolerance allows it
    normal_off     the engine's contact (both make one, or the engine alone within NEAR_TANGENT of the margin)
                   has its normal more than NORMAL_OFF_DEG from the exact one, and its sigma falls short of
                   the exact distance by more than its ccd_tolerance
"""

import dataclasses

import mujoco
import numpy as np

from ..core.exact.contact_scale import contact_scale
from ..core.relation import Relation
from ..core.tolerances import NEAR_TANGENT
from .attachment import check_model_data
from .between import BetweenFrames, Events
from .geoms import PairRecorder, ellipsoid_geoms, explicit_pairs, pair_contacts, pair_gaps, pair_margins
from .judge import KEYS, NORMAL_OFF_DEG, ellipsoids_at, one_state_ellipsoids, sigma_at, verdicts_at

#: Values (float64) of ellipsoid poses `validate` holds before looking between the steps: 2^22 = 32 MB
#: (12 per ellipsoid and step; at most 1024 steps at a time).
STEP_VALUES = 2**22

#: The kinds of disagreement, in report order (module docstring).
KINDS = ("mujoco_extra", "mujoco_missed", "near_tangent", "normal_off")
#: One line each, for reports and legends.
KIND_MEANINGS = {
    "mujoco_extra": "the engine made a contact the exact test separates",
    "mujoco_missed": "an exact contact the engine did not make",
    "near_tangent": f"a contact on one side only, within {NEAR_TANGENT:g} m of the margin (the engine's tolerance)",
    "normal_off": f"the engine's contact with its normal beyond {NORMAL_OFF_DEG:g} deg of the exact one, "
    "worse than its tolerance allows",
}


@dataclasses.dataclass
class Disagreement:
    """A candidate pair on which MuJoCo's contact and ellipsim's verdict differ (`kind` mujoco_extra,
    mujoco_missed, near_tangent), or whose MuJoCo contact has its normal off (normal_off: both make a
    contact, or MuJoCo alone within NEAR_TANGENT of the margin)."""

    step: int
    geom1: int
    geom2: int
    names: tuple
    mujoco_contact: bool  # MuJoCo has a contact with dist < margin (active: not excluded by the gap)
    mujoco_dist: float  # the smallest dist of its contacts on the pair (nan if none)
    relation: str  # ellipsim's relation of the geoms themselves (no margin); "undecided" where not proven
    contact_scale: float  # Perram-Wertheim scale of the geoms themselves (ellipsoid and sphere pairs; nan else)
    geom_distance: float  # mujoco.mj_geomDistance (signed; capped at 1)
    right: str  # "ellipsim", "mujoco" or "undetermined", per the exact test
    reason: str
    margin: float = 0.0  # the pair's margin, as MuJoCo applies it (geoms.pair_margins)
    gap: float = 0.0  # the pair's gap (geoms.pair_gaps): contacts below margin + gap, excluded above margin
    signed_distance: float = float("nan")  # ellipsim's signed distance of the geoms (judge.verdicts)
    explicit: bool = False  # the pair is a <contact><pair> element
    mujoco_pos: tuple = None  # MuJoCo's contact on the pair with the smallest dist: its point (metres)
    mujoco_normal: tuple = None  # and its unit normal, from geom1 to geom2 (None without a contact)
    ellipsim_pos: tuple = (float("nan"),) * 3  # ellipsim's contact point (midpoint of the support points)
    ellipsim_normal: tuple = (float("nan"),) * 3  # and its unit normal, from geom1 to geom2
    kind: str = ""  # one of KINDS
    pair_type: str = ""  # one of judge.KEYS
    bodies: tuple = ()  # the geoms' bodies' names
    angle: float = float("nan")  # degrees between MuJoCo's and ellipsim's normals (nan: one side only)
    sigma_mujoco: float = float("nan")  # sigma at MuJoCo's normal: a lower bound on the signed distance


@dataclasses.dataclass
class Validation:
    """Per-step agreement of MuJoCo's contacts with ellipsim's exact verdicts.

    counts : (steps, 4) int64, columns COLUMNS: candidate pairs per step (every type ellipsim judges,
        dynamic and <pair> elements), by MuJoCo's contact (dist < margin) and ellipsim's verdict (signed
        distance < margin); by_type : (steps, T, 4) the same per pair type (judge.KEYS)
    normal_off : (steps, T) int64, pairs in contact on both sides whose MuJoCo normal is off (module docstring)
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
    by_type: np.ndarray = None
    normal_off: np.ndarray = None

    def totals(self):
        return {name: int(self.counts[:, k].sum()) for k, name in enumerate(self.COLUMNS)}


def validate(model, data, nstep, *, control=None, advance=True, progress=None, between=False, observer=None):
    """Step plain MuJoCo nstep times and compare, pair by pair, its contacts with ellipsim's verdicts.

    At each step, before mj_step, mj_forward runs collision; every candidate pair of a type ellipsim
    judges (ellipsoid with ellipsoid, sphere, capsule, box, cylinder, convex mesh or height field: those
    MuJoCo's broad phase
    produced, recorded by the callback, which otherwise behaves exactly like MuJoCo, and the model's
    <pair> elements MuJoCo collides: geoms.explicit_pairs) is judged with the pair's margin
    (geoms.pair_margins: the <pair> element's, the geoms' sum, or opt.o_margin under override): MuJoCo
    says contact when it made one with dist < margin (an active contact; one in the gap, margin <= dist
    < margin + gap, is excluded); ellipsim says contact when the geoms' signed distance is < margin
    (judge.verdicts: exact classification of ellipsoid pairs at margin 0 and for overlapping pairs;
    else the proven signed distance, decided unless within the proof tolerance of the margin).  Where
    both make a contact, MuJoCo's normal is checked against the exact one (normal_off).  Disagreements
    (module docstring) carry both distances and normals, contact_scale, mj_geomDistance and who is
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
    T = len(KEYS)
    by_type = np.zeros((nstep, T, 4), dtype=np.int64)
    normal_off = np.zeros((nstep, T), dtype=np.int64)
    ncon, n_explicit, n_open = (np.zeros(nstep, dtype=np.int64) for _ in range(3))
    disagreements = []
    names = Names.of(model)
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
            found = len(disagreements)
            if len(pairs):
                judged = _judge_step(model, data, step, pairs, explicit, names)
                by_type[step], normal_off[step], n_open[step] = judged.by_type, judged.normal_off, judged.undetermined
                disagreements.extend(judged.disagreements)
            if observer is not None:
                observer(model, data, step, disagreements[found:])
            if advance:
                mujoco.mj_step(model, data)
            if progress is not None:
                progress(step + 1, nstep)
    passed = Events.concatenate(events) if checker is not None else None
    return Validation(
        nstep,
        by_type.sum(axis=1),
        ncon,
        disagreements,
        passed,
        ids.astype(np.int64),
        checker.candidates if checker is not None else 0,
        n_explicit,
        n_open,
        contacts_disabled(model),
        by_type,
        normal_off,
    )


@dataclasses.dataclass(frozen=True)
class Names:
    """A model's geom names (MuJoCo's, or geom{i}) and each geom's body's name, for disagreements."""

    geoms: list
    bodies: list

    @classmethod
    def of(cls, model):
        geoms = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(model.ngeom)]
        body = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(model.nbody)]
        body[0] = "world"
        return cls(geoms, [body[b] for b in model.geom_bodyid])


def _judge_step(model, data, step, pairs, explicit, names):
    """One step's candidates (k, 2) on MuJoCo C judged: judge_contacts on data's state and contacts."""
    margin, gap = pair_margins(model, pairs), pair_gaps(model, pairs)
    xpos, xmat = data.geom_xpos[pairs], data.geom_xmat[pairs].reshape(-1, 2, 3, 3)
    engine = pair_contacts(model, data, pairs)
    return judge_contacts(model, step, pairs, xpos, xmat, margin, gap, explicit, engine, names, data=data)


@dataclasses.dataclass
class StepJudgement:
    """What judge_contacts finds on one step's candidates (T pair types: judge.KEYS).

    by_type : (T, 4) int64 candidates by COLUMNS (both, neither, engine only, ellipsim only)
    normal_off : (T,) int64; undetermined : verdicts not proven; disagreements : list of Disagreement
    verdicts : the judge.Verdicts of the candidates
    """

    by_type: np.ndarray
    normal_off: np.ndarray
    undetermined: int
    disagreements: list
    verdicts: object


def judge_contacts(
    model, step, pairs, xpos, xmat, margin, gap, explicit, engine, names, *, ccd_tolerance=None, data=None, who="MuJoCo"
):
    """An engine's contacts on one step's candidate pairs against the exact verdicts: the counts and the
    disagreements (module docstring's kinds), for MuJoCo C (validate) and MuJoCo Warp (app/warp_compare).

    pairs (k, 2) geom ids, g1 < g2; xpos (k, 2, 3), xmat (k, 2, 3, 3) their poses; margin, gap (k,) as
    MuJoCo applies them (geoms.pair_margins, pair_gaps); explicit (k,) bool, <pair> elements; engine :
    (dist (k,), normal (k, 3) from g1 to g2, pos (k, 3)), the engine's contact on each pair, nan where
    none; names : Names of the model; ccd_tolerance : the engine's (default the model's); data : MuJoCo
    C's data at the step (for mj_geomDistance in the reports), None for another engine; who : the
    engine as reasons name it.
    """
    ccd = float(model.opt.ccd_tolerance if ccd_tolerance is None else ccd_tolerance)
    dist, normal, pos = engine
    mj = dist < margin  # nan (no contact) compares False
    # measured where the engine made any contact (its normal is checked) and where either side says contact
    built = one_state_ellipsoids(model, pairs, xpos, xmat)
    v = verdicts_at(model, pairs, xpos, xmat, margin, measure=~np.isnan(dist), measure_within=True, ellipsoids=built)
    el = v.within
    T = len(KEYS)
    column = np.where(mj, np.where(el, 0, 2), np.where(el, 3, 1))
    by_type = np.bincount(v.kind * 4 + column, minlength=4 * T).reshape(T, 4)
    # normal_off: the engine's contact (both in contact, or the engine's alone within NEAR_TANGENT of the
    # margin) whose normal is far from the exact one and worse than its tolerance allows
    near = np.abs(v.dist - margin) < NEAR_TANGENT  # nan (not measured) compares False
    asked = np.flatnonzero(mj & (el | near) & np.isfinite(v.normal[:, 0]))
    cosine = np.clip(np.einsum("ki,ki->k", normal[asked], v.normal[asked]), -1.0, 1.0)
    far = asked[np.degrees(np.arccos(cosine)) > NORMAL_OFF_DEG]
    off, s_off = np.zeros(0, dtype=np.int64), np.zeros(0)
    if len(far):
        s_mj = sigma_at(model, pairs[far], xpos[far], xmat[far], normal[far])
        short = s_mj < v.dist[far] - ccd - v.tolerance[far]
        off, s_off = far[short], s_mj[short]
    normal_off = np.bincount(v.kind[off], minlength=T)
    context = _Context(model, data, step, names, xpos, xmat, v, margin, gap, explicit, ccd, who)
    found = [
        _explain(context, i, pairs[i], mj[i], dist[i], normal[i], pos[i])
        for i in np.setdiff1d(np.flatnonzero(mj != el), off)
    ]
    found += [_normal_off(context, i, pairs[i], dist[i], normal[i], pos[i], s) for i, s in zip(off, s_off)]
    found.sort(key=lambda d: (d.geom1, d.geom2))
    return StepJudgement(by_type, normal_off, int((~v.decided).sum()), found, v)


@dataclasses.dataclass
class _Context:
    """What explaining one step's disagreements needs."""

    model: object
    data: object
    step: int
    names: Names
    xpos: np.ndarray
    xmat: np.ndarray
    v: object
    margin: np.ndarray
    gap: np.ndarray
    explicit: np.ndarray
    ccd: float
    who: str


def contacts_disabled(model):
    """True when the model disables contacts (<option><flag contact="disable"/>, as dm_control's fish
    does): MuJoCo's collision makes no contact and calls no collision callback."""
    return bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)


def no_candidates_reason(model, validation=None):
    """Why a model gave no candidate pair to judge (a Validation with counts all zero): contacts disabled,
    no two geoms of a pair type ellipsim judges that may collide, or none came within reach."""
    from .attachment import ellipsoid_pair_possible

    if contacts_disabled(model):
        return 'the model disables contacts (<option><flag contact="disable"/>): MuJoCo collides nothing'
    if not ellipsoid_pair_possible(model, "narrowphase"):
        return (
            "the model has no pair ellipsim judges (an ellipsoid with an ellipsoid, sphere, capsule, box, cylinder, "
            "convex mesh or height field, by contype/conaffinity or a <pair> element)"
        )
    return "MuJoCo's broad phase brought no pair ellipsim judges within reach (bounding volumes, margins included)"


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
    """(k,) int64 g1 * ngeom + g2 of pairs (k, 2) with g1 < g2: their order as pair_contacts needs it."""
    return pairs[:, 0].astype(np.int64) * model.ngeom + pairs[:, 1]


def _common(c, i, pair):
    """The fields every disagreement of pair (g1, g2) (row i of the step's verdicts) carries."""
    g1, g2 = int(pair[0]), int(pair[1])
    v = c.v
    relation = int(v.relation[i])
    measured = c.data is not None
    return dict(
        step=c.step,
        geom1=g1,
        geom2=g2,
        names=(c.names.geoms[g1], c.names.geoms[g2]),
        bodies=(c.names.bodies[g1], c.names.bodies[g2]),
        relation=Relation(relation).name.lower() if relation >= 0 else "undecided",
        contact_scale=_contact_scale(c, i, pair),
        geom_distance=float(mujoco.mj_geomDistance(c.model, c.data, g1, g2, 1.0, None)) if measured else float("nan"),
        margin=float(c.margin[i]),
        gap=float(c.gap[i]),
        explicit=bool(c.explicit[i]),
        pair_type=KEYS[int(v.kind[i])],
        signed_distance=float(v.dist[i]),
        ellipsim_pos=tuple(float(x) for x in v.pos[i]),
        ellipsim_normal=tuple(float(x) for x in v.normal[i]),
    )


def _contact_scale(c, i, pair):
    """The Perram-Wertheim contact scale of an ellipsoid or sphere pair (nan for the other types)."""
    if KEYS[int(c.v.kind[i])] not in ("ellipsoid-ellipsoid", "ellipsoid-sphere"):
        return float("nan")
    a = ellipsoids_at(c.model, pair[:1], c.xpos[i, :1], c.xmat[i, :1])
    b = ellipsoids_at(c.model, pair[1:], c.xpos[i, 1:], c.xmat[i, 1:])
    return float(contact_scale(a, b)[0])


def _engine_side(dist, normal, pos):
    """The engine's contact fields of a disagreement: (dist, pos or None, normal or None)."""
    if dist != dist:
        return float("nan"), None, None
    return float(dist), tuple(float(x) for x in pos), tuple(float(x) for x in normal)


def _explain(c, i, pair, mj, dist, normal, pos):
    """The Disagreement of a pair in contact on one side only."""
    v, who = c.v, c.who
    margin = float(c.margin[i])
    sd, tol, decided = float(v.dist[i]), float(v.tolerance[i]), bool(v.decided[i])
    engine_dist, engine_pos, engine_normal = _engine_side(dist, normal, pos)
    near = abs(sd - margin) < NEAR_TANGENT
    kind = "near_tangent" if near else ("mujoco_extra" if mj else "mujoco_missed")
    where = "<pair>" if c.explicit[i] else "dynamic pair"
    told = f"{who}'s dist {engine_dist:.12g}" if mj else f"{who} made no contact"
    if not decided:
        right = "undetermined"
        why = f"within the proof tolerance {tol:.2g}" if abs(sd - margin) <= tol else "an UNPROVEN maximum"
        reason = f"{where}: signed distance {sd:.12g} against margin {margin:g}, {why}; {told}"
    elif v.relation[i] == Relation.OVERLAPPING and margin >= 0:
        right = "ellipsim"
        reason = f"{where}: exact: overlapping (signed distance {sd:.12g}), below margin {margin:g}; {told}"
    elif mj:
        right = "ellipsim"
        reason = f"{where}: proven signed distance {sd:.12g} >= margin {margin:g} (proof tolerance {tol:.2g}); " + (
            f"{who}'s contact (dist {engine_dist:.12g}) is within its ccd_tolerance {c.ccd:g}" if near else told
        )
    else:
        right = "ellipsim"
        reason = f"{where}: proven signed distance {sd:.12g} < margin {margin:g} (proof tolerance {tol:.2g}); {told}"
    angle = float("nan")
    if engine_normal is not None and np.isfinite(v.normal[i]).all():
        angle = float(np.degrees(np.arccos(np.clip(np.dot(normal, v.normal[i]), -1.0, 1.0))))
    return Disagreement(
        angle=angle,
        mujoco_contact=bool(mj),
        mujoco_dist=engine_dist,
        right=right,
        reason=reason,
        mujoco_pos=engine_pos,
        mujoco_normal=engine_normal,
        kind=kind,
        **_common(c, i, pair),
    )


def _normal_off(c, i, pair, dist, normal, pos, s_mj):
    """The Disagreement of a pair with the engine's contact whose normal is off."""
    v, who = c.v, c.who
    margin = float(c.margin[i])
    sd, tol = float(v.dist[i]), float(v.tolerance[i])
    engine_dist, engine_pos, engine_normal = _engine_side(dist, normal, pos)
    angle = float(np.degrees(np.arccos(np.clip(np.dot(normal, v.normal[i]), -1.0, 1.0))))
    right = "ellipsim" if v.proven[i] else "undetermined"
    proof = f"proven signed distance {sd:.12g}" if v.proven[i] else f"signed distance {sd:.12g} (maximum not proven)"
    reason = (
        f"{who}'s normal is {angle:.3g} deg from the exact one: sigma there is {float(s_mj):.12g}, "
        f"{sd - float(s_mj):.3g} m below the {proof} (ccd_tolerance {c.ccd:g}, proof tolerance {tol:.2g}); "
        f"{who}'s dist {engine_dist:.12g}"
    )
    if not v.within[i]:
        reason += f"; the pair itself is not in contact, but within {NEAR_TANGENT:g} m of margin {margin:g}"
    return Disagreement(
        mujoco_contact=True,
        mujoco_dist=engine_dist,
        right=right,
        reason=reason,
        mujoco_pos=engine_pos,
        mujoco_normal=engine_normal,
        kind="normal_off",
        angle=angle,
        sigma_mujoco=float(s_mj),
        **_common(c, i, pair),
    )
