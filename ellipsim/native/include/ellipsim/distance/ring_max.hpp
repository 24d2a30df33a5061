// Proven maximum of sigma for nearly spheroidal pairs about a common axis: the maxima nearly form a ring.
//
// Spheroids on a common axis (on it, concentric, or near it; parallel or tilted by a little) have their maxima of
// sigma(n) = n.e - h_A(n) - h_B(n) on a circle about the axis.  When a body is a spheroid only to within
// eps of its size (a cross-section off a circle by eps, or a rotation orthonormal only to eps, as MuJoCo Warp's
// float32 geom_xmat: ~6e-8), that circle becomes a ring along which sigma varies by ~eps S: too flat for
// branch_and_bound.hpp's patches, and beyond spheroids.hpp's models, which take the non-revolution as an error
// delta0 and need 2 delta0 below the tolerance (80 u S in the deep branch).
//
// Here the model is sigma itself: h_A(n)^2 = n^T diag(a^2) n and h_B(n)^2 = n^T M n, M = U diag(b^2) U^T (exact
// for the U as given, orthonormal or not), in pole coordinates about A's axis k, n = (cos t, sin t cos phi,
// sin t sin phi) along A's axes (k, k + 1, k + 2).  spheroids.hpp's cells_bb bounds it on each cell by Taylor's
// theorem, the second partials in ball arithmetic: for a quadratic form P = n^T Q n,
//   P_t = 2 n_t.Q n, P_p = 2 n_p.Q n, P_tt = 2 (n_t.Q n_t - P), P_pp = 2 (n_pp.Q n + n_p.Q n_p),
//   P_tp = 2 (n_tp.Q n + n_t.Q n_p)   (n_tt = -n),
// and sqrt(P)'s from spheroids::root_second; Q's entries as balls carrying their rounding.  Along the ring the
// second partials are O(eps S): the cells there stay long in phi, so the ring costs few cells a level.  Centre
// values are sigma_only's (branch_and_bound.hpp: its rounding BB_ERR_SIGMA_ULPS u S) at the rounded direction
// (ERR_C_ULPS u S), as spheroids::tilted_max counts them; no model error.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "branch_and_bound.hpp"
#include "spheroids.hpp"

namespace ellipsim::distance {

namespace ring {

using spheroids::Ball;
using spheroids::HessianBalls;
using spheroids::ModelAt;

// A symmetric 3x3 form in pole order, its 6 entries (00, 01, 02, 11, 12, 22) as balls.
struct Form {
  Ball m[6];
};

// A ball 3-vector, components along (k, k + 1, k + 2).
struct BVec {
  Ball c[3];
};

// Ball of x y for balls x, y (spheroids::bm), and of x + y.
ELLIPSIM_HD Ball add(const Ball& x, const Ball& y) { return spheroids::ba(x, y, 1.0, 1.0); }

// Ball of u^T Q v.
ELLIPSIM_HD Ball quad(const Form& Q, const BVec& u, const BVec& v) {
  using spheroids::bm;
  const Ball* m = Q.m;
  const Ball w0 = add(add(bm(m[0], v.c[0]), bm(m[1], v.c[1])), bm(m[2], v.c[2]));
  const Ball w1 = add(add(bm(m[1], v.c[0]), bm(m[3], v.c[1])), bm(m[4], v.c[2]));
  const Ball w2 = add(add(bm(m[2], v.c[0]), bm(m[4], v.c[1])), bm(m[5], v.c[2]));
  return add(add(bm(u.c[0], w0), bm(u.c[1], w1)), bm(u.c[2], w2));
}

// u^T Q v at float vectors (the balls' midpoints).
ELLIPSIM_HD double quad_at(const Form& Q, const Vec3& u, const Vec3& v) {
  const Ball* m = Q.m;
  const double w0 = m[0].m * v.x + m[1].m * v.y + m[2].m * v.z;
  const double w1 = m[1].m * v.x + m[3].m * v.y + m[4].m * v.z;
  const double w2 = m[2].m * v.x + m[4].m * v.y + m[5].m * v.z;
  return u.x * w0 + u.y * w1 + u.z * w2;
}

// A form split about the pole: Q = p I + (q0 - p) e_0 e_0^T + E, p the mean of its two entries across the pole,
// q0 its pole entry, E the rest (small for a body nearly of revolution about the pole), its entries' roundings in
// E's radii.  On the sphere n^T Q n = p + (q0 - p) cos^2 t + n^T E n: ball arithmetic cannot see that
// cos^2 + sin^2 = 1, so with Q whole a cell's bounds would widen by ~p times its width in phi; split, only E's
// small entries do.
struct Split {
  double p, d;  // p, q0 - p
  Form E;
};

ELLIPSIM_HD Split split(const Form& Q) {
  using math::fabs;
  constexpr double U = tol::U;
  const double p = 0.5 * (Q.m[3].m + Q.m[5].m), d = Q.m[0].m - p;
  Split r = {p, d, Q};
  r.E.m[0] = {0.0, Q.m[0].r + 2.0 * U * (fabs(d) + fabs(p))};  // d's rounding, carried by e_0's entry
  r.E.m[3] = {Q.m[3].m - p, Q.m[3].r + 2.0 * U * (fabs(Q.m[3].m - p) + fabs(p))};
  r.E.m[5] = {Q.m[5].m - p, Q.m[5].r + 2.0 * U * (fabs(Q.m[5].m - p) + fabs(p))};
  return r;
}

// Balls of sqrt(P)'s second partials tt, pp, tp for P = n^T Q n over a cell (Q split; n, n_t, n_p, n_pp, n_tp the
// cell's pole vectors' balls; c2 = cos^2 t, s2 = sin^2 t, cs = cos t sin t), P known >= qlo.
ELLIPSIM_HD HessianBalls root_hessian(const Split& Q, const BVec& n, const BVec& nt, const BVec& np, const BVec& npp,
                                      const BVec& ntp, const Ball& c2, const Ball& s2, const Ball& cs, double qlo) {
  using spheroids::ba;
  using spheroids::bc;
  const Form& E = Q.E;
  const Ball En = quad(E, n, n);
  const Ball P = ba({Q.p, 0.0}, ba(bc(Q.d, c2), En, 1.0, 1.0), 1.0, 1.0);
  const Ball Pt = ba(bc(-2.0 * Q.d, cs), bc(2.0, quad(E, nt, n)), 1.0, 1.0);
  const Ball Pp = bc(2.0, quad(E, np, n));
  const Ball Ptt = ba(bc(-2.0 * Q.d, ba(c2, s2, 1.0, -1.0)), bc(2.0, ba(quad(E, nt, nt), En, 1.0, -1.0)), 1.0, 1.0);
  const Ball Ppp = bc(2.0, add(quad(E, npp, n), quad(E, np, np)));
  const Ball Ptp = bc(2.0, add(quad(E, ntp, n), quad(E, nt, np)));
  const spheroids::InvRoots ir = spheroids::inv_roots(P, qlo);
  return {spheroids::root_second(Ptt, Pt, Pt, ir.i1, ir.i3), spheroids::root_second(Ppp, Pp, Pp, ir.i1, ir.i3),
          spheroids::root_second(Ptp, Pt, Pp, ir.i1, ir.i3)};
}

// cells_bb's model: sigma of (e, a, U, b) itself in pole coordinates about A's axis k.
struct QuadricModel {
  int k;
  Vec3 e, a, b;  // A's frame
  Mat3 U;
  double ek, ex, ey;  // e in pole order
  Form A, B;          // diag(a^2) and U diag(b^2) U^T in pole order
  Split As, Bs;       // the same, split about the pole
  double qlo_a, qlo_b;

  // n in A's frame from its pole coordinates (z along axis k, then k + 1, k + 2).
  ELLIPSIM_HD Vec3 frame(double z, double x, double y) const {
    if (k == 0) return {z, x, y};
    if (k == 1) return {y, z, x};
    return {x, y, z};
  }

  ELLIPSIM_HD ModelAt at(double t, double p) const {
    const double ct = math::cos(t), st = math::sin(t), cp = math::cos(p), sp = math::sin(p);
    const Vec3 n = {ct, st * cp, st * sp}, nt = {-st, ct * cp, ct * sp}, np = {0.0, -st * sp, st * cp};
    const double s = sigma_only(frame(n.x, n.y, n.z), e, a, U, b);  // the centre value: sigma_only's rounding
    const double pa = quad_at(A, n, n), pb = quad_at(B, n, n);
    const double ha = math::sqrt(pa), hb = math::sqrt(pb);
    const double ia = 1.0 / ha, ib = 1.0 / hb;
    const double s_t = ek * nt.x + ex * nt.y + ey * nt.z - quad_at(A, nt, n) * ia - quad_at(B, nt, n) * ib;
    const double s_p = ex * np.y + ey * np.z - quad_at(A, np, n) * ia - quad_at(B, np, n) * ib;
    return {s, s_t, s_p, ha, hb};
  }

  ELLIPSIM_HD HessianBalls hessian(double tc, double ht, double pc, double hp) const {
    using spheroids::ba;
    using spheroids::bc;
    using spheroids::bm;
    const spheroids::TrigBall tb = spheroids::trig_ball(tc, ht), pb = spheroids::trig_ball(pc, hp);
    const Ball &ct = tb.c, &st = tb.s, &cp = pb.c, &sp = pb.s;
    const Ball zero = {0.0, 0.0};
    const BVec n = {{ct, bm(st, cp), bm(st, sp)}};
    const BVec nt = {{bc(-1.0, st), bm(ct, cp), bm(ct, sp)}};
    const BVec np = {{zero, bc(-1.0, bm(st, sp)), bm(st, cp)}};
    const BVec npp = {{zero, bc(-1.0, bm(st, cp)), bc(-1.0, bm(st, sp))}};
    const BVec ntp = {{zero, bc(-1.0, bm(ct, sp)), bm(ct, cp)}};
    const spheroids::FormBalls ef = spheroids::form_balls(ek, ex, ey, ct, st, cp, sp);
    const Ball c2 = bm(ct, ct), s2 = bm(st, st), cs = bm(ct, st);
    const HessianBalls ha = root_hessian(As, n, nt, np, npp, ntp, c2, s2, cs, qlo_a);
    const HessianBalls hb = root_hessian(Bs, n, nt, np, npp, ntp, c2, s2, cs, qlo_b);
    return {ba(ba(ef.ltt, ha.tt, 1.0, -1.0), hb.tt, 1.0, -1.0), ba(ba(ef.lpp, ha.pp, 1.0, -1.0), hb.pp, 1.0, -1.0),
            ba(ba(ef.ltp, ha.tp, 1.0, -1.0), hb.tp, 1.0, -1.0)};
  }
};

}  // namespace ring

// The proven maximum of sigma(n) = n.e - |diag(a) n| - |diag(b) U^T n| on the unit sphere (A's frame), by cells_bb
// over pole coordinates about A's axis of revolution (or nearest to one), from the incumbent n0 (unit): the
// header's comment.  When proven, max sigma <= sigma(n) + tol; n is n0 or a better cell centre.
ELLIPSIM_HD SpheroidMax ring_max(const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b, double tol, double S,
                                 const Vec3& n0) {
  using ring::Form;
  using spheroids::at;
  constexpr double U64 = tol::U;
  const int k = spheroids::axis_of(a).k;
  const int idx[3] = {k, (k + 1) % 3, (k + 2) % 3};
  const double amax = max3(a), bmax = max3(b);
  const double amin = min2(min2(a.x, a.y), a.z), bmin = min2(min2(b.x, b.y), b.z);
  // M = U diag(b^2) U^T, each entry within 4 u (sum_l |U_il U_jl| b_l^2) of the exact one: a ball of that radius
  const Vec3 b2 = {b.x * b.x, b.y * b.y, b.z * b.z};
  Form A = {}, B = {};
  const int pairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
  for (int q = 0; q < 6; ++q) {
    const int i = idx[pairs[q][0]], j = idx[pairs[q][1]];
    double m = 0.0, mag = 0.0;
    for (int l = 0; l < 3; ++l) {
      const double bl = spheroids::at(b2, l);
      m = m + U.m[3 * i + l] * U.m[3 * j + l] * bl;
      mag = mag + math::fabs(U.m[3 * i + l] * U.m[3 * j + l]) * bl;
    }
    B.m[q] = {m, 8.0 * U64 * mag};
    const double ai = spheroids::at(a, i);
    A.m[q] = i == j ? ring::Ball{ai * ai, 2.0 * U64 * ai * ai} : ring::Ball{0.0, 0.0};
  }
  // h_B^2 = |diag(b) U^T n|^2 >= b_min^2 sigma_min(U)^2 >= b_min^2 (1 - 3 def), def the largest entry of |U U^T - I|
  double def = 0.0;
  for (int p = 0; p < 3; ++p) {
    for (int q = p; q < 3; ++q) {
      const double v = U.m[3 * p] * U.m[3 * q] + U.m[3 * p + 1] * U.m[3 * q + 1] + U.m[3 * p + 2] * U.m[3 * q + 2] -
                       (p == q ? 1.0 : 0.0);
      def = max2(def, math::fabs(v));
    }
  }
  def += 4.0 * U64;
  const double qlo_a = amin * amin * (1.0 - 1e-12);
  const double qlo_b = (bmin * bmin * (1.0 - 3.0 * def) - 24.0 * U64 * bmax * bmax) * (1.0 - 1e-12);
  const double tol1 = tol - (spheroids::ERR_C_ULPS + tol::BB_ERR_SIGMA_ULPS + 8.0) * U64 * S;
  if (!(tol1 > 0.0 && qlo_a > 0.0 && qlo_b > 0.0)) return {false, n0, 0};
  const ring::QuadricModel model = {k,     e, a, b, U, at(e, k), at(e, idx[1]), at(e, idx[2]), A, B, ring::split(A),
                                     ring::split(B), qlo_a, qlo_b};
  const double nk = at(n0, k), nk1 = at(n0, idx[1]), nk2 = at(n0, idx[2]);
  const double t0 = math::atan2(math::sqrt(nk1 * nk1 + nk2 * nk2), nk);
  const double p0 = math::atan2(nk2, nk1);
  const AxisBB r = cells_bb(model, tol1, S, amax * amax, bmax * bmax * (1.0 + 4.0 * def), t0, p0);
  if (!r.moved) return {r.proven, n0, r.nodes};
  const double z = math::cos(r.t), rr = math::sin(r.t);
  return {r.proven, model.frame(z, rr * math::cos(r.p), rr * math::sin(r.p)), r.nodes};
}

}  // namespace ellipsim::distance
