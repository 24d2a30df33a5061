"""The derivative of ellipsoid pairs' signed distances with respect to a model's joint coordinates.

    jac = ellipsim.mujoco.distance_jacobian(model, data, pairs)   # jac.dist (k,), jac.jacobian (k, nv)

Chain rule: core/distance/derivatives.py gives d dist / d (centre, rotation vector) of each geom, the
rotation vector turning the geom about its centre about a world axis; MuJoCo's mj_jacGeom gives the
geom centre's linear velocity and the body's angular velocity per unit of each dof (world frame,
engine_core_smooth.c mj_jac), so d dist / d v = g_p . jacp + g_w . jacr.  The columns are MuJoCo's nv
dofs: v is a displacement of qpos in the tangent space, qpos -> mj_integratePos(qpos, v, 1).  For
hinge and slide joints that is d / d qpos itself; for a ball or free joint's quaternion it is the
derivative with respect to a rotation vector (world frame for free joints, the body frame for ball
joints, as MuJoCo's qvel), which is what a step in qpos must follow to stay on the unit quaternions.

Capsule, box and cylinder against an ellipsoid: core.pairs.shape_distance's derivatives (the narrow
phase's proven maxima, differentiated on the feature that carries the contact: core/pairs/derivatives.py),
with its statuses: SMOOTH, BRANCH, ONE_SIDED (defined), FLAT, UNPROVEN (NaN).
"""

from typing import NamedTuple

import mujoco
import numpy as np

from ..core.distance.derivatives import BRANCH, SMOOTH
from ..core.distance.ellipsoid_pair import signed_distance
from ..core.ellipsoids import Ellipsoids
from ..core.motion.impact_derivatives import endpoint_gradients
from ..core.motion.interpolation import poses_at, rotation_vectors
from ..core.pairs.derivatives import ONE_SIDED
from ..core.pairs.shape_distance import shape_distance
from .attachment import check_model_data
from .context import BOX, CAPSULE, CYLINDER, ELLIPSOID, SPHERE


class DistanceJacobian(NamedTuple):
    """distance_jacobian's result, per pair (k pairs, nv dofs).

    dist : (k,) signed distance, metres (< 0: minus the penetration depth)
    jacobian : (k, nv) d dist / d v (metres per unit of each dof), NaN where status says not defined
    normal, pos : (k, 3) the contact normal (from the first geom to the second) and point, world frame
    status : (k,) int8, ellipsim.DerivativeStatus (SMOOTH or BRANCH: defined; FLAT, UNPROVEN: NaN)
    """

    dist: np.ndarray
    jacobian: np.ndarray
    normal: np.ndarray
    pos: np.ndarray
    status: np.ndarray


def _check_pairs(model, pairs, others=False):
    try:
        arr = np.asarray(pairs)
    except Exception as exc:  # ragged lists and the like
        raise ValueError(f"pairs must be a (k, 2) array of geom ids, got {pairs!r}") from exc
    if arr.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != 2 or not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"pairs must be a (k, 2) array of integer geom ids, got shape {arr.shape} of {arr.dtype}")
    arr = arr.astype(np.int64)
    bad = np.flatnonzero((arr < 0) | (arr >= model.ngeom))
    if len(bad):
        i, j = np.unravel_index(bad[0], arr.shape)
        raise ValueError(f"pairs[{i}, {j}] = {arr[i, j]} is not a geom id of the model (ngeom {model.ngeom})")
    kind = model.geom_type[arr]
    ok = (kind == ELLIPSOID) | (kind == SPHERE)
    both = ok.all(axis=1) & (kind == ELLIPSOID).any(axis=1)
    if others:
        other = np.isin(kind, [CAPSULE, BOX, CYLINDER])
        both |= ((kind == ELLIPSOID) & other[:, ::-1]).any(axis=1)
    if not both.all():
        i = int(np.flatnonzero(~both)[0])
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"#{g}" for g in arr[i]]
        types = [mujoco.mjtGeom(int(t)).name.removeprefix("mjGEOM_").lower() for t in kind[i]]
        raise ValueError(
            f"pairs[{i}] = ({arr[i, 0]}, {arr[i, 1]}) is {names[0]} ({types[0]}) x {names[1]} ({types[1]}):"
            + (
                " distance_jacobian takes an ellipsoid against an ellipsoid, sphere, capsule, box or cylinder"
                if others
                else " it takes ellipsoid x ellipsoid and sphere x ellipsoid pairs"
            )
        )
    same = np.flatnonzero(arr[:, 0] == arr[:, 1])
    if len(same):
        raise ValueError(f"pairs[{same[0]}] names geom {arr[same[0], 0]} twice")
    return arr


def _bodies(model, data, geoms):
    """Ellipsoids (k,) of the geoms at data's kinematics (a sphere: r, r, r)."""
    size = model.geom_size[geoms].copy()
    sphere = model.geom_type[geoms] == SPHERE
    size[sphere] = size[sphere, :1]
    return Ellipsoids(data.geom_xpos[geoms], data.geom_xmat[geoms].reshape(-1, 3, 3), size)


def _others(model, data, pairs):
    """(dist, jacobian (k, nv), normal, pos, status) of capsule, box and cylinder pairs with an ellipsoid
    (module docstring), normal from each pair's first geom to its second."""
    k = len(pairs)
    flip = model.geom_type[pairs[:, 0]] != ELLIPSOID  # the ellipsoid second: swap, then turn the normal round
    e = np.where(flip, pairs[:, 1], pairs[:, 0])
    g = np.where(flip, pairs[:, 0], pairs[:, 1])
    dist, normal, pos = np.empty(k), np.empty((k, 3)), np.empty((k, 3))
    grad, status = np.empty((k, 18)), np.empty(k, np.int8)
    E = _bodies(model, data, e)
    for code, kind in ((CAPSULE, "capsule"), (BOX, "box"), (CYLINDER, "cylinder")):
        i = np.flatnonzero(model.geom_type[g] == code)
        if len(i):
            K = (data.geom_xpos[g[i]], data.geom_xmat[g[i]].reshape(-1, 3, 3), model.geom_size[g[i]])
            dist[i], normal[i], pos[i], _, der = shape_distance(E[i], kind, *K, derivatives=True)
            grad[i], status[i] = der.dist, der.status
    jac = _chain(
        grad[:, 0:3],
        grad[:, 3:6],
        grad[:, 9:12],
        grad[:, 12:15],
        *_geom_jacobians(model, data, np.column_stack([e, g])),
    )
    jac[~_defined(status)] = np.nan
    normal[flip] *= -1.0
    return dist, jac, normal, pos, status


def _defined(status):
    return (status == SMOOTH) | (status == BRANCH) | (status == ONE_SIDED)


def distance_jacobian(model, data, pairs):
    """d dist / d qpos of geom pairs with an ellipsoid, through MuJoCo's geom Jacobians.

    model, data : mujoco.MjModel and an MjData of it; data's kinematics are recomputed from its qpos
        (mj_kinematics, mj_comPos: what mj_forward computes first), nothing else of it is changed
    pairs : (k, 2) geom ids, each pair an ellipsoid against an ellipsoid, a sphere, a capsule, a box or a
        cylinder (the last three through core.pairs.shape_distance's derivatives, module docstring)
    returns : DistanceJacobian; jacobian's columns are the model's nv dofs (module docstring: for
        hinge and slide joints d / d qpos, for quaternions the tangent-space derivative)
    """
    check_model_data(model, data)
    pairs = _check_pairs(model, pairs, others=True)
    k, nv = len(pairs), model.nv
    if k == 0:
        return DistanceJacobian(
            np.zeros(0), np.zeros((0, nv)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int8)
        )
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    kinds = model.geom_type[pairs]
    two = ((kinds == ELLIPSOID) | (kinds == SPHERE)).all(axis=1)
    dist, jac = np.empty(k), np.empty((k, nv))
    normal, pos, status = np.empty((k, 3)), np.empty((k, 3)), np.empty(k, dtype=np.int8)
    if (~two).any():
        i = np.flatnonzero(~two)
        dist[i], jac[i], normal[i], pos[i], status[i] = _others(model, data, pairs[i])
    if two.any():
        i = np.flatnonzero(two)
        dist[i], jac[i], normal[i], pos[i], status[i] = _ellipsoids(model, data, pairs[i])
    return DistanceJacobian(dist, jac, normal, pos, status)


def _ellipsoids(model, data, pairs):
    a, b = _bodies(model, data, pairs[:, 0]), _bodies(model, data, pairs[:, 1])
    dist, normal, pos, _, der = signed_distance(a, b, derivatives=True)
    jacp, jacr, index = _geom_jacobians(model, data, pairs)  # one C call per geom, not per pair
    jac = _chain(der.dist[:, 0:3], der.dist[:, 3:6], der.dist[:, 9:12], der.dist[:, 12:15], jacp, jacr, index)
    jac[~_defined(der.status)] = np.nan
    return dist, jac, normal, pos, der.status


def _geom_jacobians(model, data, pairs):
    """(jacp, jacr (u, 3, nv) of the u geoms the pairs name, index (k, 2) into them): one mj_jacGeom per geom."""
    geoms, index = np.unique(pairs, return_inverse=True)
    jacp, jacr = np.empty((len(geoms), 3, model.nv)), np.empty((len(geoms), 3, model.nv))
    for i, g in enumerate(geoms):
        mujoco.mj_jacGeom(model, data, jacp[i], jacr[i], int(g))
    return jacp, jacr, index.reshape(-1, 2)


def _chain(gca, gwa, gcb, gwb, jacp, jacr, index):
    """(k, nv): the gradients with respect to each pair's two geom centres and rotation vectors through the
    geoms' Jacobians."""
    return (
        np.einsum("kc,kcv->kv", gca, jacp[index[:, 0]])
        + np.einsum("kc,kcv->kv", gwa, jacr[index[:, 0]])
        + np.einsum("kc,kcv->kv", gcb, jacp[index[:, 1]])
        + np.einsum("kc,kcv->kv", gwb, jacr[index[:, 1]])
    )


def interpolated_distance_jacobian(model, data0, data1, pairs, t):
    """The signed distance of each pair at time t of the interpolated motion between two states, and its
    derivative with respect to each state's qpos.

    The motion is core.motion.interpolation's (each geom's centre linear, its rotation along the shortest
    arc: what time_of_impact and the contacts between frames of replay and compare use), so it is a
    function of the two states' geom poses; its derivative with respect to them is
    core.motion.impact_derivatives.endpoint_gradients', chained with each state's mj_jacGeom.
    data0, data1 : two MjData of model (their kinematics are recomputed from their qpos); pairs : (k, 2)
    ellipsoid pairs as distance_jacobian; t : (k,) or a number in [0, 1].
    returns : (dist (k,), J0 (k, nv), J1 (k, nv), status (k,) DerivativeStatus); ValueError for a geom
    turning by a half turn between the states (no shortest arc).
    """
    check_model_data(model, data0)
    check_model_data(model, data1)
    pairs = _check_pairs(model, pairs)
    k = len(pairs)
    t = np.broadcast_to(np.asarray(t, dtype=np.float64), (k,)).copy()
    if not ((t >= 0.0) & (t <= 1.0)).all():
        raise ValueError(f"t must lie in [0, 1], got {t[~((t >= 0.0) & (t <= 1.0))][0]!r}")
    if k == 0:
        z = np.zeros((0, model.nv))
        return np.zeros(0), z, z.copy(), np.zeros(0, np.int8)
    for data in (data0, data1):
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
    ends = [(_bodies(model, d, pairs[:, 0]), _bodies(model, d, pairs[:, 1])) for d in (data0, data1)]
    (A0, B0), (A1, B1) = ends
    wa, wb = (
        rotation_vectors(A0, A1, "data0 geoms", "data1 geoms"),
        rotation_vectors(B0, B1, "data0 geoms", "data1 geoms"),
    )
    A, B = poses_at(A0, A1, t), poses_at(B0, B1, t)
    dist, _, _, _, der = signed_distance(A, B, derivatives=True)
    g = der.dist
    ga = endpoint_gradients(g[:, 0:3], g[:, 3:6], t, A1.rotations, wa, A.rotations)
    gb = endpoint_gradients(g[:, 9:12], g[:, 12:15], t, B1.rotations, wb, B.rotations)
    J0 = _chain(ga[0], ga[1], gb[0], gb[1], *_geom_jacobians(model, data0, pairs))
    J1 = _chain(ga[2], ga[3], gb[2], gb[3], *_geom_jacobians(model, data1, pairs))
    defined = _defined(der.status)
    J0[~defined], J1[~defined] = np.nan, np.nan
    return dist, J0, J1, der.status
