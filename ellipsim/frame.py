"""A pair of ellipsoids seen from A's frame: the thesis's "rearranged" set-up (thesis 4.1.3).

Substituting x = c_a + R_a^{-T} D_a y maps A onto the unit ball |y| <= 1 and B onto
(y - e)^T K (y - e) <= 1, where

    W = D_b^{-1} R_b^T R_a^{-T} D_a,   K = W^T W,   e = D_a^{-1} R_a^T (c_b - c_a).

R_a^{-T} = C / det(R_a) with C = cof(R_a), which equals R_a for a proper rotation.  Carrying
alpha = det(R_a)^2 and W_c = D_b^{-1} R_b^T C D_a (so K_c = W_c^T W_c = alpha K) keeps every quantity a
polynomial in the inputs, exact for any invertible R_a.  The pencil of A_y = diag(I, -1) and
alpha B_y is, by the Schur complement and adj(mu I + K) = mu^2 I + mu (t1 I - K) + adj K,

    f(mu) = det(mu A_y + alpha B_y) = mu N(mu) - (mu + alpha) P(mu)
    P(mu) = det(mu I + K_c) = mu^3 + t1 mu^2 + t2 mu + t3
    N(mu) = e^T K_c adj(mu I + K_c) e = p1 mu^2 + q mu + s3

whose coefficients are sums of squares (Cauchy-Binet and Lagrange identities), with w_j the
columns of W_c and v = W_c e:

    t1 = sum_j |w_j|^2,  t2 = sum_{j<l} |w_j x w_l|^2,  t3 = det(W_c)^2,
    p1 = |v|^2,  q = t1 p1 - |K_c e|^2 = sum_j |w_j x v|^2,  s3 = t3 |e|^2.

f(alpha lambda) = alpha^4 det(lambda A_y + B_y), and det(lambda A_y + B_y) is det(lambda A + B) of the
world quadrics times det(D_a R_a^{-1})^2 > 0, so f has the roots of det(lambda A + B) scaled by alpha.
sign f(mu) = sign(F(mu) - 1) for the Perram-Wertheim function F(mu) = mu N / ((mu + alpha) P).

Every quantity comes with its "mag": the same expression evaluated on |leaves| with each
subtraction turned into an addition.  An expression with at most n roundings on any path from
a leaf errs by at most gamma_n * mag (Higham, Accuracy and Stability of Numerical Algorithms,
ch. 3; leaf roundings such as 1/r and c_b - c_a are counted).  The depth of each value is noted
as [n].  Kernels that need only the values leave the mags unused and LLVM drops them.
"""

import math

from ._jit import jit, stage

# Pair kernels take ellipsoids as flat tuples: centre (3,), rotation (9,) row-major, radii (3,).
# Tuples live in registers; array views would cost a reference count update per pair.


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
def _inverse_transpose_numerator(Ra, exact_inverse):
    """C with R_a^{-T} = C / det(R_a), its mag, alpha = det(R_a)^2 and its mag.

    exact_inverse=False takes C = R_a and alpha = 1 (the thesis's orthonormal assumption, used by
    the uncertified set-ups).  Depth: C [2], alpha [6].
    """
    one = type(Ra[0])(1.0)
    if not exact_inverse:
        C = Ra
        mC = (abs(C[0]), abs(C[1]), abs(C[2]), abs(C[3]), abs(C[4]), abs(C[5]), abs(C[6]), abs(C[7]), abs(C[8]))
        return C, mC, one, one
    r00, r01, r02 = Ra[0], Ra[1], Ra[2]
    r10, r11, r12 = Ra[3], Ra[4], Ra[5]
    r20, r21, r22 = Ra[6], Ra[7], Ra[8]
    C = (
        r11 * r22 - r12 * r21, r12 * r20 - r10 * r22, r10 * r21 - r11 * r20,
        r02 * r21 - r01 * r22, r00 * r22 - r02 * r20, r01 * r20 - r00 * r21,
        r01 * r12 - r02 * r11, r02 * r10 - r00 * r12, r00 * r11 - r01 * r10,
    )  # fmt: skip
    mC = (
        abs(r11 * r22) + abs(r12 * r21), abs(r12 * r20) + abs(r10 * r22), abs(r10 * r21) + abs(r11 * r20),
        abs(r02 * r21) + abs(r01 * r22), abs(r00 * r22) + abs(r02 * r20), abs(r01 * r20) + abs(r00 * r21),
        abs(r01 * r12) + abs(r02 * r11), abs(r02 * r10) + abs(r00 * r12), abs(r00 * r11) + abs(r01 * r10),
    )  # fmt: skip
    det = r00 * C[0] + r01 * C[1] + r02 * C[2]
    mdet = abs(r00) * mC[0] + abs(r01) * mC[1] + abs(r02) * mC[2]
    return C, mC, det * det, mdet * mdet


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


@stage
def offset(ca, Ra, ra, cb):
    """e = D_a^{-1} R_a^T (c_b - c_a) [5] and its mag, so that q_A(c_b) = |e|^2."""
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])  # [1]
    z, mz = rotate_t(Ra, d), rotate_t_mag(Ra, (abs(d[0]), abs(d[1]), abs(d[2])))  # [4]
    i = reciprocal(ra)  # [1]
    return (z[0] * i[0], z[1] * i[1], z[2] * i[2]), (mz[0] * i[0], mz[1] * i[1], mz[2] * i[2])


@stage
def shape(Ra, ra, Rb, ib, exact_inverse):
    """W_c = D_b^{-1} R_b^T C D_a [6] (row-major 9-tuple), its mag, alpha [6] and its mag.

    ib = 1 / r_b, rounded once [1].
    """
    C, mC, alpha, malpha = _inverse_transpose_numerator(Ra, exact_inverse)
    W = (
        dot3(Rb[0], Rb[3], Rb[6], C[0], C[3], C[6]) * (ra[0] * ib[0]),
        dot3(Rb[0], Rb[3], Rb[6], C[1], C[4], C[7]) * (ra[1] * ib[0]),
        dot3(Rb[0], Rb[3], Rb[6], C[2], C[5], C[8]) * (ra[2] * ib[0]),
        dot3(Rb[1], Rb[4], Rb[7], C[0], C[3], C[6]) * (ra[0] * ib[1]),
        dot3(Rb[1], Rb[4], Rb[7], C[1], C[4], C[7]) * (ra[1] * ib[1]),
        dot3(Rb[1], Rb[4], Rb[7], C[2], C[5], C[8]) * (ra[2] * ib[1]),
        dot3(Rb[2], Rb[5], Rb[8], C[0], C[3], C[6]) * (ra[0] * ib[2]),
        dot3(Rb[2], Rb[5], Rb[8], C[1], C[4], C[7]) * (ra[1] * ib[2]),
        dot3(Rb[2], Rb[5], Rb[8], C[2], C[5], C[8]) * (ra[2] * ib[2]),
    )
    b00, b10, b20 = abs(Rb[0]), abs(Rb[3]), abs(Rb[6])
    b01, b11, b21 = abs(Rb[1]), abs(Rb[4]), abs(Rb[7])
    b02, b12, b22 = abs(Rb[2]), abs(Rb[5]), abs(Rb[8])
    mW = (
        dot3(b00, b10, b20, mC[0], mC[3], mC[6]) * (ra[0] * ib[0]),
        dot3(b00, b10, b20, mC[1], mC[4], mC[7]) * (ra[1] * ib[0]),
        dot3(b00, b10, b20, mC[2], mC[5], mC[8]) * (ra[2] * ib[0]),
        dot3(b01, b11, b21, mC[0], mC[3], mC[6]) * (ra[0] * ib[1]),
        dot3(b01, b11, b21, mC[1], mC[4], mC[7]) * (ra[1] * ib[1]),
        dot3(b01, b11, b21, mC[2], mC[5], mC[8]) * (ra[2] * ib[1]),
        dot3(b02, b12, b22, mC[0], mC[3], mC[6]) * (ra[0] * ib[2]),
        dot3(b02, b12, b22, mC[1], mC[4], mC[7]) * (ra[1] * ib[2]),
        dot3(b02, b12, b22, mC[2], mC[5], mC[8]) * (ra[2] * ib[2]),
    )
    return W, mW, alpha, malpha


@stage
def invariants(W, mW, e, me, v, mv):
    """(t1, t2, t3, p1, q, s3) and their mags from W_c, e and v = W_c e [9].

    Depths [11, 13, 12, 12, 16, 13].
    """
    w0, w1, w2 = column(W, 0), column(W, 1), column(W, 2)
    m0, m1, m2 = column(mW, 0), column(mW, 1), column(mW, 2)
    t1 = norm2(w0) + norm2(w1) + norm2(w2)
    mt1 = norm2(m0) + norm2(m1) + norm2(m2)
    x12 = cross3(w1, w2)  # [8]
    mx12 = cross3_mag(m1, m2)
    t2 = norm2(cross3(w0, w1)) + norm2(cross3(w0, w2)) + norm2(x12)
    mt2 = norm2(cross3_mag(m0, m1)) + norm2(cross3_mag(m0, m2)) + norm2(mx12)
    det = w0[0] * x12[0] + w0[1] * x12[1] + w0[2] * x12[2]  # [11]
    mdet = m0[0] * mx12[0] + m0[1] * mx12[1] + m0[2] * mx12[2]
    t3 = det * det
    mt3 = mdet * mdet
    p1 = norm2(v)
    mp1 = norm2(mv)
    q = norm2(cross3(w0, v)) + norm2(cross3(w1, v)) + norm2(cross3(w2, v))
    mq = norm2(cross3_mag(m0, mv)) + norm2(cross3_mag(m1, mv)) + norm2(cross3_mag(m2, mv))
    ee = norm2(e)  # [8]
    s3 = t3 * ee
    ms3 = mt3 * norm2(me)
    return (t1, t2, t3, p1, q, s3), (mt1, mt2, mt3, mp1, mq, ms3)


@stage
def pencil(mu, inv, alpha):
    """f(mu) = mu N(mu) - (mu + alpha) P(mu) [21] for invariants `inv` = (t1, t2, t3, p1, q, s3)."""
    t1, t2, t3, p1, q, s3 = inv
    n = (p1 * mu + q) * mu + s3
    p = ((mu + t1) * mu + t2) * mu + t3
    return mu * n - (mu + alpha) * p


@stage
def pencil_mag(mu, minv, malpha):
    """mag of `pencil`: mu N_mag(mu) + (mu + alpha_mag) P_mag(mu)."""
    t1, t2, t3, p1, q, s3 = minv
    n = (p1 * mu + q) * mu + s3
    p = ((mu + t1) * mu + t2) * mu + t3
    return mu * n + (mu + malpha) * p


@stage
def coefficients(inv, alpha):
    """Coefficients (mu^4 ... mu^0) of f(mu) = mu N(mu) - (mu + alpha) P(mu)."""
    t1, t2, t3, p1, q, s3 = inv
    one = type(t1)(1.0)
    return -one, p1 - alpha - t1, q - alpha * t1 - t2, s3 - alpha * t2 - t3, -alpha * t3
