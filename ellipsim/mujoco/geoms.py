"""Ellipsoid geoms of a MuJoCo model, the pairs MuJoCo collides (dynamic and <pair> elements), their
margins and gaps, and the exact verdict on MuJoCo's contact test `signed distance < margin`.

How MuJoCo 4.0 treats a geom pair (src/engine/engine_collision_driver.c, mj_collision,
filterCollisionPair, mj_narrowphase, mj_setContact; checked on the 4.0.0 wheel):
* margin (getMargin): a <pair> element's pair_margin, else geom_margin[g1] + geom_margin[g2];
  opt.o_margin replaces either under mjENBL_OVERRIDE (mj_assignMargin).  gap (getGap): pair_gap, else
  geom_gap[g1] + geom_gap[g2], never overridden.
* the collision function is called with margin + gap: a contact is made when dist < margin + gap;
  mj_setContact sets includemargin = margin and exclude = (dist >= margin), so the gap only adds
  contacts that stay out of the constraints.  The contact is active when dist < margin.
* <pair> elements are merged into the broad phase's body pairs by signature and always collided
  (bounding spheres with margin + gap; both bodies asleep under mjENBL_SLEEP drops them); they never
  reach mjcb_contactfilter nor the contype/conaffinity test.  A dynamic geom pair that a <pair>
  element also names is skipped (filterCollisionPair with `merged`, before the contact filter): each
  geom pair is collided once per <pair> element naming it, or once as a dynamic pair, never both.
"""

import mujoco
import numpy as np

from ..core.distance.ellipsoid_pair import GLOBAL, signed_distance
from ..core.ellipsoids import Ellipsoids, orthonormality_defect
from ..core.exact.classify import classify
from ..core.motion.broad_phase import sweep_and_prune
from ..core.relation import Relation
from ..core.tolerances import BB_TOL_REL, BB_TOL_ULPS, U
from .attachment import Attachment, check_model_data
from .context import ELLIPSOID, FILTER_PAIR_TYPES, SPHERE

_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
_SLEEP = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
_FILTERPARENT = int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
_NO_CONTACTS = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
_AWAKE = int(mujoco.mjtSleepState.mjS_AWAKE)

#: Bounding spheres of the broad phase are the largest semi-axis times this (one part in 1e9 more,
#: so that rounding in the sphere test never drops a pair whose ellipsoids touch).
_SPHERE_SLACK = 1 + 1e-9


def ellipsim_pair_types(model, g1, g2):
    """(k,) bool: are geoms g1, g2 (k,) a pair ellipsim tests (ellipsoid x ellipsoid or x sphere: the
    rows of context.FILTER_PAIR_TYPES), in either order?"""
    t1, t2 = model.geom_type[g1], model.geom_type[g2]
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    out = np.zeros(np.shape(lo), dtype=bool)
    for row in FILTER_PAIR_TYPES:
        out |= (lo == row.type1) & (hi == row.type2)
    return out


def _keys(model, pairs):
    """(k,) int64 key min(g) * ngeom + max(g) of geom pairs (k, 2), whichever order they name them in."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    return np.minimum(pairs[:, 0], pairs[:, 1]) * model.ngeom + np.maximum(pairs[:, 0], pairs[:, 1])


def _explicit(model):
    """The model's <pair> elements as (keys (p,) int64 sorted, unique; margin (p,); gap (p,)), margin
    before the override; a geom pair named by several elements (MuJoCo collides it once per element,
    and it is in contact when any contact is) gets the largest margin and the largest gap."""
    keys = _keys(model, np.stack([model.pair_geom1, model.pair_geom2], axis=1))
    unique, at = np.unique(keys, return_inverse=True)
    margin, gap = np.full(len(unique), -np.inf), np.full(len(unique), -np.inf)
    np.maximum.at(margin, at, model.pair_margin)
    np.maximum.at(gap, at, model.pair_gap)
    return unique, margin, gap


def _explicit_lookup(model, pairs):
    """(at (k,), named (k,) bool): the index into _explicit of each geom pair (k, 2), and whether a
    <pair> element names it."""
    unique = _explicit(model)[0]
    key = _keys(model, pairs)
    if len(unique) == 0:
        return np.zeros(len(key), dtype=np.intp), np.zeros(len(key), dtype=bool)
    at = np.minimum(np.searchsorted(unique, key), len(unique) - 1)
    return at, unique[at] == key


def pair_margins(model, pairs):
    """(k,) margin MuJoCo gives each geom pair (k, 2): the <pair> element's margin when one names the
    pair, else the geoms' sum; opt.o_margin instead of either under mjENBL_OVERRIDE (getMargin)."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    if model.opt.enableflags & _OVERRIDE:
        return np.full(len(pairs), float(model.opt.o_margin))
    out = model.geom_margin[pairs[:, 0]] + model.geom_margin[pairs[:, 1]]
    at, named = _explicit_lookup(model, pairs)
    out[named] = _explicit(model)[1][at[named]]
    return out


def pair_gaps(model, pairs):
    """(k,) gap MuJoCo gives each geom pair (k, 2): the <pair> element's gap when one names the pair,
    else the geoms' sum (getGap; not overridden).  MuJoCo makes a contact below margin + gap and
    excludes it from the constraints at or above margin."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    out = model.geom_gap[pairs[:, 0]] + model.geom_gap[pairs[:, 1]]
    at, named = _explicit_lookup(model, pairs)
    out[named] = _explicit(model)[2][at[named]]
    return out


def explicit_pairs(model, data=None):
    """(p, 2) int32: the geom pairs of the model's <contact><pair> elements that ellipsim tests
    (ellipsoid x ellipsoid, sphere x ellipsoid), each once, g1 < g2, sorted.

    With data: only those MuJoCo collides at data's state (none when contacts or constraints are
    disabled; under mjENBL_SLEEP not those with both bodies asleep), as mj_collision does; the
    bounding-sphere test is left out (a pair it drops is farther apart than margin + gap anyway)."""
    if model.npair == 0:
        return np.zeros((0, 2), dtype=np.int32)
    keys = _explicit(model)[0]
    pairs = np.stack(divmod(keys, model.ngeom), axis=1).astype(np.int32)
    pairs = pairs[ellipsim_pair_types(model, pairs[:, 0], pairs[:, 1])]
    if data is None:
        return pairs
    check_model_data(model, data)
    if model.opt.disableflags & _NO_CONTACTS or model.nbody + model.nflex < 2:
        return pairs[:0]
    if model.opt.enableflags & _SLEEP:
        awake = data.body_awake[model.geom_bodyid[pairs]] == _AWAKE
        pairs = pairs[awake.any(axis=1)]
    return pairs


def proof_tolerance(a, b):
    """(k,) metres: how close core.distance.ellipsoid_pair proves a GLOBAL signed distance of the pairs (a[i], b[i])
    to the true one, TOL = max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of its docstring (r_min
    the shortest of the six semi-axes, S = |c_b - c_a| + the two largest, delta the larger rotation's
    orthonormality defect + 4 u; the larger of the two rotations' defects, as either may be A's)."""
    rmin = np.minimum(a.radii.min(axis=1), b.radii.min(axis=1))
    S = np.linalg.norm(b.centers - a.centers, axis=1) + a.radii.max(axis=1) + b.radii.max(axis=1)
    delta = np.maximum(orthonormality_defect(a.rotations), orthonormality_defect(b.rotations)) + 4.0 * U
    return np.maximum(BB_TOL_REL * rmin, (BB_TOL_ULPS * U + 6.0 * delta) * S)


def within_threshold(model, data, pairs, threshold):
    """MuJoCo's contact test, signed distance of the geoms < threshold, decided pair by pair.

    pairs : (k, 2) ellipsoid or sphere geom ids; threshold : (k,) metres (the pair's margin, or
    margin + gap).  returns (within, decided, dist, relation):
    within (k,) bool, ellipsim's verdict (its float estimate where not decided); decided (k,) bool;
    dist (k,) the geoms' signed distance where it was needed (core.distance.ellipsoid_pair), else nan;
    relation (k,) int8, the exact Relation of the bare geoms.

    Exact wherever classify settles it, on every float input: threshold == 0 (interiors overlap iff the
    signed distance is < 0), overlapping with threshold > 0, separated or touching with threshold < 0,
    touching (distance exactly 0).  Elsewhere the proven signed distance: decided when its status is
    GLOBAL and it is more than proof_tolerance from threshold; an UNPROVEN maximum is never a verdict.
    """
    pairs = np.asarray(pairs).reshape(-1, 2)
    threshold = np.asarray(threshold, dtype=np.float64)
    k = len(pairs)
    zero = np.zeros(k)
    a, b = enclosing(model, data, pairs[:, 0], zero), enclosing(model, data, pairs[:, 1], zero)
    relation = classify(a, b) if k else np.zeros(0, dtype=np.int8)
    overlap, touching = relation == Relation.OVERLAPPING, relation == Relation.TOUCHING
    within = np.where(touching, threshold > 0, overlap)
    decided = np.ones(k, dtype=bool)
    dist = np.full(k, np.nan)
    dist[touching] = 0.0
    i = np.flatnonzero(~touching & (((threshold > 0) & ~overlap) | ((threshold < 0) & overlap)))
    if len(i):
        d, _, _, status = signed_distance(a[i], b[i])
        dist[i] = d
        within[i] = d < threshold[i]
        decided[i] = (status == GLOBAL) & (np.abs(d - threshold[i]) > proof_tolerance(a[i], b[i]))
    return within, decided, dist, relation


def pair_contact_dist(model, data, pairs):
    """(k,) smallest dist of data's contacts on each geom pair (k, 2) sorted by (g1, g2), g1 < g2,
    whichever order the contact names them in; nan for a pair without contact."""
    geom = data.contact.geom[: data.ncon].astype(np.int64)
    key = np.minimum(geom[:, 0], geom[:, 1]) * model.ngeom + np.maximum(geom[:, 0], geom[:, 1])
    pair_key = pairs[:, 0].astype(np.int64) * model.ngeom + pairs[:, 1]
    i = np.minimum(np.searchsorted(pair_key, key), len(pairs) - 1)
    on_pair = pair_key[i] == key
    smallest = np.full(len(pairs), np.inf)
    np.fmin.at(smallest, i[on_pair], data.contact.dist[: data.ncon][on_pair])  # fmin: as Python's min(...)
    touched = np.zeros(len(pairs), dtype=bool)
    touched[i[on_pair]] = True
    return np.where(touched, smallest, np.nan)


def enclosing(model, data, geoms, grow):
    """Ellipsoids (k,) of geoms, each grown to enclose its body offset by grow (k,)."""
    size = model.geom_size[geoms].copy()
    sphere = model.geom_type[geoms] == SPHERE
    size[sphere] = size[sphere, :1]
    scale = 1.0 + grow / size.min(axis=1)
    radii = np.where(sphere[:, None], size + grow[:, None], size * scale[:, None])
    return Ellipsoids(data.geom_xpos[geoms], data.geom_xmat[geoms].reshape(-1, 3, 3), radii)


class PairRecorder:
    """Records the ellipsoid and sphere-ellipsoid pairs MuJoCo's broad phase sends to collision, while
    the `with` block runs (the contact filter in record mode: it applies MuJoCo's own bitmask test
    and otherwise keeps every pair, so contacts and state are plain MuJoCo's).

    The buffer starts at 8 pairs per such geom and doubles when a step overflows it (that step is
    collided again): memory follows the candidates, not the g (g - 1) / 2 possible pairs."""

    def __init__(self, model, data):
        check_model_data(model, data)
        ell = int(np.count_nonzero((model.geom_type == ELLIPSOID) | (model.geom_type == SPHERE)))
        self.model, self.data, self.capacity = model, data, 8 * ell + 64
        self._att = None

    def __enter__(self):
        self._att = Attachment(self.model, self.data, "record", capacity=self.capacity).__enter__()
        return self

    def __exit__(self, *exc):
        self._att.__exit__(*exc)
        return False

    def forward(self):
        """mj_forward, and the (k, 2) int32 candidate pairs it collided, each once, g1 < g2, sorted."""
        while True:
            self._att._counters[3] = 0
            mujoco.mj_forward(self.model, self.data)
            k = int(self._att._counters[3])
            if k <= self.capacity:
                return np.unique(np.sort(self._att._pairs[:k], axis=1), axis=0)
            self._att.__exit__(None, None, None)
            self.capacity = 2 * k
            self._att = Attachment(self.model, self.data, "record", capacity=self.capacity).__enter__()


def candidate_pairs(model, data):
    """(k, 2) int32: the ellipsoid and sphere-ellipsoid geom pairs MuJoCo's broad phase sends to
    collision at the current state (runs mj_forward; contacts and state as plain MuJoCo leaves them)."""
    with PairRecorder(model, data) as recorder:
        return recorder.forward()


class PairRules:
    """MuJoCo's rules for which pairs of the geoms `ids` may collide, tested pair by pair.

    The rules of engine_collision_driver.c: geom contype/conaffinity (`(ct1 & ca2) || (ct2 & ca1)`),
    not in one weld group (same body, or bodies welded together), not parent and child weld groups
    unless one is the world (filterparent, unless mjDSBL_FILTERPARENT), no <exclude> of the two
    bodies.  Memory is linear in len(ids) and the excludes: no (g, g) matrix (500 figures have
    7500 geoms: a matrix of them is 56 MB and took minutes to build with one pass per exclude).
    """

    def __init__(self, model, ids):
        ids = np.asarray(ids, dtype=np.intp)
        body = model.geom_bodyid[ids]
        self.contype = model.geom_contype[ids].copy()
        self.conaffinity = model.geom_conaffinity[ids].copy()
        self.body = body.astype(np.int64)
        self.weld = model.body_weldid[body].astype(np.int64)
        self.parent_weld = model.body_weldid[model.body_parentid[self.weld]].astype(np.int64)
        self.filter_parent = not (model.opt.disableflags & _FILTERPARENT)
        self.nbody = int(model.nbody)
        sig = model.exclude_signature.astype(np.int64)
        b1, b2 = sig >> 16, sig & 0xFFFF
        self.excluded = np.unique(np.minimum(b1, b2) * self.nbody + np.maximum(b1, b2))

    def __len__(self):
        return len(self.body)

    def allowed(self, i, j):
        """(k,) bool: may geoms ids[i] and ids[j] collide?  i, j : (k,) indices into `ids`."""
        i, j = np.asarray(i, dtype=np.intp), np.asarray(j, dtype=np.intp)
        ok = ((self.contype[i] & self.conaffinity[j]) != 0) | ((self.contype[j] & self.conaffinity[i]) != 0)
        wi, wj = self.weld[i], self.weld[j]
        ok &= wi != wj
        if self.filter_parent:
            ok &= ~((wi == self.parent_weld[j]) | (self.parent_weld[i] == wj)) | (wi == 0) | (wj == 0)
        if len(self.excluded):
            bi, bj = self.body[i], self.body[j]
            key = np.minimum(bi, bj) * self.nbody + np.maximum(bi, bj)
            at = np.minimum(np.searchsorted(self.excluded, key), len(self.excluded) - 1)
            ok &= self.excluded[at] != key
        return ok

    def matrix(self):
        """(g, g) bool of `allowed` for every pair, False on the diagonal (for small g: it is g^2 bytes)."""
        i, j = np.indices((len(self), len(self))).reshape(2, -1)
        out = self.allowed(i, j).reshape(len(self), len(self))
        np.fill_diagonal(out, False)
        return out


def ellipsoid_geoms(model):
    """The geoms ellipsim tests: ellipsoid and sphere geoms ids (g,), their semi-axes (g, 3) (a sphere:
    r, r, r), and MuJoCo's rules for which of their pairs may collide (a PairRules over ids)."""
    ids = np.flatnonzero((model.geom_type == ELLIPSOID) | (model.geom_type == SPHERE))
    radii = model.geom_size[ids].copy()
    sphere = model.geom_type[ids] == SPHERE
    radii[sphere] = radii[sphere, :1]
    return ids, radii, PairRules(model, ids)


def frame_pairs(centers, radii, rules):
    """Pairs (frame, i, j), i < j, of every frame whose bounding spheres overlap and that `rules`
    allow: (P, 3) int64, sorted by frame.

    centers : (F, g, 3) metres; radii : (g, 3) semi-axes; rules : PairRules over the same g geoms.
    Sweep and prune per frame (core.motion.broad_phase), then MuJoCo's rules on the pairs it found, vectorised
    (no (g, g) matrix).
    """
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    g = centers.shape[1]
    if g < 2 or len(centers) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    rho = np.ascontiguousarray(radii.max(axis=1) * _SPHERE_SLACK)
    pairs = sweep_and_prune(centers, rho)
    return pairs[rules.allowed(pairs[:, 1], pairs[:, 2])]
