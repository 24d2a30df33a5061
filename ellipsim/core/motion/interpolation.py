"""The rigid motion between two poses that time_of_impact assumes, and its float64 evaluation with
proven error bounds.

Each body keeps its semi-axes; its centre moves linearly and its rotation turns at constant angular
velocity along the shortest arc (issue 12):

    c(t) = c0 + t (c1 - c0),    R(t) = R0 exp(t [w]x),    w = log(R0^T R1) as a float64 axis-angle vector.

The motion is defined *exactly* (real arithmetic) by the float64 data c0, c1, R0, R1 and w.  So that it
ends exactly on the given pose, the second half is written from the far end: R(t) = R1 exp((t - 1) [w]x)
on [1/2, 1].  The halves meet at t = 1/2 to within the rounding of w (~1e-16); time_of_impact covers
both, and at t = 0 and t = 1 the motion is exactly the input poses.  R0, R1 need only be invertible
(validated rotations are orthonormal to 1e-6): exp(phi [w]x) is an exact rotation.

Float64 evaluation, E(phi) = exp(phi [w]x) by Rodrigues' formula (u = 2^-53, alpha = |w| phi):

* sin and cos come from `sincos`, Taylor polynomials with a proven error (not libm, whose accuracy is
  documented but not proven): within SINCOS_ERR of the exact values for |x| <= 1.6 (|alpha| <= pi/2
  here: |w| < pi, |phi| <= 1/2).
* E~^T p errs by at most (RODRIGUES_ERR + 12 |alpha|) u |p| (derivation in `rodrigues_apply`), and the
  float pose fl(R_p E~) lies within DELTA_R (spectral norm) of the exact R_p E (tolerances.py).
"""

import math

import numpy as np

from ...native import ext
from .._jit import jit, stage
from ..ellipsoids import Ellipsoids
from ..tolerances import HALF_TURN_TOL, OMEGA_ZERO

# Taylor coefficients (-1)^k / (2k)! and (-1)^k / (2k + 1)!, k = 11 ... 0 (Horner's order), each rounded
# once to float64.
_COS = tuple((-1.0) ** k / math.factorial(2 * k) for k in range(11, -1, -1))
_SIN = tuple((-1.0) ** k / math.factorial(2 * k + 1) for k in range(11, -1, -1))


@stage
def sincos(x):
    """(sin x, cos x) for |x| <= 1.6, each within SINCOS_ERR (absolute) of the exact value.

    Horner in y = fl(x^2) on the Taylor polynomials to x^22 (cos) and x^23 (sin).  Bound (Higham,
    Accuracy and Stability of Numerical Algorithms, eq. 5.3, plus one rounding per coefficient):
    gamma_23 cosh(1.6) < 59.4u for cos and gamma_23 sinh(1.6) + u < 55.7u for sin (with the product by
    x); the rounding of y adds at most u x sinh(x) / 2 < 1.9u (cos) and u x (cosh x - 1) / 2 < 1.3u
    (sin); the truncated tails are below 1.3e-19 = 0.0015u.  Total < 62u = SINCOS_ERR.
    """
    y = x * x
    c = s = 0.0
    for k in range(12):
        c = c * y + _COS[k]
        s = s * y + _SIN[k]
    return x * s, c


@jit
def rotation_vector(R0, R1):
    """(w0, w1, w2, theta): the axis-angle vector of R0^T R1 and its angle in [0, pi].

    Any float answer defines a valid motion; this one reproduces R1 to ~1e-15.  Near pi (cos < 0) the
    axis comes from the symmetric part, (Q + Q^T)/2 - c I = (1 - c) k k^T, signed like the
    antisymmetric part.  R0, R1: (3, 3) arrays.
    """
    q00 = R0[0, 0] * R1[0, 0] + R0[1, 0] * R1[1, 0] + R0[2, 0] * R1[2, 0]
    q11 = R0[0, 1] * R1[0, 1] + R0[1, 1] * R1[1, 1] + R0[2, 1] * R1[2, 1]
    q22 = R0[0, 2] * R1[0, 2] + R0[1, 2] * R1[1, 2] + R0[2, 2] * R1[2, 2]
    q01 = R0[0, 0] * R1[0, 1] + R0[1, 0] * R1[1, 1] + R0[2, 0] * R1[2, 1]
    q10 = R0[0, 1] * R1[0, 0] + R0[1, 1] * R1[1, 0] + R0[2, 1] * R1[2, 0]
    q02 = R0[0, 0] * R1[0, 2] + R0[1, 0] * R1[1, 2] + R0[2, 0] * R1[2, 2]
    q20 = R0[0, 2] * R1[0, 0] + R0[1, 2] * R1[1, 0] + R0[2, 2] * R1[2, 0]
    q12 = R0[0, 1] * R1[0, 2] + R0[1, 1] * R1[1, 2] + R0[2, 1] * R1[2, 2]
    q21 = R0[0, 2] * R1[0, 1] + R0[1, 2] * R1[1, 1] + R0[2, 2] * R1[2, 1]
    c = 0.5 * (q00 + q11 + q22 - 1.0)
    v0, v1, v2 = 0.5 * (q21 - q12), 0.5 * (q02 - q20), 0.5 * (q10 - q01)
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    theta = math.atan2(s, c)
    if c > 0.0:
        if s == 0.0:
            return 0.0, 0.0, 0.0, 0.0
        f = theta / s
        return v0 * f, v1 * f, v2 * f, theta
    diag = (q00 - c, q11 - c, q22 - c)
    j = 0
    if diag[1] > diag[j]:
        j = 1
    if diag[2] > diag[j]:
        j = 2
    if j == 0:
        k0, k1, k2 = q00 - c, 0.5 * (q10 + q01), 0.5 * (q20 + q02)
    elif j == 1:
        k0, k1, k2 = 0.5 * (q01 + q10), q11 - c, 0.5 * (q21 + q12)
    else:
        k0, k1, k2 = 0.5 * (q02 + q20), 0.5 * (q12 + q21), q22 - c
    kn = math.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
    if kn == 0.0:
        return 0.0, 0.0, 0.0, theta
    if k0 * v0 + k1 * v1 + k2 * v2 < 0.0:
        kn = -kn
    f = theta / kn
    return k0 * f, k1 * f, k2 * f, theta


@jit
def _rotation_vectors(R0, R1, out, angle):
    for i in range(R0.shape[0]):
        w0, w1, w2, th = rotation_vector(R0[i], R1[i])
        if math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) < OMEGA_ZERO:
            w0 = w1 = w2 = 0.0
        out[i, 0], out[i, 1], out[i, 2] = w0, w1, w2
        angle[i] = th


def rotation_vectors(x0, x1, name0="x0", name1="x1"):
    """(n, 3) float64 axis-angle vectors w of R0^T R1 for the batches x0, x1 (Ellipsoids, equal length).

    ValueError naming the arguments and the index for a turn within HALF_TURN_TOL of a half turn, whose
    shortest arc is not defined.
    """
    w, angle = np.empty((len(x0), 3)), np.empty(len(x0))
    ext.rotation_vectors(x0.rotations, x1.rotations, w, angle)
    half = np.flatnonzero(math.pi - angle < HALF_TURN_TOL)
    if len(half):
        i = int(half[0])
        raise ValueError(
            f"a half turn between {name0}[{i}] and {name1}[{i}] (angle {float(angle[i])!r} rad, within {HALF_TURN_TOL:g} of pi): "
            "the shortest arc is not defined; add an intermediate pose"
        )
    return w


@stage
def rodrigues(w, phi):
    """(cos alpha, sin alpha, 1 - cos alpha, unit axis k, |alpha|) of E(phi) = exp(phi [w]x), alpha = |w| phi.

    Errors: theta~ = fl(|w|) = theta (1 + eta), |eta| <= 2.52u; |alpha~ - alpha| <= 3.53u |alpha~|;
    cos and sin within eps_a = SINCOS_ERR + 3.6u |alpha~| of the exact ones (sincos; |d sin| <= |d alpha|);
    |k~ - k| <= 3.53u.  w = 0 gives exactly (1, 0, 0, 0, 0), and so does phi = 0.
    """
    th = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if th == 0.0:
        return 1.0, 0.0, 0.0, (0.0, 0.0, 0.0), 0.0
    al = th * phi
    s, c = sincos(al)
    return c, s, 1.0 - c, (w[0] / th, w[1] / th, w[2] / th), abs(al)


@stage
def rodrigues_apply(rod, p):
    """E(phi)^T p = c p - s (k x p) + (1 - c)(k . p) k in float64.

    Error, with P = |p|, 0 <= 1 - cos alpha <= 1 (|alpha| <= pi/2): c p errs by (eps_a + u) P; k x p by
    (eps_k + 1.42 gamma_2) P, times s by (eps_a + eps_k + 4u) P; (1 - c)(k . p) k by (eps_a + 2 eps_k + 7.1u) P;
    the two sums by 6.01u P.  Total (3 eps_a + 3 eps_k + 18.2u) P <= (3 SINCOS_ERR/u + 28.8 + 10.8 |alpha|) u P:
    RODRIGUES_ERR + 12 |alpha| (tolerances.py).  Checked against 60-digit mpmath in tests/test_toi.py.
    """
    c, s, om, k, _ = rod
    x = (k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0])
    f = om * (k[0] * p[0] + k[1] * p[1] + k[2] * p[2])
    return (c * p[0] - s * x[0] + f * k[0], c * p[1] - s * x[1] + f * k[1], c * p[2] - s * x[2] + f * k[2])


@stage
def rodrigues_matrix(rod):
    """E(phi) = c I + s [k]x + (1 - c) k k^T, row-major; each column errs as rodrigues_apply with P = 1."""
    c, s, om, k, _ = rod
    a0, a1, a2 = om * k[0], om * k[1], om * k[2]
    return (
        c + a0 * k[0], a0 * k[1] - s * k[2], a0 * k[2] + s * k[1],
        a1 * k[0] + s * k[2], c + a1 * k[1], a1 * k[2] - s * k[0],
        a2 * k[0] - s * k[1], a2 * k[1] + s * k[0], c + a2 * k[2],
    )  # fmt: skip


@stage
def matmul(A, B):
    """A B for row-major 3x3 tuples."""
    return (
        A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7], A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
        A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7], A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
        A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7], A[6] * B[2] + A[7] * B[5] + A[8] * B[8],
    )  # fmt: skip


@stage
def rotation_at(R0, R1, w, t):
    """The float rotation at t: R0 exactly at t = 0, R1 at t = 1, else fl(R_p E~(t - tau)) (tau = 0 on
    [0, 1/2], 1 on (1/2, 1]; t - 1 is exact there by Sterbenz)."""
    if t == 0.0:
        return R0
    if t == 1.0:
        return R1
    if t <= 0.5:
        return matmul(R0, rodrigues_matrix(rodrigues(w, t)))
    return matmul(R1, rodrigues_matrix(rodrigues(w, t - 1.0)))


@jit
def _poses_at(C0, R0, C1, R1, W, t, C, R):
    st = int(t.shape[0] > 1)  # stride 0 broadcasts one time
    for i in range(C.shape[0]):
        ti = t[i * st]
        Rt = rotation_at(
            (
                R0[i, 0, 0],
                R0[i, 0, 1],
                R0[i, 0, 2],
                R0[i, 1, 0],
                R0[i, 1, 1],
                R0[i, 1, 2],
                R0[i, 2, 0],
                R0[i, 2, 1],
                R0[i, 2, 2],
            ),
            (
                R1[i, 0, 0],
                R1[i, 0, 1],
                R1[i, 0, 2],
                R1[i, 1, 0],
                R1[i, 1, 1],
                R1[i, 1, 2],
                R1[i, 2, 0],
                R1[i, 2, 1],
                R1[i, 2, 2],
            ),
            (W[i, 0], W[i, 1], W[i, 2]),
            ti,
        )
        for j in range(3):
            if ti == 0.0:
                C[i, j] = C0[i, j]
            elif ti == 1.0:
                C[i, j] = C1[i, j]
            else:
                C[i, j] = C0[i, j] + ti * (C1[i, j] - C0[i, j])
            for k in range(3):
                R[i, j, k] = Rt[3 * j + k]


def poses_at(x0, x1, t):
    """The bodies of the motion from x0 to x1 at times t, as an Ellipsoids batch (x0 itself at t = 0,
    x1 at t = 1; elsewhere the float pose, within DELTA_R of the exact rotation).

    x0, x1 : Ellipsoids of equal length and semi-axes (one body per row, at t = 0 and t = 1).
    t : float or (n,) float64 in [0, 1].
    """
    for name, value in (("x0", x0), ("x1", x1)):
        if not isinstance(value, Ellipsoids):
            raise ValueError(f"{name} must be an ellipsim.Ellipsoids batch, got {type(value).__name__}")
    if len(x0) != len(x1):
        raise ValueError(f"x0 and x1 must have the same length, got {len(x0)} and {len(x1)}")
    bad = np.flatnonzero(np.any(x0.radii != x1.radii, axis=1))
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"x1.radii[{i}] must equal x0.radii[{i}], got {x1.radii[i].tolist()} and {x0.radii[i].tolist()}"
        )
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if t.ndim != 1 or len(t) not in (1, len(x0)):
        raise ValueError(f"t must be a number or have shape ({len(x0)},), got shape {t.shape}")
    out = np.flatnonzero(~((t >= 0.0) & (t <= 1.0)))
    if len(out):
        raise ValueError(f"t[{int(out[0])}] must lie in [0, 1], got {float(t[out[0]])!r}")
    C, R = np.empty((len(x0), 3)), np.empty((len(x0), 3, 3))
    ext.poses_at(x0.centers, x0.rotations, x1.centers, x1.rotations, rotation_vectors(x0, x1), t, C, R)
    return Ellipsoids(C, R, x0.radii)
