"""Ellipsoid geoms of a MuJoCo model, and the pairs MuJoCo's broad phase would collide."""

import mujoco
import numpy as np

from ..core.ellipsoids import Ellipsoids
from .attachment import Attachment, check_model_data
from .callbacks import ELLIPSOID, SPHERE

_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)


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


def candidate_pairs(model, data):
    """(k, 2) int32: the ellipsoid and sphere-ellipsoid geom pairs MuJoCo's broad phase sends to
    collision at the current state (runs mj_forward; contacts and state as plain MuJoCo leaves them)."""
    check_model_data(model, data)
    ell = np.count_nonzero((model.geom_type == ELLIPSOID) | (model.geom_type == SPHERE))
    with Attachment(model, data, "record", capacity=max(ell * (ell - 1) // 2, 1)) as att:
        mujoco.mj_forward(model, data)
        k = int(att._counters[3])
        return np.unique(np.sort(att._pairs[:k], axis=1), axis=0)


def ellipsoid_geoms(model):
    """Ellipsoid and sphere geoms, their semi-axes (g, 3), and which pairs may collide (g, g) bool:
    MuJoCo's own rules (contype/conaffinity, not the same body, not parent and child, <exclude>)."""
    ids = np.flatnonzero((model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID) | (model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE))
    radii = model.geom_size[ids].copy()
    sphere = model.geom_type[ids] == mujoco.mjtGeom.mjGEOM_SPHERE
    radii[sphere] = radii[sphere, :1]
    body = model.geom_bodyid[ids]
    ct, ca = model.geom_contype[ids], model.geom_conaffinity[ids]
    allowed = ((ct[:, None] & ca[None, :]) != 0) | ((ct[None, :] & ca[:, None]) != 0)
    weld = model.body_weldid[body]
    parent = model.body_weldid[model.body_parentid[model.body_weldid[body]]]
    allowed &= weld[:, None] != weld[None, :]
    allowed &= ~((weld[:, None] == parent[None, :]) | (parent[:, None] == weld[None, :])) | (weld[:, None] == 0) | (weld[None, :] == 0)
    for k in range(model.nexclude):
        sig = model.exclude_signature[k]
        b1, b2 = sig >> 16, sig & 0xFFFF
        allowed &= ~(((body[:, None] == b1) & (body[None, :] == b2)) | ((body[:, None] == b2) & (body[None, :] == b1)))
    np.fill_diagonal(allowed, False)
    return ids, radii, allowed
