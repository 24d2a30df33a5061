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

The kernels are C++, ellipsim/native/include/ellipsim/distance/branch_and_bound.hpp (bound in the _ellipsim module).
"""

import math

import numpy as np

from ..tolerances import BB_ERR_SIGMA_ULPS, BB_MAX_PATCHES, BB_PATCH_SLACK_ULPS

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
