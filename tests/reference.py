"""Slow, obvious references: exact relations (rationals), signed distances (mpmath), and the maximum
of a capsule or box pair's sigma over dense directions (dense_maximum).

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
        relation(
            a.centers[ia(i)], a.rotations[ia(i)], a.radii[ia(i)], b.centers[ib(i)], b.rotations[ib(i)], b.radii[ib(i)]
        )
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
    n, ha, hb = stationary_direction(d, A, B, np.asarray(n0, dtype=float), iterations)
    return (n.T * d)[0] - ha - hb


def stationary_direction(d, A, B, n0, iterations=60):
    """(n, h_a, h_b): sigma_stationary's stationary unit n for mpmath d (3,), A, B (3x3), and the two
    support functions there."""
    import mpmath as mp

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
        try:
            step = mp.lu_solve(J, -F)
        except ZeroDivisionError:  # no isolated stationary point (concentric spheres: sigma is constant)
            break
        n = n + step[0:3]
        lam += step[3]
        if mp.norm(step) < mp.mpf(10) ** (6 - mp.mp.dps):
            break
    n /= mp.norm(n)
    _, _, ha, hb = parts(n)
    return n, ha, hb


def contact_mp(ca, Ra, ra, cb, Rb, rb, n0):
    """(sigma, normal, pos) of two ellipsoids at the stationary direction nearest n0, every input and
    output in mpmath (centres (3,), rotations 3x3 with the axes as columns, semi-axes (3,)): the
    signed distance's local value, its normal and the midpoint of the support points
    c_A + Ma n / h_a and c_B - Mb n / h_b, straight from the definitions."""
    import mpmath as mp

    Ma = Ra * mp.diag([x**2 for x in ra]) * Ra.T
    Mb = Rb * mp.diag([x**2 for x in rb]) * Rb.T
    d = cb - ca
    n, ha, hb = stationary_direction(d, Ma, Mb, n0)
    pos = (ca + Ma * n / ha + cb - Mb * n / hb) / 2
    return (n.T * d)[0] - ha - hb, n, pos


# --- moving ellipsoids (time_of_impact) --------------------------------------------------------


def fraction_of(x):
    """An mpmath number (or a float) as the exact Fraction it holds."""
    import mpmath as mp

    sign, man, exp, _ = mp.mpf(x)._mpf_
    v = Fraction(int(man)) * (Fraction(2) ** exp if exp >= 0 else Fraction(1, 2 ** (-exp)))
    return -v if sign else v


def quadric_rational(c, R, r):
    """`quadric` for a centre and rotation given as Fractions (an exactly evaluated pose)."""
    w = [1 / Fraction(float(x)) ** 2 for x in r]
    Q = [[sum(R[i][k] * w[k] * R[j][k] for k in range(3)) for j in range(3)] for i in range(3)]
    g = [-sum(Q[i][j] * c[j] for j in range(3)) for i in range(3)]
    k = sum(c[i] * Q[i][j] * c[j] for i in range(3) for j in range(3)) - 1
    return [Q[0] + [g[0]], Q[1] + [g[1]], Q[2] + [g[2]], g + [k]]


def motion_pose(c0, c1, R0, R1, w, t, dps=60):
    """The pose of one body at t of the motion time_of_impact defines (core/motion/interpolation.py), in `dps` digits:
    c0 + t (c1 - c0) and R_p exp((t - tau) [w]x) (tau = 0 for t <= 1/2, else 1), by Rodrigues' formula
    in mpmath; returned as Fractions (centre (3,), rotation 3x3 lists).  t: a float or a Fraction."""
    import mpmath as mp

    with mp.workdps(dps):
        tt = mp.mpf(t.numerator) / t.denominator if isinstance(t, Fraction) else mp.mpf(float(t))
        piece = 0 if tt <= mp.mpf(1) / 2 else 1
        Rp = mp.matrix([[mp.mpf(float(v)) for v in row] for row in (R0 if piece == 0 else R1)])
        wv = [mp.mpf(float(v)) for v in w]
        th = mp.sqrt(sum(v * v for v in wv))
        if th == 0:
            E = mp.eye(3)
        else:
            k = [v / th for v in wv]
            K = mp.matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            al = th * (tt - piece)
            E = mp.eye(3) + mp.sin(al) * K + (1 - mp.cos(al)) * K * K
        R = Rp * E
        c = [mp.mpf(float(c0[j])) + tt * (mp.mpf(float(c1[j])) - mp.mpf(float(c0[j]))) for j in range(3)]
        return [fraction_of(x) for x in c], [[fraction_of(R[i, j]) for j in range(3)] for i in range(3)]


def motion_relation(a0, a1, wa, b0, b1, wb, t, i=0):
    """0 / 1 / 2 of the exact motion at t (60-digit poses, exactly classified as the rational pencil of the
    poses' quadrics; the rotation is exact to 1e-60, so this is decisive unless the pair is within 1e-58
    of touching)."""
    ca, Ra = motion_pose(a0.centers[i], a1.centers[i], a0.rotations[i], a1.rotations[i], wa[i], t)
    cb, Rb = motion_pose(b0.centers[i], b1.centers[i], b0.rotations[i], b1.rotations[i], wb[i], t)
    n = sturm_positive_roots(pencil(quadric_rational(ca, Ra, a0.radii[i]), quadric_rational(cb, Rb, b0.radii[i])))
    return {2: 0, 1: 1, 0: 2}[n]


# --- containment --------------------------------------------------------------------------------


def max_qa_on_b(ca, Ra, ra, cb, Rb, rb, dps=60):
    """max over B of q_A(x) = |D_a^{-1} R_a^T (x - c_a)|^2, minus 1, in `dps`-digit mpmath, with B = {c_b +
    R_b^{-T} D_b z : |z| <= 1}: a trust-region maximisation by the secular equation in the eigenbasis
    of H^T H (H = D_a^{-1} R_a^T R_b^{-T} D_b), the hard case included (Geometric Tools 11.9.2 asks
    the same question by Lagrange multipliers)."""
    import mpmath as mp

    with mp.workdps(dps):
        M = lambda x: mp.matrix([[mp.mpf(float(v)) for v in row] for row in x])  # noqa: E731
        Ra, Rb = M(Ra), M(Rb)
        Da_inv = mp.diag([1 / mp.mpf(float(v)) for v in ra])
        Db = mp.diag([mp.mpf(float(v)) for v in rb])
        d = mp.matrix([mp.mpf(float(cb[i])) - mp.mpf(float(ca[i])) for i in range(3)])
        g = Da_inv * Ra.T * d
        H = Da_inv * Ra.T * (Rb.T**-1) * Db
        G = H.T * H
        gam, V = mp.eigsy((G + G.T) / 2)
        order = sorted(range(3), key=lambda i: -gam[i])  # descending
        gam = [gam[i] for i in order]
        V = mp.matrix([[V[r, i] for i in order] for r in range(3)])
        b = V.T * (H.T * g)
        gg = (g.T * g)[0]

        def value(z):
            return gg + sum(2 * b[i] * z[i] + gam[i] * z[i] ** 2 for i in range(3))

        def regular():
            # the root lam > gamma_1 of |z(lam)| = 1, z_i = b_i / (lam - gamma_i)
            f = lambda lam: sum((b[i] / (lam - gam[i])) ** 2 for i in range(3)) - 1  # noqa: E731
            lo, hi = gam[0], gam[0] + 1
            while f(hi) > 0:
                hi = gam[0] + 2 * (hi - gam[0])
            if b[0] == 0 and f(lo + mp.mpf(10) ** (-dps + 10)) < 0:
                return mp.mpf("-inf")
            for _ in range(60):
                mid = (lo + hi) / 2
                lo, hi = (mid, hi) if f(mid) > 0 else (lo, mid)
            lam = lo  # f is convex and decreasing: Newton from the left converges monotonically
            for _ in range(100):
                step = f(lam) / (2 * sum(b[i] ** 2 / (lam - gam[i]) ** 3 for i in range(3)))
                lam += step
                if step <= mp.mpf(10) ** (5 - dps) * (1 + abs(lam)):
                    break
            return value([b[i] / (lam - gam[i]) for i in range(3)])

        g1 = gam[0]
        eps = mp.mpf(10) ** (-dps + 15) * (1 + abs(g1))
        best = regular()
        if abs(b[0]) <= eps:  # hard case: lam = gamma_1, a free component along the first eigenvector
            rest = [b[i] / (g1 - gam[i]) if gam[i] != g1 else mp.mpf(0) for i in range(1, 3)]
            r2 = sum(x**2 for x in rest)
            if r2 <= 1:
                z0 = mp.sqrt(1 - r2) * (1 if b[0] >= 0 else -1)
                best = max(best, value([z0, rest[0], rest[1]]))
        return best - 1  # in this precision: 1 + 1e-60 must not round to 1


def contained(ca, Ra, ra, cb, Rb, rb, tie=1e-40):
    """(b inside a, margin): max_B q_A <= 1, where |max_B q_A - 1| < tie counts as inside (touching from
    inside, which the 60-digit value cannot tell from 1e-60 outside; tests use it on pairs whose answer is
    decided by more than that or built tangent)."""
    excess = max_qa_on_b(ca, Ra, ra, cb, Rb, rb)
    return bool(excess <= tie), float(excess)


# --- the maximum of a pair's sigma over unit directions (ellipsoid x capsule, x box) -------------
# Dense directions, then a finite-difference polish: 20 000 Fibonacci directions give the basin; damped
# Newton with central differences (h = 1e-6 rad, a monotone line search: every accepted value is sigma
# at a direction, a lower bound of the maximum) refines it freely and on each kink great circle near a
# seed; extra candidate directions (box face normals) are evaluated as points.

H = 1e-6


def fibonacci(k):
    i = np.arange(k) + 0.5
    phi, th = np.arccos(1 - 2 * i / k), np.pi * (1 + 5**0.5) * i
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1)


def _basis(n):
    a = np.where(np.abs(n[:, :1]) < 0.6, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(n, t1)


def _line_search(f, val, candidate, x):
    """Halve the step x until f(candidate(x)) >= val, per pose; the accepted points and values."""
    done = np.zeros(len(val), bool)
    point = candidate(np.zeros_like(x))
    for _ in range(30):
        c = candidate(x)
        fc = f(c)
        ok = (fc >= val) & ~done
        point = np.where(ok[:, None], c, point) if point.ndim == 2 else np.where(ok, c, point)
        val = np.where(ok, fc, val)
        done |= ok
        x = x * 0.5
        if done.all():
            break
    return point, val


def polish_free(sigma, P, n, iters=40):
    f = lambda x: sigma(P, x[:, None, :])[:, 0]  # noqa: E731
    val = f(n)
    for _ in range(iters):
        t1, t2 = _basis(n)
        steps = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1))
        fp = [f(n + H * (a * t1 + b * t2)) for a, b in steps]
        g1, g2 = (fp[0] - fp[1]) / (2 * H), (fp[2] - fp[3]) / (2 * H)
        h11, h22 = (fp[0] - 2 * val + fp[1]) / H**2, (fp[2] - 2 * val + fp[3]) / H**2
        h12 = (fp[4] + fp[5] - fp[6] - fp[7]) / (4 * H**2)
        det = h11 * h22 - h12 * h12
        nd = (h11 < 0) & (det > 0)
        x1 = np.where(nd, -(h22 * g1 - h12 * g2) / np.where(nd, det, 1), 0.05 * g1)
        x2 = np.where(nd, -(h11 * g2 - h12 * g1) / np.where(nd, det, 1), 0.05 * g2)
        cap = np.minimum(1.0, 0.3 / np.maximum(np.hypot(x1, x2), 1e-300))
        x = np.stack([x1 * cap, x2 * cap], 1)

        def candidate(x, n=n, t1=t1, t2=t2):
            c = n + x[:, :1] * t1 + x[:, 1:] * t2
            return c / np.linalg.norm(c, axis=1)[:, None]

        n, val = _line_search(f, val, candidate, x)
    return n, val


def polish_circle(sigma, P, w, n, iters=40):
    """The same on the great circle perpendicular to w: n(theta) = cos p1 + sin p2."""
    p1 = n - np.sum(n * w, 1)[:, None] * w
    bad = np.linalg.norm(p1, axis=1) < 1e-12
    p1[bad] = _basis(w[bad])[0]
    p1 /= np.linalg.norm(p1, axis=1)[:, None]
    p2 = np.cross(w, p1)
    at = lambda th: np.cos(th)[:, None] * p1 + np.sin(th)[:, None] * p2  # noqa: E731
    f = lambda th: sigma(P, at(th)[:, None, :])[:, 0]  # noqa: E731
    th = np.zeros(len(n))
    val = f(th)
    for _ in range(iters):
        fp, fm = f(th + H), f(th - H)
        g, hh = (fp - fm) / (2 * H), (fp - 2 * val + fm) / H**2
        x = np.clip(np.where(hh < 0, -g / np.where(hh < 0, hh, 1), 0.05 * g), -0.3, 0.3)
        th, val = _line_search(f, val, lambda x, th=th: th + x, x)
    return at(th), val


def dense_maximum(sigma, P, kinks, points=None):
    """(value (m,), normal (m, 3)): max over unit n of sigma(P, n) for the m poses of P (dict of (m, ...)
    arrays; sigma(P, n) takes directions (m, k, 3)), the best of the dense grid, of the polished seeds
    (free, and on every kink circle n.w = 0, w in kinks (m, j, 3), that passes within 0.15 of a seed)
    and of the candidate directions `points` (m, p, 3)."""
    M = fibonacci(20_000)
    m = len(P["cE"])
    value, normal = np.full(m, -np.inf), np.zeros((m, 3))
    seeds = np.zeros((m, 3, 3))
    for s in range(0, m, 50):
        idx = np.arange(s, min(m, s + 50))
        v = sigma({k: a[idx] for k, a in P.items()}, np.broadcast_to(M, (len(idx),) + M.shape))
        order = np.argsort(-v, axis=1)[:, :200]
        for r, i in enumerate(idx):
            value[i], normal[i] = v[r, order[r, 0]], M[order[r, 0]]
            chosen = [M[order[r, 0]]]
            for o in order[r]:  # up to 3 seeds at least 0.3 rad apart
                if len(chosen) < 3 and all(M[o] @ c < np.cos(0.3) for c in chosen):
                    chosen.append(M[o])
            seeds[i] = chosen + [chosen[0]] * (3 - len(chosen))

    def take(n, v):
        better = v > value
        value[better], normal[better] = v[better], n[better]

    if points is not None:
        pv = sigma(P, points)
        best = np.argmax(pv, axis=1)
        take(points[np.arange(m), best], pv[np.arange(m), best])
    for k in range(3):
        n0 = seeds[:, k]
        take(*polish_free(sigma, P, n0))
        for j in range(kinks.shape[1]):
            w = kinks[:, j]
            near = np.abs(np.sum(n0 * w, 1)) < 0.15
            if near.any():
                sub = {key: a[near] for key, a in P.items()}
                nc, vc = polish_circle(sigma, sub, w[near], n0[near])
                full_n, full_v = normal.copy(), np.full(m, -np.inf)
                full_n[near], full_v[near] = nc, vc
                take(full_n, full_v)
    return value, normal


# --- central differences in mpmath (test_derivatives.py, test_shape_derivatives.py) -------------


def mp_body(E, i):
    """Body i of a batch (centres, rotations, sizes arrays, as Ellipsoids) as mpmath (c, R, r)."""
    import mpmath as mp

    c = mp.matrix([mp.mpf(float(x)) for x in E.centers[i]])
    R = mp.matrix([[mp.mpf(float(x)) for x in row] for row in E.rotations[i]])
    r = [mp.mpf(float(x)) for x in E.radii[i]]
    return c, R, r


def perturbed(body, kind, axis, h):
    """body with its centre (kind 0), rotation vector (1: R -> expm([h e_axis]x) R) or sizes (2) moved by h."""
    import mpmath as mp

    c, R, r = body
    c, R, r = c.copy(), R.copy(), list(r)
    if kind == 0:
        c[axis] += h
    elif kind == 1:
        w = [mp.mpf(0)] * 3
        w[axis] = h
        K = mp.matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        R = mp.expm(K) * R
    else:
        r[axis] += h
    return c, R, r


def relative_errors(got, ref, floor=0.0):
    """The largest error per 3-column block, relative to the block's largest reference entry (at least
    `floor`: for blocks that are zero by symmetry, as a capsule side's normal against the radius)."""
    got, ref = np.atleast_2d(got), np.atleast_2d(ref)
    out = []
    for s in range(0, got.shape[1], 3):
        scale = max(np.abs(ref[:, s : s + 3]).max(), floor)
        err = np.abs(got[:, s : s + 3] - ref[:, s : s + 3]).max()
        out.append(err / scale if scale > 0 else err)
    return np.array(out)


# --- ellipsoid x capsule / box / cylinder on one feature (shape_distance's derivatives) ----------


def shape_feature_mp(kind, feature, ck, Rk, sk, n0):
    """(w, rho, P, G, bounds) of the feature of the capsule, box or cylinder K that carries a contact with
    normal ~n0 (from the ellipsoid to K), in mpmath, from the support function h_K(n) = max_{x in K - c_K}
    (-n).x: on the feature h_K(n) = n.w + rho |P n| with the rows of G orthogonal to n (the kinks it
    lies on), and the bound of each row's multiplier.  K as MuJoCo: box half-sizes, (radius, half-length)."""
    import mpmath as mp

    V = [Rk[:, j] for j in range(3)]
    n0 = mp.matrix([mp.mpf(float(x)) for x in n0])
    zero = mp.matrix(3, 3)
    if kind == "box":
        on = {"face": 2, "edge": 1, "vertex": 0}[feature]
        order = sorted(range(3), key=lambda j: abs((V[j].T * n0)[0]))
        active, free = order[:on], order[on:]
        w = sum((mp.sign((V[j].T * n0)[0]) * sk[j] * V[j] for j in free), mp.matrix(3, 1))
        return w, mp.mpf(0), zero, [V[j] for j in active], [sk[j] for j in active]
    r, L, u = sk[0], sk[1], V[2] / mp.norm(V[2])
    s = mp.sign((u.T * n0)[0])
    if feature == "side":
        return mp.matrix(3, 1), r, mp.eye(3), [u], [L]
    if feature == "end":
        return s * L * u, r, mp.eye(3), [], []
    if feature == "cap":
        t1 = V[0] - (V[0].T * u)[0] * u
        t1 /= mp.norm(t1)
        t2 = mp.matrix([u[1] * t1[2] - u[2] * t1[1], u[2] * t1[0] - u[0] * t1[2], u[0] * t1[1] - u[1] * t1[0]])
        return s * L * u, mp.mpf(0), zero, [t1, t2], [r]
    return s * L * u, r, mp.eye(3) - u * u.T, [], []  # rim


def shape_contact_mp(kind, feature, ce, Re, re, ck, Rk, sk, n0, dps=60):
    """(sigma, normal, pos, mu, witness on K) of an ellipsoid and a capsule, box or cylinder at the stationary
    point of sigma(n) = n.(c_K - c_E) - h_E(n) - h_K(n) on {|n| = 1, G n = 0} nearest n0 (shape_feature_mp),
    by Newton on the Lagrange system grad sigma - lam n - G^T mu = 0 with a central-difference Jacobian in
    `dps` digits (its error only slows Newton down: the root is the residual's).  pos: the midpoint of the
    ellipsoid's support point c_E + M n / h_E and the witness on K, support point + sigma n."""
    import mpmath as mp

    with mp.workdps(dps):
        w, rho, P, G, _ = shape_feature_mp(kind, feature, ck, Rk, sk, n0)
        M = Re * mp.diag([x**2 for x in re]) * Re.T
        d = ck - ce - w
        k = len(G)

        def parts(n):
            hE = mp.sqrt((n.T * M * n)[0])
            pn = mp.sqrt((n.T * P * n)[0]) if rho else mp.mpf(1)
            grad = d - M * n / hE - (rho * P * n / pn if rho else mp.matrix(3, 1))
            return hE, pn, grad

        def F(x):
            n, lam, mu = x[0:3], x[3], [x[4 + i] for i in range(k)]
            _, _, grad = parts(n)
            g = grad - lam * n - sum((mu[i] * G[i] for i in range(k)), mp.matrix(3, 1))
            return mp.matrix([g[0], g[1], g[2], (n.T * n)[0] - 1] + [(G[i].T * n)[0] for i in range(k)])

        n = mp.matrix([mp.mpf(float(x)) for x in n0])
        n /= mp.norm(n)
        _, _, grad = parts(n)
        x = mp.matrix([n[0], n[1], n[2], (n.T * grad)[0]] + [(G[i].T * grad)[0] for i in range(k)])
        eps = mp.mpf(10) ** (-dps // 3)
        for _ in range(40):
            f = F(x)
            J = mp.matrix(4 + k, 4 + k)
            for j in range(4 + k):
                xp, xm = x.copy(), x.copy()
                xp[j] += eps
                xm[j] -= eps
                col = (F(xp) - F(xm)) / (2 * eps)
                for i in range(4 + k):
                    J[i, j] = col[i]
            step = mp.lu_solve(J, -f)
            x += step
            if mp.norm(step) < mp.mpf(10) ** (8 - dps):
                break
        n = x[0:3]
        hE, pn, _ = parts(n)
        sigma = (n.T * d)[0] - hE - rho * pn
        pE = ce + M * n / hE
        pK = pE + sigma * n
        return sigma, n, (pE + pK) / 2, [x[4 + i] for i in range(k)], pK


def sd_point_shape_mp(kind, ck, Rk, sk, p):
    """The signed distance of the point p to the capsule, box or cylinder K, in mpmath, from its
    definition (a box's coordinates along its axes, R^-1 (p - c): the axes are the float64 ones, orthonormal
    to rounding only; a capsule's or cylinder's axis normalised, as the library does; inside: minus the
    distance to the nearest face)."""
    import mpmath as mp

    if kind == "box":
        y = mp.lu_solve(Rk, p - ck)
        q = [abs(y[j]) - sk[j] for j in range(3)]
        out = mp.sqrt(sum(max(x, 0) ** 2 for x in q))
        return out if out > 0 else max(q)
    r, L, u = sk[0], sk[1], Rk[:, 2] / mp.norm(Rk[:, 2])  # the unit axis, as the library
    a = ((p - ck).T * u)[0]
    radial = mp.norm(p - ck - a * u)
    if kind == "capsule":
        t = min(max(a, -L), L)
        return mp.sqrt(radial**2 + (a - t) ** 2) - r
    q = [radial - r, abs(a) - L]
    out = mp.sqrt(sum(max(x, 0) ** 2 for x in q))
    return out if out > 0 else max(q)
