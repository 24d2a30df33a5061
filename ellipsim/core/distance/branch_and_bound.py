"""Proven global maximisation of sigma(n) = n.e - h_A(n) - h_B(n) over the unit sphere (issue 10, part 3).

Branch and bound with concave (supergradient) majorants, after Horst & Tuy, Global Optimization:
Deterministic Approaches (1996), ch. 4; local regions certified by a Hessian lower bound.

The deep branch of distance.pair_signed_distance: a branch and bound whose answer carries a proof
that the returned value is within TOL of the global maximum, or says UNPROVEN (budget exhausted:
the MuJoCo glue falls back to MuJoCo's own function).  Everything is computed in A's principal frame: e = R_A^T (c_B - c_A),
h_A(n) = |diag(a) n|, h_B(n) = |diag(b) U^T n| with U = R_A^T R_B (B's axes in A's frame).

1. Upper bound on a patch (supergradient inequality; Rockafellar, Convex Analysis, sec. 23).
   sigma is concave and positively homogeneous of degree 1 on all of R^3 (h_A, h_B are norms).  For
   any c != 0 with gradient G(c): sigma(n) <= sigma(c) + G(c).(n - c) = G(c).n (Euler) for EVERY n
   in R^3; the inequality is pointwise, so it holds on the sphere although the sphere is not convex
   (and although the maximum over the ball, sigma(0) = 0, is not the one sought when penetrating).
   For the unit n of the cap |n - c| <= rho around a unit c, n - c = delta with c.delta = -|delta|^2/2:
       sigma(n) <= sigma(c) + |G_T| rho + max(-G.c, 0) rho^2 / 2,     G_T = G - (G.c) c
   (the rho^2 term is the sphere's own curvature: -sigma(c) rho^2 / 2 when penetrating).  A child
   patch is first tested with its parent's G (sigma <= G_parent.n), which needs no evaluation of h.
   The sphere is covered by 3 pairs of opposite faces of a cube turned so that the first certified
   maximum is the centre of face 0, each face split as a quadtree in gnomonic coordinates
   (n ~ Q (1, u, v) up to axis permutation; face 2k + 1 is face 2k mirrored through the origin, so a
   patch and its antipode share h_A, h_B and their gradients: sigma(-c) = -c.e - h_A - h_B; both are
   evaluated at the unnormalised centre p and scaled by 1/|p|, sigma being homogeneous).  A patch lies
   in the cap around p / |p| whose chord radius is its largest corner chord (the patch is the geodesic
   convex hull of its corners; tabulated for levels <= RHO_LEVELS), or, deeper,
   w sqrt(2) / max(1, |p| - w sqrt(2)) for a square of half-width w (p -> p / |p| is 1/|p|-Lipschitz
   on the plane x = 1).
2. Region certificate around a strict local maximum m (certify_region).  On the tangent plane at m,
   F(x) = sigma(m + x) is concave (restriction of a concave function to an affine plane) and
   sigma(n) = F(x) / |m + x| for the direction n of m + x.  The plane Hessian of h = |L p| is
   u -> |J(x) u|^2 / |L(m + x)|^3, J(x) u = L u x L(m + x).  J(x) u - J(0) u = L u x L x
   = (u1 x2 - u2 x1) (L t1 x L t2) is bilinear and vanishes for x parallel to u, so on the ellipse
   E = {K z : |z| <= 1} (K = V diag(kw, ks) V^T, V the eigenvectors of the plane Hessian H0 at m):
   |J(x) u - J(0) u| <= nu |K R u| (nu = |L t1 x L t2|, R the quarter turn) and
   |L(m + x)|^2 <= h0^2 + 2 |K (L T)^T L m| + lambda_max(K Gram K) =: h_hi^2; hence for any eps in (0, 1]
       -Hess F >= P := (1 - eps) sum_i (h_i0 / h_i,hi)^3 H_i0 - (1/eps - 1) sum_i nu_i^2 / h_i,hi^3 R K^2 R^T.
   Then F(x) <= F(0) + g.x - x^T P x / 2 on E, and with |m + x| <= sqrt(1 + |x|^2)(1 + 1e-14) and
   sqrt(1 + s^2) <= 1 + s^2 / 2, V = F(0) + tol < 0: sigma <= V on E once kappa = lambda_min(P) - |V| > 0
   and |g|^2 / (2 kappa) <= tol.  Beyond E, F is concave along every ray from m: with s_b the ray's exit
   from E, F(s x^) <= F(0) + s (|g| - x^^T P x^ s_b / 2), which stays <= V (1 + s^2 / 2) while
   |K^-1 x| (|V| |x|^2 + 2 |g| |x|) <= x^T P x (a concave quadratic in s, >= 0 at both ends).  The
   certified region Omega is E united with that set; a patch is inside if the disk holding its central
   projection onto the plane (radius rho_geodesic / (c.m - rho)^2) is, tested with bounds over the
   disk (and with x^T P x >= mu_K |K^-1 x|^2, mu_K = lambda_min(K P K)).  kw = ks = T is chosen by
   halving for the largest reach; along a valley (H0's eigenvalues far apart, the weak one close to
   |V|) ks = T / 2 and kw is doubled while valid.  Local maxima are found by ellipsim's Riemannian
   Newton (sigma.newton) from the bisector seed and from patches still undecided at
   NEWTON_LEVELS or whose centre beats every maximum found.
3. Branch and bound: a patch is discarded when its cap lies in a certified region or its upper bound
   is <= best + tol; otherwise it is split in four (depth first, no allocation: the quadtree position
   is (face pair, level, i, j), its cap is recomputed, and which of the two antipodal patches is still
   undecided is 2 bits per level in one int64).  A patch still undecided at DEFER_LEVEL in the main
   pass (typically a ridge or saddle as high as a poor first incumbent) has its subtree deferred (up
   to MAX_ASIDE) and searched again at the end, with the final incumbent.  GLOBAL: every patch was
   discarded, so max sigma <= best + TOL with best = sigma(returned normal).  UNPROVEN: more than
   MAX_PATCHES nodes or a patch at MAX_LEVEL still undecided (flat or non-isolated maxima, e.g.
   concentric coaxial spheroids, where sigma is constant along a circle).  A climb that converges
   with sigma > 0 ends the search: the pair is separated, sigma is concave on the ball, the local
   maximum is global (SEPARATED_MAX).

Floating point (no fused multiply-add is assumed; fastmath is off, each operation rounds once).
Every inequality above is for the exact sigma of the float data (e, a, U, b) at the float points
actually used (c, m, t1, t2, K, Q are just numbers: the inequalities hold for any of them).  What is
rounded is the evaluation; with S = |e| + max a + max b and u = 2^-53:
  * sigma at a float point (|c|^2 = 1 +- 2e-15): c.e errs by <= gamma_3 |e|, h_A by <= 3.5 u max a,
    h_B by <= 8.7 u max b (U^T c first: 5.2 u absolute), 2 subtractions by <= 2 u S:
    ERR_SIGMA = 24 u S covers it (11 u S needed; 19 u S for a patch centre, evaluated at p and scaled
    by the rounded 1/|p|, and sigma is S-Lipschitz for the few u between p / |p| and the c used);
  * the computed gradient errs by <= 32 u (S + max b^2 / h_B(c)) (the Hessian of h_B, <= max b^2 / h_B,
    amplifies the rounding of U^T c), G_T by 16 u S more; both are added times rho (and once more,
    not times rho, for the parent test, with the 4 u S of its dot product);
  * |c|^2 - 1 adds <= 9 u S; the bound's own sum 8 u S: PATCH_SLACK = 48 u S in all;
  * the region: plane Hessian entries err by <= 128 u (max a^3 / h_A^2 + max b^3 / h_B^2), 2x2
    eigenvalues by 8 u |entries|; heights, nu, Gram matrices, |K bv| and the rounding of K (<= 8 u kmax
    in norm) are taken outwards; the region test takes |K^-1 x| to 1e-9 relative (K^-1 is rounded;
    anisotropy <= 2^11), the projection to 1e-13 (1 + |x|^2);
  * the frame change: e and U are rounded (<= 10 u S) and R_A is orthonormal only to
    delta = max |R_A^T R_A - I| (computed per pair), which moves sigma by <= 6 delta S more:
    ERR_FRAME = (16 u + 6 delta) S.
The B&B runs with tol_bb = TOL - ERR_FRAME and proves max sigma_A <= best + tol_bb in A's frame, so
for the world-frame data as given: max sigma <= returned value + TOL, where
TOL = max(TOL_REL r_min, (96 u + 6 delta) S) (r_min the shortest of the six semi-axes; the u S floor is
what float64 can evaluate sigma to), and returned value <= max sigma + ERR_SIGMA + ERR_FRAME trivially.
Underflow is not analysed: unit_scale keeps the largest semi-axis near 1 and the bounds assume
semi-axis ratios far from 2^500 (tolerances.RATIO_MAX, SCALE_MIN, SCALE_MAX).
"""

import math

import numpy as np

from .._jit import jit, stage
from ..tolerances import BB_ERR_SIGMA_ULPS, BB_MAX_PATCHES, BB_PATCH_SLACK_ULPS, NEWTON_MAX_ITER
from ..vec3 import cross3, matvec, norm2, rotate_t
from .sphere_newton import CONVERGED, newton, tangent_basis, unit

#: How global_max ends: the maximum found is proven global (GLOBAL), the budget ran out (UNPROVEN:
#: the best found, no proof), or a climb reached sigma > 0 (SEPARATED_MAX: sigma is concave on the
#: ball, so that local maximum is global).
GLOBAL, UNPROVEN, SEPARATED_MAX = 0, 1, 2

U64 = 2.0**-53
PATCH_SLACK_ULPS = BB_PATCH_SLACK_ULPS
ERR_SIGMA_ULPS = BB_ERR_SIGMA_ULPS
MAX_PATCHES = BB_MAX_PATCHES

# The shape of the search (not tolerances: the proof holds for any values; these were tuned on
# leaves.xml contacts and random deep crossings of elongated ellipsoids):
MAX_LEVEL = 30  # gnomonic half-width 2^-30 (2 bits a level in one int64)
ROOT_LEVEL = 1  # 3 face pairs x 4 patches to start with
NEWTON_LEVELS = (4, 7, 10)  # an undecided patch at one of these levels may launch Newton from its centre
MAX_DISKS = 4  # certified regions kept
MAX_ASIDE = 8  # deferred subtrees
DEFER_LEVEL = 16  # an undecided patch this deep in the main pass defers its subtree


@stage
def sigma_grad(c, e, a, U, b):
    """(sigma(c), gradient G (3,), h_A(c), h_B(c)) of the homogeneous sigma at any nonzero c."""
    x0, x1, x2 = a[0] * c[0], a[1] * c[1], a[2] * c[2]
    ha = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    w = rotate_t(U, c)
    y0, y1, y2 = b[0] * w[0], b[1] * w[1], b[2] * w[2]
    hb = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    s = c[0] * e[0] + c[1] * e[1] + c[2] * e[2] - ha - hb
    ia, ib = 1.0 / ha, 1.0 / hb  # each product below errs by 2 roundings more than a division: counted
    gb = matvec(U, (b[0] * y0 * ib, b[1] * y1 * ib, b[2] * y2 * ib))
    G = (e[0] - a[0] * x0 * ia - gb[0], e[1] - a[1] * x1 * ia - gb[1], e[2] - a[2] * x2 * ia - gb[2])
    return s, G, ha, hb


@stage
def sigma_only(c, e, a, U, b):
    x0, x1, x2 = a[0] * c[0], a[1] * c[1], a[2] * c[2]
    w = rotate_t(U, c)
    y0, y1, y2 = b[0] * w[0], b[1] * w[1], b[2] * w[2]
    return (
        c[0] * e[0]
        + c[1] * e[1]
        + c[2] * e[2]
        - math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        - math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    )


def _rho_table(levels):
    """Chord radius of the cap around the centre of each quadtree patch of levels 1..levels: the largest
    chord from the centre's direction to a corner's (the patch is the geodesic convex hull of its
    corners, inside that cap), computed in float64 and rounded up by 1e-14 relative + 4e-15 (corner and
    centre directions err by a few u; Q turns the cube by a rotation orthonormal to rounding)."""
    out = [0.0] * sum(4**L for L in range(1, levels + 1))
    off = 0
    for L in range(1, levels + 1):
        n = 1 << L
        w = 1.0 / n
        for i in range(n):
            for j in range(n):
                u0, v0 = -1.0 + 2.0 * w * i, -1.0 + 2.0 * w * j
                uc, vc = u0 + w, v0 + w
                pc = math.sqrt(1.0 + uc * uc + vc * vc)
                c = (1.0 / pc, uc / pc, vc / pc)
                r = 0.0
                for u in (u0, u0 + 2.0 * w):
                    for v in (v0, v0 + 2.0 * w):
                        pk = math.sqrt(1.0 + u * u + v * v)
                        k = (1.0 / pk, u / pk, v / pk)
                        r = max(r, math.sqrt((k[0] - c[0]) ** 2 + (k[1] - c[1]) ** 2 + (k[2] - c[2]) ** 2))
                out[off + i * n + j] = r * (1.0 + 1e-14) + 4e-15
        off += n * n
    return np.array(out)


RHO_LEVELS = 5
RHO_TABLE = _rho_table(RHO_LEVELS)  # a constant of the compiled code (read only)


@stage
def patch_point(face, level, i, j, Q):
    """(p, |p|, rho): the centre p = Q (1, u_c, v_c) (permuted, signed) of quadtree patch (level, i, j)
    of a cube face, NOT normalised (sigma and its gradient are evaluated at p, off the critical path of
    the square root; sigma(p / |p|) = sigma(p) / |p|, the gradient is 0-homogeneous), and the chord
    radius rho of the cap around p / |p| that holds the patch; Q turns the cube (row-major, columns:
    where the x, y, z axes go, orthonormal to rounding)."""
    w = float(1 << (62 - level)) * 2.0**-62  # half-width 2^-level in gnomonic coordinates (exact)
    u0 = -1.0 + 2.0 * w * i
    v0 = -1.0 + 2.0 * w * j
    uc, vc = u0 + w, v0 + w
    pc = math.sqrt(1.0 + uc * uc + vc * vc)
    inv = 1.0 / pc
    # the square lies within w sqrt(2) of p_c; on it |p| >= max(1, |p_c| - w sqrt(2)), and
    # 1 / (|p_c| - hd) = inv / (1 - x) <= inv (1 + x + 2 x^2), x = hd inv <= 1/2 (no division);
    # Q changes lengths by <= 1e-15 relative
    hd = w * 1.4142135623730951
    x = hd * inv
    rho = hd * min(1.0, inv * (1.0 + x + 2.0 * x * x)) if x <= 0.5 else hd
    rho = rho * (1.0 + 4e-15) + 2e-15  # roundings of sqrt(2), sqrt, products, Q; |c - exact centre| <= 8u
    if level <= RHO_LEVELS:  # the exact circumradius (the Lipschitz bound above is up to ~20 % larger)
        rho = RHO_TABLE[((1 << (2 * level)) - 4) // 3 + (i << level) + j]
    k = face >> 1
    sg = 1.0 if (face & 1) == 0 else -1.0  # face 2k + 1 is the antipode of face 2k, patch by patch
    if k == 0:
        p = (sg, sg * uc, sg * vc)
    elif k == 1:
        p = (sg * vc, sg, sg * uc)
    else:
        p = (sg * uc, sg * vc, sg)
    return matvec(Q, p), inv, pc, rho


@stage
def patch_cap(face, level, i, j, Q):
    """(unit centre c, chord radius rho) of the cap holding quadtree patch (level, i, j) of a cube face
    (patch_point normalised)."""
    p, inv, pc, rho = patch_point(face, level, i, j, Q)
    return (p[0] * inv, p[1] * inv, p[2] * inv), rho


@stage
def _sym2_min(p, q, r):
    """Smallest eigenvalue of [[p, q], [q, r]] and an upper bound of its rounding error."""
    h = 0.5 * (p - r)
    root = math.sqrt(h * h + q * q)
    return 0.5 * (p + r) - root, 8.0 * U64 * (abs(p) + abs(r) + abs(q))


@stage
def _sym2_max(p, q, r):
    h = 0.5 * (p - r)
    return 0.5 * (p + r) + math.sqrt(h * h + q * q)


@stage
def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@stage
def _plane_terms(m, t1, t2, e, a, U, b, amax, bmax, S):
    """Everything the certificate needs at the float point m with tangent vectors t1, t2:
    (sigma(m), |g| upper bound, g1, g2, H0 (plane Hessian of h_A + h_B, 3-tuple), part A, part B, eh).

    part = (h lower, h upper, H_i (plane Hessian of h_i), Gram of L t1, L t2 shifted upwards,
    nu = |L t1 x L t2| upper bound, bv = (L t1 . L m, L t2 . L m), |error of bv| bound);
    eh bounds the entry errors of H_A and H_B.  Roundings (module docstring): Hessian entries err by
    <= 27 u amax^2 / h_A and <= 60 u bmax^3 / h_B^2; Gram entries by <= 4 u amax^2, <= 16 u bmax^2
    (shifted by twice that on the diagonal, which dominates the error matrix); nu by <= 8 u amax^2,
    <= 24 u bmax^2; bv by <= 8 u amax h_A, <= 24 u bmax^2; h_A by <= 3.5 u amax, h_B by <= 8.7 u bmax."""
    s, G, ha, hb = sigma_grad(m, e, a, U, b)
    g1, g2 = _dot(G, t1), _dot(G, t2)
    Gn = math.sqrt(norm2(G))
    epsg = U64 * (32.0 * (S + bmax * bmax / hb) + 16.0 * S)
    # |exact plane gradient| <= computed + eps_G |[t1 t2]| + rounding of the two dot products
    ghi = math.sqrt(g1 * g1 + g2 * g2) * (1.0 + 4.0 * U64) + 1.5 * epsg + 8.0 * U64 * Gn
    # A: L = diag(a)
    am = (a[0] * m[0], a[1] * m[1], a[2] * m[2])
    a1 = (a[0] * t1[0], a[1] * t1[1], a[2] * t1[2])
    a2 = (a[0] * t2[0], a[1] * t2[1], a[2] * t2[2])
    j1, j2 = cross3(a1, am), cross3(a2, am)
    ha3 = ha * ha * ha
    HA = (_dot(j1, j1) / ha3, _dot(j1, j2) / ha3, _dot(j2, j2) / ha3)
    ga = 16.0 * U64 * amax * amax
    GA = (_dot(a1, a1) + ga, _dot(a1, a2), _dot(a2, a2) + ga)
    nuA = math.sqrt(norm2(cross3(a1, a2))) * (1.0 + 4.0 * U64) + 8.0 * U64 * amax * amax
    bvA = (_dot(a1, am), _dot(a2, am))
    A = (ha - 10.0 * U64 * amax, ha + 10.0 * U64 * amax, HA, GA, nuA, bvA, 12.0 * U64 * amax * ha)
    # B: L = diag(b) U^T
    wm, w1, w2 = rotate_t(U, m), rotate_t(U, t1), rotate_t(U, t2)
    bm = (b[0] * wm[0], b[1] * wm[1], b[2] * wm[2])
    b1 = (b[0] * w1[0], b[1] * w1[1], b[2] * w1[2])
    b2 = (b[0] * w2[0], b[1] * w2[1], b[2] * w2[2])
    k1, k2 = cross3(b1, bm), cross3(b2, bm)
    hb3 = hb * hb * hb
    HB = (_dot(k1, k1) / hb3, _dot(k1, k2) / hb3, _dot(k2, k2) / hb3)
    gb = 48.0 * U64 * bmax * bmax
    GB = (_dot(b1, b1) + gb, _dot(b1, b2), _dot(b2, b2) + gb)
    nuB = math.sqrt(norm2(cross3(b1, b2))) * (1.0 + 4.0 * U64) + 24.0 * U64 * bmax * bmax
    bvB = (_dot(b1, bm), _dot(b2, bm))
    B = (hb - 16.0 * U64 * bmax, hb + 16.0 * U64 * bmax, HB, GB, nuB, bvB, 36.0 * U64 * bmax * bmax)
    H0 = (HA[0] + HB[0], HA[1] + HB[1], HA[2] + HB[2])
    eh = 128.0 * U64 * (amax * amax * amax / (ha * ha) + bmax * bmax * bmax / (hb * hb))
    return s, ghi, g1, g2, H0, A, B, eh


@stage
def _conj(c, s, x, y):
    """V diag(x, y) V^T for V = [[c, -s], [s, c]] as (00, 01, 11)."""
    return (c * c * x + s * s * y, c * s * (x - y), s * s * x + c * c * y)


@stage
def _curvature(kw, ks, cs, sn, A, B, eh):
    """Lower bound P (3-tuple, symmetric 2x2) of -Hess F on the ellipse E = {K z : |z| <= 1},
    K = V diag(kw, ks) V^T, V = [[cs, -sn], [sn, cs]] (columns: the weak and the strong direction of
    H0), and a lower bound of its smallest eigenvalue.

    For x in E and unit u: J(x) u - J0 u = L u x L x = (u1 x2 - u2 x1) (L t1 x L t2), of length
    <= nu |R u . x| <= nu |K R u| (R: the quarter turn), so
    |J(x) u|^2 >= (1 - eps) |J0 u|^2 - (1/eps - 1) nu^2 u^T R K^2 R^T u,   R K^2 R^T = V diag(ks^2, kw^2) V^T,
    and |L(m + x)|^2 = h0^2 + 2 bv.x + |L x|^2 <= h0^2 + 2 |K bv| + lambda_max(K Gram K) =: h_hi^2.
    Hence -Hess F >= (1 - eps) sum_i (h_i0 / h_i,hi)^3 H_i0 - (1/eps - 1) sum_i nu_i^2 / h_i,hi^3 R K^2 R^T."""
    K = _conj(cs, sn, kw, ks)
    kmax = max(kw, ks)
    Pb0 = Pb1 = Pb2 = 0.0
    qs = 0.0
    for part in (A, B):
        hlo, hhi, H, G, nu, bv, bverr = part
        if hlo <= 0.0:
            return (0.0, 0.0, 0.0), 0.0
        # K G K
        m00 = K[0] * G[0] + K[1] * G[1]
        m01 = K[0] * G[1] + K[1] * G[2]
        m10 = K[1] * G[0] + K[2] * G[1]
        m11 = K[1] * G[1] + K[2] * G[2]
        kgk = _sym2_max(m00 * K[0] + m01 * K[1], m00 * K[1] + m01 * K[2], m10 * K[1] + m11 * K[2])
        kgk += 32.0 * U64 * kmax * kmax * (abs(G[0]) + abs(G[1]) + abs(G[2]))  # K's rounding: ||dK|| <= 8 u kmax
        kb0, kb1 = K[0] * bv[0] + K[1] * bv[1], K[1] * bv[0] + K[2] * bv[1]
        beta = (math.sqrt(kb0 * kb0 + kb1 * kb1) + kmax * (bverr * 1.5 + 16.0 * U64 * (abs(bv[0]) + abs(bv[1])))) * (
            1.0 + 8.0 * U64
        )
        h2 = (hhi * hhi + 2.0 * beta + kgk * (1.0 + 16.0 * U64)) * (1.0 + 8.0 * U64)
        hx = math.sqrt(h2) * (1.0 + 2.0 * U64)
        r = hlo / hx
        r = r * r * r * (1.0 - 8.0 * U64)
        Pb0 += r * H[0]
        Pb1 += r * H[1]
        Pb2 += r * H[2]
        qs += nu * nu / (hx * hx * hx) * (1.0 + 8.0 * U64)
    Q = _conj(cs, sn, ks * ks * qs, kw * kw * qs)
    qshift = 16.0 * U64 * kmax * kmax * qs  # the rounding of K and of V diag V^T: entries <= 8 u kmax^2 qs
    Q = (Q[0] * (1.0 + 8.0 * U64) + qshift, Q[1], Q[2] * (1.0 + 8.0 * U64) + qshift)
    # eps from the weak direction v = (cs, sn)
    xw = cs * cs * Pb0 + 2.0 * cs * sn * Pb1 + sn * sn * Pb2
    yw = cs * cs * Q[0] + 2.0 * cs * sn * Q[1] + sn * sn * Q[2]
    if xw <= 0.0:
        return (0.0, 0.0, 0.0), 0.0
    eps = math.sqrt(max(yw, 0.0) / xw)
    eps = min(max(eps, 1e-8), 1.0)
    f, gq = 1.0 - eps, 1.0 / eps - 1.0
    P = (f * Pb0 - gq * Q[0], f * Pb1 - gq * Q[1], f * Pb2 - gq * Q[2])
    lam, lam_err = _sym2_min(P[0], P[1], P[2])
    err = lam_err + 2.0 * eh + 8.0 * U64 * (gq * (abs(Q[0]) + abs(Q[1]) + abs(Q[2])) + abs(Pb0) + abs(Pb1) + abs(Pb2))
    return (P[0] - err, P[1], P[2] - err), lam - 2.0 * err


@stage
def _chord(t):
    """A lower bound of the chord of the cap of angle atan(t) (margins for sin, atan, rounding)."""
    return 2.0 * math.sin(0.5 * math.atan(t)) * (1.0 - 1e-12) - 1e-14


@stage
def certify_region(m, e, a, U, b, amax, bmax, S, err_sigma, tol):
    """Polish the local maximum near the unit m (up to 3 Newton steps) and certify a region around it.

    Returns (ok, m, value, region): value the computed sigma(m); on the region sigma <= value + tol
    (err_sigma bounds the rounding of value).  region (21 floats): m, t1, t2 (the tangent plane),
    K^-1 (3), 1 / k_min, P (3), |V'|, |g|, R_in, R_out, launch radius.  It is
        Omega = {x : |K^-1 x| <= 1} u {x : |K^-1 x| (|V'| |x|^2 + 2 |g| |x|) <= x^T P x}
    in plane coordinates (x -> the direction of m + x1 t1 + x2 t2): inside the ellipse
    F(x) <= F(0) + g.x - x^T P x / 2 with P >= (|V'| + kappa) I, kappa > 0, |g|^2 / (2 kappa) <= tol_d;
    beyond it, along each ray, F(s x^) <= F(0) + s (|g| - x^^T P x^ s_b / 2) (concavity; s_b the ray's
    exit from the ellipse), which stays below V' (1 + s^2 / 2) while s (|V'| s + 2 |g|) <= s_b x^^T P x^ s,
    i.e. the second set.  R_in: the cap of chord R_in around m lies in Omega; R_out: Omega lies in
    the cap of chord R_out (used only to skip the full test)."""
    z21 = (0.0,) * 22
    for it in range(4):
        t1, t2 = tangent_basis(m)
        s, ghi, g1, g2, H, A, B, eh = _plane_terms(m, t1, t2, e, a, U, b, amax, bmax, S)
        V = s + tol  # the value to prove on the region
        if V >= 0.0:
            return False, m, s, z21
        tol_d = tol - err_sigma - 1e-14 * abs(V)  # = V (1 + 1e-14) - (s + err_sigma), the room left
        if tol_d <= 0.0:
            return False, m, s, z21
        Vp = -V * (1.0 + 1e-14)  # |V'|
        need = ghi * ghi / (2.0 * tol_d)
        # weak and strong directions of H0
        h = 0.5 * (H[0] - H[2])
        root = math.sqrt(h * h + H[1] * H[1])
        lw, ls = 0.5 * (H[0] + H[2]) - root, 0.5 * (H[0] + H[2]) + root
        v0, v1 = H[1], lw - H[0]
        if v0 * v0 + v1 * v1 < (lw - H[2]) ** 2 + H[1] * H[1]:
            v0, v1 = lw - H[2], H[1]
        vv = v0 * v0 + v1 * v1
        if vv > 0.0:
            iv = 1.0 / math.sqrt(vv)
            cs, sn = v0 * iv, v1 * iv
        else:
            cs, sn = 1.0, 0.0
        P0, pmin0 = _curvature(0.0, 0.0, cs, sn, A, B, eh)
        if pmin0 - Vp > 0.0 and need <= 0.25 * (pmin0 - Vp):
            break
        if it == 3:
            return False, m, s, z21
        # Newton step on the sphere: Riemannian Hessian -(H_A0 + H_B0) - sigma I
        h11, h12, h22 = -H[0] - s, -H[1], -H[2] - s
        det = h11 * h22 - h12 * h12
        if not (h11 < 0.0 and det > 0.0):
            return False, m, s, z21
        x1 = -(h22 * g1 - h12 * g2) / det
        x2 = -(h11 * g2 - h12 * g1) / det
        m = unit((m[0] + x1 * t1[0] + x2 * t2[0], m[1] + x1 * t1[1] + x2 * t2[1], m[2] + x1 * t1[2] + x2 * t2[2]))
    # isotropic: the T with the largest reach max(T, (pmin T - 2 |g|) / |V'|) among valid ones (kappa > 0,
    # |g|^2 / (2 kappa) <= tol_d), halving from 8 min_i h_i / l_i (the Hessian changes on the scale
    # h_i / l_i) while the reach grows; any T that passes the test is valid, the search only affects
    # the size of the region
    la2 = max(_sym2_max(A[3][0], A[3][1], A[3][2]), 1e-300)
    lb2 = max(_sym2_max(B[3][0], B[3][1], B[3][2]), 1e-300)
    T = min(1.0, 8.0 * min(A[0] / math.sqrt(la2), B[0] / math.sqrt(lb2)))
    bestT, best_reach, best_pmin = 0.0, 0.0, 0.0
    for _k in range(64):
        P, pmin = _curvature(T, T, cs, sn, A, B, eh)
        if pmin - Vp > 0.0 and need <= pmin - Vp:
            reach = max(T, (pmin * T - 2.0 * ghi) / Vp)
            if reach > best_reach:
                bestT, best_reach, best_pmin = T, reach, pmin
            else:
                break
        elif best_reach > 0.0:
            break
        T *= 0.5
    if bestT <= 0.0:
        return False, m, s, z21
    kw, ks = bestT, bestT
    # a valley (weak curvature barely above |V|, strong one much larger): the ellipse ks = T / 2,
    # kw doubled while valid
    if ls > 4.0 * lw and best_pmin < 4.0 * Vp:
        ks2 = 0.5 * bestT
        kw2 = 0.0
        t = bestT
        for _k in range(10):
            t *= 2.0
            P, pmin = _curvature(t, ks2, cs, sn, A, B, eh)
            if pmin - Vp > 0.0 and need <= pmin - Vp:
                kw2 = t
            else:
                break
        if kw2 >= 4.0 * bestT:
            kw, ks = kw2, ks2
    P, pmin = _curvature(kw, ks, cs, sn, A, B, eh)
    kmin, kmax = min(kw, ks), max(kw, ks)
    Ki = _conj(cs, sn, 1.0 / kw, 1.0 / ks)  # K^-1 (rounding: covered by the test's relative margins)
    # mu_K = lambda_min(K P K): x^T P x >= mu_K |K^-1 x|^2, so every x outside the ellipse with
    # |V'| |x|^2 + 2 |g| |x| <= mu_K |K^-1 x| is in Omega
    K = _conj(cs, sn, kw, ks)
    m00 = K[0] * P[0] + K[1] * P[1]
    m01 = K[0] * P[1] + K[1] * P[2]
    m10 = K[1] * P[0] + K[2] * P[1]
    m11 = K[1] * P[1] + K[2] * P[2]
    kp0, kp1, kp2 = m00 * K[0] + m01 * K[1], m00 * K[1] + m01 * K[2], m10 * K[1] + m11 * K[2]
    muK, muK_err = _sym2_min(kp0, kp1, kp2)
    muK = (
        muK
        - muK_err
        - 1e-13 * (abs(kp0) + abs(kp1) + abs(kp2))
        - 64.0 * U64 * kmax * kmax * (abs(P[0]) + abs(P[1]) + abs(P[2]))
    )
    r_in = max(kmin, (pmin * kmin - 2.0 * ghi) / Vp * (1.0 - 1e-14))
    if muK > 0.0:  # |x| <= r with |V'| r^2 + 2 |g| r <= mu_K
        r_in = max(r_in, (math.sqrt(ghi * ghi + Vp * muK) - ghi) / Vp * (1.0 - 1e-13))
    else:
        muK = 0.0
    pmax = _sym2_max(P[0], P[1], P[2])
    r_out = max(kmax, pmax * kmax / Vp) * 1.01 + 1e-9
    R_in = _chord(r_in)
    R_out = 2.0 * math.sin(0.5 * math.atan(r_out)) + 1e-9
    if R_in <= 0.0:
        return False, m, s, z21
    region = (
        m[0],
        m[1],
        m[2],
        t1[0],
        t1[1],
        t1[2],
        t2[0],
        t2[1],
        t2[2],
        Ki[0],
        Ki[1],
        Ki[2],
        1.0 / kmin,
        P[0],
        P[1],
        P[2],
        Vp,
        ghi,
        R_in,
        R_out,
        R_in,
        muK,
    )
    return True, m, s, region


@stage
def in_region(c, rho, d):
    """True if the cap |n - c| <= rho of unit n lies in the certified region d (see certify_region).

    The cap maps into the tangent plane at m (central projection, stretch <= 1 / (n.m)^2 >= ... along
    the cap's geodesics, n.m >= c.m - rho) inside the disk around x_c = (c.t1, c.t2) / c.m of radius
    r_x = rho_geodesic / (c.m - rho)^2 (+ 1e-13 (1 + |x_c|^2) for the rounding and the near-orthonormal
    t1, t2, m); that disk is tested against Omega with bounds over the disk."""
    dx, dy, dz = c[0] - d[0], c[1] - d[1], c[2] - d[2]
    q2 = dx * dx + dy * dy + dz * dz
    qi = d[18] - rho - 1e-15
    if qi > 0.0 and q2 <= qi * qi * (1.0 - 1e-14):
        return True  # cap in the inscribed cap
    qo = d[19] + rho
    if q2 >= qo * qo or rho > 1.0:
        return False
    al = c[0] * d[0] + c[1] * d[1] + c[2] * d[2]
    amin = al - rho * (1.0 + 1e-15) - 1e-15
    if amin <= 0.0:
        return False
    ial = 1.0 / al
    x0 = (c[0] * d[3] + c[1] * d[4] + c[2] * d[5]) * ial
    x1 = (c[0] * d[6] + c[1] * d[7] + c[2] * d[8]) * ial
    xx = x0 * x0 + x1 * x1
    rx = rho * (1.0 + 0.25 * rho * rho) * (1.0 + 1e-15) / (amin * amin) * (1.0 + 1e-14) + 1e-13 * (1.0 + xx)
    k0, k1 = d[9] * x0 + d[10] * x1, d[10] * x0 + d[11] * x1
    # |K^-1 x| to within 1e-9 relative: K^-1 is rounded (entries by 4 u / k_min, relative to the
    # ellipse's short axis 4 u k_max / k_min <= 1e-12 for the anisotropy <= 2^11 used)
    thi = (math.sqrt(k0 * k0 + k1 * k1) * (1.0 + 1e-9) + rx * d[12]) * (1.0 + 1e-14)
    if thi <= 1.0:
        return True  # in the ellipse
    X = (math.sqrt(xx) + rx) * (1.0 + 1e-14)
    grow = (d[16] * X * X + 2.0 * d[17] * X) * (1.0 + 1e-13)
    tlo = (math.sqrt(k0 * k0 + k1 * k1) * (1.0 - 1e-9) - rx * d[12]) * (1.0 - 1e-14)
    if grow <= d[21] * max(1.0, tlo):
        return True  # every point of the disk outside the ellipse satisfies the mu_K condition
    lhs = thi * grow
    p0, p1 = d[13] * x0 + d[14] * x1, d[14] * x0 + d[15] * x1
    rhs = (x0 * p0 + x1 * p1) * (1.0 - 1e-13) - 2.0 * rx * math.sqrt(p0 * p0 + p1 * p1) * (1.0 + 1e-13)
    return lhs <= rhs


@jit
def certify_region_call(m, e, a, U, b, amax, bmax, S, err_sigma, tol):
    """certify_region as a call (kept out of the branch and bound's loop body)."""
    return certify_region(m, e, a, U, b, amax, bmax, S, err_sigma, tol)


@jit
def climb(c, e, a, M, scale):
    """Newton from c (kept out of the branch and bound's loop body): (converged, m, sigma(m))."""
    a2 = (a[0] * a[0], a[1] * a[1], a[2] * a[2])
    m, v, st, k = newton(c, e, a2, M, scale, -math.inf, NEWTON_MAX_ITER)
    return st == CONVERGED, m, v


@stage
def _match(m, regions, nd):
    """Index of the certified region whose maximum is m (to 1e-6), or -1."""
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = regions[k]
        dx, dy, dz = m[0] - d[0], m[1] - d[1], m[2] - d[2]
        if dx * dx + dy * dy + dz * dz < 1e-12:
            return k
    return -1


@stage
def _widen1(d, D):
    return (
        d[0],
        d[1],
        d[2],
        d[3],
        d[4],
        d[5],
        d[6],
        d[7],
        d[8],
        d[9],
        d[10],
        d[11],
        d[12],
        d[13],
        d[14],
        d[15],
        d[16],
        d[17],
        d[18],
        d[19],
        max(d[20], D),
        d[21],
    )


@stage
def _widen(regions, k, D):
    """regions with the launch radius of region k raised to D: Newton from within it climbs to that
    region's maximum, so patches there launch no more runs (a heuristic: the proof never uses it)."""
    d0, d1, d2, d3 = regions
    if k == 0:
        d0 = _widen1(d0, D)
    elif k == 1:
        d1 = _widen1(d1, D)
    elif k == 2:
        d2 = _widen1(d2, D)
    else:
        d3 = _widen1(d3, D)
    return d0, d1, d2, d3


@stage
def in_regions(c, rho, regions, nd):
    """True if the cap |n - c| <= rho lies in one of the certified regions."""
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        if in_region(c, rho, regions[k]):
            return True
    return False


@stage
def _in_caps(c, rho, regions, nd):
    """True if the cap |n - c| <= rho lies in the inscribed cap (chord R_in) of a certified region
    (triangle inequality; |c - m| compared squared, with margins for its rounding)."""
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = regions[k]
        q = d[18] - rho - 1e-15
        if q > 0.0:
            dx, dy, dz = c[0] - d[0], c[1] - d[1], c[2] - d[2]
            if dx * dx + dy * dy + dz * dz <= q * q * (1.0 - 1e-14):
                return True
    return False


@stage
def _near_regions(c, rho, regions, nd):
    """True if the cap |n - c| <= rho meets one of the launch caps (heuristic: no rounding care)."""
    for k in range(MAX_DISKS):
        if k >= nd:
            break
        d = regions[k]
        q = d[20] + rho
        dx, dy, dz = c[0] - d[0], c[1] - d[1], c[2] - d[2]
        if dx * dx + dy * dy + dz * dz < q * q:
            return True
    return False


@stage
def _h_parts(c, e, a, U, b):
    """(c.e, h_A(c), h_B(c), grad h_A(c) + grad h_B(c), 1 / h_B): sigma and its gradient at c and at -c
    (sigma(+-c) = +-c.e - h_A - h_B, G(+-c) = e -+ (grad h_A + grad h_B); the h are even)."""
    x0, x1, x2 = a[0] * c[0], a[1] * c[1], a[2] * c[2]
    ha = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    w = rotate_t(U, c)
    y0, y1, y2 = b[0] * w[0], b[1] * w[1], b[2] * w[2]
    hb = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    ce = c[0] * e[0] + c[1] * e[1] + c[2] * e[2]
    iab = 1.0 / (ha * hb)
    ia, ib = hb * iab, ha * iab  # 1/h_A, 1/h_B with 2 roundings more than a division: counted
    gb = matvec(U, (b[0] * y0 * ib, b[1] * y1 * ib, b[2] * y2 * ib))
    gs = (a[0] * x0 * ia + gb[0], a[1] * x1 * ia + gb[1], a[2] * x2 * ia + gb[2])
    return ce, ha, hb, gs, ib


@stage
def _test(c, rho, s, G, epsg, lv):
    """sigma <= lv on the cap |n - c| <= rho, from sigma(c) = s and G = grad sigma(c): the bound
    s + (|G_T| + eps_G) rho + max(-G.c, 0) rho^2 / 2 <= lv, compared without a square root."""
    gc = G[0] * c[0] + G[1] * c[1] + G[2] * c[2]
    t0, t1, t2 = G[0] - gc * c[0], G[1] - gc * c[1], G[2] - gc * c[2]
    r = lv - s - max(-gc, 0.0) * (rho * rho) * 0.5000000000001 - epsg * rho
    if r < 0.0:
        return False
    tt = (t0 * t0 + t1 * t1 + t2 * t2) * (rho * rho)
    return tt * (1.0 + 16.0 * U64) <= r * r * (1.0 - 8.0 * U64)


@stage
def _next(fp, level, i, j, root):
    """The next quadtree position after (fp, level, i, j) in depth-first order, skipping its subtree,
    within the subtree of the node at level `root` (0: the whole face pair): (fp, level, i, j, done)."""
    while level > root + 1 and (i & 1) == 1 and (j & 1) == 1:
        level -= 1
        i >>= 1
        j >>= 1
    if level == root + 1 and (i & 1) == 1 and (j & 1) == 1:
        return fp, level, i, j, True
    if (j & 1) == 0:
        return fp, level, i, j + 1, False
    return fp, level, i + 1, j - 1, False


@jit  # a function of its own, not inlined into its caller: the narrow-phase callback compiles faster
def global_max(n0, v0, have0, e, a, U, b, M, scale, tol, max_patches):
    """Proven global maximum of sigma on the unit sphere, in A's frame.

    n0, v0: a local maximum already found (have0 True) or nothing.  tol: the tolerance in A's frame
    (tol_bb of the module docstring, >= (PATCH_SLACK + 32) u S).  Returns (status GLOBAL, UNPROVEN or
    SEPARATED_MAX (see above), best unit n, sigma(n) as computed, nodes evaluated, Newton runs);
    GLOBAL proves max sigma <= sigma(n) + tol for the exact sigma of (e, a, U, b).

    Depth first over the quadtrees of 3 pairs of opposite cube faces: a node is a patch and its
    antipode, which share h_A, h_B and their gradients (one evaluation for two patches).  Which of the
    two is still undecided is kept as 2 bits per level in one int64, so nothing is allocated."""
    amax = max(a[0], a[1], a[2])
    bmax = max(b[0], b[1], b[2])
    S = math.sqrt(norm2(e)) + amax + bmax
    slack = PATCH_SLACK_ULPS * U64 * S
    err_sigma = ERR_SIGMA_ULPS * U64 * S
    best_n, best = (1.0, 0.0, 0.0), -math.inf
    z21 = (0.0,) * 22
    regions = (z21, z21, z21, z21)
    nd = 0
    runs = 0
    if have0:
        ok, m, v, reg = certify_region_call(n0, e, a, U, b, amax, bmax, S, err_sigma, tol)
        if ok:
            regions = (reg, regions[0], regions[1], regions[2])
            nd = 1
            best_n, best = m, v
        else:
            best_n, best = n0, sigma_only(n0, e, a, U, b)
    # the cube turned so that the first certified maximum is the centre of face 0 (its region then
    # meets few large patches); the identity if there is none
    Q = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    if nd > 0:
        r0 = regions[0]
        Q = (r0[0], r0[3], r0[6], r0[1], r0[4], r0[7], r0[2], r0[5], r0[8])
    z5 = (0, 0, 0, 0, 0)
    aside = (z5, z5, z5, z5, z5, z5, z5, z5)  # deferred subtrees: (face pair, level, i, j, sides)
    nu, ai = 0, 0
    sub, L0 = False, 0  # in the main pass the subtrees are the face pairs (root level 0)
    fp, level, i, j = 0, ROOT_LEVEL, 0, 0
    alive = 0  # bits 2L, 2L + 1: the patch (+) and its antipode (-) at level L were undecided
    count = 0
    # the last node split: its gradient parts (sigma(n) <= G_p.n for every n, Euler + concavity)
    # pre-test its children before their own evaluation (valid while no deeper node was split)
    pf, pl, pi, pj, pgs, peps = -1, -1, 0, 0, (0.0, 0.0, 0.0), 0.0
    dot_err = 4.0 * U64 * S
    while True:
        count += 1
        if count > max_patches:
            return UNPROVEN, best_n, best, count, runs
        par = 3 if level == ROOT_LEVEL else (alive >> (2 * (level - 1))) & 3
        p, inv, pc, rho = patch_point(2 * fp, level, i, j, Q)
        c = (p[0] * inv, p[1] * inv, p[2] * inv)
        if pl == level - 1 and pi == i >> 1 and pj == j >> 1 and pf == fp:
            lvp = best + tol - slack - peps * 1.0001 - dot_err
            for side in range(2):
                if (par >> side) & 1:
                    if side == 0:
                        cs, G = c, (e[0] - pgs[0], e[1] - pgs[1], e[2] - pgs[2])
                    else:
                        cs, G = (-c[0], -c[1], -c[2]), (e[0] + pgs[0], e[1] + pgs[1], e[2] + pgs[2])
                    if _test(cs, rho, G[0] * cs[0] + G[1] * cs[1] + G[2] * cs[2], G, peps, lvp):
                        par &= ~(1 << side)
            if par == 0:
                fp, level, i, j, fin = _next(fp, level, i, j, L0)
                if fin:
                    if not sub and fp < 2:
                        fp, level, i, j = fp + 1, ROOT_LEVEL, 0, 0
                        continue
                    if ai >= nu:
                        break
                    fp, level, i, j, fl = aside[ai]
                    ai += 1
                    sh = 2 * (level - 1)
                    alive = (alive & ~(3 << sh)) | (fl << sh)
                    sub, L0, pl = True, level, -1
                continue
        ce, ha, hb, gs, ib = _h_parts(p, e, a, U, b)  # at p = |p| c: scale the values (not G) by 1/|p|
        ce, ha, hb = ce * inv, ha * inv, hb * inv
        epsg = U64 * (32.0 * (S + bmax * bmax * ib * pc * 1.01) + 16.0 * S)
        flags = 0
        for side in range(2):
            if not (par >> side) & 1:
                continue
            if side == 0:
                cs, s, G = c, ce - ha - hb, (e[0] - gs[0], e[1] - gs[1], e[2] - gs[2])
            else:
                cs, s, G = (-c[0], -c[1], -c[2]), -ce - ha - hb, (e[0] + gs[0], e[1] + gs[1], e[2] + gs[2])
            done = _in_caps(cs, rho, regions, nd)
            if not done:
                done = _test(cs, rho, s, G, epsg, best + tol - slack)
            if not done and nd > 0:
                done = in_regions(cs, rho, regions, nd)
            launch = False
            if s > best:  # a better point than every maximum found: a new basin
                best_n, best = cs, s
                done, launch = False, True
            elif not done and (level == NEWTON_LEVELS[0] or level == NEWTON_LEVELS[1] or level == NEWTON_LEVELS[2]):
                # undecided at a Newton level: climb from its centre unless the patch touches a
                # launch cap (then it is most likely the rim of a known basin); at the last Newton
                # level unless its centre lies in one
                launch = not _near_regions(cs, rho if level != NEWTON_LEVELS[2] else 0.0, regions, nd)
            if launch:
                conv, m, v = climb(cs, e, a, M, scale)
                runs += 1
                if conv and v > 0.0:
                    # separated: sigma is concave on the ball and this local maximum is global
                    return SEPARATED_MAX, m, sigma_only(m, e, a, U, b), count, runs
                if conv:
                    kd = _match(m, regions, nd)
                    if kd >= 0:
                        dx, dy, dz = cs[0] - regions[kd][0], cs[1] - regions[kd][1], cs[2] - regions[kd][2]
                        regions = _widen(regions, kd, math.sqrt(dx * dx + dy * dy + dz * dz) + rho)
                    else:
                        ok, m, v, reg = certify_region_call(m, e, a, U, b, amax, bmax, S, err_sigma, tol)
                        if v > best:
                            best_n, best = m, v
                        if ok:
                            regions = (reg, regions[0], regions[1], regions[2])
                            nd = min(nd + 1, MAX_DISKS)
                            done = in_regions(cs, rho, regions, nd)
                if not done:
                    done = _test(cs, rho, s, G, epsg, best + tol - slack)
            if not done:
                flags |= 1 << side
        if flags != 0 and not sub and level >= DEFER_LEVEL and nu < MAX_ASIDE:
            # undecided this deep in the main pass (typically a ridge or saddle as high as a poor
            # incumbent): defer the subtree; it is searched again at the end, with the final incumbent
            aside = ((fp, level, i, j, flags), aside[0], aside[1], aside[2], aside[3], aside[4], aside[5], aside[6])
            nu += 1
            flags = 0
        if flags == 0:
            if sub and level == L0:
                fin = True
            else:
                fp, level, i, j, fin = _next(fp, level, i, j, L0)
            if fin:
                if not sub and fp < 2:
                    fp, level, i, j = fp + 1, ROOT_LEVEL, 0, 0
                    continue
                if ai >= nu:
                    break
                fp, level, i, j, fl = aside[ai]
                ai += 1
                sh = 2 * (level - 1)
                alive = (alive & ~(3 << sh)) | (fl << sh)
                sub, L0, pl = True, level, -1
        elif level >= MAX_LEVEL:
            return UNPROVEN, best_n, best, count, runs
        else:
            sh = 2 * level
            alive = (alive & ~(3 << sh)) | (flags << sh)
            pf, pl, pi, pj, pgs, peps = fp, level, i, j, gs, epsg
            level += 1
            i *= 2
            j *= 2
    return GLOBAL, best_n, best, count, runs
