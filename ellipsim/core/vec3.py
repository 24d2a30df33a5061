"""3-vectors and 3x3 matrices as flat tuples, for the per-pair kernels.

Pair kernels take an ellipsoid as (centre (3,), rotation (9,) row-major, radii (3,)) tuples: tuples
live in registers, where array views would cost a reference count update per pair.
"""

import math

from ._jit import jit, stage


@jit
def load(C, R, r, i):
    """Ellipsoid i of a batch as (centre, rotation row-major, radii) tuples."""
    return (
        (C[i, 0], C[i, 1], C[i, 2]),
        (R[i, 0, 0], R[i, 0, 1], R[i, 0, 2], R[i, 1, 0], R[i, 1, 1], R[i, 1, 2], R[i, 2, 0], R[i, 2, 1], R[i, 2, 2]),
        (r[i, 0], r[i, 1], r[i, 2]),
    )


@jit
def dot3(x0, x1, x2, y0, y1, y2):
    return x0 * y0 + x1 * y1 + x2 * y2


@jit
def cross3(x, y):
    return (x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])


@jit
def cross3_mag(mx, my):
    return (mx[1] * my[2] + mx[2] * my[1], mx[2] * my[0] + mx[0] * my[2], mx[0] * my[1] + mx[1] * my[0])


@jit
def norm2(x):
    return x[0] * x[0] + x[1] * x[1] + x[2] * x[2]


@jit
def column(M, j):
    return (M[j], M[3 + j], M[6 + j])


@jit
def matvec(M, x):
    return (
        M[0] * x[0] + M[1] * x[1] + M[2] * x[2],
        M[3] * x[0] + M[4] * x[1] + M[5] * x[2],
        M[6] * x[0] + M[7] * x[1] + M[8] * x[2],
    )


@stage
def sandwich(R, w0, w1, w2):
    """R diag(w) R^T for a row-major 3x3 tuple R: its upper triangle (s00, s01, s02, s11, s12, s22)."""
    return (
        R[0] * R[0] * w0 + R[1] * R[1] * w1 + R[2] * R[2] * w2,
        R[0] * R[3] * w0 + R[1] * R[4] * w1 + R[2] * R[5] * w2,
        R[0] * R[6] * w0 + R[1] * R[7] * w1 + R[2] * R[8] * w2,
        R[3] * R[3] * w0 + R[4] * R[4] * w1 + R[5] * R[5] * w2,
        R[3] * R[6] * w0 + R[4] * R[7] * w1 + R[5] * R[8] * w2,
        R[6] * R[6] * w0 + R[7] * R[7] * w1 + R[8] * R[8] * w2,
    )


@jit
def rotate_t(R, d):
    """R^T d for a row-major 3x3 tuple, a rotation or not [depth of d + 3]."""
    return (
        R[0] * d[0] + R[3] * d[1] + R[6] * d[2],
        R[1] * d[0] + R[4] * d[1] + R[7] * d[2],
        R[2] * d[0] + R[5] * d[1] + R[8] * d[2],
    )


@jit
def rotate_t_mag(R, md):
    """mag of rotate_t: |R|^T md."""
    return (
        abs(R[0]) * md[0] + abs(R[3]) * md[1] + abs(R[6]) * md[2],
        abs(R[1]) * md[0] + abs(R[4]) * md[1] + abs(R[7]) * md[2],
        abs(R[2]) * md[0] + abs(R[5]) * md[1] + abs(R[8]) * md[2],
    )


@jit
def reciprocal(r):
    one = type(r[0])(1.0)
    return one / r[0], one / r[1], one / r[2]


_UNIT_LO, _UNIT_HI = 2.0**-51, 2.0**50  # frexp exponents -50 ... 50


@jit
def unit_scale(ra, rb):
    """1.0, or for a pair whose largest semi-axis is beyond 2^+-50 the power of two that brings it
    into [0.5, 1): scaling a pair by a power of two is exact, and keeps products such as r^10 (the
    narrow phase's bisector seed) and q(x)^2 inside float64's normal range.  1.0 (semi-axes from
    1e-15 to 1e15) leaves results bit-identical."""
    m = max(ra[0], ra[1], ra[2], rb[0], rb[1], rb[2])
    if _UNIT_LO <= m < _UNIT_HI:
        return 1.0
    return math.ldexp(1.0, -math.frexp(m)[1])


@jit
def scaled(r, p):
    return r[0] * p, r[1] * p, r[2] * p


@jit
def rotation_defect(R):
    """max_ij |(R^T R - I)_ij| of a row-major 3x3 tuple (ellipsoids.orthonormality_defect, one matrix)."""
    d = 0.0
    for i in range(3):
        for j in range(i, 3):
            v = R[i] * R[j] + R[3 + i] * R[3 + j] + R[6 + i] * R[6 + j] - (1.0 if i == j else 0.0)
            d = max(d, abs(v))
    return d
