"""Exact rational fallback: the relation of two ellipsoids on their float64 inputs, always right.

Every float64 is a dyadic rational, so the pencil of exact/pair_frame.hpp (with C = cof(R_a), alpha =
det(R_a)^2, valid for any invertible R_a) has rational coefficients that Python's Fraction computes
exactly.  The theorem of Wang, Wang & Kim (thesis ch. 4, Theorem 1) then reads the relation off the
number of distinct positive roots, counted by an exact Sturm sequence (thesis 4.2.1): two means
separated, one (a double root) touching, none overlapping.  Slow (about a millisecond a pair), so
only pairs the certified float path leaves undecided come here.
"""

from fractions import Fraction

from ..relation import OVERLAPPING, SEPARATED, TOUCHING


def exact_pair(ca, Ra, ra, cb, Rb, rb):
    """The float inputs as Fractions (vectors as lists, rotations as lists of rows), with the
    cofactor matrix C of R_a and det R_a (R_a^-T = C / det)."""
    ca, cb, ra, rb = ([Fraction(float(x)) for x in v] for v in (ca, cb, ra, rb))
    Ra = [[Fraction(float(x)) for x in row] for row in Ra]
    Rb = [[Fraction(float(x)) for x in row] for row in Rb]
    C = _cofactor(Ra)
    return ca, Ra, ra, cb, Rb, rb, C, sum(Ra[0][k] * C[0][k] for k in range(3))


def _cofactor(R):
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    return [
        [r11 * r22 - r12 * r21, r12 * r20 - r10 * r22, r10 * r21 - r11 * r20],
        [r02 * r21 - r01 * r22, r00 * r22 - r02 * r20, r01 * r20 - r00 * r21],
        [r01 * r12 - r02 * r11, r02 * r10 - r00 * r12, r00 * r11 - r01 * r10],
    ]


def pencil_coefficients(ca, Ra, ra, cb, Rb, rb):
    """Exact coefficients (mu^4 ... 1) of f(mu) = mu N(mu) - (mu + alpha) P(mu) (exact/pair_frame.hpp), as Fractions.

    Uses the plain matrix formulas (K = W^T W, principal minors, |K e|^2), not the sums of squares
    of the float path, so the two are independent.
    """
    ca, Ra, ra, cb, Rb, rb, C, det = exact_pair(ca, Ra, ra, cb, Rb, rb)
    alpha = det * det
    W = [[sum(Rb[k][i] * C[k][j] for k in range(3)) * ra[j] / rb[i] for j in range(3)] for i in range(3)]
    d = [cb[k] - ca[k] for k in range(3)]
    e = [sum(Ra[k][i] * d[k] for k in range(3)) / ra[i] for i in range(3)]
    K = [[sum(W[k][i] * W[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    t1 = K[0][0] + K[1][1] + K[2][2]
    t2 = (
        (K[0][0] * K[1][1] - K[0][1] * K[1][0])
        + (K[0][0] * K[2][2] - K[0][2] * K[2][0])
        + (K[1][1] * K[2][2] - K[1][2] * K[2][1])
    )
    cK = _cofactor(K)
    t3 = sum(K[0][k] * cK[0][k] for k in range(3))
    Ke = [sum(K[i][j] * e[j] for j in range(3)) for i in range(3)]
    p1 = sum(e[i] * Ke[i] for i in range(3))
    q = t1 * p1 - sum(x * x for x in Ke)
    s3 = t3 * sum(x * x for x in e)
    return [Fraction(-1), p1 - alpha - t1, q - alpha * t1 - t2, s3 - alpha * t2 - t3, -alpha * t3]


def _strip(p):
    """Drop leading zero coefficients (highest degree first)."""
    i = 0
    while i < len(p) and p[i] == 0:
        i += 1
    return p[i:]


def _remainder(num, den):
    """Remainder of polynomial division (coefficient lists, highest degree first, den[0] != 0)."""
    num = list(num)
    while len(num) >= len(den):
        factor = num[0] / den[0]
        for k in range(len(den)):
            num[k] -= factor * den[k]
        num.pop(0)
    return _strip(num)


def _sign_changes(values):
    signs = [v > 0 for v in values if v != 0]
    return sum(1 for s, t in zip(signs, signs[1:]) if s != t)


def distinct_positive_roots(coefficients):
    """Number of distinct roots in (0, inf) of a polynomial with nonzero constant term (Sturm)."""
    p = _strip(list(coefficients))
    if p[-1] == 0:
        raise ValueError("distinct_positive_roots needs a nonzero constant term")
    n = len(p) - 1
    if n == 0:  # a nonzero constant
        return 0
    chain = [p, _strip([c * (n - k) for k, c in enumerate(p[:-1])])]
    while len(chain[-1]) > 1:
        r = _remainder(chain[-2], chain[-1])
        if not r:
            break
        chain.append([-c for c in r])
    return _sign_changes([s[-1] for s in chain]) - _sign_changes([s[0] for s in chain])


def relation(ca, Ra, ra, cb, Rb, rb):
    """Exact relation code (0 separated, 1 touching, 2 overlapping) of one pair of ellipsoids."""
    count = distinct_positive_roots(pencil_coefficients(ca, Ra, ra, cb, Rb, rb))
    if count == 2:
        return SEPARATED
    if count == 1:
        return TOUCHING
    if count == 0:
        return OVERLAPPING
    raise AssertionError(f"the pencil of two ellipsoids has {count} distinct positive roots; at most 2 is a theorem")
