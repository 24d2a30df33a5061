"""The geom pairs of a MuJoCo model that MuJoCo collides (dynamic and <pair> elements), their margins and
gaps, MuJoCo's rules for them, and its candidate pairs as its broad phase makes them (the exact verdict on
its contact test is judge.py's).

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

from ..core.motion.broad_phase import sweep_and_prune
from .attachment import Attachment, check_model_data
from .context import ELLIPSOID, SPHERE
from .judge import judged, judged_geoms

_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
_SLEEP = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
_FILTERPARENT = int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
_NO_CONTACTS = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
_AWAKE = int(mujoco.mjtSleepState.mjS_AWAKE)

#: Bounding spheres of the broad phase are the largest semi-axis times this (one part in 1e9 more,
#: so that rounding in the sphere test never drops a pair whose ellipsoids touch).
_SPHERE_SLACK = 1 + 1e-9


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
    if model.npair == 0:
        return out
    at, named = _explicit_lookup(model, pairs)
    out[named] = _explicit(model)[1][at[named]]
    return out


def pair_gaps(model, pairs):
    """(k,) gap MuJoCo gives each geom pair (k, 2): the <pair> element's gap when one names the pair,
    else the geoms' sum (getGap; not overridden).  MuJoCo makes a contact below margin + gap and
    excludes it from the constraints at or above margin."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    out = model.geom_gap[pairs[:, 0]] + model.geom_gap[pairs[:, 1]]
    if model.npair == 0:
        return out
    at, named = _explicit_lookup(model, pairs)
    out[named] = _explicit(model)[2][at[named]]
    return out


def explicit_pairs(model, data=None):
    """(p, 2) int32: the geom pairs of the model's <contact><pair> elements that ellipsim judges
    (a row of context.PAIR_TYPES: judge.judged), each once, g1 < g2, sorted.

    With data: only those MuJoCo collides at data's state (none when contacts or constraints are
    disabled; under mjENBL_SLEEP not those with both bodies asleep), as mj_collision does; the
    bounding-sphere test is left out (a pair it drops is farther apart than margin + gap anyway)."""
    if model.npair == 0:
        return np.zeros((0, 2), dtype=np.int32)
    keys = _explicit(model)[0]
    pairs = np.stack(divmod(keys, model.ngeom), axis=1).astype(np.int32)
    pairs = pairs[judged(model, pairs[:, 0], pairs[:, 1])]
    if data is None:
        return pairs
    check_model_data(model, data)
    if model.opt.disableflags & _NO_CONTACTS or model.nbody + model.nflex < 2:
        return pairs[:0]
    if model.opt.enableflags & _SLEEP:
        awake = data.body_awake[model.geom_bodyid[pairs]] == _AWAKE
        pairs = pairs[awake.any(axis=1)]
    return pairs


def pair_contacts(model, data, pairs):
    """MuJoCo's contact on each geom pair (k, 2), g1 < g2, sorted by (g1, g2), whichever order the contact
    names them in: the one with the smallest dist when it made several.  returns dist (k,) metres (nan for
    a pair without contact), normal (k, 3) unit from g1 to g2, pos (k, 3) (nan without contact)."""
    n = data.ncon
    geom = data.contact.geom[:n].astype(np.int64)
    key = np.minimum(geom[:, 0], geom[:, 1]) * model.ngeom + np.maximum(geom[:, 0], geom[:, 1])
    pair_key = pairs[:, 0].astype(np.int64) * model.ngeom + pairs[:, 1]
    k = len(pairs)
    dist, normal, pos = np.full(k, np.nan), np.full((k, 3), np.nan), np.full((k, 3), np.nan)
    if k == 0 or n == 0:
        return dist, normal, pos
    i = np.minimum(np.searchsorted(pair_key, key), k - 1)
    on_pair = np.flatnonzero(pair_key[i] == key)
    if len(on_pair) == 0:
        return dist, normal, pos
    d = data.contact.dist[:n][on_pair]
    order = on_pair[np.lexsort((d, i[on_pair]))]  # by pair, smallest dist first
    first = order[np.r_[True, i[order[1:]] != i[order[:-1]]]]
    at = i[first]
    dist[at] = data.contact.dist[:n][first]
    sign = np.where(geom[first, 0] == pairs[at, 0], 1.0, -1.0)  # MuJoCo's normal points from its geom1
    normal[at] = sign[:, None] * data.contact.frame[:n][first, :3]
    pos[at] = data.contact.pos[:n][first]
    return dist, normal, pos


class PairRecorder:
    """Records the pairs of every type ellipsim judges (context.PAIR_TYPES) that MuJoCo's broad phase
    sends to collision, while the `with` block runs (the contact filter in record mode: it applies
    MuJoCo's own bitmask test and otherwise keeps every pair, so contacts and state are plain MuJoCo's).

    The buffer starts at 8 pairs per such geom and doubles when a step overflows it (that step is
    collided again): memory follows the candidates, not the g (g - 1) / 2 possible pairs."""

    def __init__(self, model, data):
        check_model_data(model, data)
        self.model, self.data, self.capacity = model, data, 8 * len(judged_geoms(model)) + 64
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
    """(k, 2) int32: the geom pairs of every type ellipsim judges (ellipsoid with ellipsoid, sphere,
    capsule, box or cylinder: context.PAIR_TYPES) that MuJoCo's broad phase sends to collision at the
    current state, g1 < g2, sorted (runs mj_forward; contacts and state as plain MuJoCo leaves them)."""
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

    centers : (F, g, 3) metres; radii : (g, 3) semi-axes (the sphere: the largest, a part in 1e9 more), or
    (g,) the bounding spheres' radii themselves; rules : PairRules over the same g geoms.
    Sweep and prune per frame (core.motion.broad_phase), then MuJoCo's rules on the pairs it found, vectorised
    (no (g, g) matrix).
    """
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    g = centers.shape[1]
    if g < 2 or len(centers) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    radii = np.asarray(radii, dtype=np.float64)
    rho = np.ascontiguousarray(radii.max(axis=1) * _SPHERE_SLACK if radii.ndim == 2 else radii)
    pairs = sweep_and_prune(centers, rho)
    return pairs[rules.allowed(pairs[:, 1], pairs[:, 2])]
