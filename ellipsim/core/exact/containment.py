"""Containment: does ellipsoid b lie inside ellipsoid a?  Exact on the float64 inputs, as classify is.

Criterion (closed sets: b touching a's boundary from inside counts as inside).  In A's frame
(pair_frame.py), A is the unit ball |y| <= 1 and B = {y : (y - e)^T K (y - e) <= 1}; let A_y = diag(I, -1)
and B_y = [[K, -K e], [-e^T K, e^T K e - 1]].  Geometric Tools (Eberly, "Intersection of Ellipsoids",
11.9.2) maximises q_A over B by Lagrange multipliers; we use the dual of that maximisation:

    B subset A  <=>  there is nu > 0 with  N(nu) = B_y - nu A_y  positive semidefinite.

(=>: the S-lemma (Yakubovich), since q_B < 1 somewhere: q_B <= 1 implies q_A <= 1 iff q_A - 1 <=
tau (q_B - 1) everywhere for some tau >= 0, and tau > 0 as q_A is unbounded; a quadratic function is
nonnegative everywhere iff its homogeneous 4x4 matrix is PSD; nu = 1 / tau.  <=: if N(nu) is PSD then
q_B(y) - 1 >= nu (|y|^2 - 1) for all y.)  det N(nu) is the characteristic polynomial det(lambda A + B)
of Wang, Wang & Kim (thesis ch. 4) at lambda = -nu: containment is read off its NEGATIVE roots, as
separation is read off its positive ones.  In pair_frame.py's scaled variables (K_c = alpha K,
mu = -alpha nu), f(mu) = det(mu A_y + alpha B_y) = alpha^4 det N(nu).

Float filter (decisions proven by error bounds: pair_frame.py's mags, Higham's gamma_n):
* inside: B's centre, rotation and axes those of A, axes no longer (exact comparisons); or, strictly,
  mu < 0 with K_c + mu I positive definite (Sylvester: three leading minors > 0) and f(mu) > 0, so that
  N(nu) is positive definite and q_B <= 1 forces |y| < 1.  mu maximises the concave
  H(nu') = 1 - alpha / nu' - e^T K_c (K_c - nu' I)^{-1} e on (0, kappa_1) (the secular equation of the
  trust-region problem max_B |y|^2, in K_c's Jacobi eigenbasis).
* not inside: a sorted semi-axis of B longer than A's (widths of B are at most A's), B's centre not
  strictly inside A, the bounding spheres apart, or a point strictly inside B with |y| > 1 (the
  maximiser of |y|^2 over B pulled slightly towards B's centre, or the ends of B's axes).
* UNDECIDED otherwise (internal tangency, identical-but-rotated axes, near-tangency): rationals.

Exact fallback (Fractions, any invertible rotations through cof(R_a), as rational_fallback.py).  The set
F = {nu > 0 : N(nu) PSD} is a closed interval inside (0, kappa_1]; N is singular at its left end, so F is
non-empty iff some positive root r of T(nu) = det N(nu) has N(r) PSD, i.e. the sums of principal minors
E_1, E_2, E_3 of N(r) (the elementary symmetric functions of its eigenvalues; E_4 = T(r) = 0) are all
>= 0.  The distinct positive roots of T are isolated by Sturm sequences and bisection on rationals; the
sign of E_k at an isolated root is decided exactly (a gcd says when it is 0, otherwise the isolating
interval is refined until E_k has no root in it).
"""

import math
from fractions import Fraction
from itertools import combinations

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..ellipsoids import check_pair, check_parallel
from ..tolerances import (
    AXIS_SLACK,
    CONTAIN_NEWTON_STEPS,
    CONTAIN_RTOL,
    CONTAIN_RTOL_FINE,
    ERR_POLY,
    ERR_SHORT,
    ERR_WITNESS,
    JACOBI_SWEEPS,
)
from ..vec3 import cross3, cross3_mag, load, matvec, norm2, reciprocal
from .certified_filter import _in_float_range, _positive, bounding_spheres_apart
from .pair_frame import invariants, offset, shape
from .rational_fallback import _remainder, _strip, exact_pair

INSIDE, NOT_INSIDE = 1, 0
UNDECIDED = -1


@stage
def _sort3(r):
    a, b, c = r
    if a > b:
        a, b = b, a
    if b > c:
        b, c = c, b
    if a > b:
        a, b = b, a
    return a, b, c


# --- K_c's eigenbasis (float guidance only) ----------------------------------------------------


@stage
def _givens(app, aqq, apq):
    """(t, c, s) of the Jacobi rotation annihilating a_pq (Numerical Recipes, 11.1)."""
    theta = (aqq - app) / (2.0 * apq)
    t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
    c = 1.0 / math.sqrt(t * t + 1.0)
    return t, c, t * c


@stage
def _rotate_columns(vp, vq, c, s):
    return (
        (c * vp[0] - s * vq[0], c * vp[1] - s * vq[1], c * vp[2] - s * vq[2]),
        (s * vp[0] + c * vq[0], s * vp[1] + c * vq[1], s * vp[2] + c * vq[2]),
    )


@stage
def _jacobi3(K):
    """Eigenvalues (ascending) and eigenvectors (as three column tuples) of the symmetric K (upper
    triangle k00, k01, k02, k11, k12, k22) by cyclic Jacobi on scalars."""
    a00, a01, a02, a11, a12, a22 = K
    v0, v1, v2 = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    for _ in range(JACOBI_SWEEPS):
        if a01 * a01 + a02 * a02 + a12 * a12 <= 1e-36 * (a00 * a00 + a11 * a11 + a22 * a22):
            break
        if a01 != 0.0:  # (p, q) = (0, 1), r = 2
            t, c, s = _givens(a00, a11, a01)
            a00, a11, a01 = a00 - t * a01, a11 + t * a01, 0.0
            a02, a12 = c * a02 - s * a12, s * a02 + c * a12
            v0, v1 = _rotate_columns(v0, v1, c, s)
        if a02 != 0.0:  # (0, 2), r = 1
            t, c, s = _givens(a00, a22, a02)
            a00, a22, a02 = a00 - t * a02, a22 + t * a02, 0.0
            a01, a12 = c * a01 - s * a12, s * a01 + c * a12
            v0, v2 = _rotate_columns(v0, v2, c, s)
        if a12 != 0.0:  # (1, 2), r = 0
            t, c, s = _givens(a11, a22, a12)
            a11, a22, a12 = a11 - t * a12, a22 + t * a12, 0.0
            a01, a02 = c * a01 - s * a02, s * a01 + c * a02
            v1, v2 = _rotate_columns(v1, v2, c, s)
    if a00 > a11:
        a00, a11, v0, v1 = a11, a00, v1, v0
    if a11 > a22:
        a11, a22, v1, v2 = a22, a11, v2, v1
    if a00 > a11:
        a00, a11, v0, v1 = a11, a00, v1, v0
    return (a00, a11, a22), (v0, v1, v2)


@stage
def _secular(nu, kap, eh2, alpha):
    """H(nu') = 1 - alpha / nu' - sum kappa_i eh_i^2 / (kappa_i - nu') and dH/dnu'."""
    h = 1.0 - alpha / nu
    dh = alpha / (nu * nu)
    for i in range(3):
        g = 1.0 / (kap[i] - nu)
        h -= kap[i] * eh2[i] * g
        dh -= kap[i] * eh2[i] * g * g
    return h, dh


@stage
def _maximise_secular(kap, eh2, alpha, rtol):
    """nu' in (0, kappa_1) maximising the concave H: bisection on the sign of H', with Newton steps on
    the nearly linear zeta = 1 / sqrt(sum kappa eh^2 / (kappa - nu)^2) - nu' / sqrt(alpha)."""
    lo, hi = 0.0, kap[0]
    nu = 0.5 * kap[0]
    ia = 1.0 / math.sqrt(alpha)
    for _ in range(CONTAIN_NEWTON_STEPS):
        s1 = s2 = 0.0
        for i in range(3):
            g = 1.0 / (kap[i] - nu)
            s1 += kap[i] * eh2[i] * g * g
            s2 += kap[i] * eh2[i] * g * g * g
        if alpha / (nu * nu) - s1 > 0.0:  # H'(nu') > 0: the maximiser lies right of nu'
            lo = nu
        else:
            hi = nu
        new = 0.5 * (lo + hi)
        if s1 > 0.0:
            z = 1.0 / math.sqrt(s1) - nu * ia
            dz = -s2 / (s1 * math.sqrt(s1)) - ia
            new = nu - z / dz
            if not lo < new < hi:
                new = 0.5 * (lo + hi)
        done = abs(new - nu) <= rtol * nu or hi - lo <= rtol * kap[0]
        nu = new
        if done:
            break
    return nu


# --- certificates ------------------------------------------------------------------------------


@stage
def _inside_certificate(mu, W, mW, inv, minv, alpha, malpha):
    """K_c + mu I positive definite (leading minors) and f(mu) > 0, all certified (mu < 0): B strictly
    inside A.  Minors: |w0|^2 + mu, |w0 x w1|^2 + mu (|w0|^2 + |w1|^2) + mu^2 (Lagrange), P(mu)."""
    t1, t2, t3, p1, q, s3 = inv
    mt1, mt2, mt3, mp1, mq, ms3 = minv
    am = abs(mu)
    w0, w1 = (W[0], W[3], W[6]), (W[1], W[4], W[7])
    m0, m1 = (mW[0], mW[3], mW[6]), (mW[1], mW[4], mW[7])
    if not _positive(norm2(w0) + mu, norm2(m0) + am, ERR_POLY):
        return False
    d2 = norm2(cross3(w0, w1)) + mu * (norm2(w0) + norm2(w1)) + mu * mu
    if not _positive(d2, norm2(cross3_mag(m0, m1)) + am * (norm2(m0) + norm2(m1)) + mu * mu, ERR_POLY):
        return False
    p = ((mu + t1) * mu + t2) * mu + t3
    mp = ((am + mt1) * am + mt2) * am + mt3
    if not _positive(p, mp, ERR_POLY):
        return False
    n = (p1 * mu + q) * mu + s3
    mn = (mp1 * am + mq) * am + ms3
    return _positive(mu * n - (mu + alpha) * p, am * mn + (am + malpha) * mp, ERR_POLY)


@stage
def _outside_certificate(y, W, mW, e, me, alpha, malpha):
    """y strictly outside A (|y|^2 > 1 [4]) and strictly inside B (alpha - |W_c (y - e)|^2 > 0 [13])."""
    yy = norm2(y)
    if not _positive(yy - 1.0, yy + 1.0, ERR_WITNESS):
        return False
    u = (y[0] - e[0], y[1] - e[1], y[2] - e[2])
    mu_ = (abs(y[0]) + me[0], abs(y[1]) + me[1], abs(y[2]) + me[2])
    return _positive(alpha - norm2(matvec(W, u)), malpha + norm2(matvec(mW, mu_)), ERR_WITNESS)


@stage
def _towards(y, e, f):
    """e + f (y - e): y pulled towards B's centre."""
    return (e[0] + f * (y[0] - e[0]), e[1] + f * (y[1] - e[1]), e[2] + f * (y[2] - e[2]))


@stage
def _in_basis(V, z):
    """V z for V given as three column tuples."""
    return (
        V[0][0] * z[0] + V[1][0] * z[1] + V[2][0] * z[2],
        V[0][1] * z[0] + V[1][1] * z[1] + V[2][1] * z[2],
        V[0][2] * z[0] + V[1][2] * z[1] + V[2][2] * z[2],
    )


@jit
def contains_pair(A, B):
    """INSIDE (1) when B is certainly inside A, NOT_INSIDE (0) when certainly not, else UNDECIDED (-1);
    A, B from vec3.load."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    if ca == cb and Ra == Rb and rb[0] <= ra[0] and rb[1] <= ra[1] and rb[2] <= ra[2]:
        return INSIDE  # the same frame and no longer axes: q_A <= q_B everywhere, exactly
    sa, sb = _sort3(ra), _sort3(rb)
    if sb[0] > sa[0] * AXIS_SLACK or sb[1] > sa[1] * AXIS_SLACK or sb[2] > sa[2] * AXIS_SLACK:
        return NOT_INSIDE
    d = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
    if bounding_spheres_apart(ra, rb, norm2(d)):
        return NOT_INSIDE
    if not _in_float_range(ra, rb):
        return UNDECIDED
    e, me = offset(ca, Ra, ra, cb)
    ee = norm2(e)
    if _positive(ee - 1.0, norm2(me) + 1.0, ERR_SHORT):  # q_A(c_b) > 1: B's centre is outside A
        return NOT_INSIDE
    W, mW, alpha, malpha = shape(Ra, ra, Rb, reciprocal(rb), True)
    v, mv = matvec(W, e), matvec(mW, me)
    inv, minv = invariants(W, mW, e, me, v, mv)
    w0, w1, w2 = (W[0], W[3], W[6]), (W[1], W[4], W[7]), (W[2], W[5], W[8])
    K = (norm2(w0), w0[0] * w1[0] + w0[1] * w1[1] + w0[2] * w1[2], w0[0] * w2[0] + w0[1] * w2[1] + w0[2] * w2[2],
         norm2(w1), w1[0] * w2[0] + w1[1] * w2[1] + w1[2] * w2[2], norm2(w2))  # fmt: skip
    kap, V = _jacobi3(K)
    if not kap[0] > 0.0:
        return UNDECIDED
    eh = (V[0][0] * e[0] + V[0][1] * e[1] + V[0][2] * e[2], V[1][0] * e[0] + V[1][1] * e[1] + V[1][2] * e[2],
          V[2][0] * e[0] + V[2][1] * e[1] + V[2][2] * e[2])  # fmt: skip
    eh2 = (eh[0] * eh[0], eh[1] * eh[1], eh[2] * eh[2])
    nu = _maximise_secular(kap, eh2, alpha, CONTAIN_RTOL)
    for attempt in range(2):  # a multiplier to 1e-9 settles all but ~1 pair in 50 000; then to rounding
        rel = _certificates(nu, kap, V, eh, eh2, e, me, W, mW, inv, minv, alpha, malpha)
        if rel != UNDECIDED or attempt == 1:
            return rel
        nu = _maximise_secular(kap, eh2, alpha, CONTAIN_RTOL_FINE)
    return UNDECIDED


@stage
def _certificates(nu, kap, V, eh, eh2, e, me, W, mW, inv, minv, alpha, malpha):
    """INSIDE / NOT_INSIDE proven from the candidates the multiplier nu gives, else UNDECIDED."""
    if _secular(nu, kap, eh2, alpha)[0] > 0.0:
        # inside: the maximiser, then points towards kappa_1 and towards 0 where H is still positive
        if _inside_certificate(-nu, W, mW, inv, minv, alpha, malpha):
            return INSIDE
        for f in (0.5, 0.9, 0.99, 0.999999):
            cand = nu + f * (kap[0] - nu)
            if _secular(cand, kap, eh2, alpha)[0] > 0.0 and _inside_certificate(-cand, W, mW, inv, minv, alpha, malpha):
                return INSIDE
        for f in (0.75, 0.95):
            cand = nu * f
            if _secular(cand, kap, eh2, alpha)[0] > 0.0 and _inside_certificate(-cand, W, mW, inv, minv, alpha, malpha):
                return INSIDE
        return UNDECIDED
    # not inside: the maximiser of |y|^2 on B, y = (K_c - nu' I)^{-1} K_c e, pulled towards e
    y = _in_basis(V, (kap[0] * eh[0] / (kap[0] - nu), kap[1] * eh[1] / (kap[1] - nu), kap[2] * eh[2] / (kap[2] - nu)))
    # the hard case (e nearly orthogonal to the first eigenvector): move along it to B's boundary
    u = (y[0] - e[0], y[1] - e[1], y[2] - e[2])
    qb = norm2(matvec(W, u)) / alpha
    if qb < 1.0:
        tt = math.sqrt((1.0 - qb) * alpha / kap[0])
        if V[0][0] * y[0] + V[0][1] * y[1] + V[0][2] * y[2] < 0.0:
            tt = -tt
        y = (y[0] + tt * V[0][0], y[1] + tt * V[0][1], y[2] + tt * V[0][2])
    yy = norm2(y)
    for f in (1.0 - 0.25 * min(1.0, max(yy - 1.0, 0.0)), 1.0 - 1e-9, 1.0 - 1e-4, 0.999):
        if _outside_certificate(_towards(y, e, f), W, mW, e, me, alpha, malpha):
            return NOT_INSIDE
    for i in range(3):  # the ends of B's principal axes
        s = math.sqrt(alpha / kap[i]) * 0.999999
        for sg in (-1.0, 1.0):
            yi = (e[0] + sg * s * V[i][0], e[1] + sg * s * V[i][1], e[2] + sg * s * V[i][2])
            if _outside_certificate(yi, W, mW, e, me, alpha, malpha):
                return NOT_INSIDE
    return UNDECIDED


@jit
def _contains(Ca, Ra, ra, Cb, Rb, rb, out, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(lo, hi):
        out[i] = contains_pair(load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb))


def certify_containment(a, b, n, parallel):
    """int8 (n,): INSIDE / NOT_INSIDE where the float path is certain, UNDECIDED (-1) elsewhere."""
    out = np.empty(n, dtype=np.int8)
    threads.run(ext.contains, n, parallel, a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out)
    return out


def contains(a, b, *, parallel=None):
    """Whether b[i] lies inside a[i], exactly (closed sets: touching a's boundary from inside counts).

    a, b : Ellipsoids; a batch of length 1 broadcasts against the other.
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (n,) bool.  Pairs the float filter cannot prove (internal tangency, near it) are decided
        in exact integer arithmetic (~2 ms each; certify_containment tells which; contains_exact below is
        the same decision in Python's Fractions, the tests' reference).
    """
    n = check_pair(a, b)
    out = certify_containment(a, b, n, check_parallel(parallel, n))
    ext.resolve_containment(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out, 0, n)
    return out.astype(bool)


# --- exact rational fallback ---------------------------------------------------------------------


def frame_matrices(ca, Ra, ra, cb, Rb, rb):
    """Exact K (3x3) and e of B in A's frame, as Fractions (any invertible rotations)."""
    ca, Ra, ra, cb, Rb, rb, C, det = exact_pair(ca, Ra, ra, cb, Rb, rb)
    # W = D_b^{-1} R_b^T R_a^{-T} D_a with R_a^{-T} = C / det
    W = [[sum(Rb[k][i] * C[k][j] for k in range(3)) * ra[j] / (rb[i] * det) for j in range(3)] for i in range(3)]
    d = [cb[k] - ca[k] for k in range(3)]
    e = [sum(Ra[k][i] * d[k] for k in range(3)) / ra[i] for i in range(3)]
    K = [[sum(W[k][i] * W[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return K, e


def _det(M):
    """Determinant by Gaussian elimination on Fractions."""
    M = [row[:] for row in M]
    n, sign, out = len(M), 1, Fraction(1)
    for col in range(n):
        piv = next((r for r in range(col, n) if M[r][col] != 0), None)
        if piv is None:
            return Fraction(0)
        if piv != col:
            M[col], M[piv] = M[piv], M[col]
            sign = -sign
        out *= M[col][col]
        for r in range(col + 1, n):
            f = M[r][col] / M[col][col]
            for k in range(col, n):
                M[r][k] -= f * M[col][k]
    return sign * out


def _interpolate(xs, ys):
    """Coefficients (highest degree first) of the polynomial through the points (xs, ys) (Lagrange)."""
    coeffs = [Fraction(0)] * len(xs)
    for i, xi in enumerate(xs):
        basis, denom = [Fraction(1)], Fraction(1)
        for j, xj in enumerate(xs):
            if j != i:
                basis = [Fraction(0)] + basis
                for k in range(len(basis) - 1):
                    basis[k] -= xj * basis[k + 1]
                denom *= xi - xj
        for k in range(len(basis)):
            coeffs[k] += ys[i] * basis[k] / denom
    return _strip(coeffs[::-1])


def pencil_polynomials(K, e):
    """T(nu) = det N(nu) and E_1, E_2, E_3 (sums of principal minors of N(nu)), exact, by interpolation."""
    Ke = [sum(K[i][j] * e[j] for j in range(3)) for i in range(3)]
    eKe = sum(e[i] * Ke[i] for i in range(3))

    def N(nu):
        M = [[K[i][j] - (nu if i == j else 0) for j in range(3)] + [-Ke[i]] for i in range(3)]
        return M + [[-Ke[0], -Ke[1], -Ke[2], eKe - 1 + nu]]

    def minor_sum(M, k):
        return sum((_det([[M[i][j] for j in J] for i in J]) for J in combinations(range(4), k)), Fraction(0))

    xs = [Fraction(k) for k in range(5)]
    mats = [N(x) for x in xs]
    return [_interpolate(xs[: k + 1], [minor_sum(M, k) for M in mats[: k + 1]]) for k in (4, 1, 2, 3)]


def _integral(p):
    """The Fraction polynomial p times the positive lcm of its denominators: integer coefficients, the
    same sign as p everywhere."""
    m = math.lcm(*(c.denominator for c in p)) if p else 1
    return [c.numerator * (m // c.denominator) for c in p]


def _sign(ip, x):
    """Sign of the integer polynomial ip at the Fraction x = n/d, in integers only: d^deg ip(n/d) by
    homogeneous Horner (d > 0 keeps the sign), no gcd per operation as Fraction arithmetic has."""
    if not ip:
        return 0
    n, d = x.numerator, x.denominator
    v, dk = ip[0], 1
    for c in ip[1:]:
        dk *= d
        v = v * n + c * dk
    return (v > 0) - (v < 0)


def _deriv(p):
    n = len(p) - 1
    return _strip([c * (n - k) for k, c in enumerate(p[:-1])])


def _quotient(num, den):
    num, q = list(num), []
    while len(num) >= len(den):
        f = num[0] / den[0]
        q.append(f)
        for k in range(len(den)):
            num[k] -= f * den[k]
        num.pop(0)
    return _strip(q) if q else [Fraction(0)]


def _gcd(a, b):
    a, b = _strip(a), _strip(b)
    while b:
        a, b = b, _remainder(a, b)
    return [c / a[0] for c in a] if a else a


def _squarefree(p):
    g = _gcd(p, _deriv(p))
    return _quotient(p, g) if len(g) > 1 else p


class _Sturm:
    """The Sturm sequence of a square-free polynomial p (integer members, _integral) and its root
    counts; sign variations are memoised per point, as bisection revisits each end."""

    def __init__(self, p):
        chain = [p, _deriv(p)] if len(p) > 1 else [p]
        while len(chain[-1]) > 1:
            r = _remainder(chain[-2], chain[-1])
            if not r:
                break
            chain.append([-c for c in r])
        self.chain = [_integral(q) for q in chain]
        self.memo = {}

    def sign(self, x):
        """Sign of p at x."""
        return _sign(self.chain[0], x)

    def variations(self, x):
        v = self.memo.get(x)
        if v is None:
            s = [v > 0 for v in (_sign(q, x) for q in self.chain) if v != 0]
            v = self.memo[x] = sum(1 for a, b in zip(s, s[1:]) if a != b)
        return v

    def count(self, lo, hi):
        """Distinct roots of p in (lo, hi]."""
        return self.variations(lo) - self.variations(hi)


def _log2(x):
    """floor(log2 x) to within one, for x > 0."""
    return x.numerator.bit_length() - x.denominator.bit_length()


def _split(lo, hi):
    """A point strictly between 0 < lo < hi: a power of two halfway in exponent while hi/lo > 4 (roots of
    float-built polynomials span hundreds of binades), the midpoint otherwise."""
    if hi > 4 * lo:
        e = (_log2(lo) + _log2(hi)) // 2
        mid = Fraction(1 << e) if e >= 0 else Fraction(1, 1 << -e)
        if lo < mid < hi:
            return mid
    return (lo + hi) / 2


def _positive_roots(p):
    """(roots, square-free part, its Sturm sequence): the distinct positive roots of p, each ("exact", r)
    or ("interval", lo, hi) with exactly one root in the open interval (lo, hi)."""
    p = _squarefree(_strip(p))
    while len(p) > 1 and p[-1] == 0:
        p = p[:-1]  # a factor mu: the positive roots stay
    sturm = _Sturm(p)
    if len(p) <= 1:
        return [], p, sturm
    top = max(abs(c) for c in p[1:])
    hi = 1 + top / abs(p[0])  # Cauchy's bound on |roots|
    lo = abs(p[-1]) / (abs(p[-1]) + max(abs(c) for c in p[:-1])) / 2  # half its bound for 1/roots
    out, stack = [], [(lo, hi)]
    while stack:
        lo, hi = stack.pop()
        k = sturm.count(lo, hi)
        if k == 0:
            continue
        if k == 1:
            out.append(("exact", hi) if sturm.sign(hi) == 0 else ("interval", lo, hi))
            continue
        mid = _split(lo, hi)
        stack += [(lo, mid), (mid, hi)]
    return out, p, sturm


def _sign_at_root(q, root, sturm, sf):
    """Sign of the polynomial q at an isolated root of the square-free sf (its Sturm sequence `sturm`)."""
    if not q:
        return 0
    iq = _integral(q)
    if root[0] == "exact":
        return _sign(iq, root[1])
    _, lo, hi = root
    g = _gcd(sf, q)
    if len(g) > 1 and _Sturm(g).count(lo, hi) > 0:
        return 0  # q shares the root
    qs = _squarefree(q)
    if len(qs) <= 1:
        return (q[0] > 0) - (q[0] < 0)
    qsturm = _Sturm(qs)
    while True:  # refine (lo, hi) around the root until q has no root in it
        mid = _split(lo, hi)
        if qsturm.count(lo, hi) == 0 and _sign(iq, mid) != 0:
            return _sign(iq, mid)
        if sturm.sign(mid) == 0:
            return _sign(iq, mid)
        if sturm.count(lo, mid) == 1:
            hi = mid
        else:
            lo = mid


def contains_exact(ca, Ra, ra, cb, Rb, rb):
    """INSIDE (1) or NOT_INSIDE (0) for one pair, in rationals (module docstring)."""
    T, E1, E2, E3 = pencil_polynomials(*frame_matrices(ca, Ra, ra, cb, Rb, rb))
    roots, sf, sturm = _positive_roots(T)
    for root in roots:
        if all(_sign_at_root(E, root, sturm, sf) >= 0 for E in (E1, E2, E3)):
            return INSIDE
    return NOT_INSIDE
