"""MuJoCo's GJK/EPA contacts against ellipsim's narrow phase on the same states, refereed.

Every ellipsoid and sphere-ellipsoid contact of the data is compared, those of <contact><pair>
elements included; a contact exists when the signed distance is below the pair's margin + gap (MuJoCo
4.0 calls the collision function with margin + gap: geoms.py), so a contact on one side only is judged
against that threshold, by the proven signed distance.
"""

import copy
import dataclasses

import mujoco
import numpy as np

from ..core.distance.ellipsoid_pair import GLOBAL, signed_distance
from ..core.tolerances import ANGLE_TOL, DIST_TOL, NEAR_TANGENT, POS_TOL, TIGHT_CCD_ITERATIONS, TIGHT_CCD_TOLERANCE
from .attachment import Attachment, check_model_data
from .context import ELLIPSOID
from .geoms import explicit_pairs, pair_gaps, pair_margins
from .judge import enclosing, pair_type, proof_tolerance

#: the pair types compare_narrowphase compares: ellipsoid x ellipsoid and x sphere (judge.KEYS 0, 1)
_ROUND = (0, 1)


@dataclasses.dataclass
class ContactDifference:
    """An ellipsoid pair whose contact differs between MuJoCo and ellipsim beyond the bounds."""

    step: int
    geom1: int
    geom2: int
    names: tuple
    mujoco: tuple  # (dist, normal (3,), pos (3,)) or None: no contact
    ellipsim: tuple  # likewise
    ddist: float
    angle: float  # radians between the normals (nan if one side has no contact)
    dpos: float
    sigma_mujoco: float  # sigma(n) at MuJoCo's normal: the signed distance is the maximum of sigma
    sigma_ellipsim: float  # ... and at ellipsim's
    proven: bool  # ellipsim's maximum is proven global (core.distance.ellipsoid_pair GLOBAL)
    right: str  # "ellipsim", "mujoco" or "undetermined"
    reason: str
    threshold: float = 0.0  # the pair's margin + gap: a contact exists below it (geoms.pair_margins, pair_gaps)
    explicit: bool = False  # the pair is a <contact><pair> element


@dataclasses.dataclass
class NarrowphaseComparison:
    """Contacts of MuJoCo's GJK/EPA and of ellipsim's narrow phase on the same states."""

    steps: int
    matched: int  # ellipsoid pairs in contact on both sides
    near_tangent: int  # pairs in contact on one side only, with |dist - (margin + gap)| < NEAR_TANGENT
    max_ddist: float  # over matched pairs
    max_angle: float
    max_dpos: float
    differences: list  # ContactDifference beyond DIST_TOL / ANGLE_TOL / POS_TOL, or unmatched
    explicit_matched: int = 0  # of `matched`, the pairs of <contact><pair> elements


@dataclasses.dataclass
class _Contacts:
    """The ellipsoid and sphere-ellipsoid contacts of a data, one per (geom1, geom2) as the contacts
    name them (the last, when MuJoCo made several), sorted by key = geom1 * ngeom + geom2."""

    key: np.ndarray  # (k,) int64
    dist: np.ndarray  # (k,)
    normal: np.ndarray  # (k, 3)
    pos: np.ndarray  # (k, 3)

    def at(self, j):
        """Contact j as (dist, normal (3,), pos (3,))."""
        return float(self.dist[j]), self.normal[j].copy(), self.pos[j].copy()

    def get(self, key):
        """The contact with `key`, or None."""
        j = int(np.searchsorted(self.key, key))
        return self.at(j) if j < len(self.key) and self.key[j] == key else None


def _ellipsoid_contacts(model, data):
    """_Contacts of the ellipsoid and sphere-ellipsoid contacts in data."""
    con, n = data.contact, data.ncon
    geom = con.geom[:n].astype(np.int64)
    kept = np.flatnonzero(np.isin(pair_type(model, geom[:, 0], geom[:, 1]), _ROUND))
    key, first_from_end = np.unique((geom[kept, 0] * model.ngeom + geom[kept, 1])[::-1], return_index=True)
    last = kept[::-1][first_from_end]
    return _Contacts(key, con.dist[:n][last], con.frame[:n][last, :3], con.pos[:n][last])


def _sigma(model, data, g1, g2, n):
    """sigma(n) = n . (c2 - c1) - h1(n) - h2(-n) for the geoms' ellipsoids, n normalised."""
    n = np.asarray(n, float) / np.linalg.norm(n)

    def h(g, v):
        r = model.geom_size[g] if model.geom_type[g] == ELLIPSOID else np.repeat(model.geom_size[g, 0], 3)
        return float(np.linalg.norm(r * (data.geom_xmat[g].reshape(3, 3).T @ v)))

    return float(n @ (data.geom_xpos[g2] - data.geom_xpos[g1]) - h(g1, n) - h(g2, -n))


def compare_narrowphase(model, data, nstep, *, progress=None):
    """Step plain MuJoCo nstep times; at each state compare MuJoCo's ellipsoid contacts with ellipsim's.

    At every step the same state is collided twice (mj_forward): with MuJoCo's functions and with
    mode="narrowphase"; then plain mj_step advances.  Pairs in contact on both sides are compared
    (dist, normal angle, position); a difference beyond the bounds in tolerances.py, or a contact on
    one side only with |dist - threshold| >= NEAR_TANGENT (threshold: the pair's margin + gap, below
    which MuJoCo makes a contact; the <pair> element's for explicit pairs), is reported with the
    referee: the signed distance is the maximum over n of sigma(n), so sigma at each side's normal
    shows whose is better, and when ellipsim's maximum is proven global it is the exact answer to
    rounding (a contact on one side only: the side whose contact agrees with `proven signed distance
    < threshold` is right; within the proof tolerance of the threshold, or unproven, undetermined).
    Deep penetrations that sigma cannot settle are re-collided by MuJoCo at ccd_tolerance
    TIGHT_CCD_TOLERANCE.
    """
    check_model_data(model, data)
    if not isinstance(nstep, (int, np.integer)) or nstep < 1:
        raise ValueError(f"nstep must be a positive integer, got {nstep!r}")
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(model.ngeom)]
    matched = near = explicit_matched = 0
    named = explicit_pairs(model)
    named = named[np.isin(pair_type(model, named[:, 0], named[:, 1]), _ROUND)]
    named = named[:, 0].astype(np.int64) * model.ngeom + named[:, 1]
    worst = [0.0, 0.0, 0.0]
    differences = []
    tight = copy.copy(model)  # a third opinion for what sigma cannot settle: GJK/EPA run to 1e-11
    tight.opt.ccd_tolerance, tight.opt.ccd_iterations = TIGHT_CCD_TOLERANCE, TIGHT_CCD_ITERATIONS
    tight_data = mujoco.MjData(tight)
    for step in range(nstep):
        mujoco.mj_getState(model, data, state, spec)
        mujoco.mj_forward(model, data)
        theirs = _ellipsoid_contacts(model, data)
        with Attachment(model, data, "narrowphase"):
            mujoco.mj_setState(model, data, state, spec)
            mujoco.mj_forward(model, data)
            ours = _ellipsoid_contacts(model, data)
        mujoco.mj_setState(model, data, state, spec)
        mujoco.mj_forward(model, data)
        keys = np.union1d(theirs.key, ours.key)
        g = np.stack(divmod(keys, model.ngeom), axis=1)
        threshold = pair_margins(model, g) + pair_gaps(model, g)
        explicit = np.isin(np.minimum(g[:, 0], g[:, 1]) * model.ngeom + np.maximum(g[:, 0], g[:, 1]), named)
        i_mj, i_el = np.searchsorted(theirs.key, keys), np.searchsorted(ours.key, keys)
        on_mj, on_el = np.isin(keys, theirs.key), np.isin(keys, ours.key)
        both = on_mj & on_el
        m, e = i_mj[both], i_el[both]
        ddist = np.abs(theirs.dist[m] - ours.dist[e])
        # vecdot and sqrt(vecdot) are the per-vector a @ b and np.linalg.norm, to the bit
        angle = np.arccos(np.clip(np.vecdot(theirs.normal[m], ours.normal[e]), -1.0, 1.0))
        dp = theirs.pos[m] - ours.pos[e]
        dpos = np.sqrt(np.vecdot(dp, dp))
        matched += int(both.sum())
        explicit_matched += int((both & explicit).sum())
        worst = [float(np.fmax.reduce(x, initial=w)) for w, x in zip(worst, (ddist, angle, dpos))]  # fmax: as max()
        within = np.zeros(len(keys), dtype=bool)
        within[both] = (ddist <= DIST_TOL) & (angle <= ANGLE_TOL) & (dpos <= POS_TOL)
        one_dist = np.empty(len(keys))  # the dist of the one side in contact
        one_dist[on_el], one_dist[on_mj] = ours.dist[i_el[on_el]], theirs.dist[i_mj[on_mj]]
        tangent = ~both & (np.abs(one_dist - threshold) < NEAR_TANGENT)
        near += int(tangent.sum())
        for j in np.flatnonzero(~(within | tangent)):
            mj = theirs.at(i_mj[j]) if on_mj[j] else None
            el = ours.at(i_el[j]) if on_el[j] else None
            key = divmod(int(keys[j]), model.ngeom)
            differences.append(_referee(model, data, step, key, names, mj, el, float(threshold[j]), bool(explicit[j])))
        undetermined = [x for x in differences if x.step == step and x.right == "undetermined"]
        if undetermined:
            mujoco.mj_setState(tight, tight_data, state, spec)
            mujoco.mj_forward(tight, tight_data)
            third = _ellipsoid_contacts(tight, tight_data)
            for x in undetermined:
                t = third.get(x.geom1 * model.ngeom + x.geom2)
                if t is not None and x.mujoco and x.ellipsim:
                    el_err, mj_err = abs(t[0] - x.ellipsim[0]), abs(t[0] - x.mujoco[0])
                    x.right = "ellipsim" if el_err < mj_err else "mujoco"
                    x.reason += (
                        f"; MuJoCo at ccd_tolerance {TIGHT_CCD_TOLERANCE:g} gives {t[0]:.12g}: "
                        f"{el_err:.2g} from ellipsim, {mj_err:.2g} from MuJoCo's default"
                    )
        mujoco.mj_step(model, data)
        if progress is not None:
            progress(step + 1, nstep)
    return NarrowphaseComparison(nstep, matched, near, *worst, differences, explicit_matched)


def _referee(model, data, step, key, names, mj, el, threshold, explicit):
    g1, g2 = key
    zero = np.zeros(1)
    a = enclosing(model, data, np.array([g1]), zero)
    b = enclosing(model, data, np.array([g2]), zero)
    dist, normal, pos, status = signed_distance(a, b)
    proven = bool(status[0] == GLOBAL)
    tol = float(proof_tolerance(a, b)[0])
    s_el = _sigma(model, data, g1, g2, normal[0])
    s_mj = _sigma(model, data, g1, g2, mj[1]) if mj else float("nan")
    ddist = abs(mj[0] - el[0]) if mj and el else float("nan")
    angle = float(np.arccos(np.clip(mj[1] @ el[1], -1, 1))) if mj and el else float("nan")
    dpos = float(np.linalg.norm(mj[2] - el[2])) if mj and el else float("nan")
    eps = 1e-12 * float(np.abs(model.geom_size[[g1, g2]]).max())
    if mj and s_mj > s_el + eps:
        right, reason = "mujoco", f"MuJoCo's normal reaches sigma {s_mj:.9g} > ellipsim's {s_el:.9g}"
    elif proven and not (mj and el):
        side = "MuJoCo only" if mj else "ellipsim only"
        sd = float(dist[0])
        below = sd < threshold
        if abs(sd - threshold) <= tol:
            right = "undetermined"
        else:  # a contact belongs below the threshold: the side with one is right iff the pair is below
            right = "ellipsim" if below == bool(el) else "mujoco"
        reason = (
            f"contact on {side}; proven signed distance {sd:.12g} {'<' if below else '>='} threshold {threshold:g} "
            f"(margin + gap{' of the <pair>' if explicit else ''}; proof tolerance {tol:.2g})"
        )
    elif proven:
        right = "ellipsim"
        reason = (
            f"ellipsim's maximum is proven global: signed distance {s_el:.9g}; MuJoCo reports {mj[0]:.9g} "
            f"and its normal reaches only sigma {s_mj:.9g} (ccd_tolerance {model.opt.ccd_tolerance:g})"
        )
    elif not (mj and el):
        right, reason = (
            "undetermined",
            f"contact on one side only, no proof in budget: sigma {s_el:.9g} against threshold {threshold:g}",
        )
    elif mj and mj[0] < s_el - eps:
        right = "ellipsim"
        reason = (
            f"deep penetration (no proof in budget): MuJoCo's depth {-mj[0]:.9g} exceeds the "
            f"depth {-s_el:.9g} along ellipsim's normal, so it is too deep by at least the difference"
        )
    else:
        right, reason = "undetermined", f"deep penetration, no proof in budget: sigma {s_el:.9g}"
    return ContactDifference(
        step,
        g1,
        g2,
        (names[g1], names[g2]),
        mj,
        el,
        ddist,
        angle,
        dpos,
        s_mj,
        s_el,
        proven,
        right,
        reason,
        threshold,
        explicit,
    )
