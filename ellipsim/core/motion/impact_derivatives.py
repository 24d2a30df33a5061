"""The derivative of the first-contact time with respect to the two poses of each body.

time_of_impact proves toi within TOI_TOL of the first contact t* of the motion (interpolation.py:
c(t) = c0 + t (c1 - c0), R(t) = R0 Exp(t w), w = Log(R0^T R1)).  At t* the distance is zero; where the
contact is transversal (d dist / dt < 0 there) the implicit function theorem on dist(t*; theta) = 0 gives

    d t* / d theta = -(d dist / d theta) / (d dist / d t)    at t*,

with d dist / d (centre, rotation vector) from derivatives.py at the pose P(t*) and the chain rule through
the motion: d c(t) / d c0 = (1 - t) I, d c(t) / d c1 = t I; a turn Exp(omega1) R1 of the end pose turns
R(t) by K omega1 (world frame), one Exp(omega0) R0 of the start pose by (I - K) omega0, with
K = t R(t) J_r(t w) J_r(w)^-1 R1^T (J_r: SO(3)'s right Jacobian, Exp(phi + delta) ~ Exp(phi) Exp(J_r(phi)
delta); Sola, Deray, Atchuthan, "A micro Lie theory for state estimation in robotics", 2018, eqs. 143-146).
d dist / d t = g_c . (c1 - c0) + g_omega . R(t) w per body (world angular velocity R(t) w).

t* itself is found from toi by Newton's method on dist(t) = 0 (the distance is smooth near a transversal
contact; toi is within 1e-9 of t*, so two steps reach rounding).  Columns: IMPACT_PARAMETERS, 3 each
(centres in metres, rotation vectors in radians turning a pose about its centre about a world axis).
"""

from typing import NamedTuple

import numpy as np

from ..distance.derivatives import SMOOTH
from ..distance.ellipsoid_pair import signed_distance
from ..tolerances import TOI_DERIV_NEWTON_STEPS, TOI_DERIV_NEWTON_TOL, TOI_TRANSVERSAL_REL
from .interpolation import poses_at

#: the 24 columns of d t* / d theta
IMPACT_PARAMETERS = (
    "center_a0",
    "rotation_a0",
    "center_a1",
    "rotation_a1",
    "center_b0",
    "rotation_b0",
    "center_b1",
    "rotation_b1",
)

# Per-pair codes of ImpactDerivatives.status
DEFINED, NO_CONTACT, AT_START, GRAZING, UNRESOLVED = 0, 1, 2, 3, 4


class ImpactDerivatives(NamedTuple):
    """time_of_impact(..., derivatives=True)'s last result.

    toi : (n, 24) d t* / d theta, columns IMPACT_PARAMETERS (NaN where status is not DEFINED)
    status : (n,) int8: DEFINED (a transversal first contact), NO_CONTACT (toi = inf), AT_START (toi = 0:
        not separated at t = 0, no first contact to move), GRAZING (d dist / dt is zero to within
        TOI_TRANSVERSAL_REL at t*: the first contact is tangential and t* is not differentiable),
        UNRESOLVED (time_of_impact's UNRESOLVED, or the contact's normal not isolated)
    """

    toi: np.ndarray
    status: np.ndarray


def _skew(v):
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def _right_jacobian(phi, inverse=False):
    """(k, 3, 3) J_r(phi) or its inverse (series below 1e-4 rad: the next terms are ~theta^4 < 1e-16)."""
    th = np.linalg.norm(phi, axis=1)
    small = th < 1e-4
    t = np.where(small, 1.0, th)
    t2 = th * th
    if inverse:
        c1 = np.full_like(th, 0.5)
        c2 = np.where(small, 1 / 12 + t2 / 720, 1 / t**2 - (1 + np.cos(t)) / (2 * t * np.sin(t)))
    else:
        c1 = -np.where(small, 0.5 - t2 / 24, (1 - np.cos(t)) / t**2)
        c2 = np.where(small, 1 / 6 - t2 / 120, (t - np.sin(t)) / t**3)
    P = _skew(phi)
    return np.eye(3) + c1[:, None, None] * P + c2[:, None, None] * (P @ P)


def endpoint_gradients(g_c, g_w, t, R1, w, R_t):
    """[d / d c0, d / d omega0, d / d c1, d / d omega1], each (k, 3), of a function of one body's pose at
    time t of the motion from pose 0 to pose 1 (module docstring), from its gradient with respect to the pose
    at t: g_c (k, 3) centre, g_w (k, 3) rotation vector (world frame).  t (k,); R1 (k, 3, 3) the pose at 1;
    w (k, 3) the motion's rotation vector Log(R0^T R1); R_t (k, 3, 3) the rotation at t."""
    K = t[:, None, None] * R_t @ _right_jacobian(t[:, None] * w) @ _right_jacobian(w, inverse=True)
    K = K @ np.swapaxes(R1, 1, 2)
    turn0 = np.einsum("ikj,ik->ij", np.eye(3) - K, g_w)  # (I - K)^T g_w
    turn1 = np.einsum("ikj,ik->ij", K, g_w)
    return [(1.0 - t)[:, None] * g_c, turn0, t[:, None] * g_c, turn1]


def impact_derivatives(a0, a1, b0, b1, toi, contact, wa, wb):
    """ImpactDerivatives of the pairs (module docstring); toi as time_of_impact returned it, contact (n,) bool
    its status CONTACT or CONTACT_AT_FLOAT_POSE (a proven contact at toi), wa, wb the (len(a0), 3),
    (len(b0), 3) rotation vectors of the motions (interpolation.rotation_vectors)."""
    n = len(toi)
    out = np.full((n, 24), np.nan)
    code = np.full(n, UNRESOLVED, dtype=np.int8)
    code[np.isinf(toi)] = NO_CONTACT
    code[toi == 0.0] = AT_START
    sel = np.flatnonzero(contact & (toi > 0.0) & (toi <= 1.0))
    if not len(sel):
        return ImpactDerivatives(out, code)
    ia = sel if len(a0) > 1 else np.zeros(len(sel), dtype=np.int64)
    ib = sel if len(b0) > 1 else np.zeros(len(sel), dtype=np.int64)
    A0, A1, B0, B1 = a0[ia], a1[ia], b0[ib], b1[ib]
    va, vb = A1.centers - A0.centers, B1.centers - B0.centers
    t = toi[sel].copy()
    converged = np.zeros(len(sel), dtype=bool)
    for _ in range(TOI_DERIV_NEWTON_STEPS):  # Newton on dist(t) = 0 from toi
        A, B = poses_at(A0, A1, t), poses_at(B0, B1, t)
        dist, _, _, _, der = signed_distance(A, B, derivatives=True)
        g = der.dist
        rate = (
            np.einsum("ij,ij->i", g[:, 0:3], va)
            + np.einsum("ij,ij->i", g[:, 3:6], np.einsum("ijk,ik->ij", A.rotations, wa[ia]))
            + np.einsum("ij,ij->i", g[:, 9:12], vb)
            + np.einsum("ij,ij->i", g[:, 12:15], np.einsum("ijk,ik->ij", B.rotations, wb[ib]))
        )
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.where(rate < 0.0, -dist / rate, 0.0)
        converged = np.abs(step) <= TOI_DERIV_NEWTON_TOL
        if converged.all():
            break
        t = np.clip(t + np.nan_to_num(step), 0.0, 1.0)
    speed = (
        np.linalg.norm(va, axis=1)
        + np.linalg.norm(vb, axis=1)
        + np.linalg.norm(wa[ia], axis=1) * A0.radii.max(axis=1)
        + np.linalg.norm(wb[ib], axis=1) * B0.radii.max(axis=1)
    )
    transversal = rate < -TOI_TRANSVERSAL_REL * speed
    smooth = der.status == SMOOTH
    ok = transversal & smooth & converged
    code[sel] = np.where(ok, DEFINED, np.where(smooth & ~transversal, GRAZING, UNRESOLVED))
    cols = []
    for g_c, g_w, x1, w, R_t in (
        (g[:, 0:3], g[:, 3:6], A1, wa[ia], A.rotations),
        (g[:, 9:12], g[:, 12:15], B1, wb[ib], B.rotations),
    ):
        cols += endpoint_gradients(g_c, g_w, t, x1.rotations, w, R_t)
    d = -np.concatenate(cols, axis=1) / rate[:, None]
    d[~ok] = np.nan
    out[sel] = d
    return ImpactDerivatives(out, code)
