"""Exact first derivatives of the signed distance of two ellipsoids, of its normal and of its contact point,
with respect to both poses and semi-axes.

At a unique, nondegenerate maximiser n* of sigma(n; theta) = n.d - h_A(n) - h_B(n) over the unit sphere
(ellipsoid_pair.py; h(n) = |D R^T n|, h_B(-n) = h_B(n)), the distance is differentiable and
(envelope theorem, Danskin; Bertsekas, Nonlinear Programming, Prop. B.25)

    d dist / d theta = d sigma(n*; theta) / d theta   at n* held fixed;

n* follows from the implicit function theorem on the stationarity condition P grad sigma = 0 on the
sphere (P = I - n n^T): with the Riemannian Hessian H = P hess(sigma) P - sigma P (sigma is positively
homogeneous of degree 1, so n.grad sigma = sigma) and a tangent basis T,

    d n* / d theta = -T (T^T H T)^-1 T^T d grad sigma / d theta,

and the contact point, the midpoint of the support points c_A + g_A(n*) and c_B - g_B(n*) with
g = grad h = R D^2 R^T n / h, by the chain rule through n*.  hess h = (R D^2 R^T - g g^T) / h.

Parameters, 9 per body, 18 columns in this order (PARAMETERS): the centre (metres), a rotation vector
omega (radians: R -> expm([omega]_x) R, a turn about the body's centre about a world axis, the
angular-velocity convention of MuJoCo's mj_jac), the semi-axes (metres).

The derivative is defined where the maximiser is unique and isolated.  Status per pair
(status.DerivativeStatus; the kernels' int8 codes below):
* SMOOTH: sigma's maximum exceeds -(rho_A + rho_B) (separated, or penetrating by less than the sum of
  the rolling radii: max sigma + rho is then the distance from the centre offset to a convex set, whose
  nearest point is unique, ellipsoid_pair.py) and the Hessian is negative definite: the derivatives.
* BRANCH: a deeper proven maximum (or concentric bodies, where sigma(n) = sigma(-n)): the derivatives
  of the maximum found, which is the distance's own derivative where that maximiser is the only one; where
  another maximiser ties (not excluded here) the distance has a kink and these are the derivatives of
  one of its active branches (an element of its Clarke generalised gradient), still a valid descent
  direction for pushing the pair apart.
* FLAT: the Hessian is singular to within rounding (a circle of maxima, as coaxial spheroids have, or
  nearly so): NaN.
* UNPROVEN: the maximum itself is not proven: NaN.

Before differentiating, n* is polished by Newton's method on the sphere with the same Hessian (at most
POLISH_STEPS steps, kept only when sigma does not drop by more than rounding): the proven maximum is
exact to the proof's tolerance in value, which leaves the maximiser itself accurate only to about the
square root of it along a flat direction.
"""

import math
from typing import NamedTuple

import numpy as np

from .._jit import jit, stage
from ..tolerances import DERIV_FLAT_REL, DERIV_POLISH_SLACK_ULPS, DERIV_POLISH_STEPS, U
from ..vec3 import load, matvec, norm2, rotate_t, sandwich, scaled, unit_scale
from .sphere_newton import rolling_radius

#: the 18 columns of each derivative, 3 each: (name, metres or radians)
PARAMETERS = ("center_a", "rotation_a", "radii_a", "center_b", "rotation_b", "radii_b")

#: the kernels' codes, status.DerivativeStatus by name (tests/test_derivatives.py checks they agree)
SMOOTH, BRANCH, FLAT, UNPROVEN = 0, 1, 2, 3


class DistanceDerivatives(NamedTuple):
    """signed_distance(..., derivatives=True)'s fifth result; columns as PARAMETERS, 3 each.

    dist : (n, 18) d dist / d parameter
    normal : (n, 3, 18) d normal / d parameter
    pos : (n, 3, 18) d contact point / d parameter
    status : (n,) int8, DerivativeStatus
    """

    dist: np.ndarray
    normal: np.ndarray
    pos: np.ndarray
    status: np.ndarray


@stage
def _support(R, r, n):
    """(h, g, z) of an ellipsoid at unit n, about its centre: h = |D R^T n|, g = grad h = R D^2 R^T n / h,
    z = R^T n."""
    z = rotate_t(R, n)
    x = (r[0] * z[0], r[1] * z[1], r[2] * z[2])
    h = math.sqrt(norm2(x))
    g = matvec(R, (r[0] * x[0] / h, r[1] * x[1] / h, r[2] * x[2] / h))
    return h, g, z


@stage
def _hess(R, r, g, h):
    """hess h = (R D^2 R^T - g g^T) / h as a symmetric row-major 9-tuple."""
    s00, s01, s02, s11, s12, s22 = sandwich(R, r[0] * r[0], r[1] * r[1], r[2] * r[2])
    k = 1.0 / h
    m00, m01, m02 = (s00 - g[0] * g[0]) * k, (s01 - g[0] * g[1]) * k, (s02 - g[0] * g[2]) * k
    m11, m12, m22 = (s11 - g[1] * g[1]) * k, (s12 - g[1] * g[2]) * k, (s22 - g[2] * g[2]) * k
    return (m00, m01, m02, m01, m11, m12, m02, m12, m22)


@stage
def _tangent(n):
    """An orthonormal basis (t1, t2) of the plane normal to the unit n."""
    if abs(n[0]) < 0.6:
        v = (0.0, -n[2], n[1])  # e_x x n
    else:
        v = (n[2], 0.0, -n[0])  # e_y x n
    s = 1.0 / math.sqrt(norm2(v))
    t1 = (v[0] * s, v[1] * s, v[2] * s)
    t2 = (n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])
    return t1, t2


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def _cross(x, y):
    return (x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])


@stage
def _local(n, d, Ra, ra, Rb, rb):
    """Everything at the unit n: (sigma, grad sigma, h_A, g_A, z_A, J_A, h_B, g_B, z_B, J_B, t1, t2,
    the reduced Hessian (h11, h12, h22))."""
    ha, ga, za = _support(Ra, ra, n)
    hb, gb, zb = _support(Rb, rb, n)
    Ja, Jb = _hess(Ra, ra, ga, ha), _hess(Rb, rb, gb, hb)
    s = _dot(n, d) - ha - hb
    grad = (d[0] - ga[0] - gb[0], d[1] - ga[1] - gb[1], d[2] - ga[2] - gb[2])
    t1, t2 = _tangent(n)
    J = (Ja[0] + Jb[0], Ja[1] + Jb[1], Ja[2] + Jb[2], Ja[3] + Jb[3], Ja[4] + Jb[4], Ja[5] + Jb[5],
         Ja[6] + Jb[6], Ja[7] + Jb[7], Ja[8] + Jb[8])  # fmt: skip
    Jt1, Jt2 = matvec(J, t1), matvec(J, t2)
    h11, h12, h22 = -_dot(t1, Jt1) - s, -_dot(t1, Jt2), -_dot(t2, Jt2) - s
    return s, grad, ha, ga, za, Ja, hb, gb, zb, Jb, t1, t2, (h11, h12, h22)


@stage
def _top_eigenvalue(H):
    """The larger eigenvalue of the symmetric 2x2 (h11, h12, h22)."""
    m, q = 0.5 * (H[0] + H[2]), 0.5 * (H[0] - H[2])
    return m + math.sqrt(q * q + H[1] * H[1])


@stage
def _write_nan(grad, jn, jp, i):
    for j in range(18):
        grad[i, j] = math.nan
        for k in range(3):
            jn[i, k, j] = math.nan
            jp[i, k, j] = math.nan


@stage
def _pair_derivatives(A, B, normal, dist_status, grad, jn, jp, i):
    """The derivatives of pair i at its maximiser `normal` (world, unit) into grad[i], jn[i], jp[i];
    returns the DerivativeStatus."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    if dist_status != 0:
        _write_nan(grad, jn, jp, i)
        return UNPROVEN
    u = unit_scale(ra, rb)  # a power of two (exact): lengths in units where the largest semi-axis is < 2^50
    ra, rb = scaled(ra, u), scaled(rb, u)
    d = ((cb[0] - ca[0]) * u, (cb[1] - ca[1]) * u, (cb[2] - ca[2]) * u)
    S = math.sqrt(norm2(d)) + max(ra[0], ra[1], ra[2]) + max(rb[0], rb[1], rb[2])
    n = normal
    s, grad_s, ha, ga, za, Ja, hb, gb, zb, Jb, t1, t2, H = _local(n, d, Ra, ra, Rb, rb)
    for _ in range(DERIV_POLISH_STEPS):  # Newton on the sphere (module docstring)
        if not _top_eigenvalue(H) < -DERIV_FLAT_REL * S:
            break
        r1, r2 = _dot(t1, grad_s), _dot(t2, grad_s)
        det = H[0] * H[2] - H[1] * H[1]
        a1, a2 = -(H[2] * r1 - H[1] * r2) / det, -(H[0] * r2 - H[1] * r1) / det
        m = (n[0] + a1 * t1[0] + a2 * t2[0], n[1] + a1 * t1[1] + a2 * t2[1], n[2] + a1 * t1[2] + a2 * t2[2])
        k = 1.0 / math.sqrt(norm2(m))
        m = (m[0] * k, m[1] * k, m[2] * k)
        local = _local(m, d, Ra, ra, Rb, rb)
        if local[0] < s - DERIV_POLISH_SLACK_ULPS * U * S:
            break
        n = m
        s, grad_s, ha, ga, za, Ja, hb, gb, zb, Jb, t1, t2, H = local
        if a1 * a1 + a2 * a2 < 1e-32:
            break
    if not _top_eigenvalue(H) < -DERIV_FLAT_REL * S:
        _write_nan(grad, jn, jp, i)
        return FLAT
    rho = rolling_radius(ra) + rolling_radius(rb)
    status = SMOOTH if s > -rho and (d[0] != 0.0 or d[1] != 0.0 or d[2] != 0.0) else BRANCH
    det = H[0] * H[2] - H[1] * H[1]
    i11, i12, i22 = H[2] / det, -H[1] / det, H[0] / det  # (T^T H T)^-1
    iu = 1.0 / u
    for j in range(18):
        body, kind, axis = j // 9, (j % 9) // 3, j % 3
        e = (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0, 1.0 if axis == 2 else 0.0)
        sign = -1.0 if body == 0 else 1.0
        R, r, h, g, z, Jm = (Ra, ra, ha, ga, za, Ja) if body == 0 else (Rb, rb, hb, gb, zb, Jb)
        # dv: d dist; b: d grad sigma; q: the contact point's explicit part (without n*'s motion)
        if kind == 0:  # centre: sigma has sign * n.c, the contact point half of it
            dv = sign * n[axis]
            b = (sign * e[0], sign * e[1], sign * e[2])
            q = (0.5 * e[0], 0.5 * e[1], 0.5 * e[2])
            cols = (1.0, u, 1.0)  # scales back to world units: dist, normal, pos
        elif kind == 1:  # rotation: d g / d omega = -[g]x + J [n]x, d h / d omega = g x n
            nxg = _cross(n, g)
            dv = nxg[axis]
            Jn = matvec(Jm, _cross(n, e))
            gxe = _cross(g, e)
            b = (gxe[0] - Jn[0], gxe[1] - Jn[1], gxe[2] - Jn[2])  # -d g / d omega
            q = (-0.5 * b[0] * -sign, -0.5 * b[1] * -sign, -0.5 * b[2] * -sign)
            cols = (iu, 1.0, iu)
        else:  # semi-axis: d h / d r_k = r_k z_k^2 / h, d g / d r_k = (2 r_k z_k R e_k - g r_k z_k^2 / h) / h
            rk, zk = r[axis], z[axis]
            dv = -rk * zk * zk / h
            c = (R[axis], R[3 + axis], R[6 + axis])
            w = rk * zk * zk / h
            b = (-(2.0 * rk * zk * c[0] - g[0] * w) / h, -(2.0 * rk * zk * c[1] - g[1] * w) / h,
                 -(2.0 * rk * zk * c[2] - g[2] * w) / h)  # fmt: skip
            q = (-0.5 * b[0] * -sign, -0.5 * b[1] * -sign, -0.5 * b[2] * -sign)
            cols = (1.0, u, 1.0)
        # dn = -T (T^T H T)^-1 T^T b
        b1, b2 = _dot(t1, b), _dot(t2, b)
        a1, a2 = -(i11 * b1 + i12 * b2), -(i12 * b1 + i22 * b2)
        dn = (a1 * t1[0] + a2 * t2[0], a1 * t1[1] + a2 * t2[1], a1 * t1[2] + a2 * t2[2])
        # the contact point moves with n* through (J_A - J_B) / 2
        pa, pb = matvec(Ja, dn), matvec(Jb, dn)
        grad[i, j] = dv * cols[0]
        for k in range(3):
            jn[i, k, j] = dn[k] * cols[1]
            jp[i, k, j] = (q[k] + 0.5 * (pa[k] - pb[k])) * cols[2]
    return status


@jit
def _derivatives(Ca, Ra, ra, Cb, Rb, rb, normal, dist_status, grad, jn, jp, status, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(lo, hi):
        n = (normal[i, 0], normal[i, 1], normal[i, 2])
        A, B = load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb)
        status[i] = _pair_derivatives(A, B, n, dist_status[i], grad, jn, jp, i)
