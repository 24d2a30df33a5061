// Proven global maximisation of sigma(n) = n.e - h_A(n) - h_B(n) over the unit sphere: the deep branch of the
// narrow phase (ellipsim/core/distance/branch_and_bound.py, whose docstring has the proofs and the rounding
// analysis).
//
// Branch and bound with concave (supergradient) majorants, after Horst & Tuy, Global Optimization:
// Deterministic Approaches (1996), ch. 4; local regions certified by a Hessian lower bound.  Everything is in
// A's principal frame: e = R_A^T (c_B - c_A), h_A(n) = |diag(a) n|, h_B(n) = |diag(b) U^T n| with
// U = R_A^T R_B.
// 1. A patch's upper bound (Rockafellar, Convex Analysis, sec. 23): sigma is concave and positively
//    homogeneous of degree 1, so sigma(n) <= G(c).n for every n; on the cap |n - c| <= rho around a unit c,
//    sigma(n) <= sigma(c) + |G_T| rho + max(-G.c, 0) rho^2 / 2.  The sphere is covered by 3 pairs of opposite
//    faces of a cube (turned so that the first certified maximum is the centre of face 0), each split as a
//    quadtree in gnomonic coordinates; a patch and its antipode share h_A, h_B and their gradients.
// 2. A region certificate around a strict local maximum m (certify_region): on the tangent plane at m,
//    F(x) = sigma(m + x) is concave, -Hess F >= P on an ellipse E = {K z : |z| <= 1}, and sigma <= value + tol
//    on E united with the set beyond it where concavity along rays keeps F below the bound.
// 3. Depth first over the quadtrees: a patch is discarded when its cap lies in a certified region or its
//    upper bound is below best + tol; GLOBAL when nothing is left, UNPROVEN when the budget runs out,
//    SEPARATED_MAX when a climb reaches sigma > 0 (sigma is concave on the ball: that maximum is global).
//
// No scratch arrays: the search state is a patch position, 2 bits a level in one int64 (which of a patch and
// its antipode is still undecided), 4 certified regions and 8 deferred subtrees in fixed-size arrays, as in
// the Python (nothing is allocated).
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "rho_table.hpp"
#include "sphere_newton.hpp"

namespace ellipsim::distance {

namespace branch_and_bound {

// How global_max ends: the maximum found is proven global (GLOBAL), the budget ran out (UNPROVEN: the best
// found, no proof), or a climb reached sigma > 0 (SEPARATED_MAX: sigma is concave on the ball, so that local
// maximum is global).
constexpr int GLOBAL = 0, UNPROVEN = 1, SEPARATED_MAX = 2;

constexpr double U64 = 0x1p-53;
constexpr double PATCH_SLACK_ULPS = tol::BB_PATCH_SLACK_ULPS;
constexpr double ERR_SIGMA_ULPS = tol::BB_ERR_SIGMA_ULPS;
constexpr int MAX_PATCHES = tol::BB_MAX_PATCHES;

// The shape of the search (not tolerances: the proof holds for any values; these were tuned on leaves.xml
// contacts and random deep crossings of elongated ellipsoids):
constexpr int MAX_LEVEL = 30;  // gnomonic half-width 2^-30 (2 bits a level in one int64)
constexpr int ROOT_LEVEL = 1;  // 3 face pairs x 4 patches to start with
// NEWTON_LEVELS = (4, 7, 10): an undecided patch at one of these levels may launch Newton from its centre
constexpr int NEWTON_LEVEL_0 = 4, NEWTON_LEVEL_1 = 7, NEWTON_LEVEL_2 = 10;
constexpr int MAX_DISKS = 4;     // certified regions kept
constexpr int MAX_ASIDE = 8;     // deferred subtrees
constexpr int DEFER_LEVEL = 16;  // an undecided patch this deep in the main pass defers its subtree
constexpr int REGION_SIZE = 22;  // the floats of a certified region (certify_region)

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

// A symmetric 2x2 matrix [[xx, xy], [xy, yy]].
struct Sym2 {
  double xx, xy, yy;
};

// (smallest eigenvalue of [[p, q], [q, r]], an upper bound of its rounding error).
struct EigenBound {
  double value, err;
};

ELLIPSIM_HD EigenBound sym2_min(double p, double q, double r) {
  const double h = 0.5 * (p - r);
  const double root = math::sqrt(h * h + q * q);
  return {0.5 * (p + r) - root, 8.0 * U64 * (math::fabs(p) + math::fabs(r) + math::fabs(q))};
}

ELLIPSIM_HD double sym2_max(double p, double q, double r) {
  const double h = 0.5 * (p - r);
  return 0.5 * (p + r) + math::sqrt(h * h + q * q);
}

// One body's part of the certificate at m: (h lower, h upper, H_i (plane Hessian of h_i), Gram of L t1, L t2
// shifted upwards, nu = |L t1 x L t2| upper bound, bv = (L t1 . L m, L t2 . L m), |error of bv| bound).
struct Part {
  double hlo, hhi;
  Sym2 H, G;
  double nu;
  double bv0, bv1;
  double bverr;
};

// (sigma(m), |g| upper bound, g1, g2, H0 (plane Hessian of h_A + h_B), part A, part B, eh).
struct PlaneTerms {
  double s, ghi, g1, g2;
  Sym2 H;
  Part A, B;
  double eh;
};

}  // namespace branch_and_bound

// (sigma(c), gradient G, h_A(c), h_B(c)) of the homogeneous sigma at any nonzero c.
struct SigmaGrad {
  double s;
  Vec3 G;
  double ha, hb;
};

ELLIPSIM_HD SigmaGrad sigma_grad(const Vec3& c, const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b) {
  const double x0 = a.x * c.x, x1 = a.y * c.y, x2 = a.z * c.z;
  const double ha = math::sqrt(x0 * x0 + x1 * x1 + x2 * x2);
  const Vec3 w = rotate_t(U, c);
  const double y0 = b.x * w.x, y1 = b.y * w.y, y2 = b.z * w.z;
  const double hb = math::sqrt(y0 * y0 + y1 * y1 + y2 * y2);
  const double s = c.x * e.x + c.y * e.y + c.z * e.z - ha - hb;
  const double ia = 1.0 / ha, ib = 1.0 / hb;  // each product below errs by 2 roundings more than a division: counted
  const Vec3 gb = matvec(U, {b.x * y0 * ib, b.y * y1 * ib, b.z * y2 * ib});
  return {s, {e.x - a.x * x0 * ia - gb.x, e.y - a.y * x1 * ia - gb.y, e.z - a.z * x2 * ia - gb.z}, ha, hb};
}

ELLIPSIM_HD double sigma_only(const Vec3& c, const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b) {
  const double x0 = a.x * c.x, x1 = a.y * c.y, x2 = a.z * c.z;
  const Vec3 w = rotate_t(U, c);
  const double y0 = b.x * w.x, y1 = b.y * w.y, y2 = b.z * w.z;
  return c.x * e.x + c.y * e.y + c.z * e.z - math::sqrt(x0 * x0 + x1 * x1 + x2 * x2) -
         math::sqrt(y0 * y0 + y1 * y1 + y2 * y2);
}

// (p, |p|^-1, |p|, rho) of a quadtree patch.
struct PatchPoint {
  Vec3 p;
  double inv, pc, rho;
};

// The centre p = Q (1, u_c, v_c) (permuted, signed) of quadtree patch (level, i, j) of a cube face, NOT
// normalised (sigma and its gradient are evaluated at p, off the critical path of the square root;
// sigma(p / |p|) = sigma(p) / |p|, the gradient is 0-homogeneous), and the chord radius rho of the cap around
// p / |p| that holds the patch; Q turns the cube (row-major, columns: where the x, y, z axes go, orthonormal
// to rounding).
ELLIPSIM_HD PatchPoint patch_point(int face, int level, int64_t i, int64_t j, const Mat3& Q) {
  using namespace branch_and_bound;
  const double w = double(int64_t(1) << (62 - level)) * 0x1p-62;  // half-width 2^-level (exact)
  const double u0 = -1.0 + 2.0 * w * double(i);
  const double v0 = -1.0 + 2.0 * w * double(j);
  const double uc = u0 + w, vc = v0 + w;
  const double pc = math::sqrt(1.0 + uc * uc + vc * vc);
  const double inv = 1.0 / pc;
  // the square lies within w sqrt(2) of p_c; on it |p| >= max(1, |p_c| - w sqrt(2)), and
  // 1 / (|p_c| - hd) = inv / (1 - x) <= inv (1 + x + 2 x^2), x = hd inv <= 1/2 (no division);
  // Q changes lengths by <= 1e-15 relative
  const double hd = w * 1.4142135623730951;
  const double x = hd * inv;
  double rho = x <= 0.5 ? hd * min2(1.0, inv * (1.0 + x + 2.0 * x * x)) : hd;
  rho = rho * (1.0 + 4e-15) + 2e-15;  // roundings of sqrt(2), sqrt, products, Q; |c - exact centre| <= 8u
  // the exact circumradius (the Lipschitz bound above is up to ~20 % larger)
  if (level <= RHO_LEVELS) rho = rho_table(((int64_t(1) << (2 * level)) - 4) / 3 + (i << level) + j);
  const int k = face >> 1;
  const double sg = (face & 1) == 0 ? 1.0 : -1.0;  // face 2k + 1 is the antipode of face 2k, patch by patch
  Vec3 p;
  if (k == 0) {
    p = {sg, sg * uc, sg * vc};
  } else if (k == 1) {
    p = {sg * vc, sg, sg * uc};
  } else {
    p = {sg * uc, sg * vc, sg};
  }
  return {matvec(Q, p), inv, pc, rho};
}

// (unit centre c, chord radius rho) of the cap holding quadtree patch (level, i, j) of a cube face.
struct PatchCap {
  Vec3 c;
  double rho;
};

ELLIPSIM_HD PatchCap patch_cap(int face, int level, int64_t i, int64_t j, const Mat3& Q) {
  const PatchPoint pp = patch_point(face, level, i, j, Q);
  return {{pp.p.x * pp.inv, pp.p.y * pp.inv, pp.p.z * pp.inv}, pp.rho};
}

namespace branch_and_bound {

// Everything the certificate needs at the float point m with tangent vectors t1, t2 (PlaneTerms).  eh bounds
// the entry errors of H_A and H_B.  Roundings (branch_and_bound.py): Hessian entries err by <= 27 u amax^2 / h_A
// and <= 60 u bmax^3 / h_B^2; Gram entries by <= 4 u amax^2, <= 16 u bmax^2 (shifted by twice that on the
// diagonal, which dominates the error matrix); nu by <= 8 u amax^2, <= 24 u bmax^2; bv by <= 8 u amax h_A,
// <= 24 u bmax^2; h_A by <= 3.5 u amax, h_B by <= 8.7 u bmax.
ELLIPSIM_HD PlaneTerms plane_terms(const Vec3& m, const Vec3& t1, const Vec3& t2, const Vec3& e, const Vec3& a,
                                   const Mat3& U, const Vec3& b, double amax, double bmax, double S) {
  const SigmaGrad sg = sigma_grad(m, e, a, U, b);
  const double s = sg.s, ha = sg.ha, hb = sg.hb;
  const double g1 = dot(sg.G, t1), g2 = dot(sg.G, t2);
  const double Gn = math::sqrt(norm2(sg.G));
  const double epsg = U64 * (32.0 * (S + bmax * bmax / hb) + 16.0 * S);
  // |exact plane gradient| <= computed + eps_G |[t1 t2]| + rounding of the two dot products
  const double ghi = math::sqrt(g1 * g1 + g2 * g2) * (1.0 + 4.0 * U64) + 1.5 * epsg + 8.0 * U64 * Gn;
  // A: L = diag(a)
  const Vec3 am = {a.x * m.x, a.y * m.y, a.z * m.z};
  const Vec3 a1 = {a.x * t1.x, a.y * t1.y, a.z * t1.z};
  const Vec3 a2 = {a.x * t2.x, a.y * t2.y, a.z * t2.z};
  const Vec3 j1 = cross3(a1, am), j2 = cross3(a2, am);
  const double ha3 = ha * ha * ha;
  const Sym2 HA = {dot(j1, j1) / ha3, dot(j1, j2) / ha3, dot(j2, j2) / ha3};
  const double ga = 16.0 * U64 * amax * amax;
  const Sym2 GA = {dot(a1, a1) + ga, dot(a1, a2), dot(a2, a2) + ga};
  const double nuA = math::sqrt(norm2(cross3(a1, a2))) * (1.0 + 4.0 * U64) + 8.0 * U64 * amax * amax;
  const double ha_lo = ha - 10.0 * U64 * amax, ha_hi = ha + 10.0 * U64 * amax;
  const Part A = {ha_lo, ha_hi, HA, GA, nuA, dot(a1, am), dot(a2, am), 12.0 * U64 * amax * ha};
  // B: L = diag(b) U^T
  const Vec3 wm = rotate_t(U, m), w1 = rotate_t(U, t1), w2 = rotate_t(U, t2);
  const Vec3 bm = {b.x * wm.x, b.y * wm.y, b.z * wm.z};
  const Vec3 b1 = {b.x * w1.x, b.y * w1.y, b.z * w1.z};
  const Vec3 b2 = {b.x * w2.x, b.y * w2.y, b.z * w2.z};
  const Vec3 k1 = cross3(b1, bm), k2 = cross3(b2, bm);
  const double hb3 = hb * hb * hb;
  const Sym2 HB = {dot(k1, k1) / hb3, dot(k1, k2) / hb3, dot(k2, k2) / hb3};
  const double gb = 48.0 * U64 * bmax * bmax;
  const Sym2 GB = {dot(b1, b1) + gb, dot(b1, b2), dot(b2, b2) + gb};
  const double nuB = math::sqrt(norm2(cross3(b1, b2))) * (1.0 + 4.0 * U64) + 24.0 * U64 * bmax * bmax;
  const double hb_lo = hb - 16.0 * U64 * bmax, hb_hi = hb + 16.0 * U64 * bmax;
  const Part B = {hb_lo, hb_hi, HB, GB, nuB, dot(b1, bm), dot(b2, bm), 36.0 * U64 * bmax * bmax};
  const Sym2 H0 = {HA.xx + HB.xx, HA.xy + HB.xy, HA.yy + HB.yy};
  const double eh = 128.0 * U64 * (amax * amax * amax / (ha * ha) + bmax * bmax * bmax / (hb * hb));
  return {s, ghi, g1, g2, H0, A, B, eh};
}

// V diag(x, y) V^T for V = [[c, -s], [s, c]] as (00, 01, 11).
ELLIPSIM_HD Sym2 conj(double c, double s, double x, double y) {
  return {c * c * x + s * s * y, c * s * (x - y), s * s * x + c * c * y};
}

// (lower bound P of -Hess F on the ellipse, a lower bound of its smallest eigenvalue).
struct Curvature {
  Sym2 P;
  double pmin;
};

// Lower bound P of -Hess F on the ellipse E = {K z : |z| <= 1}, K = V diag(kw, ks) V^T,
// V = [[cs, -sn], [sn, cs]] (columns: the weak and the strong direction of H0), and a lower bound of its
// smallest eigenvalue.  For x in E and unit u: J(x) u - J0 u = L u x L x = (u1 x2 - u2 x1) (L t1 x L t2), of
// length <= nu |R u . x| <= nu |K R u| (R: the quarter turn), so
// |J(x) u|^2 >= (1 - eps) |J0 u|^2 - (1/eps - 1) nu^2 u^T R K^2 R^T u,   R K^2 R^T = V diag(ks^2, kw^2) V^T,
// and |L(m + x)|^2 = h0^2 + 2 bv.x + |L x|^2 <= h0^2 + 2 |K bv| + lambda_max(K Gram K) =: h_hi^2.  Hence
// -Hess F >= (1 - eps) sum_i (h_i0 / h_i,hi)^3 H_i0 - (1/eps - 1) sum_i nu_i^2 / h_i,hi^3 R K^2 R^T.
ELLIPSIM_HD Curvature curvature(double kw, double ks, double cs, double sn, const Part& A, const Part& B, double eh) {
  using math::fabs;
  const Sym2 K = conj(cs, sn, kw, ks);
  const double kmax = max2(kw, ks);
  double Pb0 = 0.0, Pb1 = 0.0, Pb2 = 0.0;
  double qs = 0.0;
  for (int q = 0; q < 2; ++q) {
    const Part& part = q == 0 ? A : B;
    const Sym2 &H = part.H, &G = part.G;
    if (part.hlo <= 0.0) return {{0.0, 0.0, 0.0}, 0.0};
    // K G K
    const double m00 = K.xx * G.xx + K.xy * G.xy;
    const double m01 = K.xx * G.xy + K.xy * G.yy;
    const double m10 = K.xy * G.xx + K.yy * G.xy;
    const double m11 = K.xy * G.xy + K.yy * G.yy;
    double kgk = sym2_max(m00 * K.xx + m01 * K.xy, m00 * K.xy + m01 * K.yy, m10 * K.xy + m11 * K.yy);
    kgk += 32.0 * U64 * kmax * kmax * (fabs(G.xx) + fabs(G.xy) + fabs(G.yy));  // K's rounding: ||dK|| <= 8 u kmax
    const double kb0 = K.xx * part.bv0 + K.xy * part.bv1, kb1 = K.xy * part.bv0 + K.yy * part.bv1;
    const double beta = (math::sqrt(kb0 * kb0 + kb1 * kb1) +
                         kmax * (part.bverr * 1.5 + 16.0 * U64 * (fabs(part.bv0) + fabs(part.bv1)))) *
                        (1.0 + 8.0 * U64);
    const double h2 = (part.hhi * part.hhi + 2.0 * beta + kgk * (1.0 + 16.0 * U64)) * (1.0 + 8.0 * U64);
    const double hx = math::sqrt(h2) * (1.0 + 2.0 * U64);
    double r = part.hlo / hx;
    r = r * r * r * (1.0 - 8.0 * U64);
    Pb0 += r * H.xx;
    Pb1 += r * H.xy;
    Pb2 += r * H.yy;
    qs += part.nu * part.nu / (hx * hx * hx) * (1.0 + 8.0 * U64);
  }
  Sym2 Q = conj(cs, sn, ks * ks * qs, kw * kw * qs);
  const double qshift = 16.0 * U64 * kmax * kmax * qs;  // the rounding of K and of V diag V^T: entries <= 8 u kmax^2 qs
  Q = {Q.xx * (1.0 + 8.0 * U64) + qshift, Q.xy, Q.yy * (1.0 + 8.0 * U64) + qshift};
  // eps from the weak direction v = (cs, sn)
  const double xw = cs * cs * Pb0 + 2.0 * cs * sn * Pb1 + sn * sn * Pb2;
  const double yw = cs * cs * Q.xx + 2.0 * cs * sn * Q.xy + sn * sn * Q.yy;
  if (xw <= 0.0) return {{0.0, 0.0, 0.0}, 0.0};
  double eps = math::sqrt(max2(yw, 0.0) / xw);
  eps = min2(max2(eps, 1e-8), 1.0);
  const double f = 1.0 - eps, gq = 1.0 / eps - 1.0;
  const Sym2 P = {f * Pb0 - gq * Q.xx, f * Pb1 - gq * Q.xy, f * Pb2 - gq * Q.yy};
  const EigenBound lam = sym2_min(P.xx, P.xy, P.yy);
  const double err = lam.err + 2.0 * eh +
                     8.0 * U64 * (gq * (fabs(Q.xx) + fabs(Q.xy) + fabs(Q.yy)) + fabs(Pb0) + fabs(Pb1) + fabs(Pb2));
  return {{P.xx - err, P.xy, P.yy - err}, lam.value - 2.0 * err};
}

// A lower bound of the chord of the cap of angle atan(t) (margins for sin, atan, rounding).
ELLIPSIM_HD double chord(double t) { return 2.0 * math::sin(0.5 * math::atan(t)) * (1.0 - 1e-12) - 1e-14; }

}  // namespace branch_and_bound

// A certified region (22 floats): m, t1, t2 (the tangent plane), K^-1 (3), 1 / k_min, P (3), |V'|, |g|, R_in,
// R_out, launch radius, mu_K (certify_region).
struct Region {
  double d[branch_and_bound::REGION_SIZE];
};

// (ok, m, value, region) of certify_region.
struct Certified {
  bool ok;
  Vec3 m;
  double value;
  Region region;
};

// Polish the local maximum near the unit m (up to 3 Newton steps) and certify a region around it.
//
// Returns (ok, m, value, region): value the computed sigma(m); on the region sigma <= value + tol (err_sigma
// bounds the rounding of value).  The region is
//     Omega = {x : |K^-1 x| <= 1} u {x : |K^-1 x| (|V'| |x|^2 + 2 |g| |x|) <= x^T P x}
// in plane coordinates (x -> the direction of m + x1 t1 + x2 t2): inside the ellipse
// F(x) <= F(0) + g.x - x^T P x / 2 with P >= (|V'| + kappa) I, kappa > 0, |g|^2 / (2 kappa) <= tol_d; beyond it,
// along each ray, F(s x^) <= F(0) + s (|g| - x^^T P x^ s_b / 2) (concavity; s_b the ray's exit from the
// ellipse), which stays below V' (1 + s^2 / 2) while s (|V'| s + 2 |g|) <= s_b x^^T P x^ s, i.e. the second
// set.  R_in: the cap of chord R_in around m lies in Omega; R_out: Omega lies in the cap of chord R_out (used
// only to skip the full test).
ELLIPSIM_HD Certified certify_region(Vec3 m, const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b, double amax,
                                     double bmax, double S, double err_sigma, double tol) {
  using namespace branch_and_bound;
  using math::fabs;
  const Region z21 = {};
  Vec3 t1, t2;
  PlaneTerms pt;
  double Vp = 0.0, need = 0.0, lw = 0.0, ls = 0.0, cs = 1.0, sn = 0.0;
  for (int it = 0; it < 4; ++it) {
    const TangentBasis tb = tangent_basis(m);
    t1 = tb.t1;
    t2 = tb.t2;
    pt = plane_terms(m, t1, t2, e, a, U, b, amax, bmax, S);
    const double s = pt.s;
    const Sym2& H = pt.H;
    const double V = s + tol;  // the value to prove on the region
    if (V >= 0.0) return {false, m, s, z21};
    const double tol_d = tol - err_sigma - 1e-14 * fabs(V);  // = V (1 + 1e-14) - (s + err_sigma), the room left
    if (tol_d <= 0.0) return {false, m, s, z21};
    Vp = -V * (1.0 + 1e-14);  // |V'|
    need = pt.ghi * pt.ghi / (2.0 * tol_d);
    // weak and strong directions of H0
    const double h = 0.5 * (H.xx - H.yy);
    const double root = math::sqrt(h * h + H.xy * H.xy);
    lw = 0.5 * (H.xx + H.yy) - root;
    ls = 0.5 * (H.xx + H.yy) + root;
    double v0 = H.xy, v1 = lw - H.xx;
    const double lh = lw - H.yy;
    if (v0 * v0 + v1 * v1 < lh * lh + H.xy * H.xy) {
      v0 = lw - H.yy;
      v1 = H.xy;
    }
    const double vv = v0 * v0 + v1 * v1;
    if (vv > 0.0) {
      const double iv = 1.0 / math::sqrt(vv);
      cs = v0 * iv;
      sn = v1 * iv;
    } else {
      cs = 1.0;
      sn = 0.0;
    }
    const Curvature c0 = curvature(0.0, 0.0, cs, sn, pt.A, pt.B, pt.eh);
    if (c0.pmin - Vp > 0.0 && need <= 0.25 * (c0.pmin - Vp)) break;
    if (it == 3) return {false, m, s, z21};
    // Newton step on the sphere: Riemannian Hessian -(H_A0 + H_B0) - sigma I
    const double h11 = -H.xx - s, h12 = -H.xy, h22 = -H.yy - s;
    const double det = h11 * h22 - h12 * h12;
    if (!(h11 < 0.0 && det > 0.0)) return {false, m, s, z21};
    const double x1 = -(h22 * pt.g1 - h12 * pt.g2) / det;
    const double x2 = -(h11 * pt.g2 - h12 * pt.g1) / det;
    m = unit({m.x + x1 * t1.x + x2 * t2.x, m.y + x1 * t1.y + x2 * t2.y, m.z + x1 * t1.z + x2 * t2.z});
  }
  const double s = pt.s, ghi = pt.ghi, eh = pt.eh;
  const Part &A = pt.A, &B = pt.B;
  // isotropic: the T with the largest reach max(T, (pmin T - 2 |g|) / |V'|) among valid ones (kappa > 0,
  // |g|^2 / (2 kappa) <= tol_d), halving from 8 min_i h_i / l_i (the Hessian changes on the scale h_i / l_i)
  // while the reach grows; any T that passes the test is valid, the search only affects the size of the region
  const double la2 = max2(sym2_max(A.G.xx, A.G.xy, A.G.yy), 1e-300);
  const double lb2 = max2(sym2_max(B.G.xx, B.G.xy, B.G.yy), 1e-300);
  double T = min2(1.0, 8.0 * min2(A.hlo / math::sqrt(la2), B.hlo / math::sqrt(lb2)));
  double bestT = 0.0, best_reach = 0.0, best_pmin = 0.0;
  for (int k = 0; k < 64; ++k) {
    const Curvature c = curvature(T, T, cs, sn, A, B, eh);
    if (c.pmin - Vp > 0.0 && need <= c.pmin - Vp) {
      const double reach = max2(T, (c.pmin * T - 2.0 * ghi) / Vp);
      if (reach > best_reach) {
        bestT = T;
        best_reach = reach;
        best_pmin = c.pmin;
      } else {
        break;
      }
    } else if (best_reach > 0.0) {
      break;
    }
    T *= 0.5;
  }
  if (bestT <= 0.0) return {false, m, s, z21};
  double kw = bestT, ks = bestT;
  // a valley (weak curvature barely above |V|, strong one much larger): the ellipse ks = T / 2, kw doubled
  // while valid
  if (ls > 4.0 * lw && best_pmin < 4.0 * Vp) {
    const double ks2 = 0.5 * bestT;
    double kw2 = 0.0;
    double t = bestT;
    for (int k = 0; k < 10; ++k) {
      t *= 2.0;
      const Curvature c = curvature(t, ks2, cs, sn, A, B, eh);
      if (c.pmin - Vp > 0.0 && need <= c.pmin - Vp) {
        kw2 = t;
      } else {
        break;
      }
    }
    if (kw2 >= 4.0 * bestT) {
      kw = kw2;
      ks = ks2;
    }
  }
  const Curvature cv = curvature(kw, ks, cs, sn, A, B, eh);
  const Sym2& P = cv.P;
  const double pmin = cv.pmin;
  const double kmin = min2(kw, ks), kmax = max2(kw, ks);
  const Sym2 Ki = conj(cs, sn, 1.0 / kw, 1.0 / ks);  // K^-1 (rounding: covered by the test's relative margins)
  // mu_K = lambda_min(K P K): x^T P x >= mu_K |K^-1 x|^2, so every x outside the ellipse with
  // |V'| |x|^2 + 2 |g| |x| <= mu_K |K^-1 x| is in Omega
  const Sym2 K = conj(cs, sn, kw, ks);
  const double m00 = K.xx * P.xx + K.xy * P.xy;
  const double m01 = K.xx * P.xy + K.xy * P.yy;
  const double m10 = K.xy * P.xx + K.yy * P.xy;
  const double m11 = K.xy * P.xy + K.yy * P.yy;
  const double kp0 = m00 * K.xx + m01 * K.xy, kp1 = m00 * K.xy + m01 * K.yy, kp2 = m10 * K.xy + m11 * K.yy;
  const EigenBound mk = sym2_min(kp0, kp1, kp2);
  double muK = mk.value - mk.err - 1e-13 * (fabs(kp0) + fabs(kp1) + fabs(kp2)) -
               64.0 * U64 * kmax * kmax * (fabs(P.xx) + fabs(P.xy) + fabs(P.yy));
  double r_in = max2(kmin, (pmin * kmin - 2.0 * ghi) / Vp * (1.0 - 1e-14));
  if (muK > 0.0) {  // |x| <= r with |V'| r^2 + 2 |g| r <= mu_K
    r_in = max2(r_in, (math::sqrt(ghi * ghi + Vp * muK) - ghi) / Vp * (1.0 - 1e-13));
  } else {
    muK = 0.0;
  }
  const double pmax = sym2_max(P.xx, P.xy, P.yy);
  const double r_out = max2(kmax, pmax * kmax / Vp) * 1.01 + 1e-9;
  const double R_in = chord(r_in);
  const double R_out = 2.0 * math::sin(0.5 * math::atan(r_out)) + 1e-9;
  if (R_in <= 0.0) return {false, m, s, z21};
  const double ik = 1.0 / kmin;
  const Region region = {{m.x,   m.y, m.z,  t1.x, t1.y, t1.z, t2.x, t2.y, t2.z,  Ki.xx, Ki.xy,
                          Ki.yy, ik,  P.xx, P.xy, P.yy, Vp,   ghi,  R_in, R_out, R_in,  muK}};
  return {true, m, s, region};
}

// True if the cap |n - c| <= rho of unit n lies in the certified region d (see certify_region).  The cap in the
// inscribed cap (chord R_in) is; one not inside the cap of chord R_out, or of rho > 1, is not.  Otherwise its
// central projection onto the tangent plane lies in the disk around x_c = (c.t1, c.t2) / c.m of radius
// r_x = rho_geodesic / (c.m - rho)^2 (+ 1e-13 (1 + |x_c|^2) for the rounding and the near-orthonormal t1, t2,
// m); that disk is tested against Omega with bounds over the disk.
ELLIPSIM_HD bool in_region(const Vec3& c, double rho, const Region& region) {
  const double* d = region.d;
  const double dx = c.x - d[0], dy = c.y - d[1], dz = c.z - d[2];
  const double q2 = dx * dx + dy * dy + dz * dz;
  const double qi = d[18] - rho - 1e-15;
  if (qi > 0.0 && q2 <= qi * qi * (1.0 - 1e-14)) return true;  // cap in the inscribed cap
  const double qo = d[19] + rho;
  if (q2 >= qo * qo || rho > 1.0) return false;
  const double al = c.x * d[0] + c.y * d[1] + c.z * d[2];
  const double amin = al - rho * (1.0 + 1e-15) - 1e-15;
  if (amin <= 0.0) return false;
  const double ial = 1.0 / al;
  const double x0 = (c.x * d[3] + c.y * d[4] + c.z * d[5]) * ial;
  const double x1 = (c.x * d[6] + c.y * d[7] + c.z * d[8]) * ial;
  const double xx = x0 * x0 + x1 * x1;
  const double rx = rho * (1.0 + 0.25 * rho * rho) * (1.0 + 1e-15) / (amin * amin) * (1.0 + 1e-14) + 1e-13 * (1.0 + xx);
  const double k0 = d[9] * x0 + d[10] * x1, k1 = d[10] * x0 + d[11] * x1;
  // |K^-1 x| to within 1e-9 relative: K^-1 is rounded (entries by 4 u / k_min, relative to the ellipse's short
  // axis 4 u k_max / k_min <= 1e-12 for the anisotropy <= 2^11 used)
  const double thi = (math::sqrt(k0 * k0 + k1 * k1) * (1.0 + 1e-9) + rx * d[12]) * (1.0 + 1e-14);
  if (thi <= 1.0) return true;  // in the ellipse
  const double X = (math::sqrt(xx) + rx) * (1.0 + 1e-14);
  const double grow = (d[16] * X * X + 2.0 * d[17] * X) * (1.0 + 1e-13);
  const double tlo = (math::sqrt(k0 * k0 + k1 * k1) * (1.0 - 1e-9) - rx * d[12]) * (1.0 - 1e-14);
  if (grow <= d[21] * max2(1.0, tlo)) return true;  // every point of the disk outside the ellipse satisfies mu_K's
  const double lhs = thi * grow;
  const double p0 = d[13] * x0 + d[14] * x1, p1 = d[14] * x0 + d[15] * x1;
  const double rhs = (x0 * p0 + x1 * p1) * (1.0 - 1e-13) - 2.0 * rx * math::sqrt(p0 * p0 + p1 * p1) * (1.0 + 1e-13);
  return lhs <= rhs;
}

// certify_region as a call (in the Python kept out of the branch and bound's loop body).
ELLIPSIM_HD Certified certify_region_call(const Vec3& m, const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b,
                                          double amax, double bmax, double S, double err_sigma, double tol) {
  return certify_region(m, e, a, U, b, amax, bmax, S, err_sigma, tol);
}

// (converged, m, sigma(m)) of climb.
struct Climb {
  bool converged;
  Vec3 m;
  double value;
};

// Newton from c (in the Python kept out of the branch and bound's loop body).
ELLIPSIM_HD Climb climb(const Vec3& c, const Vec3& e, const Vec3& a, const Mat3& M, double scale) {
  const Vec3 a2 = {a.x * a.x, a.y * a.y, a.z * a.z};
  const NewtonResult r = newton(c, e, a2, M, scale, -INFINITY, tol::NEWTON_MAX_ITER);
  return {r.status == CONVERGED, r.n, r.value};
}

namespace branch_and_bound {

// Index of the certified region whose maximum is m (to 1e-6), or -1.
ELLIPSIM_HD int match(const Vec3& m, const Region* regions, int nd) {
  for (int k = 0; k < MAX_DISKS; ++k) {
    if (k >= nd) break;
    const double* d = regions[k].d;
    const double dx = m.x - d[0], dy = m.y - d[1], dz = m.z - d[2];
    if (dx * dx + dy * dy + dz * dz < 1e-12) return k;
  }
  return -1;
}

// regions with the launch radius of region k raised to D: Newton from within it climbs to that region's
// maximum, so patches there launch no more runs (a heuristic: the proof never uses it).
ELLIPSIM_HD void widen(Region* regions, int k, double D) {
  Region& d = regions[k == 0 ? 0 : k == 1 ? 1 : k == 2 ? 2 : 3];
  d.d[20] = max2(d.d[20], D);
}

}  // namespace branch_and_bound

// True if the cap |n - c| <= rho lies in one of the certified regions.
ELLIPSIM_HD bool in_regions(const Vec3& c, double rho, const Region* regions, int nd) {
  for (int k = 0; k < branch_and_bound::MAX_DISKS; ++k) {
    if (k >= nd) break;
    if (in_region(c, rho, regions[k])) return true;
  }
  return false;
}

namespace branch_and_bound {

// True if the cap |n - c| <= rho lies in the inscribed cap (chord R_in) of a certified region (triangle
// inequality; |c - m| compared squared, with margins for its rounding).
ELLIPSIM_HD bool in_caps(const Vec3& c, double rho, const Region* regions, int nd) {
  for (int k = 0; k < MAX_DISKS; ++k) {
    if (k >= nd) break;
    const double* d = regions[k].d;
    const double q = d[18] - rho - 1e-15;
    if (q > 0.0) {
      const double dx = c.x - d[0], dy = c.y - d[1], dz = c.z - d[2];
      if (dx * dx + dy * dy + dz * dz <= q * q * (1.0 - 1e-14)) return true;
    }
  }
  return false;
}

// True if the cap |n - c| <= rho meets one of the launch caps (heuristic: no rounding care).
ELLIPSIM_HD bool near_regions(const Vec3& c, double rho, const Region* regions, int nd) {
  for (int k = 0; k < MAX_DISKS; ++k) {
    if (k >= nd) break;
    const double* d = regions[k].d;
    const double q = d[20] + rho;
    const double dx = c.x - d[0], dy = c.y - d[1], dz = c.z - d[2];
    if (dx * dx + dy * dy + dz * dz < q * q) return true;
  }
  return false;
}

// (c.e, h_A(c), h_B(c), grad h_A(c) + grad h_B(c), 1 / h_B).
struct HParts {
  double ce, ha, hb;
  Vec3 gs;
  double ib;
};

// sigma and its gradient at c and at -c (sigma(+-c) = +-c.e - h_A - h_B, G(+-c) = e -+ (grad h_A + grad h_B);
// the h are even).
ELLIPSIM_HD HParts h_parts(const Vec3& c, const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b) {
  const double x0 = a.x * c.x, x1 = a.y * c.y, x2 = a.z * c.z;
  const double ha = math::sqrt(x0 * x0 + x1 * x1 + x2 * x2);
  const Vec3 w = rotate_t(U, c);
  const double y0 = b.x * w.x, y1 = b.y * w.y, y2 = b.z * w.z;
  const double hb = math::sqrt(y0 * y0 + y1 * y1 + y2 * y2);
  const double ce = c.x * e.x + c.y * e.y + c.z * e.z;
  const double iab = 1.0 / (ha * hb);
  const double ia = hb * iab, ib = ha * iab;  // 1/h_A, 1/h_B with 2 roundings more than a division: counted
  const Vec3 gb = matvec(U, {b.x * y0 * ib, b.y * y1 * ib, b.z * y2 * ib});
  return {ce, ha, hb, {a.x * x0 * ia + gb.x, a.y * x1 * ia + gb.y, a.z * x2 * ia + gb.z}, ib};
}

// sigma <= lv on the cap |n - c| <= rho, from sigma(c) = s and G = grad sigma(c): the bound
// s + (|G_T| + eps_G) rho + max(-G.c, 0) rho^2 / 2 <= lv, compared without a square root.
ELLIPSIM_HD bool test(const Vec3& c, double rho, double s, const Vec3& G, double epsg, double lv) {
  const double gc = G.x * c.x + G.y * c.y + G.z * c.z;
  const double t0 = G.x - gc * c.x, t1 = G.y - gc * c.y, t2 = G.z - gc * c.z;
  const double r = lv - s - max2(-gc, 0.0) * (rho * rho) * 0.5000000000001 - epsg * rho;
  if (r < 0.0) return false;
  const double tt = (t0 * t0 + t1 * t1 + t2 * t2) * (rho * rho);
  return tt * (1.0 + 16.0 * U64) <= r * r * (1.0 - 8.0 * U64);
}

// A quadtree position (face pair, level, i, j) and whether the subtree walk is done.
struct Position {
  int fp, level;
  int64_t i, j;
  bool done;
};

// The next quadtree position after (fp, level, i, j) in depth-first order, skipping its subtree, within the
// subtree of the node at level `root` (0: the whole face pair).
ELLIPSIM_HD Position next(int fp, int level, int64_t i, int64_t j, int root) {
  while (level > root + 1 && (i & 1) == 1 && (j & 1) == 1) {
    level -= 1;
    i >>= 1;
    j >>= 1;
  }
  if (level == root + 1 && (i & 1) == 1 && (j & 1) == 1) return {fp, level, i, j, true};
  if ((j & 1) == 0) return {fp, level, i, j + 1, false};
  return {fp, level, i + 1, j - 1, false};
}

}  // namespace branch_and_bound

// (status GLOBAL, UNPROVEN or SEPARATED_MAX, best unit n, sigma(n) as computed, nodes evaluated, Newton runs).
struct GlobalMax {
  int status;
  Vec3 n;
  double value;
  int64_t count;
  int runs;
};

// Proven global maximum of sigma on the unit sphere, in A's frame.
//
// n0, v0: a local maximum already found (have0 true) or nothing.  tol: the tolerance in A's frame (tol_bb of
// branch_and_bound.py, >= (PATCH_SLACK + 32) u S).  GLOBAL proves max sigma <= sigma(n) + tol for the exact
// sigma of (e, a, U, b).
//
// Depth first over the quadtrees of 3 pairs of opposite cube faces: a node is a patch and its antipode, which
// share h_A, h_B and their gradients (one evaluation for two patches).  Which of the two is still undecided is
// kept as 2 bits per level in one int64, so nothing is allocated.
ELLIPSIM_HD GlobalMax global_max(const Vec3& n0, double v0, bool have0, const Vec3& e, const Vec3& a, const Mat3& U,
                                 const Vec3& b, const Mat3& M, double scale, double tol, int64_t max_patches) {
  using namespace branch_and_bound;
  (void)v0;
  const double amax = max3(a);
  const double bmax = max3(b);
  const double S = math::sqrt(norm2(e)) + amax + bmax;
  const double slack = PATCH_SLACK_ULPS * U64 * S;
  const double err_sigma = ERR_SIGMA_ULPS * U64 * S;
  Vec3 best_n = {1.0, 0.0, 0.0};
  double best = -INFINITY;
  Region regions[MAX_DISKS] = {};
  int nd = 0;
  int runs = 0;
  // regions = (reg, regions[0], regions[1], regions[2])
  auto push_region = [&regions](const Region& reg) {
    for (int k = MAX_DISKS - 1; k > 0; --k) regions[k] = regions[k - 1];
    regions[0] = reg;
  };
  if (have0) {
    const Certified c = certify_region_call(n0, e, a, U, b, amax, bmax, S, err_sigma, tol);
    if (c.ok) {
      push_region(c.region);
      nd = 1;
      best_n = c.m;
      best = c.value;
    } else {
      best_n = n0;
      best = sigma_only(n0, e, a, U, b);
    }
  }
  // the cube turned so that the first certified maximum is the centre of face 0 (its region then meets few
  // large patches); the identity if there is none
  Mat3 Q = {{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}};
  if (nd > 0) {
    const double* r0 = regions[0].d;
    Q = {{r0[0], r0[3], r0[6], r0[1], r0[4], r0[7], r0[2], r0[5], r0[8]}};
  }
  int64_t aside[MAX_ASIDE][5] = {};  // deferred subtrees: (face pair, level, i, j, sides)
  int nu = 0, ai = 0;
  bool sub = false;
  int L0 = 0;  // in the main pass the subtrees are the face pairs (root level 0)
  int fp = 0, level = ROOT_LEVEL;
  int64_t i = 0, j = 0;
  int64_t alive = 0;  // bits 2L, 2L + 1: the patch (+) and its antipode (-) at level L were undecided
  int64_t count = 0;
  // the last node split: its gradient parts (sigma(n) <= G_p.n for every n, Euler + concavity) pre-test its
  // children before their own evaluation (valid while no deeper node was split)
  int pf = -1, pl = -1;
  int64_t pi = 0, pj = 0;
  Vec3 pgs = {0.0, 0.0, 0.0};
  double peps = 0.0;
  const double dot_err = 4.0 * U64 * S;
  // the end of a subtree: the next face pair in the main pass, else the next deferred subtree (false: none)
  auto finish = [&]() {
    if (!sub && fp < 2) {
      fp = fp + 1;
      level = ROOT_LEVEL;
      i = 0;
      j = 0;
      return true;
    }
    if (ai >= nu) return false;
    const int64_t* d = aside[ai];
    fp = int(d[0]);
    level = int(d[1]);
    i = d[2];
    j = d[3];
    const int64_t fl = d[4];
    ai += 1;
    const int sh = 2 * (level - 1);
    alive = (alive & ~(int64_t(3) << sh)) | (fl << sh);
    sub = true;
    L0 = level;
    pl = -1;
    return true;
  };
  while (true) {
    count += 1;
    if (count > max_patches) return {UNPROVEN, best_n, best, count, runs};
    int64_t par = level == ROOT_LEVEL ? 3 : (alive >> (2 * (level - 1))) & 3;
    const PatchPoint pp = patch_point(2 * fp, level, i, j, Q);
    const double inv = pp.inv, rho = pp.rho;
    const Vec3 c = {pp.p.x * inv, pp.p.y * inv, pp.p.z * inv};
    if (pl == level - 1 && pi == i >> 1 && pj == j >> 1 && pf == fp) {
      const double lvp = best + tol - slack - peps * 1.0001 - dot_err;
      for (int side = 0; side < 2; ++side) {
        if ((par >> side) & 1) {
          Vec3 cs, G;
          if (side == 0) {
            cs = c;
            G = {e.x - pgs.x, e.y - pgs.y, e.z - pgs.z};
          } else {
            cs = {-c.x, -c.y, -c.z};
            G = {e.x + pgs.x, e.y + pgs.y, e.z + pgs.z};
          }
          if (test(cs, rho, G.x * cs.x + G.y * cs.y + G.z * cs.z, G, peps, lvp)) par &= ~(int64_t(1) << side);
        }
      }
      if (par == 0) {
        const Position nx = next(fp, level, i, j, L0);
        fp = nx.fp;
        level = nx.level;
        i = nx.i;
        j = nx.j;
        if (nx.done && !finish()) break;
        continue;
      }
    }
    const HParts hp = h_parts(pp.p, e, a, U, b);  // at p = |p| c: scale the values (not G) by 1/|p|
    const double ce = hp.ce * inv, ha = hp.ha * inv, hb = hp.hb * inv;
    const Vec3& gs = hp.gs;
    const double epsg = U64 * (32.0 * (S + bmax * bmax * hp.ib * pp.pc * 1.01) + 16.0 * S);
    int64_t flags = 0;
    for (int side = 0; side < 2; ++side) {
      if (!((par >> side) & 1)) continue;
      Vec3 cs, G;
      double s;
      if (side == 0) {
        cs = c;
        s = ce - ha - hb;
        G = {e.x - gs.x, e.y - gs.y, e.z - gs.z};
      } else {
        cs = {-c.x, -c.y, -c.z};
        s = -ce - ha - hb;
        G = {e.x + gs.x, e.y + gs.y, e.z + gs.z};
      }
      bool done = in_caps(cs, rho, regions, nd);
      if (!done) done = test(cs, rho, s, G, epsg, best + tol - slack);
      if (!done && nd > 0) done = in_regions(cs, rho, regions, nd);
      bool launch = false;
      if (s > best) {  // a better point than every maximum found: a new basin
        best_n = cs;
        best = s;
        done = false;
        launch = true;
      } else if (!done && (level == NEWTON_LEVEL_0 || level == NEWTON_LEVEL_1 || level == NEWTON_LEVEL_2)) {
        // undecided at a Newton level: climb from its centre unless the patch touches a launch cap (then it
        // is most likely the rim of a known basin); at the last Newton level unless its centre lies in one
        launch = !near_regions(cs, level != NEWTON_LEVEL_2 ? rho : 0.0, regions, nd);
      }
      if (launch) {
        const Climb cl = climb(cs, e, a, M, scale);
        runs += 1;
        if (cl.converged && cl.value > 0.0)
          // separated: sigma is concave on the ball and this local maximum is global
          return {SEPARATED_MAX, cl.m, sigma_only(cl.m, e, a, U, b), count, runs};
        if (cl.converged) {
          const int kd = match(cl.m, regions, nd);
          if (kd >= 0) {
            const double* d = regions[kd].d;
            const double dx = cs.x - d[0], dy = cs.y - d[1], dz = cs.z - d[2];
            widen(regions, kd, math::sqrt(dx * dx + dy * dy + dz * dz) + rho);
          } else {
            const Certified cr = certify_region_call(cl.m, e, a, U, b, amax, bmax, S, err_sigma, tol);
            if (cr.value > best) {
              best_n = cr.m;
              best = cr.value;
            }
            if (cr.ok) {
              push_region(cr.region);
              nd = min2(nd + 1, MAX_DISKS);
              done = in_regions(cs, rho, regions, nd);
            }
          }
        }
        if (!done) done = test(cs, rho, s, G, epsg, best + tol - slack);
      }
      if (!done) flags |= int64_t(1) << side;
    }
    if (flags != 0 && !sub && level >= DEFER_LEVEL && nu < MAX_ASIDE) {
      // undecided this deep in the main pass (typically a ridge or saddle as high as a poor incumbent): defer
      // the subtree; it is searched again at the end, with the final incumbent
      for (int k = MAX_ASIDE - 1; k > 0; --k)
        for (int q = 0; q < 5; ++q) aside[k][q] = aside[k - 1][q];
      aside[0][0] = fp;
      aside[0][1] = level;
      aside[0][2] = i;
      aside[0][3] = j;
      aside[0][4] = flags;
      nu += 1;
      flags = 0;
    }
    if (flags == 0) {
      bool fin;
      if (sub && level == L0) {
        fin = true;
      } else {
        const Position nx = next(fp, level, i, j, L0);
        fp = nx.fp;
        level = nx.level;
        i = nx.i;
        j = nx.j;
        fin = nx.done;
      }
      if (fin && !finish()) break;
    } else if (level >= MAX_LEVEL) {
      return {UNPROVEN, best_n, best, count, runs};
    } else {
      const int sh = 2 * level;
      alive = (alive & ~(int64_t(3) << sh)) | (flags << sh);
      pf = fp;
      pl = level;
      pi = i;
      pj = j;
      pgs = gs;
      peps = epsg;
      level += 1;
      i *= 2;
      j *= 2;
    }
  }
  return {GLOBAL, best_n, best, count, runs};
}

}  // namespace ellipsim::distance
