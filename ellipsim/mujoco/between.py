"""Contacts between frames: ellipsoid pairs separated at frame k and at frame k + 1 that touch in
between (a limb passing through another within one frame, a graze), by continuous collision
detection (core.motion.time_of_impact) on the interpolated motion.

Between two frames each ellipsoid moves as core.motion.interpolation defines (centre linear, rotation at constant
angular velocity along the shortest arc).  That is an interpolation of the two poses: neither a
replay's own in-between poses nor a simulation's mj_step need follow it, so an event says "on the
interpolated motion the pair touches between these frames", from `begin` to `end`.

Per chunk of consecutive frames: core.motion.broad_phase.swept_pairs (one sweep and prune per block of steps
over each geom's box of centres, MuJoCo's pair rules (geoms.PairRules) on the pairs it finds, then per
step the closest approach of the two centres' straight paths against the sum of the bounding radii and
enclosing capsules kept apart by conservative advancement; conservative, with room for rounding), and
pairs known to touch at either end dropped (or, not known, found so by exact classify).  The pairs'
poses are gathered and validated in one batch, and one time_of_impact call decides the pairs; the
contacts it finds get their end from the reversed motion (1 - toi(a1, a0, b1, b0), time_of_impact's
docstring) and a contact point from core.signed_distance at the pose at toi.
"""

import dataclasses
import math

import numpy as np

from ..core.distance.ellipsoid_pair import signed_distance
from ..core.ellipsoids import Ellipsoids, orthonormality_defect
from ..core.exact.classify import classify
from ..core.motion.broad_phase import swept_pairs as broadphase_swept_pairs
from ..core.motion.interpolation import poses_at
from ..core.motion.time_of_impact import Impact, time_of_impact
from ..core.relation import Relation
from ..core.tolerances import BOUNDING_INFLATION, HALF_TURN_TOL, ORTHONORMAL_TOL

#: A geom turning by more than pi - HALF_TURN_MARGIN between two frames has no well-defined
#: interpolated motion (core.motion.interpolation refuses turns within HALF_TURN_TOL = 1e-6 rad of pi): its pairs
#: are reported UNRESOLVED over the whole step.  100 x HALF_TURN_TOL: the angle is computed here with
#: numpy (atan2 of the same quantities as core.motion.interpolation.rotation_vector, errors ~1e-15 rad).
HALF_TURN_MARGIN = 100 * HALF_TURN_TOL

STATUS_NAMES = {int(s): s.name.lower() for s in Impact}


@dataclasses.dataclass
class Events:
    """Contacts that begin and end between two frames (E of them, sorted by frame and begin).

    frame : (E,) int64, frame k: separated at k and k + 1 (exact classify), touching in between
    pair : (E, 2) int64, i < j, indices into the g ellipsoid geoms the checker was given
    toi : (E,) float64 in (0, 1): first contact, as a fraction of the step (core.motion.time_of_impact)
    begin, end : (E,) float64 seconds: first and last contact on the interpolated motion
    until : (E,) float64 seconds, the time of frame k + 1
    status : (E,) int8 core.motion.time_of_impact.Impact code of the first contact (UNRESOLVED: a possible
        contact, e.g. a graze within float64 resolution, or a half turn between the frames)
    half_turn : (E,) bool, a geom of the pair turns by about pi between the frames: no interpolated
        motion, reported UNRESOLVED with begin, end the frames' times
    point : (E, 3) float64 metres, where: core.signed_distance's contact point of the pair's pose at
        toi (for a half turn: the midpoint of the centres half-way through the step)
    """

    frame: np.ndarray
    pair: np.ndarray
    toi: np.ndarray
    begin: np.ndarray
    end: np.ndarray
    until: np.ndarray
    status: np.ndarray
    half_turn: np.ndarray
    point: np.ndarray

    def __len__(self):
        return len(self.frame)

    @classmethod
    def empty(cls):
        return cls(
            np.zeros(0, dtype=np.int64),
            np.zeros((0, 2), dtype=np.int64),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0, dtype=np.int8),
            np.zeros(0, dtype=bool),
            np.zeros((0, 3)),
        )

    @classmethod
    def concatenate(cls, parts):
        parts = list(parts)
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(cls)))

    def status_name(self, e):
        """Event e's status as text: contact, contact_at_float_pose or unresolved (+ " (half turn
        between the frames)")."""
        name = STATUS_NAMES[int(self.status[e])]
        return name + " (half turn between the frames)" if self.half_turn[e] else name


#: Up to this many geoms, the checker tests MuJoCo's pair rules from a (g, g) matrix inside the
#: sweep (g^2 bytes: 1 MB); beyond, vectorised on the sweep's pairs (geoms.PairRules: no matrix).
RULES_MATRIX_MAX = 1024


def swept_pairs(centers, rotations, radii, rules, matrix=None):
    """(P, 3) int64 (step, i, j), i < j, sorted by step: the pairs `rules` allow that may touch between
    frames step and step + 1 on the interpolated motion (conservative: core.motion.broad_phase.swept_pairs
    over the bounding radii inflated by BOUNDING_INFLATION, MuJoCo's rules on the sweep's pairs).

    centers : (F, g, 3) metres; rotations : (F, g, 3, 3); radii : (g, 3) semi-axes; rules :
    geoms.PairRules over the same g geoms; matrix : optional rules.matrix(), used instead of rules."""
    radii = np.asarray(radii, dtype=np.float64)
    rho = radii.max(axis=1) * BOUNDING_INFLATION
    return broadphase_swept_pairs(centers, rotations, radii, rho, rules.allowed if matrix is None else matrix)


def turn_angles(R0, R1):
    """(...) angles in [0, pi] of R0^T R1, radians; R0, R1 : (..., 3, 3) (core.motion.interpolation.rotation_vector's
    atan2 of the antisymmetric part's norm and (trace - 1) / 2; the antisymmetric part of R0^T R1 is
    minus half the sum of the cross products of the rows)."""
    c = 0.5 * (np.einsum("...ij,...ij->...", R0, R1) - 1.0)
    v = 0.5 * np.cross(R0, R1).sum(axis=-2)
    return np.arctan2(np.sqrt(np.einsum("...k,...k->...", v, v)), c)


class BetweenFrames:
    """Finds Events in consecutive chunks of frames of the same g ellipsoid geoms; the last frame of
    a chunk is kept for the step into the next.

    radii : (g, 3) semi-axes, metres; rules : geoms.PairRules over the same g geoms (MuJoCo's rules
    for which pairs may collide).
    """

    def __init__(self, radii, rules):
        self.radii = np.ascontiguousarray(radii, dtype=np.float64)
        self.rules = rules
        self._last = None  # (frame, time, centres (g, 3), rotations (g, 3, 3), contact pairs (k, 2))
        self.candidates = 0  # pairs handed to time_of_impact, all chunks
        self._matrix = rules.matrix() if len(self.radii) <= RULES_MATRIX_MAX else None

    @staticmethod
    def _explain(frames, rotations):
        """Raise the ValueError naming the first geom and frame whose rotation is not orthonormal, if any."""
        g = rotations.shape[1]
        defect = orthonormality_defect(rotations.reshape(-1, 3, 3))
        wrong = np.flatnonzero(defect > ORTHONORMAL_TOL)
        if len(wrong):
            f, x = divmod(int(wrong[0]), g)
            raise ValueError(
                f"rotations of geom {x} at frame {frames[f]} must be orthonormal: max |R^T R - I| = "
                f"{defect[wrong[0]]:.3g} exceeds the tolerance {ORTHONORMAL_TOL:g}"
            )

    def check(self, frames, times, centers, rotations, contacts=None):
        """Events of the steps into and within these frames.

        frames : (f,) int64 consecutive frame numbers (following the previous chunk's); times : (f,)
        seconds; centers : (f, g, 3) metres; rotations : (f, g, 3, 3) (or (f, g, 9): MuJoCo's geom_xmat).
        contacts : optional (P, 3) int64 (frame, i, j), i < j: pairs known not to be separated at that
            frame (exact classify), skipped at its two steps; None: exact classify of the candidates at
            both ends drops them (time_of_impact's verdict there, toi = 0, at a tenth of the cost when
            they touch: a resting pile).
        ValueError names a non-finite pose, or a rotation of a pair's geom that is not orthonormal
        (validated in one batch of the pairs' poses), by geom and frame.
        """
        frames = np.asarray(frames, dtype=np.int64)
        times = np.asarray(times, dtype=np.float64)
        centers = np.asarray(centers, dtype=np.float64)
        rotations = np.asarray(rotations, dtype=np.float64)
        if rotations.ndim == 3 and rotations.shape[-1] == 9:  # MuJoCo's xmat rows
            rotations = rotations.reshape(*rotations.shape[:2], 3, 3)
        g = len(self.radii)
        if (
            centers.shape != (len(frames), g, 3)
            or rotations.shape != (len(frames), g, 3, 3)
            or times.shape != frames.shape
        ):
            raise ValueError(
                f"centers, rotations and times must have shapes ({len(frames)}, {g}, 3), ({len(frames)}, {g}, 3, 3) "
                f"and ({len(frames)},) for {len(frames)} frames of {g} geoms, got {centers.shape}, "
                f"{rotations.shape} and {times.shape}"
            )
        classify_ends = contacts is None
        contacts = np.zeros((0, 3), dtype=np.int64) if contacts is None else np.asarray(contacts, dtype=np.int64)
        if len(frames) == 0:
            return Events.empty()
        last = self._last
        if last is not None and frames[0] != last[0] + 1:
            raise ValueError(f"frames must continue at frame {last[0] + 1}, got frame {frames[0]}")
        self._last = (
            frames[-1],
            times[-1],
            centers[-1].copy(),
            rotations[-1].copy(),
            contacts[contacts[:, 0] == frames[-1], 1:],
        )
        if last is not None:
            frames = np.r_[last[0], frames]
            times = np.r_[last[1], times]
            centers = np.concatenate([last[2][None], centers])
            rotations = np.concatenate([last[3][None], rotations])
            contacts = np.concatenate([np.column_stack([np.full(len(last[4]), last[0]), last[4]]), contacts])
        if len(frames) < 2 or g < 2:
            return Events.empty()
        bad = ~(np.isfinite(centers).all(axis=2) & np.isfinite(rotations).all(axis=(2, 3)))
        if bad.any():
            f, x = np.argwhere(bad)[0]
            raise ValueError(
                f"centers and rotations must be finite, got a non-finite pose of geom {x} at frame {frames[f]}"
            )
        pairs = swept_pairs(centers, rotations, self.radii, self.rules, self._matrix)
        if len(contacts):  # drop pairs touching at either end of their step
            first = frames[0]
            known = np.unique((contacts[:, 0] - first) * g * g + contacts[:, 1] * g + contacts[:, 2])
            key = pairs[:, 0] * g * g + pairs[:, 1] * g + pairs[:, 2]
            drop = np.zeros(len(key), dtype=bool)
            for k in (key, key + g * g):  # the pair at frame k, at frame k + 1 (known is sorted and short)
                at = np.minimum(np.searchsorted(known, k), len(known) - 1)
                drop |= known[at] == k
            pairs = pairs[~drop]
        if len(pairs) == 0:
            return Events.empty()
        s, i, j = pairs.T
        n = len(s)
        # the four poses of every pair in one batch (validated once: finite, orthonormal rotations)
        rows = np.concatenate([s * g + i, (s + 1) * g + i, s * g + j, (s + 1) * g + j])
        try:
            every = Ellipsoids(
                np.take(centers.reshape(-1, 3), rows, axis=0),
                np.take(rotations.reshape(-1, 3, 3), rows, axis=0),
                np.take(self.radii, np.concatenate([i, i, j, j]), axis=0),
            )
        except ValueError:
            self._explain(frames, rotations)
            raise
        a0, a1, b0, b1 = every[:n], every[n : 2 * n], every[2 * n : 3 * n], every[3 * n :]
        # geoms turning by about a half turn in a step: cos of the angle (trace - 1) / 2 first, the
        # angle itself only where it is below -1/2 (more than 120 degrees)
        half = np.zeros(n, dtype=bool)
        for x0, x1 in ((a0, a1), (b0, b1)):
            cos = 0.5 * (np.einsum("nij,nij->n", x0.rotations, x1.rotations) - 1.0)
            wide = np.flatnonzero(cos < -0.5)
            half[wide] |= math.pi - turn_angles(x0.rotations[wide], x1.rotations[wide]) < HALF_TURN_MARGIN
        if classify_ends:  # touching at frame k or k + 1: time_of_impact's toi = 0 either way, ~10x faster
            apart = (classify(a0, b0) == Relation.SEPARATED) & (classify(a1, b1) == Relation.SEPARATED)
            ok = np.flatnonzero(~half & apart)
        else:
            ok = np.flatnonzero(~half)
        s_ok, i_ok, j_ok = s[ok], i[ok], j[ok]
        if len(ok) < n:
            a0, a1, b0, b1 = a0[ok], a1[ok], b0[ok], b1[ok]
        self.candidates += len(ok)
        toi, status = time_of_impact(a0, a1, b0, b1, return_status=True)
        hit = np.flatnonzero(np.isfinite(toi) & (toi > 0))  # toi = 0: not separated at frame k
        back = time_of_impact(a1[hit], a0[hit], b1[hit], b0[hit]) if len(hit) else np.zeros(0)
        keep = back > 0  # reversed toi = 0: not separated at frame k + 1
        hit, back = hit[keep], back[keep]
        t_hit = toi[hit]
        t_end = np.where(np.isfinite(back), 1.0 - back, t_hit)  # an UNRESOLVED start may have no end
        t_end = np.maximum(t_end, t_hit)
        point = np.zeros((len(hit), 3))
        if len(hit):
            pa = poses_at(a0[hit], a1[hit], t_hit)
            pb = poses_at(b0[hit], b1[hit], t_hit)
            point = signed_distance(pa, pb)[2]
        h = np.flatnonzero(half)
        sh, ih, jh = s[h], i[h], j[h]
        mid_h = 0.25 * (centers[sh, ih] + centers[sh + 1, ih] + centers[sh, jh] + centers[sh + 1, jh])
        step = np.r_[s_ok[hit], sh]
        frac_begin = np.r_[t_hit, np.zeros(len(h))]
        frac_end = np.r_[t_end, np.ones(len(h))]
        dt = times[step + 1] - times[step]
        events = Events(
            frame=frames[step],
            pair=np.column_stack([np.r_[i_ok[hit], ih], np.r_[j_ok[hit], jh]]).astype(np.int64),
            toi=frac_begin,
            begin=times[step] + frac_begin * dt,
            end=times[step] + frac_end * dt,
            until=times[step + 1],
            status=np.r_[status[hit], np.full(len(h), Impact.UNRESOLVED)].astype(np.int8),
            half_turn=np.r_[np.zeros(len(hit), dtype=bool), np.ones(len(h), dtype=bool)],
            point=np.concatenate([point, mid_h]).reshape(-1, 3),
        )
        order = np.lexsort((events.pair[:, 1], events.pair[:, 0], events.toi, events.frame))
        return Events(*(getattr(events, f.name)[order] for f in dataclasses.fields(Events)))
