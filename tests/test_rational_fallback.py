"""core/exact/rational_fallback.py on its own: the exact relation of two ellipsoids from rationals, against an
exact reference written here and against pairs whose answer is known by construction.

The reference (`exact_relation`, also used by tests/test_certified_filter.py) shares nothing with the module or
with tests/reference.py: the world quadrics M = [[Q, -Q c], [-c^T Q, c^T Q c - 1]], Q = R D^-2 R^T, in Fractions;
det(lambda M_A + M_B) expanded symbolically (Leibniz over the 24 permutations, polynomial products); the distinct
positive roots counted by real-root isolation (the square-free part by an exact gcd, then Descartes' rule of signs
on bisected intervals of (0, Cauchy bound), the Vincent-Collins-Akritas method), not by a Sturm sequence.

Checked: pencil_coefficients against the reference's determinant (an exact identity, f(mu) = alpha^3 (prod r_a)^2
det(mu / alpha M_A + M_B), for float rotations that are not exactly orthonormal); distinct_positive_roots against
the isolation on polynomials with known roots (double, negative, clustered); relation on dyadic pairs built
exactly: tangent spheres (along an axis and along (3, 4, 12) / 13), tangent axis-aligned ellipsoids under signed
permutations, internally tangent and strictly contained, concentric, separated and overlapping by a hair (2^-40);
and relation against the reference on random and near-tangent float pairs.
"""

import itertools
from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot

from ellipsim.core.exact import rational_fallback as rf
from ellipsim.core.relation import OVERLAPPING, SEPARATED, TOUCHING

# --- the reference: polynomials as coefficient lists, lowest degree first -----------------------------


def p_trim(p):
    p = list(p)
    while p and p[-1] == 0:
        p.pop()
    return p


def p_mul(a, b):
    out = [Fraction(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        if x:
            for j, y in enumerate(b):
                out[i + j] += x * y
    return out


def p_add(a, b):
    n = max(len(a), len(b))
    return [(a[k] if k < len(a) else 0) + (b[k] if k < len(b) else 0) for k in range(n)]


def p_divmod(num, den):
    num, den = p_trim(num), p_trim(den)
    q = [Fraction(0)] * max(len(num) - len(den) + 1, 1)
    while len(num) >= len(den) and num:
        f = num[-1] / den[-1]
        k = len(num) - len(den)
        q[k] = f
        for i, c in enumerate(den):
            num[k + i] -= f * c
        num = p_trim(num)
    return q, num


def p_gcd(a, b):
    a, b = p_trim(a), p_trim(b)
    while b:
        a, b = b, p_divmod(a, b)[1]
    return [c / a[-1] for c in a]


def p_eval(p, x):
    v = Fraction(0)
    for c in reversed(p):
        v = v * x + c
    return v


def sign_variations(p):
    s = [c > 0 for c in p if c != 0]
    return sum(a != b for a, b in zip(s, s[1:]))


def binomial_poly(a, b, k):
    """(a + b y)^k, lowest degree first."""
    out = [Fraction(1)]
    for _ in range(k):
        out = p_mul(out, [a, b])
    return out


def roots_in(p, lo, hi):
    """Distinct roots of the square-free p in the open interval (lo, hi): Descartes' rule of signs on
    (1 + y)^n p((lo + hi y) / (1 + y)), whose positive roots are those of p in (lo, hi); bisect while it is
    above 1."""
    n = len(p) - 1
    q = [Fraction(0)]
    for k, c in enumerate(p):
        if c:
            q = p_add(
                q, [c * x for x in p_mul(binomial_poly(lo, hi, k), binomial_poly(Fraction(1), Fraction(1), n - k))]
            )
    v = sign_variations(q)
    if v <= 1:
        return v
    mid = (lo + hi) / 2
    return (p_eval(p, mid) == 0) + roots_in(p, lo, mid) + roots_in(p, mid, hi)


def positive_roots(p):
    """Distinct roots in (0, inf) of p (lowest degree first, p(0) != 0)."""
    p = p_trim(p)
    assert p and p[0] != 0
    if len(p) == 1:
        return 0
    dp = [k * c for k, c in enumerate(p)][1:]
    sq, rem = p_divmod(p, p_gcd(p, dp))
    assert not rem
    bound = 1 + max(abs(c / sq[-1]) for c in sq[:-1])  # Cauchy: every root is below it in modulus
    return roots_in(sq, Fraction(0), Fraction(bound))


def quadric(c, R, r):
    c = [Fraction(float(x)) for x in c]
    R = [[Fraction(float(x)) for x in row] for row in R]
    inv2 = [1 / Fraction(float(x)) ** 2 for x in r]
    Q = [[sum(R[i][k] * inv2[k] * R[j][k] for k in range(3)) for j in range(3)] for i in range(3)]
    Qc = [sum(Q[i][j] * c[j] for j in range(3)) for i in range(3)]
    M = [[Q[i][j] for j in range(3)] + [-Qc[i]] for i in range(3)]
    M.append([-x for x in Qc] + [sum(c[i] * Qc[i] for i in range(3)) - 1])
    return M


def _parity(perm):
    sign, seen = 1, list(perm)
    for i in range(len(seen)):
        while seen[i] != i:
            j = seen[i]
            seen[i], seen[j] = seen[j], seen[i]
            sign = -sign
    return sign


def pencil_det(MA, MB):
    """det(lambda MA + MB) (lowest degree first) by the Leibniz formula on linear polynomial entries."""
    out = [Fraction(0)]
    for perm in itertools.permutations(range(4)):
        term = [Fraction(_parity(perm))]
        for i, j in enumerate(perm):
            term = p_mul(term, [MB[i][j], MA[i][j]])
        out = p_add(out, term)
    return out + [Fraction(0)] * (5 - len(out))


def exact_relation(ca, Ra, ra, cb, Rb, rb):
    """0 separated (two distinct positive roots), 1 touching (one), 2 overlapping (none): Wang, Wang & Kim."""
    n = positive_roots(pencil_det(quadric(ca, Ra, ra), quadric(cb, Rb, rb)))
    return {2: SEPARATED, 1: TOUCHING, 0: OVERLAPPING}[n]


# --- pairs ----------------------------------------------------------------------------------------

I3 = np.eye(3)
PERMS = [np.eye(3)[list(p)] * s for p in itertools.permutations(range(3)) for s in ([1, 1, 1], [-1, 1, -1])]


def random_pair(rng):
    Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
    return (rng.uniform(-1, 1, 3), Ra, rng.uniform(0.1, 1, 3), rng.uniform(-1, 1, 3), Rb, rng.uniform(0.1, 1, 3))


def contact_scale(ca, Ra, ra, cb, Rb, rb):
    """Perram-Wertheim: the factor by which both ellipsoids, scaled about their centres, just touch
    (sqrt of max over lambda of lambda (1 - lambda) d^T ((1 - lambda) S_A + lambda S_B)^-1 d, S = R D^2 R^T)."""
    from scipy.optimize import minimize_scalar

    SA, SB = Ra @ np.diag(np.square(ra)) @ Ra.T, Rb @ np.diag(np.square(rb)) @ Rb.T
    d = np.asarray(cb) - np.asarray(ca)
    F = lambda lam: -lam * (1 - lam) * d @ np.linalg.solve((1 - lam) * SA + lam * SB, d)  # noqa: E731
    res = minimize_scalar(F, bounds=(0, 1), method="bounded", options={"xatol": 1e-14})
    return float(np.sqrt(-res.fun))


def near_tangent(rng, delta):
    """A random pair with B's centre moved along the centre line to just touching, then by a relative delta."""
    ca, Ra, ra, cb, Rb, rb = random_pair(rng)
    s = contact_scale(ca, Ra, ra, cb, Rb, rb)
    return ca, Ra, ra, ca + (cb - ca) / s * (1 + delta), Rb, rb


# --- the reference checks itself on pairs with known answers ------------------------------------------


def test_reference_on_known_pairs():
    assert positive_roots([Fraction(-6), 11, -6, 1]) == 3  # (x - 1)(x - 2)(x - 3)
    assert positive_roots(p_mul([Fraction(-1), 1], p_mul([Fraction(-1), 1], [Fraction(2), 1]))) == 1  # double root
    assert positive_roots([Fraction(1), 0, 1]) == 0
    one = [Fraction(0), 0, 0]
    assert exact_relation(one, I3, [1, 1, 1], [3, 0, 0], I3, [1, 1, 1]) == SEPARATED
    assert exact_relation(one, I3, [1, 1, 1], [2, 0, 0], I3, [1, 1, 1]) == TOUCHING
    assert exact_relation(one, I3, [1, 1, 1], [1, 0, 0], I3, [1, 1, 1]) == OVERLAPPING
    assert exact_relation(one, I3, [2, 2, 2], [1, 0, 0], I3, [1, 1, 1]) == OVERLAPPING  # internally tangent


# --- pencil_coefficients and distinct_positive_roots ------------------------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_pencil_coefficients_are_the_world_pencil(seed):
    """f(mu) = alpha^3 (prod r_a)^2 p(mu / alpha), p = det(lambda M_A + M_B), alpha = det(R_a)^2, coefficient by
    coefficient and exactly, for float rotations orthonormal only to rounding."""
    rng = np.random.default_rng(seed)
    ca, Ra, ra, cb, Rb, rb = random_pair(rng)
    f = rf.pencil_coefficients(ca, Ra, ra, cb, Rb, rb)[::-1]  # lowest degree first
    p = pencil_det(quadric(ca, Ra, ra), quadric(cb, Rb, rb))
    R = [[Fraction(float(x)) for x in row] for row in Ra]
    det = (
        R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1])
        - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
        + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0])
    )
    assert det != 1  # not exactly orthonormal: the identity is not trivially alpha = 1
    alpha = det * det
    prod = Fraction(float(ra[0])) * Fraction(float(ra[1])) * Fraction(float(ra[2]))
    assert [f[k] for k in range(5)] == [alpha ** (3 - k) * prod**2 * p[k] for k in range(5)]


def test_distinct_positive_roots_against_isolation():
    rng = np.random.default_rng(7)
    for _ in range(300):
        roots = [Fraction(int(x), int(rng.integers(1, 9))) for x in rng.integers(-6, 7, int(rng.integers(1, 5)))]
        roots = [r for r in roots if r != 0]
        if rng.uniform() < 0.3 and roots:
            roots.append(roots[0])  # a double root
        if rng.uniform() < 0.2 and roots:
            roots.append(roots[0] + Fraction(1, 2**60))  # a cluster
        p = [Fraction(int(rng.integers(1, 5)) * int(rng.choice([-1, 1])))]
        for r in roots:
            p = p_mul(p, [-r, Fraction(1)])
        if rng.uniform() < 0.3 or not roots:
            p = p_mul(p, [Fraction(1), 0, 1])  # complex roots
        want = len({r for r in roots if r > 0})
        assert positive_roots(p) == want
        assert rf.distinct_positive_roots(p[::-1]) == want, (roots, p)
    with pytest.raises(ValueError, match="nonzero constant term"):
        rf.distinct_positive_roots([Fraction(1), Fraction(-1), Fraction(0)])


def test_distinct_positive_roots_of_a_nonzero_constant():
    """A nonzero constant has a nonzero constant term and no roots (never a pencil: those have degree 4)."""
    assert rf.distinct_positive_roots([Fraction(3)]) == 0


# --- relation on pairs built exactly ------------------------------------------------------------------

HAIR = 2.0**-40


def spheres(ra, rb, d):
    return [0.0, 0.0, 0.0], I3, [ra] * 3, list(d), I3, [rb] * 3


@pytest.mark.parametrize(
    "ra, rb, d",
    [
        (1.0, 1.0, (2.0, 0.0, 0.0)),
        (0.5, 0.25, (0.0, -0.75, 0.0)),
        (1.0, 0.625, (3 / 8, 4 / 8, 12 / 8)),  # |d| = 13/8 exactly
        (2.0**-30, 2.0**-31, (0.0, 0.0, 3 * 2.0**-31)),
        (2.0**40, 3 * 2.0**40, (2.0**42, 0.0, 0.0)),
    ],
)
def test_relation_of_tangent_spheres_and_hairs(ra, rb, d):
    d = np.array(d)
    assert rf.relation(*spheres(ra, rb, d)) == TOUCHING
    assert rf.relation(*spheres(ra, rb, d * (1 + HAIR))) == SEPARATED
    assert rf.relation(*spheres(ra, rb, d * (1 - HAIR))) == OVERLAPPING
    assert rf.relation(*spheres(ra * (1 - HAIR), rb, d)) == SEPARATED
    assert rf.relation(*spheres(ra, rb * (1 + HAIR), d)) == OVERLAPPING


@pytest.mark.parametrize("k", range(len(PERMS)))
def test_relation_of_tangent_axis_aligned_ellipsoids(k):
    """A = (2, 1, 0.5) at the origin, B = (0.75, 0.25, 1.5) in a signed permutation P of its axes, each
    touching A at the tip of one of A's axes along B's axis there (the contact is at both tips)."""
    P = PERMS[k]
    ra, rb = np.array([2.0, 1.0, 0.5]), np.array([0.75, 0.25, 1.5])
    rbw = np.abs(P) @ rb  # B's semi-axes along the world axes
    for axis in range(3):
        for sign in (1.0, -1.0):
            e = np.zeros(3)
            e[axis] = sign
            for gap, want in ((0.0, TOUCHING), (HAIR, SEPARATED), (-HAIR, OVERLAPPING)):
                cb = e * (ra[axis] + rbw[axis]) * (1 + gap)
                assert rf.relation([0.0, 0.0, 0.0], I3, ra, cb, P, rb) == want, (axis, sign, gap)
                assert rf.relation(cb, P, rb, [0.0, 0.0, 0.0], I3, ra) == want  # the other way round


def test_relation_of_contained_and_concentric_pairs():
    """Internally tangent (B inside A touching its tip), strictly inside, concentric, the same ellipsoid twice,
    and A inside B: overlapping, whatever the order."""
    A = ([0.0, 0.0, 0.0], I3, [2.0, 1.0, 1.0])
    for B in (
        ([1.5, 0.0, 0.0], I3, [0.5, 0.5, 0.5]),  # touches A at (2, 0, 0) from inside
        ([1.5 - HAIR, 0.0, 0.0], I3, [0.5, 0.5, 0.5]),
        ([0.25, 0.0, 0.0], I3, [0.5, 0.25, 0.25]),
        ([0.0, 0.0, 0.0], PERMS[3], [0.75, 0.5, 0.25]),
        ([0.0, 0.0, 0.0], I3, [2.0, 1.0, 1.0]),
        ([0.0, 0.0, 0.0], I3, [8.0, 8.0, 8.0]),
    ):
        assert rf.relation(*A, *B) == OVERLAPPING and rf.relation(*B, *A) == OVERLAPPING
    B = ([1.5 + 2.0**-30, 0.0, 0.0], I3, [0.5, 0.5, 0.5])  # pokes out of A by a hair: still overlapping
    assert rf.relation(*A, *B) == OVERLAPPING


@pytest.mark.parametrize("seed", range(3))
def test_relation_against_the_reference_on_float_pairs(seed):
    """Random pairs and pairs moved to within 1e-15 ... 1e-6 of touching (and to touching, to rounding)."""
    rng = np.random.default_rng(50 + seed)
    pairs = [random_pair(rng) for _ in range(15)]
    pairs += [near_tangent(rng, delta) for delta in (0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6)]
    got = [rf.relation(*p) for p in pairs]
    assert got == [exact_relation(*p) for p in pairs]
    assert got[-4:] == [SEPARATED, OVERLAPPING, SEPARATED, OVERLAPPING]
    assert {SEPARATED, OVERLAPPING} <= set(got[:15])
