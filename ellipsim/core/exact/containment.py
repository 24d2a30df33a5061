"""Containment: does ellipsoid b lie inside ellipsoid a?  Exact on the float64 inputs, as classify is.

Criterion (closed sets: b touching a's boundary from inside counts as inside).  In A's frame
(exact/pair_frame.hpp), A is the unit ball |y| <= 1 and B = {y : (y - e)^T K (y - e) <= 1}; let A_y = diag(I, -1)
and B_y = [[K, -K e], [-e^T K, e^T K e - 1]].  Geometric Tools (Eberly, "Intersection of Ellipsoids",
11.9.2) maximises q_A over B by Lagrange multipliers; we use the dual of that maximisation:

    B subset A  <=>  there is nu > 0 with  N(nu) = B_y - nu A_y  positive semidefinite.

(=>: the S-lemma (Yakubovich), since q_B < 1 somewhere: q_B <= 1 implies q_A <= 1 iff q_A - 1 <=
tau (q_B - 1) everywhere for some tau >= 0, and tau > 0 as q_A is unbounded; a quadratic function is
nonnegative everywhere iff its homogeneous 4x4 matrix is PSD; nu = 1 / tau.  <=: if N(nu) is PSD then
q_B(y) - 1 >= nu (|y|^2 - 1) for all y.)  det N(nu) is the characteristic polynomial det(lambda A + B)
of Wang, Wang & Kim (thesis ch. 4) at lambda = -nu: containment is read off its NEGATIVE roots, as
separation is read off its positive ones.  In exact/pair_frame.hpp's scaled variables (K_c = alpha K,
mu = -alpha nu), f(mu) = det(mu A_y + alpha B_y) = alpha^4 det N(nu).

Float filter (decisions proven by error bounds: exact/pair_frame.hpp's mags, Higham's gamma_n):
* inside: B's centre, rotation and axes those of A, axes no longer (exact comparisons); or, strictly,
  mu < 0 with K_c + mu I positive definite (Sylvester: three leading minors > 0) and f(mu) > 0, so that
  N(nu) is positive definite and q_B <= 1 forces |y| < 1.  mu maximises the concave
  H(nu') = 1 - alpha / nu' - e^T K_c (K_c - nu' I)^{-1} e on (0, kappa_1) (the secular equation of the
  trust-region problem max_B |y|^2, in K_c's Jacobi eigenbasis).
* not inside: a sorted semi-axis of B longer than A's (widths of B are at most A's), B's centre not
  strictly inside A, the bounding spheres apart, or a point strictly inside B with |y| > 1 (the
  maximiser of |y|^2 over B pulled slightly towards B's centre, or the ends of B's axes).
* UNDECIDED otherwise (internal tangency, identical-but-rotated axes, near-tangency): exact arithmetic.

Exact fallback (exact/containment_fallback.hpp in integers; contains_exact below the same in Fractions, the
tests' reference; any invertible rotations through cof(R_a), as rational_fallback.py).  The set
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
from ..ellipsoids import check_pair, check_parallel
from .rational_fallback import _remainder, _strip, exact_pair

INSIDE, NOT_INSIDE = 1, 0
UNDECIDED = -1


# --- K_c's eigenbasis (float guidance only) ----------------------------------------------------


# --- certificates ------------------------------------------------------------------------------


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
