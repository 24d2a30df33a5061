"""Slow, obvious references: exact relations (rationals) and signed distances (mpmath).

Independent of the library: it builds A = [[Q, -Q c], [-c^T Q, c^T Q c - 1]] with
Q = R diag(1/r^2) R^T straight from the definition |diag(1/r) R^T (x - c)| <= 1, gets det(lambda A + B)
by exact interpolation at lambda = 0..4 (Gaussian elimination on Fractions), and counts distinct
positive roots with a textbook Sturm chain.
"""

from fractions import Fraction

import numpy as np


def quadric(c, R, r):
    c = [Fraction(float(x)) for x in c]
    R = [[Fraction(float(x)) for x in row] for row in R]
    w = [1 / Fraction(float(x)) ** 2 for x in r]
    Q = [[sum(R[i][k] * w[k] * R[j][k] for k in range(3)) for j in range(3)] for i in range(3)]
    g = [-sum(Q[i][j] * c[j] for j in range(3)) for i in range(3)]
    k = sum(c[i] * Q[i][j] * c[j] for i in range(3) for j in range(3)) - 1
    return [Q[0] + [g[0]], Q[1] + [g[1]], Q[2] + [g[2]], g + [k]]


def det(M):
    M = [row[:] for row in M]
    n, sign, out = len(M), 1, Fraction(1)
    for col in range(n):
        pivot = next((r for r in range(col, n) if M[r][col] != 0), None)
        if pivot is None:
            return Fraction(0)
        if pivot != col:
            M[col], M[pivot] = M[pivot], M[col]
            sign = -sign
        out *= M[col][col]
        for r in range(col + 1, n):
            f = M[r][col] / M[col][col]
            for k in range(col, n):
                M[r][k] -= f * M[col][k]
    return sign * out


def pencil(A, B):
    """Coefficients (highest degree first) of det(lambda A + B), by Lagrange interpolation."""
    xs = [Fraction(k) for k in range(5)]
    ys = [det([[x * A[i][j] + B[i][j] for j in range(4)] for i in range(4)]) for x in xs]
    coeffs = [Fraction(0)] * 5  # lowest degree first while building
    for i, xi in enumerate(xs):
        basis = [Fraction(1)]
        denom = Fraction(1)
        for j, xj in enumerate(xs):
            if j != i:
                basis = [Fraction(0)] + basis  # times lambda
                for k in range(len(basis) - 1):
                    basis[k] -= xj * basis[k + 1]
                denom *= xi - xj
        for k in range(5):
            coeffs[k] += ys[i] * basis[k] / denom
    return coeffs[::-1]


def sturm_positive_roots(p):
    while p and p[0] == 0:
        p = p[1:]
    deg = len(p) - 1
    chain = [p, [c * (deg - k) for k, c in enumerate(p[:-1])]]
    while True:
        num, den = chain[-2][:], chain[-1]
        while len(num) >= len(den):
            f = num[0] / den[0]
            num = [a - f * b for a, b in zip(num, den + [0] * (len(num) - len(den)))][1:]
        while num and num[0] == 0:
            num = num[1:]
        if not num:
            break
        chain.append([-c for c in num])
        if len(num) == 1:
            break

    def changes(vals):
        s = [v > 0 for v in vals if v != 0]
        return sum(a != b for a, b in zip(s, s[1:]))

    return changes([q[-1] for q in chain]) - changes([q[0] for q in chain])


def relation(ca, Ra, ra, cb, Rb, rb):
    """0 separated, 1 touching, 2 overlapping."""
    n = sturm_positive_roots(pencil(quadric(ca, Ra, ra), quadric(cb, Rb, rb)))
    return {2: 0, 1: 1, 0: 2}[n]


def relations(a, b):
    n = max(len(a), len(b))
    ia = (lambda i: i) if len(a) > 1 else (lambda i: 0)
    ib = (lambda i: i) if len(b) > 1 else (lambda i: 0)
    return [
        relation(a.centers[ia(i)], a.rotations[ia(i)], a.radii[ia(i)], b.centers[ib(i)], b.rotations[ib(i)], b.radii[ib(i)])
        for i in range(n)
    ]


def sigma_stationary(d, Ma, Mb, n0, iterations=60):
    """sigma(n) = n.d - sqrt(n'Ma n) - sqrt(n'Mb n) at the stationary point on the unit sphere nearest
    the unit n0, in the current mpmath precision: Newton on the Lagrange system
    F(n, lam) = (d - Ma n / h_a - Mb n / h_b - lam n, |n|^2 - 1) = 0 with its analytic Jacobian.
    Independent of the library's and the benchmark's parametrisations (both work in a tangent
    plane); Ma = R diag(r^2) R' is an ellipsoid's support-function matrix (h(n) = sqrt(n'Ma n))."""
    import mpmath as mp

    d = mp.matrix([mp.mpf(float(x)) for x in d])
    A = mp.matrix(np.asarray(Ma, dtype=float).tolist())
    B = mp.matrix(np.asarray(Mb, dtype=float).tolist())
    n = mp.matrix([mp.mpf(float(x)) for x in np.asarray(n0, dtype=float) / np.linalg.norm(n0)])

    def parts(n):
        an, bn = A * n, B * n
        return an, bn, mp.sqrt((n.T * an)[0]), mp.sqrt((n.T * bn)[0])

    an, bn, ha, hb = parts(n)
    lam = (n.T * (d - an / ha - bn / hb))[0]
    for _ in range(iterations):
        an, bn, ha, hb = parts(n)
        g = d - an / ha - bn / hb - lam * n
        F = mp.matrix([g[0], g[1], g[2], (n.T * n)[0] - 1])
        H = -(A / ha - an * an.T / ha**3) - (B / hb - bn * bn.T / hb**3) - lam * mp.eye(3)
        J = mp.matrix(4, 4)
        for i in range(3):
            for j in range(3):
                J[i, j] = H[i, j]
            J[i, 3] = -n[i]
            J[3, i] = 2 * n[i]
        step = mp.lu_solve(J, -F)
        n = n + step[0:3]
        lam += step[3]
        if mp.norm(step) < mp.mpf(10) ** (6 - mp.mp.dps):
            break
    n /= mp.norm(n)
    _, _, ha, hb = parts(n)
    return (n.T * d)[0] - ha - hb
