"""A one-shot proof that a deep local maximum of sigma is global: the internal ellipsoid of A + (-B)
tangent in the contact direction (Kurzhanski & Valyi, Ellipsoidal Calculus for Estimation and Control,
1997, sec. 2.3: internal approximations of a sum of ellipsoids).

In A's principal frame (as branch_and_bound.py) sigma(n) = n.e - |F_A n| - |F_B n| with F_A = diag(a),
F_B = diag(b) U^T, and max over unit n of sigma is the signed distance of the point e to the centred
Minkowski sum M = A + B (support h_A + h_B).  For any orthogonal S, X = S F_A + F_B has |X n| <=
|F_A n| + |F_B n| (triangle inequality), so the ellipsoid Q = X^T (unit ball) lies inside M and

    max sigma <= sd(e, Q) = -dist(e, boundary of Q)    (e inside Q).

Choosing S to turn F_A n* / h_A(n*) onto F_B n* / h_B(n*) at the local maximum n* makes Q touch M there
with the same support point: sd(e, Q) = sigma(n*) exactly when the ball of radius -sigma(n*) about e
fits in Q, which the remaining freedom of S (a turn or a reflection about that direction) serves: it
is chosen to maximise the smallest curvature radius of Q at the contact, (the smallest singular value
of S' M_A + M_B)^2 / (h_A + h_B) with M_A, M_B the two bodies' tangent maps, over 8 turns and 8
reflections.  dist(e, boundary Q)^2 >= g(t) = t (e^T (W + t I)^-1 e - 1) for every t > -lambda_min(W),
W = X^T X (Lagrangian weak duality, as point_ellipsoid.py's bound in Q's principal frame), with equality
at t* = sigma(n*) (h_A(n*) + h_B(n*)) when the bound is tight: no eigen-decomposition and no root
finding.  On leaves.xml's deep contacts and random deep crossings (generic, 8:1 elongated, 25:1:1/10
leaves) it proves 89-99 % of the first runs' maxima for ~0.3 us; the rest go to the branch and bound.

Rounding (u = 2^-53; every bound below is taken outwards): the float S has |S n| <= (1 + eta) |n| with
eta from its computed orthonormality defect, the float X differs from S F_A + F_B by <= 6.1 u (max a +
max b) in norm (both add to max sigma <= sd(e, Q) + eps1); W + t I is formed and Cholesky-factored in
float, L L^T = K + E with |E| <= gamma_4 |L||L^T| (Higham, Accuracy and Stability of Numerical
Algorithms, 2nd ed., Thm 10.3) plus the rounding of forming K; lambda_min(L L^T) >= 1 / |L^-1|_F^2 from
the explicit 3x3 triangular inverse; the forward substitution's backward error |dL| <= gamma_3 |L|
(Thm 8.5).  Then e^T K^-1 e <= |y|^2 (1 + gamma_3 N |L|_F)^2 / (1 - |E| lambda_lo^-1), N >= |L^-1|_F.
"""

import math

from .._jit import jit, stage
from ..tolerances import U
from ..vec3 import rotate_t
from .sphere_newton import tangent_basis

#: turns (and as many reflections) of S tried about the contact direction: 8, 45 degrees apart
_COS = tuple(math.cos(2.0 * math.pi * k / 8) for k in range(8))
_SIN = tuple(math.sin(2.0 * math.pi * k / 8) for k in range(8))


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def _row(bi, q1i, q2i, ah, c1, c2):
    """Row i of bh ah^T + q1 c1^T + q2 c2^T."""
    return (
        bi * ah[0] + q1i * c1[0] + q2i * c2[0],
        bi * ah[1] + q1i * c1[1] + q2i * c2[1],
        bi * ah[2] + q1i * c1[2] + q2i * c2[2],
    )


@stage
def _lambda_min2(z00, z01, z10, z11):
    """The smallest eigenvalue of Z^T Z for the 2x2 Z (its smallest singular value squared)."""
    f = z00 * z00 + z01 * z01 + z10 * z10 + z11 * z11
    d = z00 * z11 - z01 * z10
    r = f * f - 4.0 * d * d
    return 2.0 * d * d / (f + math.sqrt(max(r, 0.0))) if f > 0.0 else 0.0


@jit
def inner_sum_bound(n, e, a, Ub, b, value):
    """An upper bound on max over unit m of sigma(m) = m.e - |diag(a) m| - |diag(b) Ub^T m| (the float
    data's sigma, exactly), from the internal ellipsoid of A + B tangent at the unit n with
    sigma(n) = value < 0 (module docstring); inf where it gives none (e not inside it by the bounds)."""
    if not value < 0.0:
        return math.inf
    ua = (a[0] * n[0], a[1] * n[1], a[2] * n[2])
    w = rotate_t(Ub, n)
    ub_ = (b[0] * w[0], b[1] * w[1], b[2] * w[2])
    ha, hb = math.sqrt(_dot(ua, ua)), math.sqrt(_dot(ub_, ub_))
    if not (ha > 0.0 and hb > 0.0):
        return math.inf
    ah = (ua[0] / ha, ua[1] / ha, ua[2] / ha)
    bh = (ub_[0] / hb, ub_[1] / hb, ub_[2] / hb)
    t1, t2 = tangent_basis(n)
    p1, p2 = tangent_basis(ah)
    q1, q2 = tangent_basis(bh)
    fa1 = (a[0] * t1[0], a[1] * t1[1], a[2] * t1[2])
    fa2 = (a[0] * t2[0], a[1] * t2[1], a[2] * t2[2])
    w1, w2 = rotate_t(Ub, t1), rotate_t(Ub, t2)
    fb1 = (b[0] * w1[0], b[1] * w1[1], b[2] * w1[2])
    fb2 = (b[0] * w2[0], b[1] * w2[1], b[2] * w2[2])
    ma00, ma01, ma10, ma11 = _dot(p1, fa1), _dot(p1, fa2), _dot(p2, fa1), _dot(p2, fa2)
    mb00, mb01, mb10, mb11 = _dot(q1, fb1), _dot(q1, fb2), _dot(q2, fb1), _dot(q2, fb2)
    # S' (p-coordinates to q-coordinates): the turn or reflection with the largest smallest curvature
    best, bc, bs, bsign = -1.0, 1.0, 0.0, 1.0
    for k in range(8):
        c, s = _COS[k], _SIN[k]
        for sign in (1.0, -1.0):  # [[c, -s], [s, c]] or [[c, s], [s, -c]]
            s01, s11 = -sign * s, sign * c
            lm = _lambda_min2(
                c * ma00 + s01 * ma10 + mb00,
                c * ma01 + s01 * ma11 + mb01,
                s * ma00 + s11 * ma10 + mb10,
                s * ma01 + s11 * ma11 + mb11,
            )
            if lm > best:
                best, bc, bs, bsign = lm, c, s, sign
    s00, s01, s10, s11 = bc, -bsign * bs, bs, bsign * bc
    # S = bh ah^T + sum_ij S'_ij q_i p_j^T, row by row
    c1 = (s00 * p1[0] + s01 * p2[0], s00 * p1[1] + s01 * p2[1], s00 * p1[2] + s01 * p2[2])  # row q1 of S'
    c2 = (s10 * p1[0] + s11 * p2[0], s10 * p1[1] + s11 * p2[1], s10 * p1[2] + s11 * p2[2])
    S0 = _row(bh[0], q1[0], q2[0], ah, c1, c2)
    S1 = _row(bh[1], q1[1], q2[1], ah, c1, c2)
    S2 = _row(bh[2], q1[2], q2[2], ah, c1, c2)
    # |S x| <= (1 + eta) |x|: eta >= |S^T S - I|_2, from its entries (+ their rounding, 4 u each)
    cols = ((S0[0], S1[0], S2[0]), (S0[1], S1[1], S2[1]), (S0[2], S1[2], S2[2]))
    defect = 0.0
    for i in range(3):
        for j in range(3):
            g = _dot(cols[i], cols[j]) - (1.0 if i == j else 0.0)
            defect += g * g
    eta = math.sqrt(defect) + 12.0 * U
    amax, bmax = max(a[0], a[1], a[2]), max(b[0], b[1], b[2])
    # X = S diag(a) + diag(b) Ub^T: X_ij = S_ij a_j + b_i Ub_ji
    X = (
        (S0[0] * a[0] + b[0] * Ub[0], S0[1] * a[1] + b[0] * Ub[3], S0[2] * a[2] + b[0] * Ub[6]),
        (S1[0] * a[0] + b[1] * Ub[1], S1[1] * a[1] + b[1] * Ub[4], S1[2] * a[2] + b[1] * Ub[7]),
        (S2[0] * a[0] + b[2] * Ub[2], S2[1] * a[1] + b[2] * Ub[5], S2[2] * a[2] + b[2] * Ub[8]),
    )
    eps1 = eta * (1.0 + eta) * amax + 6.1 * U * ((1.0 + eta) * amax + bmax)
    xc = ((X[0][0], X[1][0], X[2][0]), (X[0][1], X[1][1], X[2][1]), (X[0][2], X[1][2], X[2][2]))
    t = value * (ha + hb)
    k00 = _dot(xc[0], xc[0]) + t
    k11 = _dot(xc[1], xc[1]) + t
    k22 = _dot(xc[2], xc[2]) + t
    k10, k20, k21 = _dot(xc[1], xc[0]), _dot(xc[2], xc[0]), _dot(xc[2], xc[1])
    xf2 = _dot(xc[0], xc[0]) + _dot(xc[1], xc[1]) + _dot(xc[2], xc[2])
    # Cholesky K = L L^T
    if not k00 > 0.0:
        return math.inf
    l00 = math.sqrt(k00)
    l10, l20 = k10 / l00, k20 / l00
    r = k11 - l10 * l10
    if not r > 0.0:
        return math.inf
    l11 = math.sqrt(r)
    l21 = (k21 - l20 * l10) / l11
    r = k22 - l20 * l20 - l21 * l21
    if not r > 0.0:
        return math.inf
    l22 = math.sqrt(r)
    lf2 = l00 * l00 + l10 * l10 + l20 * l20 + l11 * l11 + l21 * l21 + l22 * l22
    # |L^-1|_F from the explicit inverse, each entry taken outwards
    i00, i11, i22 = 1.0 / l00, 1.0 / l11, 1.0 / l22
    i10 = abs(l10) / (l00 * l11)
    i21 = abs(l21) / (l11 * l22)
    i20 = (abs(l10 * l21 - l11 * l20) + 4.0 * U * (abs(l10 * l21) + abs(l11 * l20))) / (l00 * l11 * l22)
    N = math.sqrt(i00 * i00 + i11 * i11 + i22 * i22 + i10 * i10 + i21 * i21 + i20 * i20) * (1.0 + 16.0 * U)
    lam_lo = (1.0 - 4.0 * U) / (N * N)
    # |E| <= gamma_4 |L|_F^2 (factor) + gamma_4 |X|_F^2 + u (|diag K| + |t|) (forming K)
    epsk = 4.1 * U * (lf2 + xf2) + 2.0 * U * (abs(k00) + abs(k11) + abs(k22) + 3.0 * abs(t))
    if not epsk < 0.5 * lam_lo:
        return math.inf
    lam = lam_lo - epsk  # <= lambda_min(K), K = X^T X + t I exactly for the float X and t
    # z ~ K^-1 e by the factor; then e^T K^-1 e = 2 z.e - z^T K z + r^T K^-1 r exactly, r = e - K z, whose
    # rounding enters once (z^T K z = |X z|^2 + t |z|^2 with the float X) or squared (r): no cond(K) factor
    y0 = e[0] / l00
    y1 = (e[1] - l10 * y0) / l11
    y2 = (e[2] - l20 * y0 - l21 * y1) / l22
    z2 = y2 / l22
    z1 = (y1 - l21 * z2) / l11
    z0 = (y0 - l10 * z1 - l20 * z2) / l00
    z = (z0, z1, z2)
    az = (abs(z0), abs(z1), abs(z2))
    ze = _dot(z, e)
    ze_err = 3.1 * U * (az[0] * abs(e[0]) + az[1] * abs(e[1]) + az[2] * abs(e[2]))
    xz = (_dot(X[0], z), _dot(X[1], z), _dot(X[2], z))
    mx = (
        abs(X[0][0]) * az[0] + abs(X[0][1]) * az[1] + abs(X[0][2]) * az[2],
        abs(X[1][0]) * az[0] + abs(X[1][1]) * az[1] + abs(X[1][2]) * az[2],
        abs(X[2][0]) * az[0] + abs(X[2][1]) * az[1] + abs(X[2][2]) * az[2],
    )
    lo0 = max(abs(xz[0]) - 3.1 * U * mx[0], 0.0)
    lo1 = max(abs(xz[1]) - 3.1 * U * mx[1], 0.0)
    lo2 = max(abs(xz[2]) - 3.1 * U * mx[2], 0.0)
    xx_lo = (lo0 * lo0 + lo1 * lo1 + lo2 * lo2) * (1.0 - 4.0 * U)
    zz_up = _dot(z, z) * (1.0 + 4.0 * U)
    tz = -t * zz_up * (1.0 + U)  # -t |z|^2 >= 0
    body = 2.0 * (ze + ze_err) - xx_lo + tz
    body += 3.1 * U * (2.0 * (abs(ze) + ze_err) + xx_lo + tz)
    # r = e - X^T (X z) - t z, each component outwards
    r0 = e[0] - (X[0][0] * xz[0] + X[1][0] * xz[1] + X[2][0] * xz[2]) - t * z0
    r1 = e[1] - (X[0][1] * xz[0] + X[1][1] * xz[1] + X[2][1] * xz[2]) - t * z1
    r2 = e[2] - (X[0][2] * xz[0] + X[1][2] * xz[1] + X[2][2] * xz[2]) - t * z2
    mxx = (
        abs(X[0][0]) * mx[0] + abs(X[1][0]) * mx[1] + abs(X[2][0]) * mx[2],
        abs(X[0][1]) * mx[0] + abs(X[1][1]) * mx[1] + abs(X[2][1]) * mx[2],
        abs(X[0][2]) * mx[0] + abs(X[1][2]) * mx[1] + abs(X[2][2]) * mx[2],
    )
    re0 = abs(r0) + 9.1 * U * (abs(e[0]) + mxx[0] + abs(t) * az[0])
    re1 = abs(r1) + 9.1 * U * (abs(e[1]) + mxx[1] + abs(t) * az[1])
    re2 = abs(r2) + 9.1 * U * (abs(e[2]) + mxx[2] + abs(t) * az[2])
    v = (body + (re0 * re0 + re1 * re1 + re2 * re2) * (1.0 + 4.0 * U) / lam) * (1.0 + 2.0 * U)
    if not v < 1.0:
        return math.inf
    g = -t * ((1.0 - v) * (1.0 - 2.0 * U)) * (1.0 - 2.0 * U)
    return -math.sqrt(g) * (1.0 - 2.0 * U) + eps1 * (1.0 + 2.0 * U)
