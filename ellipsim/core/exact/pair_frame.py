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

from .._jit import stage
from ..vec3 import column, cross3, cross3_mag, dot3, norm2, reciprocal, rotate_t, rotate_t_mag


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
    C, mC, det, mdet = cofactors(Ra)
    return C, mC, det * det, mdet * mdet


@stage
def cofactors(R):
    """Cofactor matrix C of R (row-major 9-tuple; R^-1 = C^T / det), its mag, det R and its mag.
    Depths: C [2], det [5]."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
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
    return C, mC, det, mdet


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
