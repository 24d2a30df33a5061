"""Ellipsoid geoms of a MuJoCo model, and the pairs MuJoCo's broad phase would collide."""

import mujoco
import numpy as np

from ..core.broadphase import sweep_and_prune
from ..core.ellipsoids import Ellipsoids
from .attachment import Attachment, check_model_data
from .callbacks import ELLIPSOID, SPHERE

_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
_FILTERPARENT = int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)

#: Bounding spheres of the broad phase are the largest semi-axis times this (one part in 1e9 more,
#: so that rounding in the sphere test never drops a pair whose ellipsoids touch).
_SPHERE_SLACK = 1 + 1e-9


def pair_margins(model, pairs):
    """(k,) margin of each geom pair (k, 2): opt.o_margin under mjENBL_OVERRIDE, else the geoms' sum."""
    if model.opt.enableflags & _OVERRIDE:
        return np.full(len(pairs), float(model.opt.o_margin))
    return model.geom_margin[pairs[:, 0]] + model.geom_margin[pairs[:, 1]]


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
    Sweep and prune per frame (core.broadphase), then MuJoCo's rules on the pairs it found, vectorised
    (no (g, g) matrix).
    """
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    g = centers.shape[1]
    if g < 2 or len(centers) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    rho = np.ascontiguousarray(radii.max(axis=1) * _SPHERE_SLACK)
    pairs = sweep_and_prune(centers, rho)
    return pairs[rules.allowed(pairs[:, 1], pairs[:, 2])]
