"""`ellipsim fix`: a motion corrected until no two ellipsoid limbs come closer than a clearance.

    result = fix_motion(model, motion, clearance=0.005)      # a FixResult; result.motion (frames, nq)

Per frame, the smallest change of qpos in a metric (MuJoCo's joint-space inertia M(q), the kinetic
energy of the change, or the identity) that leaves every candidate ellipsoid pair of the model's collision
rules (mujoco.geoms: contype/conaffinity, parent-child, <exclude>) at least `clearance` apart: a sequence
of quadratic programs on the pairs closer than clearance (Gauss-Newton on the constraints, a
sequential-QP step),

    min 1/2 d^T W d   subject to   dist_k + J_k d >= clearance + slack   for each such pair k,

J_k = d dist_k / d qpos from ellipsim.mujoco.distance_jacobian (exact derivatives at a proven global
maximum), solved exactly through its dual (a nonnegative least-squares problem, scipy's BVLS), d applied by
mj_integratePos (free and ball joints stay on the unit quaternions), limited hinges and slides clamped into
their ranges.  Smooth across frames: the per-frame changes are spread to `smooth` frames on either side
with a cos^2 taper (per dof, the largest tapered change of the neighbourhood), and every frame then
projected again from there, so a correction ramps in and out instead of popping.  Consistent across
frames: a frame of a run of bad frames starts from the previous frame's corrected pose (its change carried
over), so a limb pushed out of another to one side stays on that side as the original motion goes deeper;
each frame's own smallest change flips to the other side midway, and the limb then passes through between
those two frames, which no local repair undoes (the replay dance: 192 contacts between frames before the
repair and 19 after it without this, 166 and 0 with it).  Two frames both kept
apart can still touch in between (interpolating two poses that each just clear a limb cuts the corner):
contacts between frames (mujoco.between: time_of_impact on the interpolated motion) get both frames
corrected together, with constraints on the poses in between.  Frames whose
neighbourhood needs no change keep their qpos bit for bit: a motion without a pair closer than the
clearance comes back unchanged.

Verified afterwards: every corrected frame's pairs by the proven signed distance (>= clearance); the
command line also replays the result (replay.replay: exact classify of every frame, contacts between frames).  A pair that no change within the iterations frees (two geoms of one rigid
body set, a joint at its limit, the model's own rest pose) is reported, never silently dropped.
"""

import dataclasses
import time

import mujoco
import numpy as np
from scipy.optimize import lsq_linear

from ..core.distance.ellipsoid_pair import GLOBAL, signed_distance
from ..mujoco.between import BetweenFrames
from ..mujoco.geoms import ellipsoid_geoms, frame_pairs
from ..mujoco.jacobian import _bodies, distance_jacobian, interpolated_distance_jacobian
from .mjcf import make_data

METRICS = ("mass", "identity")
#: the pair types fix keeps apart, as indices into mujoco.judge.KEYS: ellipsoid x ellipsoid and x sphere
PAIR_TYPES = (0, 1)
#: Gauss-Newton iterations per frame before a pair is declared not freed
MAX_ITERATIONS = 30
#: target = clearance + SLACK_REL * (the model's smallest ellipsoid semi-axis): the constraints are
#: linearised, so each step aims a little beyond the clearance (the next check is the exact distance);
#: 1e-4: a few micrometres on the figure, enough that competing pairs settle in a few steps
SLACK_REL = 1e-4
#: rounds of adding the limited joints' ranges that a step crosses as constraints of its QP
LIMIT_ROUNDS = 4
#: the largest change of any one dof per Gauss-Newton step (radians or metres): a trust region, since the
#: constraints are linearised (a pair whose Jacobian row is small asks for a step far beyond where the
#: linearisation holds, and overshoots)
STEP_MAX = 0.25
#: rounds of the between-frames repair (_repair_between), the margin kept in between doubling each round
#: from 4 slack up to BETWEEN_MARGIN_MAX slack (5 % of the smallest semi-axis: with 20 uncapped rounds the
#: margin reached metres and the corrections diverged on the dance, 8e3 instead of 102).  The rounds past
#: the cap settle neighbouring frame pairs that push each other back (the 64-figure dance: 8, 2 and 0
#: contacts left after 8, 12 and 16 rounds)
BETWEEN_ROUNDS = 16
BETWEEN_MARGIN_MAX = 512.0
#: Why a contact between frames is left, and why one is not checked (FixResult.between, half_turns)
BETWEEN_REASON = (
    f"contacts between frames: {BETWEEN_ROUNDS} rounds of correcting both frames together, with the motion in "
    "between constrained, did not free them"
)
HALF_TURN_REASON = "a geom of the pair turns by about a half turn between the frames: no interpolated motion to check"
#: A Jacobian entry below this (metres per radian or metre) moves the pair by nothing that counts
MOVES = 1e-9
#: instants of the interpolated motion between two frames scanned for a pair's closest approach (the
#: constraints sit at the closest and its neighbours; the margin covers what lies between grid points)
BETWEEN_GRID = 21


@dataclasses.dataclass
class FixResult:
    """What fix_motion did.  Arrays per frame (F frames) or per pair left closer than the clearance."""

    motion: np.ndarray  #: (F, nq) the corrected motion
    clearance: float
    changed: np.ndarray  #: (F,) bool: qpos differs from the input
    change: np.ndarray  #: (F,) the change's size in the metric, sqrt(d^T W d) (d: mj_differentiatePos)
    largest_joint: np.ndarray  #: (F,) int: the joint whose qpos moved most (-1: none)
    largest_joint_change: np.ndarray  #: (F,) its change (rad or m; for free/ball joints the rotation or translation)
    before_min: np.ndarray  #: (F,) smallest candidate pair distance of the input (inf: no candidate pair)
    after_min: np.ndarray  #: (F,) the same for the corrected motion, proven
    before_violations: np.ndarray  #: (F,) pairs closer than the clearance in the input
    unfreed: list  #: (frame, geom1, geom2, distance, reason) of pairs still closer than the clearance (_reason)
    unproven: int  #: pair distances whose maximum was not proven (counted as not freed)
    between: list  #: (frame, geom1, geom2) of contacts between frames f and f + 1 the repair left
    #: (BETWEEN_ROUNDS rounds of correcting both frames together did not free them)
    half_turns: list  #: (frame, geom1, geom2) of candidate pairs with a geom turning by about a half turn between
    #: frames f and f + 1: no interpolated motion, so not checked between those frames (nor repaired)
    joint_names: list
    geom_names: list
    seconds: float = 0.0

    def summary(self, show=10):
        F = len(self.motion)
        lines = [
            f"  frames changed: {int(self.changed.sum())} of {F}; pairs closer than {self.clearance:g} m in the input: "
            f"{int(self.before_violations.sum())} (in {int((self.before_violations > 0).sum())} frames)"
        ]
        if self.changed.any():
            f = int(np.argmax(self.change))
            j = int(self.largest_joint[f])
            lines.append(
                f"  largest change: frame {f}, {self.change[f]:.4g} in the metric; most at joint "
                f"{self.joint_names[j]} ({self.largest_joint_change[f]:.4g})"
            )
        finite = np.isfinite(self.after_min)
        if finite.any():
            lines.append(
                f"  closest pair after the fix: {self.after_min[finite].min():.4g} m (before: {self.before_min[finite].min():.4g} m)"
            )
        if self.between:
            lines.append(f"  still touching between frames: {len(self.between)} pairs ({BETWEEN_REASON})")
            for frame, g1, g2 in self.between[:show]:
                lines.append(f"    frames {frame}-{frame + 1}: {self.geom_names[g1]} x {self.geom_names[g2]}")
        if self.half_turns:
            lines.append(f"  not checked between frames: {len(self.half_turns)} pairs ({HALF_TURN_REASON})")
            for frame, g1, g2 in self.half_turns[:show]:
                lines.append(f"    frames {frame}-{frame + 1}: {self.geom_names[g1]} x {self.geom_names[g2]}")
        if self.unfreed:
            lines.append(f"  not freed: {len(self.unfreed)} pair-frames")
            for frame, g1, g2, d, why in self.unfreed[:show]:
                lines.append(f"    frame {frame}: {self.geom_names[g1]} x {self.geom_names[g2]} at {d:.4g} m: {why}")
            if len(self.unfreed) > show:
                lines.append(f"    ... and {len(self.unfreed) - show} more (--show N, or --json)")
        else:
            lines.append(f"  every candidate pair of every frame is at least {self.clearance:g} m apart (proven)")
        return lines

    def report(self):
        frames = []
        for f in np.flatnonzero(self.changed | (self.before_violations > 0)):
            j = int(self.largest_joint[f])
            frames.append(
                {
                    "frame": int(f),
                    "changed": bool(self.changed[f]),
                    "change": float(self.change[f]),
                    "largest_joint": self.joint_names[j] if j >= 0 else None,
                    "largest_joint_change": float(self.largest_joint_change[f]),
                    "pairs_closer_before": int(self.before_violations[f]),
                    "min_distance_before": float(self.before_min[f]),
                    "min_distance_after": float(self.after_min[f]),
                }
            )
        return {
            "clearance": self.clearance,
            "frames": len(self.motion),
            "frames_changed": int(self.changed.sum()),
            "total_change": float(self.change.sum()),
            "pairs_closer_before": int(self.before_violations.sum()),
            "unproven": int(self.unproven),
            "not_freed": [
                {
                    "frame": int(f),
                    "geoms": [self.geom_names[g1], self.geom_names[g2]],
                    "distance": float(d),
                    "reason": why,
                }
                for f, g1, g2, d, why in self.unfreed
            ],
            "touching_between_frames": [
                {"frame": int(f), "geoms": [self.geom_names[g1], self.geom_names[g2]], "reason": BETWEEN_REASON}
                for f, g1, g2 in self.between
            ],
            "half_turns_between_frames": [
                {"frame": int(f), "geoms": [self.geom_names[g1], self.geom_names[g2]], "reason": HALF_TURN_REASON}
                for f, g1, g2 in self.half_turns
            ],
            "per_frame": frames,
            "seconds": self.seconds,
        }


class _Frames:
    """The model posed frame by frame: candidate pairs, their distances and Jacobians, the metric."""

    def __init__(self, model, clearance, metric):
        self.model, self.clearance, self.metric = model, clearance, metric
        self.data = make_data(model, "fix")
        self.other = make_data(model, "fix")  # the second frame of a pair of frames (_two_frames)
        self.ids, radii, self.rules = ellipsoid_geoms(model)
        self.radii = radii
        self.grown = radii + 0.5 * clearance  # bounding spheres of radius max semi-axis + clearance / 2
        self.slack = SLACK_REL * (radii.min() if len(radii) else 1.0)
        self.limited = np.flatnonzero(
            model.jnt_limited.astype(bool)
            & np.isin(model.jnt_type, [mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE])
        )

    def pairs(self, qpos, grow=0.0):
        """(k, 2) geom ids of the candidate pairs at qpos, g1 < g2 (bounding spheres grown by half the
        clearance, and by `grow`)."""
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        centers = self.data.geom_xpos[self.ids][None]
        found = frame_pairs(centers, self.grown + grow, self.rules)
        return self.ids[found[:, 1:]]

    def poses(self, motion):
        """(F, g, 3) centres and (F, g, 3, 3) rotations of the ellipsoid geoms at every frame."""
        C = np.empty((len(motion), len(self.ids), 3))
        R = np.empty((len(motion), len(self.ids), 3, 3))
        for f, q in enumerate(motion):
            self.data.qpos[:] = q
            mujoco.mj_kinematics(self.model, self.data)
            C[f] = self.data.geom_xpos[self.ids]
            R[f] = self.data.geom_xmat[self.ids].reshape(-1, 3, 3)
        return C, R

    def between(self, motion):
        """Contacts between consecutive frames of `motion` (mujoco.between.BetweenFrames: time_of_impact
        on the interpolated motion): (frame (E,), geom pairs (E, 2) ids, g1 < g2, half turn (E,) bool: a
        geom of the pair turns by about pi between the frames, so there is no interpolated motion to check
        or repair)."""
        ev = BetweenFrames(self.radii, self.rules).check(
            np.arange(len(motion)), np.arange(len(motion), dtype=float), *self.poses(motion)
        )
        return ev.frame, np.sort(self.ids[ev.pair], axis=1), ev.half_turn

    def distances(self, qpos):
        """(candidate pairs (k, 2), their signed distances (k,), proven lower bounds where GLOBAL, the
        maximum's status (k,)) at qpos."""
        pairs = self.pairs(qpos)  # (poses the geoms at qpos)
        a, b = _bodies(self.model, self.data, pairs[:, 0]), _bodies(self.model, self.data, pairs[:, 1])
        dist, _, _, status = signed_distance(a, b)
        return pairs, dist, status

    def factor(self, qpos):
        """Factor the metric at qpos: M(q) (mj_crb, mj_factorM into data's qLD), or nothing for the identity."""
        if self.metric == "mass":
            self.data.qpos[:] = qpos
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_comPos(self.model, self.data)
            mujoco.mj_crb(self.model, self.data)
            mujoco.mj_factorM(self.model, self.data)

    def solve(self, rows):
        """W^-1 rows^T as (k, nv) rows (the factor of the last `factor` call: sparse, linear in nv)."""
        if self.metric == "identity":
            return rows.copy()
        out = np.empty_like(rows)
        mujoco.mj_solveM(self.model, self.data, out, rows)
        return out

    def size(self, qpos, d):
        """sqrt(d^T W(qpos) d)."""
        if self.metric == "identity":
            return float(np.sqrt(d @ d))
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_crb(self.model, self.data)
        Md = np.empty_like(d)
        mujoco.mj_mulM(self.model, self.data, Md, d)
        return float(np.sqrt(max(d @ Md, 0.0)))

    def clamp(self, qpos):
        m = self.model
        a = m.jnt_qposadr[self.limited]
        qpos[a] = np.clip(qpos[a], m.jnt_range[self.limited, 0], m.jnt_range[self.limited, 1])
        return qpos

    def _step(self, q, J, need):
        """The QP step: min 1/2 d'Wd s.t. J d >= need and the limited joints' ranges (rows added as the
        step crosses them), through the dual: min 1/2 l'Gl - need'l, l >= 0, G = J W^-1 J' (BVLS)."""
        m = self.model
        dof = m.jnt_dofadr[self.limited]
        adr = m.jnt_qposadr[self.limited]
        lo, hi = m.jnt_range[self.limited, 0] - q[adr], m.jnt_range[self.limited, 1] - q[adr]
        rows, b = J, need
        d = np.zeros(m.nv)
        for _ in range(LIMIT_ROUNDS):
            Y = self.solve(rows)  # W^-1 rows'
            d = Y.T @ _dual(rows @ Y.T, b)
            over, under = d[dof] > hi + 1e-12, d[dof] < lo - 1e-12
            if not (over.any() or under.any()):
                break
            extra = np.zeros((int(over.sum() + under.sum()), m.nv))
            k = np.concatenate([dof[over], dof[under]])
            extra[np.arange(len(k)), k] = np.r_[-np.ones(int(over.sum())), np.ones(int(under.sum()))]
            rows = np.vstack([rows, extra])
            b = np.r_[b, -hi[over], lo[under]]
        return _capped(d)

    def project(self, qpos):
        """(qpos moved until every candidate pair is at least the clearance apart, or the iterations run out;
        the pairs still closer (k, 2), their distances)."""
        q = qpos.copy()
        self.factor(q)  # the metric at the frame's own pose
        for _ in range(MAX_ITERATIONS):
            pairs, dist, _ = self.distances(q)
            if not (dist < self.clearance).any():
                return q, pairs[:0], dist[:0]
            close = dist < self.clearance + self.slack
            active = pairs[close]  # the Jacobians of these only (mj_jacGeom: a dense row per geom)
            self.data.qpos[:] = q
            jac = distance_jacobian(self.model, self.data, active)
            usable = np.isfinite(jac.jacobian).all(axis=1) & np.any(jac.jacobian != 0.0, axis=1)
            if not usable.any():
                break
            d = self._step(q, jac.jacobian[usable], self.clearance + self.slack - jac.dist[usable])
            if not np.isfinite(d).all() or not d.any():
                break
            mujoco.mj_integratePos(self.model, q, d, 1.0)
            q = self.clamp(q)
        pairs, dist, _ = self.distances(q)
        bad = dist < self.clearance
        return q, pairs[bad], dist[bad]

    def reasons(self, qpos, pairs):
        """Why each pair (k, 2) is still closer than the clearance at qpos, the corrected pose: no joint moves
        either geom relative to the other; every joint that could part them is at the limit it would cross
        (named); the model's own rest pose (qpos0) has them that close too; or MAX_ITERATIONS steps of the
        solver did not part them (pairs pulling opposite ways)."""
        m = self.model
        self.data.qpos[:] = qpos
        jac = distance_jacobian(m, self.data, pairs)
        rest = dict(zip(map(tuple, self.pairs(m.qpos0).tolist()), self.distances(m.qpos0)[1]))
        out = []
        for k, (g1, g2) in enumerate(pairs.tolist()):
            dofs = self._between_dofs(m.geom_bodyid[g1], m.geom_bodyid[g2])
            row = jac.jacobian[k]
            if len(dofs) == 0:
                out.append(
                    "no joint moves either geom relative to the other (no joint on the tree path between their bodies)"
                )
                continue
            moving = dofs[np.abs(row[dofs]) > MOVES] if np.isfinite(row).all() else dofs
            held = [self._held(qpos, d, row[d]) for d in moving]
            if len(moving) == 0:
                out.append("no joint's motion changes their distance at this pose (a stationary point of it)")
            elif all(held):
                out.append("; ".join(dict.fromkeys(held)))  # each joint once
            elif rest.get((g1, g2), np.inf) < self.clearance:
                out.append(
                    f"the model's rest pose (qpos0) has them {rest[(g1, g2)]:.4g} m apart too: its own geometry, "
                    "which the joints' ranges keep"
                )
            else:
                out.append(
                    f"the iteration budget: {MAX_ITERATIONS} solver steps did not part them (other pairs pull back)"
                )
        return out

    def _between_dofs(self, b1, b2):
        """(n,) the dofs of the joints on the tree path between bodies b1 and b2 (they move one relative to
        the other); none when the two are one rigid body set."""
        m = self.model

        def chain(b):
            out = [b]
            while b:
                b = int(m.body_parentid[b])
                out.append(b)
            return out

        c1, c2 = chain(int(b1)), chain(int(b2))
        common = next(b for b in c1 if b in set(c2))
        bodies = [b for b in c1[: c1.index(common)] + c2[: c2.index(common)]]
        dofs = [np.arange(m.body_dofadr[b], m.body_dofadr[b] + m.body_dofnum[b]) for b in bodies if m.body_dofnum[b]]
        return np.concatenate(dofs).astype(np.int64) if dofs else np.zeros(0, dtype=np.int64)

    def _held(self, qpos, dof, slope):
        """'' when dof is free to part the pair (slope: d dist / d dof), else which limit holds it."""
        m = self.model
        j = int(m.dof_jntid[dof])
        if j not in set(self.limited.tolist()):
            return ""
        q, (lo, hi) = qpos[m.jnt_qposadr[j]], m.jnt_range[j]
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"
        if slope > 0 and q >= hi - 1e-9 * max(1.0, abs(hi)):
            return f"joint {name} at its upper limit {hi:g}"
        if slope < 0 and q <= lo + 1e-9 * max(1.0, abs(lo)):
            return f"joint {name} at its lower limit {lo:g}"
        return ""

    def min_distance(self, qpos):
        """(smallest proven distance over the candidate pairs (inf: none), pairs closer than the
        clearance, pairs whose maximum is unproven)."""
        _, dist, status = self.distances(qpos)
        if not len(dist):
            return np.inf, 0, 0
        return float(dist.min()), int((dist < self.clearance).sum()), int((status != GLOBAL).sum())


def _dual(G, b):
    """The multipliers l >= 0 minimising 1/2 l'Gl - b'l (the QP's dual; G = J W^-1 J' >= 0): BVLS on the
    Cholesky factor of G, regularised by 1e-12 of its mean diagonal (more, a thousandfold at a time, where
    rounding leaves a rank-deficient G indefinite: two pairs with the same Jacobian row)."""
    scale = np.trace(G) / len(G) + 1e-300
    for k in range(6):
        try:
            L = np.linalg.cholesky(G + np.eye(len(G)) * scale * 10.0 ** (3 * k - 12))
            break
        except np.linalg.LinAlgError:
            continue
    else:
        return np.zeros(len(G))
    return lsq_linear(L.T, np.linalg.solve(L, b), bounds=(0.0, np.inf), method="bvls").x


def _capped(d):
    """d scaled down to at most STEP_MAX on every dof (the trust region)."""
    big = np.abs(d).max() if len(d) else 0.0
    return d * (STEP_MAX / big) if big > STEP_MAX else d


def _two_frames(frames, out, f, pairs, margin):
    """Frames f and f + 1 corrected together (Gauss-Newton, as _Frames.project) until their pairs keep the
    clearance and `pairs` (k, 2) keep clearance + margin over the interpolated motion between them
    (mujoco.jacobian.interpolated_distance_jacobian: each geom's centre linear, its rotation along the
    shortest arc, the motion the contacts between frames are found on), constrained at each pair's closest
    instant on a grid of BETWEEN_GRID and its two neighbours, found again every iteration."""
    m, nv, C = frames.model, frames.model.nv, frames.clearance
    other = frames.other
    k = len(pairs)
    grid = np.linspace(0.0, 1.0, BETWEEN_GRID)
    for _ in range(MAX_ITERATIONS):
        qa, qb = out[f].copy(), out[f + 1].copy()
        blocks, needs = [], []
        for q, which in ((qa, 0), (qb, 1)):
            close_pairs, dist, _ = frames.distances(q)
            close = dist < C + frames.slack
            if close.any():
                frames.data.qpos[:] = q
                jac = distance_jacobian(m, frames.data, close_pairs[close])
                ok = np.isfinite(jac.jacobian).all(axis=1) & np.any(jac.jacobian != 0.0, axis=1)
                J, zero = jac.jacobian[ok], np.zeros((int(ok.sum()), nv))
                blocks.append(np.hstack([J, zero] if which == 0 else [zero, J]))
                needs.append(C + frames.slack - jac.dist[ok])
        frames.data.qpos[:], other.qpos[:] = qa, qb
        try:
            scan = interpolated_distance_jacobian(
                m, frames.data, other, np.repeat(pairs, len(grid), 0), np.tile(grid, k)
            )
            low = np.argmin(scan[0].reshape(k, len(grid)), axis=1)
            at = np.clip(low[:, None] + [-1, 0, 1], 0, len(grid) - 1)
            dist, J0, J1, _ = interpolated_distance_jacobian(
                m, frames.data, other, np.repeat(pairs, 3, 0), grid[at].reshape(-1)
            )
        except ValueError:  # a half turn between the frames: no interpolated motion to correct
            return
        close = (
            (dist < C + margin)
            & np.isfinite(J0).all(axis=1)
            & np.isfinite(J1).all(axis=1)
            & (np.any(J0 != 0.0, axis=1) | np.any(J1 != 0.0, axis=1))
        )
        if close.any():
            blocks.append(np.hstack([J0[close], J1[close]]))
            needs.append(C + margin + frames.slack - dist[close])
        if not blocks:
            return
        rows, b = np.vstack(blocks), np.concatenate(needs)
        if not (b > frames.slack).any():
            return
        frames.factor(qa)
        ya = frames.solve(np.ascontiguousarray(rows[:, :nv]))
        frames.factor(qb)
        yb = frames.solve(np.ascontiguousarray(rows[:, nv:]))
        lam = _dual(rows[:, :nv] @ ya.T + rows[:, nv:] @ yb.T, b)
        step = _capped(np.r_[ya.T @ lam, yb.T @ lam])  # the trust region, on both frames at once
        da, db = step[:nv], step[nv:]
        if not (np.isfinite(da).all() and np.isfinite(db).all()) or not (da.any() or db.any()):
            return
        mujoco.mj_integratePos(m, qa, da, 1.0)
        mujoco.mj_integratePos(m, qb, db, 1.0)
        out[f], out[f + 1] = frames.clamp(qa), frames.clamp(qb)


def _repair_between(frames, out):
    """Pairs touching between two corrected frames (interpolating two poses that each just clear a limb cuts
    the corner, or the two frames were pushed to opposite sides): the two frames corrected together with
    constraints on the poses in between (_two_frames), the margin doubled each round (BETWEEN_ROUNDS).
    Returns the (frame, g1, g2) still touching between frames, and those with a half turn between frames
    (not checked)."""
    left, turns = [], []
    for k in range(BETWEEN_ROUNDS + 1):
        ev_frame, ev_pair, half = frames.between(out)
        events = [(int(f), int(g1), int(g2)) for f, (g1, g2) in zip(ev_frame, ev_pair)]
        left = [e for e, h in zip(events, half) if not h]
        turns = [e for e, h in zip(events, half) if h]
        if not left or k == BETWEEN_ROUNDS:
            break
        margin = min(4.0 * frames.slack * 2.0**k, BETWEEN_MARGIN_MAX * frames.slack)
        for f in np.unique(ev_frame[~half]):
            _two_frames(frames, out, int(f), ev_pair[(ev_frame == f) & ~half], margin)
    return left, turns


def _taper(smooth):
    k = np.arange(-smooth, smooth + 1)
    return np.cos(0.5 * np.pi * k / (smooth + 1)) ** 2


def _spread(delta, smooth):
    """Per dof, the largest tapered change within `smooth` frames (signed as it is)."""
    if smooth == 0:
        return delta.copy()
    F = len(delta)
    w = _taper(smooth)
    best = np.zeros_like(delta)
    for k, wk in zip(range(-smooth, smooth + 1), w):
        if abs(k) >= F:  # (a motion shorter than the window)
            continue
        lo, hi = max(0, -k), min(F, F - k)
        cand = np.zeros_like(delta)
        cand[lo:hi] = wk * delta[lo + k : hi + k]
        take = np.abs(cand) > np.abs(best)
        best[take] = cand[take]
    return best


def fix_motion(model, motion, *, clearance=0.0, metric="mass", smooth=4, between=True, progress=None):
    """The motion (F, nq) corrected so that every candidate ellipsoid pair of every frame is at least
    `clearance` metres apart (module docstring); a FixResult.

    clearance : metres, >= 0 (0: no two ellipsoid limbs overlap).  metric : "mass" (M(q)) or "identity".
    smooth : frames on either side over which a correction ramps in and out (0: per frame only).
    between : also repair the pairs that touch between two frames on the interpolated motion (module
        docstring; FixResult.between lists what is left).
    progress : optional callable(done, total) over 2 F frame passes.
    """
    motion = np.asarray(motion, dtype=np.float64)
    if motion.ndim != 2 or motion.shape[1] != model.nq or len(motion) == 0:
        raise ValueError(f"motion must have shape (frames, {model.nq}) (frames >= 1), got {motion.shape}")
    if (
        isinstance(clearance, bool)
        or not isinstance(clearance, (int, float, np.floating))
        or not 0 <= clearance < np.inf
    ):
        raise ValueError(f"clearance must be a finite number >= 0 (metres), got {clearance!r}")
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {METRICS}, got {metric!r}")
    if isinstance(smooth, bool) or not isinstance(smooth, (int, np.integer)) or smooth < 0:
        raise ValueError(f"smooth must be an integer >= 0 (frames), got {smooth!r}")
    if not isinstance(between, bool):
        raise ValueError(f"between must be True or False, got {between!r}")
    start = time.perf_counter()
    frames = _Frames(model, float(clearance), metric)
    F, nv = len(motion), model.nv
    before_min, before_bad, unproven = np.full(F, np.inf), np.zeros(F, dtype=np.int64), 0
    delta = np.zeros((F, nv))
    first = motion.copy()
    for f in range(F):  # pass 1: each frame, from the previous frame's correction (module docstring)
        before_min[f], before_bad[f], _ = frames.min_distance(motion[f])
        if before_bad[f]:
            warm = bool(f and delta[f - 1].any())
            q0 = motion[f].copy()
            if warm:
                mujoco.mj_integratePos(model, q0, delta[f - 1], 1.0)
            first[f], left, _ = frames.project(frames.clamp(q0))
            if warm and len(left):  # the carried change does not free the frame: its own smallest change, if better
                own, left_own, _ = frames.project(motion[f])
                if len(left_own) < len(left):
                    first[f] = own
            mujoco.mj_differentiatePos(model, delta[f], 1.0, motion[f], first[f])
        if progress:
            progress(f + 1, 2 * F)
    spread = _spread(delta, smooth)
    out = motion.copy()
    after_min = before_min.copy()
    for f in range(F):  # pass 2: from the spread change, projected again
        if spread[f].any() or before_bad[f]:
            q = motion[f].copy()
            mujoco.mj_integratePos(model, q, spread[f], 1.0)
            out[f], _, _ = frames.project(frames.clamp(q))
        if progress:
            progress(F + f + 1, 2 * F)
    between_left, half_turns = _repair_between(frames, out) if between else ([], [])
    changed = np.any(out != motion, axis=1)
    unfreed = []
    for f in np.flatnonzero(changed | (before_bad > 0)):  # corrected frames, and bad ones left as they were
        pairs, dist, status = frames.distances(out[f])
        bad = dist < frames.clearance
        reasons = frames.reasons(out[f], pairs[bad]) if bad.any() else []
        unfreed += [
            (int(f), int(g1), int(g2), float(d), why) for (g1, g2), d, why in zip(pairs[bad], dist[bad], reasons)
        ]
        after_min[f] = dist.min() if len(dist) else np.inf
        unproven += int((status != GLOBAL).sum())
    change, joint, joint_change = np.zeros(F), np.full(F, -1, dtype=np.int64), np.zeros(F)
    d = np.zeros(nv)
    dof_joint = model.dof_jntid
    for f in np.flatnonzero(changed):
        mujoco.mj_differentiatePos(model, d, 1.0, motion[f], out[f])
        change[f] = frames.size(motion[f], d)
        per_joint = np.zeros(model.njnt)
        np.maximum.at(per_joint, dof_joint, np.abs(d))
        joint[f] = int(np.argmax(per_joint))
        joint_change[f] = per_joint[joint[f]]
    names = lambda kind, n: [mujoco.mj_id2name(model, kind, i) or f"#{i}" for i in range(n)]
    return FixResult(
        motion=out,
        clearance=float(clearance),
        changed=changed,
        change=change,
        largest_joint=joint,
        largest_joint_change=joint_change,
        before_min=before_min,
        after_min=after_min,
        before_violations=before_bad,
        unfreed=unfreed,
        unproven=unproven,
        between=between_left,
        half_turns=half_turns,
        joint_names=names(mujoco.mjtObj.mjOBJ_JOINT, model.njnt),
        geom_names=names(mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
        seconds=time.perf_counter() - start,
    )
