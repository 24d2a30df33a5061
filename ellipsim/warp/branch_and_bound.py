"""The proven global maximisation of sigma over the unit sphere as Warp functions: a float64 port of
core/distance/branch_and_bound.py (its module docstring has the method and the rounding analysis), same
operations in the same order, same tolerances and budgets (imported from the CPU modules).

Entry point: global_max(n0, v0, have0, e, a, U, b, M, scale, tol, max_patches) -> (status, n, value,
count, runs), argument for argument the CPU's branch_and_bound.global_max, in A's principal frame:
    e = R_A^T (c_B - c_A) (wp.vec3d), a = r_A (semi-axes, NOT squared), U = R_A^T R_B (wp.mat33d,
    row-major as the CPU's 9-tuple), b = r_B, M = U diag(r_B^2) U^T (kernels._sandwich(U, rb * rb)),
    scale = max of the six semi-axes (Newton's scale), n0 / v0 / have0: a local maximum already found
    (have0 = the first Newton run CONVERGED; n0 its unit normal, v0 its sigma) or anything with
    have0 False, tol = tol_bb of ellipsoid_pair._pair:
        S = |e| + max r_A + max r_B, rmin = min of the six semi-axes,
        delta = vec3.rotation_defect(R_A) + 4 u (u = 2^-53),
        tol = max(BB_TOL_REL rmin, (BB_TOL_ULPS u + 6 delta) S),
        tol_bb = tol - (BB_FRAME_ULPS u + 6 delta) S,
    max_patches = tolerances.BB_MAX_PATCHES.
Returns status GLOBAL (0: max sigma <= value + tol proven), UNPROVEN (1: budget or MAX_LEVEL) or
SEPARATED_MAX (2: a climb converged with sigma > 0, the global maximum), the unit n (A's frame),
value = sigma(n) as computed, the nodes evaluated and the Newton runs.  (The CPU's ellipsoid_pair also
runs spheroids.py's parallel_max / tilted_max around it for spheroid pairs; those are not ported here.)

Warp specifics: regions are 4 vectors of 22 float64 (vec22d, the CPU's 22-tuples, same layout), the
deferred subtrees 5 int vectors of length MAX_ASIDE; constant expressions are module constants (Warp
evaluates an expression of literals in float32); the rho table of levels <= RHO_LEVELS is recomputed
per patch with the table's own operations (same bits); 2^-level by exact halvings; -inf as -1e300
(only ever compared with finite values or replaced).  No allocation, no recursion.
"""

import warp as wp

from ..core.distance.branch_and_bound import (
    DEFER_LEVEL,
    ERR_SIGMA_ULPS,
    GLOBAL,
    MAX_ASIDE,
    MAX_DISKS,
    MAX_LEVEL,
    NEWTON_LEVELS,
    PATCH_SLACK_ULPS,
    RHO_LEVELS,
    ROOT_LEVEL,
    SEPARATED_MAX,
    U64,
    UNPROVEN,
)
from ..core.tolerances import NEWTON_MAX_ITER
from .sphere_newton import CONVERGED, NO_CUTOFF, _cross, _dot, _mtv, _mv, _tangent1, _tangent2, _unit, newton

F64 = wp.float64
I64 = wp.int64

assert MAX_DISKS == 4 and MAX_ASIDE == 8 and len(NEWTON_LEVELS) == 3

NL0, NL1, NL2 = NEWTON_LEVELS
NEG_INF = -1e300

# constant expressions of the CPU code (module constants: exact float64)
U2 = 2.0 * U64
U4 = 4.0 * U64
U8 = 8.0 * U64
U10 = 10.0 * U64
U12 = 12.0 * U64
U16 = 16.0 * U64
U24 = 24.0 * U64
U32 = 32.0 * U64
U36 = 36.0 * U64
U48 = 48.0 * U64
U64X = 64.0 * U64
U128 = 128.0 * U64
P2U = 1.0 + 2.0 * U64
P4U = 1.0 + 4.0 * U64
P8U = 1.0 + 8.0 * U64
M8U = 1.0 - 8.0 * U64
P16U = 1.0 + 16.0 * U64
SLACK_U = PATCH_SLACK_ULPS * U64
ERRS_U = ERR_SIGMA_ULPS * U64
P1E9 = 1.0 + 1e-9
M1E9 = 1.0 - 1e-9
P1E12M = 1.0 - 1e-12
P1E13 = 1.0 + 1e-13
M1E13 = 1.0 - 1e-13
P1E14 = 1.0 + 1e-14
M1E14 = 1.0 - 1e-14
P1E15 = 1.0 + 1e-15
P4E15 = 1.0 + 4e-15
SQRT2 = 1.4142135623730951

vec22d = wp.types.vector(length=22, dtype=wp.float64)
vec12d = wp.types.vector(length=12, dtype=wp.float64)
vec8i = wp.types.vector(length=8, dtype=wp.int32)


# ---------------------------------------------------------------- small helpers


@wp.func
def climb(c: wp.vec3d, e: wp.vec3d, a: wp.vec3d, M: wp.mat33d, scale: wp.float64):
    """branch_and_bound.climb: Newton from c, (converged, m, sigma(m))."""
    a2 = wp.vec3d(a[0] * a[0], a[1] * a[1], a[2] * a[2])
    m, v, run = newton(c, e, a2, M, scale, NEWTON_MAX_ITER, F64(NO_CUTOFF))
    return run == CONVERGED, m, v


# ---------------------------------------------------------------- sigma


@wp.func
def sigma_grad(c: wp.vec3d, e: wp.vec3d, a: wp.vec3d, U: wp.mat33d, b: wp.vec3d):
    """(sigma(c), G, h_A(c), h_B(c)) of the homogeneous sigma at any nonzero c."""
    x0 = a[0] * c[0]
    x1 = a[1] * c[1]
    x2 = a[2] * c[2]
    ha = wp.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    w = _mtv(U, c)
    y0 = b[0] * w[0]
    y1 = b[1] * w[1]
    y2 = b[2] * w[2]
    hb = wp.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    s = c[0] * e[0] + c[1] * e[1] + c[2] * e[2] - ha - hb
    ia = F64(1.0) / ha
    ib = F64(1.0) / hb
    gb = _mv(U, wp.vec3d(b[0] * y0 * ib, b[1] * y1 * ib, b[2] * y2 * ib))
    G = wp.vec3d(e[0] - a[0] * x0 * ia - gb[0], e[1] - a[1] * x1 * ia - gb[1], e[2] - a[2] * x2 * ia - gb[2])
    return s, G, ha, hb


@wp.func
def sigma_only(c: wp.vec3d, e: wp.vec3d, a: wp.vec3d, U: wp.mat33d, b: wp.vec3d) -> wp.float64:
    x0 = a[0] * c[0]
    x1 = a[1] * c[1]
    x2 = a[2] * c[2]
    w = _mtv(U, c)
    y0 = b[0] * w[0]
    y1 = b[1] * w[1]
    y2 = b[2] * w[2]
    return (
        c[0] * e[0]
        + c[1] * e[1]
        + c[2] * e[2]
        - wp.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        - wp.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    )


# ---------------------------------------------------------------- patches


@wp.func
def _rho_exact(level: int, i: int, j: int) -> wp.float64:
    """RHO_TABLE[level, i, j] of the CPU module, recomputed with _rho_table's operations."""
    n = 1 << level
    w = F64(1.0) / F64(n)
    u0 = F64(-1.0) + F64(2.0) * w * F64(i)
    v0 = F64(-1.0) + F64(2.0) * w * F64(j)
    uc = u0 + w
    vc = v0 + w
    pc = wp.sqrt(F64(1.0) + uc * uc + vc * vc)
    c = wp.vec3d(F64(1.0) / pc, uc / pc, vc / pc)
    r = F64(0.0)
    for ku in range(2):
        u = u0
        if ku == 1:
            u = u0 + F64(2.0) * w
        for kv in range(2):
            v = v0
            if kv == 1:
                v = v0 + F64(2.0) * w
            pk = wp.sqrt(F64(1.0) + u * u + v * v)
            k = wp.vec3d(F64(1.0) / pk, u / pk, v / pk)
            d0 = k[0] - c[0]
            d1 = k[1] - c[1]
            d2 = k[2] - c[2]
            r = wp.max(r, wp.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
    return r * F64(P1E14) + F64(4e-15)


@wp.func
def patch_point(face: int, level: int, i: int, j: int, Q: wp.mat33d):
    """(p, 1 / |p|, |p|, rho): branch_and_bound.patch_point."""
    w = F64(1.0)
    for _k in range(level):
        w = w * F64(0.5)  # 2^-level, exact
    u0 = F64(-1.0) + F64(2.0) * w * F64(i)
    v0 = F64(-1.0) + F64(2.0) * w * F64(j)
    uc = u0 + w
    vc = v0 + w
    pc = wp.sqrt(F64(1.0) + uc * uc + vc * vc)
    inv = F64(1.0) / pc
    hd = w * F64(SQRT2)
    x = hd * inv
    rho = hd
    if x <= F64(0.5):
        rho = hd * wp.min(F64(1.0), inv * (F64(1.0) + x + F64(2.0) * x * x))
    rho = rho * F64(P4E15) + F64(2e-15)
    if level <= RHO_LEVELS:
        rho = _rho_exact(level, i, j)
    k = face >> 1
    sg = F64(1.0)
    if (face & 1) != 0:
        sg = F64(-1.0)
    p = wp.vec3d(sg * uc, sg * vc, sg)
    if k == 0:
        p = wp.vec3d(sg, sg * uc, sg * vc)
    elif k == 1:
        p = wp.vec3d(sg * vc, sg, sg * uc)
    return _mv(Q, p), inv, pc, rho


@wp.func
def patch_cap(face: int, level: int, i: int, j: int, Q: wp.mat33d):
    """(unit centre c, chord radius rho) of the cap holding quadtree patch (level, i, j)."""
    p, inv, pc, rho = patch_point(face, level, i, j, Q)
    return wp.vec3d(p[0] * inv, p[1] * inv, p[2] * inv), rho


# ---------------------------------------------------------------- region certificate


@wp.func
def _sym2_min(p: wp.float64, q: wp.float64, r: wp.float64):
    h = F64(0.5) * (p - r)
    root = wp.sqrt(h * h + q * q)
    return F64(0.5) * (p + r) - root, F64(U8) * (wp.abs(p) + wp.abs(r) + wp.abs(q))


@wp.func
def _sym2_max(p: wp.float64, q: wp.float64, r: wp.float64) -> wp.float64:
    h = F64(0.5) * (p - r)
    return F64(0.5) * (p + r) + wp.sqrt(h * h + q * q)


@wp.func
def _plane_terms(
    m: wp.vec3d,
    t1: wp.vec3d,
    t2: wp.vec3d,
    e: wp.vec3d,
    a: wp.vec3d,
    U: wp.mat33d,
    b: wp.vec3d,
    amax: wp.float64,
    bmax: wp.float64,
    S: wp.float64,
):
    """branch_and_bound._plane_terms; a part is a vec12d: (h lo, h hi, H (3), Gram (3), nu, bv (2), bv err)."""
    s, G, ha, hb = sigma_grad(m, e, a, U, b)
    g1 = _dot(G, t1)
    g2 = _dot(G, t2)
    Gn = wp.sqrt(_dot(G, G))
    epsg = F64(U64) * (F64(32.0) * (S + bmax * bmax / hb) + F64(16.0) * S)
    ghi = wp.sqrt(g1 * g1 + g2 * g2) * F64(P4U) + F64(1.5) * epsg + F64(U8) * Gn
    # A: L = diag(a)
    am = wp.vec3d(a[0] * m[0], a[1] * m[1], a[2] * m[2])
    a1 = wp.vec3d(a[0] * t1[0], a[1] * t1[1], a[2] * t1[2])
    a2 = wp.vec3d(a[0] * t2[0], a[1] * t2[1], a[2] * t2[2])
    j1 = _cross(a1, am)
    j2 = _cross(a2, am)
    ha3 = ha * ha * ha
    ga = F64(U16) * amax * amax
    ca = _cross(a1, a2)
    nuA = wp.sqrt(_dot(ca, ca)) * F64(P4U) + F64(U8) * amax * amax
    A = vec12d(
        ha - F64(U10) * amax,
        ha + F64(U10) * amax,
        _dot(j1, j1) / ha3,
        _dot(j1, j2) / ha3,
        _dot(j2, j2) / ha3,
        _dot(a1, a1) + ga,
        _dot(a1, a2),
        _dot(a2, a2) + ga,
        nuA,
        _dot(a1, am),
        _dot(a2, am),
        F64(U12) * amax * ha,
    )
    # B: L = diag(b) U^T
    wm = _mtv(U, m)
    w1 = _mtv(U, t1)
    w2 = _mtv(U, t2)
    bm = wp.vec3d(b[0] * wm[0], b[1] * wm[1], b[2] * wm[2])
    b1 = wp.vec3d(b[0] * w1[0], b[1] * w1[1], b[2] * w1[2])
    b2 = wp.vec3d(b[0] * w2[0], b[1] * w2[1], b[2] * w2[2])
    k1 = _cross(b1, bm)
    k2 = _cross(b2, bm)
    hb3 = hb * hb * hb
    gb = F64(U48) * bmax * bmax
    cb = _cross(b1, b2)
    nuB = wp.sqrt(_dot(cb, cb)) * F64(P4U) + F64(U24) * bmax * bmax
    B = vec12d(
        hb - F64(U16) * bmax,
        hb + F64(U16) * bmax,
        _dot(k1, k1) / hb3,
        _dot(k1, k2) / hb3,
        _dot(k2, k2) / hb3,
        _dot(b1, b1) + gb,
        _dot(b1, b2),
        _dot(b2, b2) + gb,
        nuB,
        _dot(b1, bm),
        _dot(b2, bm),
        F64(U36) * bmax * bmax,
    )
    H0 = wp.vec3d(A[2] + B[2], A[3] + B[3], A[4] + B[4])
    eh = F64(U128) * (amax * amax * amax / (ha * ha) + bmax * bmax * bmax / (hb * hb))
    return s, ghi, g1, g2, H0, A, B, eh


@wp.func
def _conj(c: wp.float64, s: wp.float64, x: wp.float64, y: wp.float64) -> wp.vec3d:
    """V diag(x, y) V^T for V = [[c, -s], [s, c]] as (00, 01, 11)."""
    return wp.vec3d(c * c * x + s * s * y, c * s * (x - y), s * s * x + c * c * y)


@wp.func
def _curvature(kw: wp.float64, ks: wp.float64, cs: wp.float64, sn: wp.float64, A: vec12d, B: vec12d, eh: wp.float64):
    """branch_and_bound._curvature: (P lower bound of -Hess F on E, lower bound of lambda_min(P))."""
    zero3 = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    K = _conj(cs, sn, kw, ks)
    kmax = wp.max(kw, ks)
    Pb0 = F64(0.0)
    Pb1 = F64(0.0)
    Pb2 = F64(0.0)
    qs = F64(0.0)
    for ip in range(2):
        part = A
        if ip == 1:
            part = B
        hlo = part[0]
        hhi = part[1]
        if hlo <= F64(0.0):
            return zero3, F64(0.0)
        m00 = K[0] * part[5] + K[1] * part[6]
        m01 = K[0] * part[6] + K[1] * part[7]
        m10 = K[1] * part[5] + K[2] * part[6]
        m11 = K[1] * part[6] + K[2] * part[7]
        kgk = _sym2_max(m00 * K[0] + m01 * K[1], m00 * K[1] + m01 * K[2], m10 * K[1] + m11 * K[2])
        kgk = kgk + F64(U32) * kmax * kmax * (wp.abs(part[5]) + wp.abs(part[6]) + wp.abs(part[7]))
        kb0 = K[0] * part[9] + K[1] * part[10]
        kb1 = K[1] * part[9] + K[2] * part[10]
        beta = (
            wp.sqrt(kb0 * kb0 + kb1 * kb1)
            + kmax * (part[11] * F64(1.5) + F64(U16) * (wp.abs(part[9]) + wp.abs(part[10])))
        ) * F64(P8U)
        h2 = (hhi * hhi + F64(2.0) * beta + kgk * F64(P16U)) * F64(P8U)
        hx = wp.sqrt(h2) * F64(P2U)
        r = hlo / hx
        r = r * r * r * F64(M8U)
        Pb0 = Pb0 + r * part[2]
        Pb1 = Pb1 + r * part[3]
        Pb2 = Pb2 + r * part[4]
        qs = qs + part[8] * part[8] / (hx * hx * hx) * F64(P8U)
    Q = _conj(cs, sn, ks * ks * qs, kw * kw * qs)
    qshift = F64(U16) * kmax * kmax * qs
    Q = wp.vec3d(Q[0] * F64(P8U) + qshift, Q[1], Q[2] * F64(P8U) + qshift)
    xw = cs * cs * Pb0 + F64(2.0) * cs * sn * Pb1 + sn * sn * Pb2
    yw = cs * cs * Q[0] + F64(2.0) * cs * sn * Q[1] + sn * sn * Q[2]
    if xw <= F64(0.0):
        return zero3, F64(0.0)
    eps = wp.sqrt(wp.max(yw, F64(0.0)) / xw)
    eps = wp.min(wp.max(eps, F64(1e-8)), F64(1.0))
    f = F64(1.0) - eps
    gq = F64(1.0) / eps - F64(1.0)
    P0 = f * Pb0 - gq * Q[0]
    P1 = f * Pb1 - gq * Q[1]
    P2 = f * Pb2 - gq * Q[2]
    lam, lam_err = _sym2_min(P0, P1, P2)
    err = (
        lam_err
        + F64(2.0) * eh
        + F64(U8) * (gq * (wp.abs(Q[0]) + wp.abs(Q[1]) + wp.abs(Q[2])) + wp.abs(Pb0) + wp.abs(Pb1) + wp.abs(Pb2))
    )
    return wp.vec3d(P0 - err, P1, P2 - err), lam - F64(2.0) * err


@wp.func
def _chord(t: wp.float64) -> wp.float64:
    return F64(2.0) * wp.sin(F64(0.5) * wp.atan(t)) * F64(P1E12M) - F64(1e-14)


@wp.func
def certify_region(
    m0: wp.vec3d,
    e: wp.vec3d,
    a: wp.vec3d,
    U: wp.mat33d,
    b: wp.vec3d,
    amax: wp.float64,
    bmax: wp.float64,
    S: wp.float64,
    err_sigma: wp.float64,
    tol: wp.float64,
):
    """branch_and_bound.certify_region: (ok, m, value, region (vec22d, the CPU's layout))."""
    z = vec22d()
    m = m0
    t1 = wp.vec3d()
    t2 = wp.vec3d()
    s = F64(0.0)
    ghi = F64(0.0)
    g1 = F64(0.0)
    g2 = F64(0.0)
    H = wp.vec3d()
    A = vec12d()
    B = vec12d()
    eh = F64(0.0)
    Vp = F64(0.0)
    need = F64(0.0)
    lw = F64(0.0)
    ls = F64(0.0)
    cs = F64(1.0)
    sn = F64(0.0)
    for it in range(4):
        t1 = _tangent1(m)
        t2 = _tangent2(m, t1)
        s, ghi, g1, g2, H, A, B, eh = _plane_terms(m, t1, t2, e, a, U, b, amax, bmax, S)
        V = s + tol
        if V >= F64(0.0):
            return False, m, s, z
        tol_d = tol - err_sigma - F64(1e-14) * wp.abs(V)
        if tol_d <= F64(0.0):
            return False, m, s, z
        Vp = -V * F64(P1E14)
        need = ghi * ghi / (F64(2.0) * tol_d)
        h = F64(0.5) * (H[0] - H[2])
        root = wp.sqrt(h * h + H[1] * H[1])
        lw = F64(0.5) * (H[0] + H[2]) - root
        ls = F64(0.5) * (H[0] + H[2]) + root
        v0 = H[1]
        v1 = lw - H[0]
        if v0 * v0 + v1 * v1 < (lw - H[2]) * (lw - H[2]) + H[1] * H[1]:
            v0 = lw - H[2]
            v1 = H[1]
        vv = v0 * v0 + v1 * v1
        if vv > F64(0.0):
            iv = F64(1.0) / wp.sqrt(vv)
            cs = v0 * iv
            sn = v1 * iv
        else:
            cs = F64(1.0)
            sn = F64(0.0)
        P0, pmin0 = _curvature(F64(0.0), F64(0.0), cs, sn, A, B, eh)
        if pmin0 - Vp > F64(0.0) and need <= F64(0.25) * (pmin0 - Vp):
            break
        if it == 3:
            return False, m, s, z
        h11 = -H[0] - s
        h12 = -H[1]
        h22 = -H[2] - s
        det = h11 * h22 - h12 * h12
        if not (h11 < F64(0.0) and det > F64(0.0)):
            return False, m, s, z
        x1 = -(h22 * g1 - h12 * g2) / det
        x2 = -(h11 * g2 - h12 * g1) / det
        m = _unit(
            wp.vec3d(m[0] + x1 * t1[0] + x2 * t2[0], m[1] + x1 * t1[1] + x2 * t2[1], m[2] + x1 * t1[2] + x2 * t2[2])
        )
    la2 = wp.max(_sym2_max(A[5], A[6], A[7]), F64(1e-300))
    lb2 = wp.max(_sym2_max(B[5], B[6], B[7]), F64(1e-300))
    T = wp.min(F64(1.0), F64(8.0) * wp.min(A[0] / wp.sqrt(la2), B[0] / wp.sqrt(lb2)))
    bestT = F64(0.0)
    best_reach = F64(0.0)
    best_pmin = F64(0.0)
    for _k in range(64):
        P, pmin = _curvature(T, T, cs, sn, A, B, eh)
        if pmin - Vp > F64(0.0) and need <= pmin - Vp:
            reach = wp.max(T, (pmin * T - F64(2.0) * ghi) / Vp)
            if reach > best_reach:
                bestT = T
                best_reach = reach
                best_pmin = pmin
            else:
                break
        elif best_reach > F64(0.0):
            break
        T = T * F64(0.5)
    if bestT <= F64(0.0):
        return False, m, s, z
    kw = bestT
    ks = bestT
    if ls > F64(4.0) * lw and best_pmin < F64(4.0) * Vp:
        ks2 = F64(0.5) * bestT
        kw2 = F64(0.0)
        t = bestT
        for _k in range(10):
            t = t * F64(2.0)
            P, pmin = _curvature(t, ks2, cs, sn, A, B, eh)
            if pmin - Vp > F64(0.0) and need <= pmin - Vp:
                kw2 = t
            else:
                break
        if kw2 >= F64(4.0) * bestT:
            kw = kw2
            ks = ks2
    P, pmin = _curvature(kw, ks, cs, sn, A, B, eh)
    kmin = wp.min(kw, ks)
    kmax = wp.max(kw, ks)
    Ki = _conj(cs, sn, F64(1.0) / kw, F64(1.0) / ks)
    K = _conj(cs, sn, kw, ks)
    m00 = K[0] * P[0] + K[1] * P[1]
    m01 = K[0] * P[1] + K[1] * P[2]
    m10 = K[1] * P[0] + K[2] * P[1]
    m11 = K[1] * P[1] + K[2] * P[2]
    kp0 = m00 * K[0] + m01 * K[1]
    kp1 = m00 * K[1] + m01 * K[2]
    kp2 = m10 * K[1] + m11 * K[2]
    muK, muK_err = _sym2_min(kp0, kp1, kp2)
    muK = (
        muK
        - muK_err
        - F64(1e-13) * (wp.abs(kp0) + wp.abs(kp1) + wp.abs(kp2))
        - F64(U64X) * kmax * kmax * (wp.abs(P[0]) + wp.abs(P[1]) + wp.abs(P[2]))
    )
    r_in = wp.max(kmin, (pmin * kmin - F64(2.0) * ghi) / Vp * F64(M1E14))
    if muK > F64(0.0):
        r_in = wp.max(r_in, (wp.sqrt(ghi * ghi + Vp * muK) - ghi) / Vp * F64(M1E13))
    else:
        muK = F64(0.0)
    pmax = _sym2_max(P[0], P[1], P[2])
    r_out = wp.max(kmax, pmax * kmax / Vp) * F64(1.01) + F64(1e-9)
    R_in = _chord(r_in)
    R_out = F64(2.0) * wp.sin(F64(0.5) * wp.atan(r_out)) + F64(1e-9)
    if R_in <= F64(0.0):
        return False, m, s, z
    region = vec22d()
    region[0] = m[0]
    region[1] = m[1]
    region[2] = m[2]
    region[3] = t1[0]
    region[4] = t1[1]
    region[5] = t1[2]
    region[6] = t2[0]
    region[7] = t2[1]
    region[8] = t2[2]
    region[9] = Ki[0]
    region[10] = Ki[1]
    region[11] = Ki[2]
    region[12] = F64(1.0) / kmin
    region[13] = P[0]
    region[14] = P[1]
    region[15] = P[2]
    region[16] = Vp
    region[17] = ghi
    region[18] = R_in
    region[19] = R_out
    region[20] = R_in
    region[21] = muK
    return True, m, s, region


@wp.func
def in_region(c: wp.vec3d, rho: wp.float64, d: vec22d) -> bool:
    """branch_and_bound.in_region: the cap |n - c| <= rho lies in the certified region d."""
    dx = c[0] - d[0]
    dy = c[1] - d[1]
    dz = c[2] - d[2]
    q2 = dx * dx + dy * dy + dz * dz
    qi = d[18] - rho - F64(1e-15)
    if qi > F64(0.0) and q2 <= qi * qi * F64(M1E14):
        return True
    qo = d[19] + rho
    if q2 >= qo * qo or rho > F64(1.0):
        return False
    al = c[0] * d[0] + c[1] * d[1] + c[2] * d[2]
    amin = al - rho * F64(P1E15) - F64(1e-15)
    if amin <= F64(0.0):
        return False
    ial = F64(1.0) / al
    x0 = (c[0] * d[3] + c[1] * d[4] + c[2] * d[5]) * ial
    x1 = (c[0] * d[6] + c[1] * d[7] + c[2] * d[8]) * ial
    xx = x0 * x0 + x1 * x1
    rx = rho * (F64(1.0) + F64(0.25) * rho * rho) * F64(P1E15) / (amin * amin) * F64(P1E14) + F64(1e-13) * (
        F64(1.0) + xx
    )
    k0 = d[9] * x0 + d[10] * x1
    k1 = d[10] * x0 + d[11] * x1
    thi = (wp.sqrt(k0 * k0 + k1 * k1) * F64(P1E9) + rx * d[12]) * F64(P1E14)
    if thi <= F64(1.0):
        return True
    X = (wp.sqrt(xx) + rx) * F64(P1E14)
    grow = (d[16] * X * X + F64(2.0) * d[17] * X) * F64(P1E13)
    tlo = (wp.sqrt(k0 * k0 + k1 * k1) * F64(M1E9) - rx * d[12]) * F64(M1E14)
    if grow <= d[21] * wp.max(F64(1.0), tlo):
        return True
    lhs = thi * grow
    p0 = d[13] * x0 + d[14] * x1
    p1 = d[14] * x0 + d[15] * x1
    rhs = (x0 * p0 + x1 * p1) * F64(M1E13) - F64(2.0) * rx * wp.sqrt(p0 * p0 + p1 * p1) * F64(P1E13)
    return lhs <= rhs


@wp.func
def _region(r0: vec22d, r1: vec22d, r2: vec22d, r3: vec22d, k: int) -> vec22d:
    if k == 0:
        return r0
    if k == 1:
        return r1
    if k == 2:
        return r2
    return r3


@wp.func
def _match(m: wp.vec3d, r0: vec22d, r1: vec22d, r2: vec22d, r3: vec22d, nd: int) -> int:
    """Index of the certified region whose maximum is m (to 1e-6), or -1."""
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = _region(r0, r1, r2, r3, k)
        dx = m[0] - d[0]
        dy = m[1] - d[1]
        dz = m[2] - d[2]
        if dx * dx + dy * dy + dz * dz < F64(1e-12):
            return k
    return -1


@wp.func
def in_regions(c: wp.vec3d, rho: wp.float64, r0: vec22d, r1: vec22d, r2: vec22d, r3: vec22d, nd: int) -> bool:
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        if in_region(c, rho, _region(r0, r1, r2, r3, k)):
            return True
    return False


@wp.func
def _in_caps(c: wp.vec3d, rho: wp.float64, r0: vec22d, r1: vec22d, r2: vec22d, r3: vec22d, nd: int) -> bool:
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = _region(r0, r1, r2, r3, k)
        q = d[18] - rho - F64(1e-15)
        if q > F64(0.0):
            dx = c[0] - d[0]
            dy = c[1] - d[1]
            dz = c[2] - d[2]
            if dx * dx + dy * dy + dz * dz <= q * q * F64(M1E14):
                return True
    return False


@wp.func
def _near_regions(c: wp.vec3d, rho: wp.float64, r0: vec22d, r1: vec22d, r2: vec22d, r3: vec22d, nd: int) -> bool:
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = _region(r0, r1, r2, r3, k)
        q = d[20] + rho
        dx = c[0] - d[0]
        dy = c[1] - d[1]
        dz = c[2] - d[2]
        if dx * dx + dy * dy + dz * dz < q * q:
            return True
    return False


@wp.func
def _h_parts(c: wp.vec3d, e: wp.vec3d, a: wp.vec3d, U: wp.mat33d, b: wp.vec3d):
    """(c.e, h_A(c), h_B(c), grad h_A + grad h_B, 1 / h_B): branch_and_bound._h_parts."""
    x0 = a[0] * c[0]
    x1 = a[1] * c[1]
    x2 = a[2] * c[2]
    ha = wp.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    w = _mtv(U, c)
    y0 = b[0] * w[0]
    y1 = b[1] * w[1]
    y2 = b[2] * w[2]
    hb = wp.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    ce = c[0] * e[0] + c[1] * e[1] + c[2] * e[2]
    iab = F64(1.0) / (ha * hb)
    ia = hb * iab
    ib = ha * iab
    gb = _mv(U, wp.vec3d(b[0] * y0 * ib, b[1] * y1 * ib, b[2] * y2 * ib))
    gs = wp.vec3d(a[0] * x0 * ia + gb[0], a[1] * x1 * ia + gb[1], a[2] * x2 * ia + gb[2])
    return ce, ha, hb, gs, ib


@wp.func
def _test(c: wp.vec3d, rho: wp.float64, s: wp.float64, G: wp.vec3d, epsg: wp.float64, lv: wp.float64) -> bool:
    """sigma <= lv on the cap |n - c| <= rho (branch_and_bound._test)."""
    gc = G[0] * c[0] + G[1] * c[1] + G[2] * c[2]
    t0 = G[0] - gc * c[0]
    t1 = G[1] - gc * c[1]
    t2 = G[2] - gc * c[2]
    r = lv - s - wp.max(-gc, F64(0.0)) * (rho * rho) * F64(0.5000000000001) - epsg * rho
    if r < F64(0.0):
        return False
    tt = (t0 * t0 + t1 * t1 + t2 * t2) * (rho * rho)
    return tt * F64(P16U) <= r * r * F64(M8U)


@wp.func
def _next(fp: int, level: int, i: int, j: int, root: int):
    """The next quadtree position in depth-first order skipping the subtree (branch_and_bound._next)."""
    lv = level
    ii = i
    jj = j
    while lv > root + 1 and (ii & 1) == 1 and (jj & 1) == 1:
        lv = lv - 1
        ii = ii >> 1
        jj = jj >> 1
    if lv == root + 1 and (ii & 1) == 1 and (jj & 1) == 1:
        return fp, lv, ii, jj, True
    if (jj & 1) == 0:
        return fp, lv, ii, jj + 1, False
    return fp, lv, ii + 1, jj - 1, False


# ---------------------------------------------------------------- the branch and bound


@wp.func
def global_max(
    n0: wp.vec3d,
    v0: wp.float64,
    have0: bool,
    e: wp.vec3d,
    a: wp.vec3d,
    U: wp.mat33d,
    b: wp.vec3d,
    M: wp.mat33d,
    scale: wp.float64,
    tol: wp.float64,
    max_patches: int,
):
    """Proven global maximum of sigma on the unit sphere, in A's frame (branch_and_bound.global_max;
    module docstring for the arguments): (status, n, value, count, runs)."""
    amax = wp.max(a[0], wp.max(a[1], a[2]))
    bmax = wp.max(b[0], wp.max(b[1], b[2]))
    S = wp.sqrt(_dot(e, e)) + amax + bmax
    slack = F64(SLACK_U) * S
    err_sigma = F64(ERRS_U) * S
    best_n = wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    best = F64(NEG_INF)
    r0 = vec22d()
    r1 = vec22d()
    r2 = vec22d()
    r3 = vec22d()
    nd = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    runs = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    if have0:
        ok, m, v, reg = certify_region(n0, e, a, U, b, amax, bmax, S, err_sigma, tol)
        if ok:
            r0 = reg
            nd = 1
            best_n = m
            best = v
        else:
            best_n = n0
            best = sigma_only(n0, e, a, U, b)
    Q = wp.mat33d(F64(1.0), F64(0.0), F64(0.0), F64(0.0), F64(1.0), F64(0.0), F64(0.0), F64(0.0), F64(1.0))
    if nd > 0:
        Q = wp.mat33d(r0[0], r0[3], r0[6], r0[1], r0[4], r0[7], r0[2], r0[5], r0[8])
    a_fp = vec8i()
    a_lv = vec8i()
    a_i = vec8i()
    a_j = vec8i()
    a_fl = vec8i()
    nu = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    ai = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    sub = bool(False)  # noqa: UP018 (a dynamic variable for Warp's loops)
    L0 = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    fp = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    level = int(ROOT_LEVEL)
    i = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    j = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    alive = I64(0)
    count = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    pf = int(-1)  # noqa: UP018 (a dynamic variable for Warp's loops)
    pl = int(-1)  # noqa: UP018 (a dynamic variable for Warp's loops)
    pi = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    pj = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
    pgs = wp.vec3d(F64(0.0), F64(0.0), F64(0.0))
    peps = F64(0.0)
    dot_err = F64(U4) * S
    fin = bool(False)  # noqa: UP018 (a dynamic variable for Warp's loops)
    while True:
        count = count + 1
        if count > max_patches:
            return UNPROVEN, best_n, best, count, runs
        par = int(3)  # noqa: UP018 (a dynamic variable for Warp's loops)
        if level != ROOT_LEVEL:
            par = int((alive >> I64(2 * (level - 1))) & I64(3))
        p, inv, pc, rho = patch_point(2 * fp, level, i, j, Q)
        c = wp.vec3d(p[0] * inv, p[1] * inv, p[2] * inv)
        if pl == level - 1 and pi == (i >> 1) and pj == (j >> 1) and pf == fp:
            lvp = best + tol - slack - peps * F64(1.0001) - dot_err
            for side in range(2):
                if ((par >> side) & 1) != 0:
                    cs = c
                    G = wp.vec3d(e[0] - pgs[0], e[1] - pgs[1], e[2] - pgs[2])
                    if side == 1:
                        cs = wp.vec3d(-c[0], -c[1], -c[2])
                        G = wp.vec3d(e[0] + pgs[0], e[1] + pgs[1], e[2] + pgs[2])
                    if _test(cs, rho, G[0] * cs[0] + G[1] * cs[1] + G[2] * cs[2], G, peps, lvp):
                        par = par & ~(1 << side)
            if par == 0:
                fp, level, i, j, fin = _next(fp, level, i, j, L0)
                if fin:
                    if not sub and fp < 2:
                        fp = fp + 1
                        level = int(ROOT_LEVEL)
                        i = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
                        j = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
                        continue
                    if ai >= nu:
                        break
                    fp = a_fp[ai]
                    level = a_lv[ai]
                    i = a_i[ai]
                    j = a_j[ai]
                    fl = a_fl[ai]
                    ai = ai + 1
                    sh = I64(2 * (level - 1))
                    alive = (alive & ~(I64(3) << sh)) | (I64(fl) << sh)
                    sub = True
                    L0 = level
                    pl = -1
                continue
        ce, ha, hb, gs, ib = _h_parts(p, e, a, U, b)
        ce = ce * inv
        ha = ha * inv
        hb = hb * inv
        epsg = F64(U64) * (F64(32.0) * (S + bmax * bmax * ib * pc * F64(1.01)) + F64(16.0) * S)
        flags = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
        for side in range(2):
            if ((par >> side) & 1) == 0:
                continue
            cs = c
            s = ce - ha - hb
            G = wp.vec3d(e[0] - gs[0], e[1] - gs[1], e[2] - gs[2])
            if side == 1:
                cs = wp.vec3d(-c[0], -c[1], -c[2])
                s = -ce - ha - hb
                G = wp.vec3d(e[0] + gs[0], e[1] + gs[1], e[2] + gs[2])
            done = _in_caps(cs, rho, r0, r1, r2, r3, nd)
            if not done:
                done = _test(cs, rho, s, G, epsg, best + tol - slack)
            if not done and nd > 0:
                done = in_regions(cs, rho, r0, r1, r2, r3, nd)
            launch = bool(False)  # noqa: UP018 (a dynamic variable for Warp's loops)
            if s > best:
                best_n = cs
                best = s
                done = False
                launch = True
            elif not done and (level == NL0 or level == NL1 or level == NL2):
                rr = rho
                if level == NL2:
                    rr = F64(0.0)
                launch = not _near_regions(cs, rr, r0, r1, r2, r3, nd)
            if launch:
                conv, m, v = climb(cs, e, a, M, scale)
                runs = runs + 1
                if conv and v > F64(0.0):
                    return SEPARATED_MAX, m, sigma_only(m, e, a, U, b), count, runs
                if conv:
                    kd = _match(m, r0, r1, r2, r3, nd)
                    if kd >= 0:
                        dk = _region(r0, r1, r2, r3, kd)
                        dx = cs[0] - dk[0]
                        dy = cs[1] - dk[1]
                        dz = cs[2] - dk[2]
                        D = wp.sqrt(dx * dx + dy * dy + dz * dz) + rho
                        if kd == 0:
                            r0[20] = wp.max(r0[20], D)
                        elif kd == 1:
                            r1[20] = wp.max(r1[20], D)
                        elif kd == 2:
                            r2[20] = wp.max(r2[20], D)
                        else:
                            r3[20] = wp.max(r3[20], D)
                    else:
                        ok2, m2, v2, reg2 = certify_region(m, e, a, U, b, amax, bmax, S, err_sigma, tol)
                        if v2 > best:
                            best_n = m2
                            best = v2
                        if ok2:
                            r3 = r2
                            r2 = r1
                            r1 = r0
                            r0 = reg2
                            nd = wp.min(nd + 1, MAX_DISKS)
                            done = in_regions(cs, rho, r0, r1, r2, r3, nd)
                if not done:
                    done = _test(cs, rho, s, G, epsg, best + tol - slack)
            if not done:
                flags = flags | (1 << side)
        if flags != 0 and not sub and level >= DEFER_LEVEL and nu < MAX_ASIDE:
            # defer the subtree (pushed in front, as the CPU's tuple)
            for kk in range(MAX_ASIDE - 1):
                k2 = MAX_ASIDE - 1 - kk
                a_fp[k2] = a_fp[k2 - 1]
                a_lv[k2] = a_lv[k2 - 1]
                a_i[k2] = a_i[k2 - 1]
                a_j[k2] = a_j[k2 - 1]
                a_fl[k2] = a_fl[k2 - 1]
            a_fp[0] = fp
            a_lv[0] = level
            a_i[0] = i
            a_j[0] = j
            a_fl[0] = flags
            nu = nu + 1
            flags = 0
        if flags == 0:
            if sub and level == L0:
                fin = True
            else:
                fp, level, i, j, fin = _next(fp, level, i, j, L0)
            if fin:
                if not sub and fp < 2:
                    fp = fp + 1
                    level = int(ROOT_LEVEL)
                    i = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
                    j = int(0)  # noqa: UP018 (a dynamic variable for Warp's loops)
                    continue
                if ai >= nu:
                    break
                fp = a_fp[ai]
                level = a_lv[ai]
                i = a_i[ai]
                j = a_j[ai]
                fl = a_fl[ai]
                ai = ai + 1
                sh = I64(2 * (level - 1))
                alive = (alive & ~(I64(3) << sh)) | (I64(fl) << sh)
                sub = True
                L0 = level
                pl = -1
        elif level >= MAX_LEVEL:
            return UNPROVEN, best_n, best, count, runs
        else:
            sh = I64(2 * level)
            alive = (alive & ~(I64(3) << sh)) | (I64(flags) << sh)
            pf = fp
            pl = level
            pi = i
            pj = j
            pgs = gs
            peps = epsg
            level = level + 1
            i = i * 2
            j = j * 2
    return GLOBAL, best_n, best, count, runs
