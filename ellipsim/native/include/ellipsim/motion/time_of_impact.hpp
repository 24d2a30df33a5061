// Continuous collision detection: the first time two moving ellipsoids stop being separated
// (ellipsim/core/motion/time_of_impact.py has the derivations and the search's description).
//
// The motion is interpolation.hpp's.  Every real t in [0, toi - TOI_TOL] is proven separated by a chain of
// interval certificates, each a fixed plane normal n with n.d(t) - h_A(n; t) - h_B(-n; t) > 0 on its interval,
// the bound covering the exact motion and every float pose within rounding of it (the pose ball); at toi the
// pair is proven not separated (CONTACT: the motion, CONTACT_AT_FLOAT_POSE: the float pose P(toi)).
//
// The search per pair: swept bounding spheres, then a sweep of certified steps from the proven end, probing the
// float pose just beyond it by the certified filter when a step stalls.  Instants the filter cannot decide are
// looked up in the pair's oracle (ot, orel[:ocount]: exact relations at float times, caller-owned, filled by the
// exact fallback between kernel runs; python/time_of_impact.cpp) or asked for with NEED_EXACT and t_exact.
//
// Plain functions on doubles and small value types, one per numba stage, each expression in the Python's order
// of evaluation so that the two give the same bits; nothing allocates.
#pragma once

#include "../math.hpp"

#include "../exact/certified_filter.hpp"
#include "../exact/contact_scale.hpp"
#include "../exact/pair_frame.hpp"
#include "../relation.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "interpolation.hpp"

namespace ellipsim::motion::time_of_impact {

using exact::Cofactors;

// Statuses (int8), as `Impact` reports them; NEED_EXACT is internal (the kernel asks for the exact relation).
constexpr int8_t NO_CONTACT = 0;
constexpr int8_t CONTACT = 1;
constexpr int8_t CONTACT_AT_FLOAT_POSE = 2;
constexpr int8_t UNRESOLVED = 3;
constexpr int8_t NEED_EXACT = -1;

// _g: gamma_n with 1% for the rounding of the bound itself.
constexpr double g(int n) { return n * tol::U / (1.0 - n * tol::U) * 1.01; }

constexpr double G2 = g(2), G3 = g(3), G4 = g(4), G5 = g(5), G6 = g(6), G8 = g(8);
constexpr double ROUND_UP = 1.0 + 0x1p-40;  // a few roundings of a nonnegative bound, upwards

// --- tuples ---------------------------------------------------------------------------------------------------

// _load3: row i of a C-contiguous (n, 3) array.
ELLIPSIM_HD Vec3 load3(const double* X, int64_t i) { return {X[3 * i], X[3 * i + 1], X[3 * i + 2]}; }

// _load9: matrix i of a C-contiguous (n, 3, 3) array, row-major.
ELLIPSIM_HD Mat3 load9(const double* R, int64_t i) {
  const double* r = R + 9 * i;
  return {{r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]}};
}

// _norm.
ELLIPSIM_HD double norm(const Vec3& x) { return math::sqrt(norm2(x)); }

// _affine: x + f y.
ELLIPSIM_HD Vec3 affine(const Vec3& x, double f, const Vec3& y) { return {x.x + f * y.x, x.y + f * y.y, x.z + f * y.z}; }

// _scaled_norm: |D x| for D = diag(r).
ELLIPSIM_HD double scaled_norm(const Vec3& r, const Vec3& x) { return norm({r.x * x.x, r.y * x.y, r.z * x.z}); }

// --- R_p^{-1} n -------------------------------------------------------------------------------------------------

struct Solved {
  Vec3 p;
  double eps;  // |p~ - p|_2 <= eps
};

// _solve_inverse: p = R^{-1} n = C^T n / det and its error bound.
ELLIPSIM_HD Solved solve_inverse(const Cofactors<double>& inv, const Vec3& n) {
  const Vec3 N = rotate_t(inv.C, n);
  const Vec3 mN = rotate_t(inv.mC, abs3(n));
  const double det = inv.det, mdet = inv.mdet;
  const double ad = math::fabs(det);
  const double xi = G5 * mdet / (ad - G5 * mdet);
  const Vec3 p = {N.x / det, N.y / det, N.z / det};
  const double eps = (G5 * norm(mN) + norm(N) * (xi + 2.0 * tol::U) * 1.01) / (ad * (1.0 - xi));
  return {p, eps * 1.01};
}

// --- the certificate on an interval ---------------------------------------------------------------------------

// One body's terms of the certificate (_body_terms' seven values, then the half's r, r_max and theta).
struct Body {
  Vec3 q, x, aq, mx;
  double eps_q, c1, c2;
  Vec3 r;
  double rm, th;
};

// _body_terms: q = E(phi_m)^T R_p^{-1} n, x = w x q, their mags, eps_q and (c1, c2) for the exact q.
ELLIPSIM_HD Body body_terms(const Vec3& n, const Cofactors<double>& inv_p, const Vec3& w, const Rodrigues& rod,
                            const Vec3& r) {
  const Solved sv = solve_inverse(inv_p, n);
  const Vec3& p = sv.p;
  double eps_q = sv.eps;
  const Vec3 q = rodrigues_apply(rod, p);
  if (rod.om != 0.0 || rod.s != 0.0)  // a turn (none: E = I, applied exactly)
    eps_q += (tol::RODRIGUES_ERR + 12.0 * rod.al) * tol::U * norm(p) * 1.01;
  const Vec3 x = cross3(w, q);
  const Vec3 aq = abs3(q), aw = abs3(w);
  const Vec3 mx = cross3_mag(aw, aq);
  const Vec3 y = cross3(w, x);
  const Vec3 my = cross3_mag(aw, abs3(x));
  const double rm = max3(r);
  const double th = norm(w) * (1.0 + 8.0 * tol::U);
  const double mxs = mx.x + mx.y + mx.z;
  const double c1 = scaled_norm(r, x) * ROUND_UP + rm * (G2 * mxs + th * eps_q);
  const double c2 = scaled_norm(r, y) * ROUND_UP +
                    rm * (G2 * (my.x + my.y + my.z) + th * G2 * mxs * 1.01 + th * th * eps_q);
  return {q, x, aq, mx, eps_q, c1 * ROUND_UP, c2 * ROUND_UP, {0.0, 0.0, 0.0}, 0.0, 0.0};
}

// _setup's tuple: n.d and n.v at m, the error terms E0 + |s| E1, and both bodies' terms.
struct Setup {
  double nd, nv, E0, E1;
  Body A, B;
};

// _margin_lower: a certified lower bound of n.d(m + s) - phi_A(s) - phi_B(s) (not yet minus Q).
ELLIPSIM_HD double margin_lower(double s, const Setup& setup) {
  const double pa = scaled_norm(setup.A.r, affine(setup.A.q, -s, setup.A.x));
  const double pb = scaled_norm(setup.B.r, affine(setup.B.q, -s, setup.B.x));
  return setup.nd + s * setup.nv - pa - pb - (setup.E0 + math::fabs(s) * setup.E1 + (G3 + G4) * (pa + pb)) * 1.01;
}

// _remainder: Q(S) = S^2/2 |D W^2 q| + theta^2 S^3/6 |D W q|, rounded up.
ELLIPSIM_HD double remainder(double S, const Body& X) {
  return (0.5 * S * S * X.c2 + X.th * X.th * S * S * S * X.c1 / 6.0) * ROUND_UP;
}

// _certified: the margin bound on an interval from lo (the least _margin_lower at its ends) and S >= |s| on it.
ELLIPSIM_HD double certified(double lo, double S, const Setup& setup) {
  const double Q = remainder(S, setup.A) + remainder(S, setup.B);
  return lo - Q * (1.0 + 4.0 * tol::U) - G2 * (math::fabs(lo) + Q);
}

// _model_root: float guess of where the bound M0 + L1 S - Qc S^2 falls to zero.
ELLIPSIM_HD double model_root(const Setup& setup, double M0, double S_full) {
  double L1 = setup.nv - setup.E1;
  double Qc = 0.0;
  const Body* bodies[2] = {&setup.A, &setup.B};
  for (int k = 0; k < 2; ++k) {
    const Body& X = *bodies[k];
    const Vec3 z = {X.r.x * X.q.x, X.r.y * X.q.y, X.r.z * X.q.z};
    const Vec3 y = {X.r.x * X.x.x, X.r.y * X.x.y, X.r.z * X.x.z};
    const double ph = norm(z);
    if (ph > 0.0) L1 += (z.x * y.x + z.y * y.y + z.z * y.z) / ph;  // -d phi/ds = (Dq . Dx) / |Dq|
    Qc += 0.5 * X.c2;
  }
  if (Qc > 0.0) return min2(S_full, (L1 + math::sqrt(L1 * L1 + 4.0 * Qc * M0)) / (2.0 * Qc));
  if (L1 < 0.0) return min2(S_full, M0 / -L1);
  return S_full;
}

// _span_up: an upper bound of b - a for floats a <= b (exact by Sterbenz when a >= b / 2).
ELLIPSIM_HD double span_up(double a, double b) {
  const double d = b - a;
  if (a >= 0.5 * b) return d;
  return d * (1.0 + 4.0 * tol::U);
}

struct End {
  double b, fail;
};

// _largest_end: (b, fail), the largest float b in [m, end] found whose certificate on [a, b] holds, and the
// smallest end seen to fail; (a, a) when [a, m] itself fails.  The whole rest, a model guess, Illinois falsi.
ELLIPSIM_HD End largest_end(double a, double m, double end, const Setup& setup, bool quick) {
  const double M0 = margin_lower(0.0, setup);
  double slo = 0.0;
  double Mmin = M0;
  if (m > a) {
    slo = span_up(a, m);
    Mmin = min2(M0, margin_lower(-slo, setup));
  }
  const double L0 = certified(Mmin, slo, setup);
  if (!(L0 > 0.0)) return {a, a};
  const double S = span_up(m, end);
  const double L_hi = certified(min2(Mmin, margin_lower(S, setup)), max2(slo, S), setup);
  if (L_hi > 0.0) return {end, end};
  if (quick) return {m, end};
  double best = m;
  double lo_s = 0.0, lo_L = L0, hi_s = S, hi_L = L_hi;
  const double g = 0.95 * model_root(setup, L0, S);
  if (0.0 < g && g < S) {
    const double b = min2(m + g, end);
    if (b > m) {
      const double Sc = span_up(m, b);
      const double Lc = certified(min2(Mmin, margin_lower(Sc, setup)), max2(slo, Sc), setup);
      if (Lc > 0.0) {
        best = b;
        lo_s = Sc, lo_L = Lc;
        const double b2 = min2(m + 1.25 * g, end);
        const double S2 = span_up(m, b2);
        const double L2 = certified(min2(Mmin, margin_lower(S2, setup)), max2(slo, S2), setup);
        if (L2 > 0.0) {
          best = b2;
          lo_s = S2, lo_L = L2;
        } else if (S2 < hi_s) {
          hi_s = S2, hi_L = L2;
        }
      } else {
        hi_s = Sc, hi_L = Lc;
      }
    }
  }
  int side = 0;
  for (int it = 0; it < tol::TOI_FALSI_STEPS; ++it) {
    if (hi_s - lo_s <= tol::TOI_FALSI_RTOL * max2(lo_s, slo)) break;
    const double c = lo_s + 0.999 * lo_L * (hi_s - lo_s) / (lo_L - hi_L);
    const double b = min2(m + c, end);
    if (!(b > m)) break;
    const double Sc = span_up(m, b);
    const double Lc = certified(min2(Mmin, margin_lower(Sc, setup)), max2(slo, Sc), setup);
    if (Lc > 0.0) {
      best = b;
      lo_s = Sc, lo_L = Lc;
      if (side == -1) hi_L *= 0.5;
      side = -1;
    } else {
      hi_s = Sc, hi_L = Lc;
      if (side == 1) lo_L *= 0.5;
      side = 1;
    }
  }
  return {best, m + hi_s};
}

// One half's constants (_pair_data's half0, half1): tau = 0 on [0, 1/2], tau = 1 on (1/2, 1].
struct Half {
  Cofactors<double> inv_a, inv_b;
  Vec3 wa, wb, ra, rb;
  double rma, rmb, tha, thb;
  Vec3 d_tau, md_tau, v, mv;
  double ball;
  Vec3 da, db;
};

// _ctx_at's tuple: the half's constants with the rotations evaluated at a time m.
struct Ctx {
  int piece;
  Rodrigues rod_a, rod_b;
  const Half* half;
};

// _setup: everything the certificate needs for the plane normal n expanded at the float time m.
ELLIPSIM_HD Setup setup(const Vec3& n, double m, const Ctx& ctx) {
  const Half& h = *ctx.half;
  const double phi = m - double(ctx.piece);
  const Vec3 an = abs3(n);
  const double ap = math::fabs(phi);
  const Vec3 d = affine(h.d_tau, phi, h.v);
  const double nd = n.x * d.x + n.y * d.y + n.z * d.z;
  const Vec3& md = h.md_tau;
  const Vec3& mv = h.mv;
  const double m_nd = G8 * (an.x * (md.x + ap * mv.x) + an.y * (md.y + ap * mv.y) + an.z * (md.z + ap * mv.z));
  const double nv = n.x * h.v.x + n.y * h.v.y + n.z * h.v.z;
  const double m_nv = G6 * (an.x * mv.x + an.y * mv.y + an.z * mv.z);
  Body A = body_terms(n, h.inv_a, h.wa, ctx.rod_a, h.ra);
  A.r = h.ra, A.rm = h.rma, A.th = h.tha;
  Body B = body_terms(n, h.inv_b, h.wb, ctx.rod_b, h.rb);
  B.r = h.rb, B.rm = h.rmb, B.th = h.thb;
  const Vec3 &ra = h.ra, &rb = h.rb;
  const double ma0 = ra.x * A.aq.x + ra.y * A.aq.y + ra.z * A.aq.z + rb.x * B.aq.x + rb.y * B.aq.y + rb.z * B.aq.z;
  const double ma1 = ra.x * A.mx.x + ra.y * A.mx.y + ra.z * A.mx.z + rb.x * B.mx.x + rb.y * B.mx.y + rb.z * B.mx.z;
  const double E0 = m_nd + G5 * ma0 + h.rma * A.eps_q + h.rmb * B.eps_q + G4 * math::fabs(nd) +
                    h.ball * norm(n) * (1.0 + 4.0 * tol::U) + tol::TAU;
  const double E1 = m_nv + G5 * ma1 + h.rma * A.eps_q * h.tha + h.rmb * B.eps_q * h.thb + G4 * math::fabs(nv);
  return {nd, nv, E0, E1, A, B};
}

// _ctx_at: the half's constants with the rotations evaluated at the time m.
ELLIPSIM_HD Ctx ctx_at(double m, int piece, const Half& half) {
  const double phi = m - double(piece);
  return {piece, rodrigues(half.wa, phi), rodrigues(half.wb, phi), &half};
}

// --- poses and the exact relation at an instant -------------------------------------------------------------

// _pose's tuple: the float centres and rotations of A and B at t on a half.
struct FloatPose {
  Vec3 ca;
  Mat3 Ra;
  Vec3 cb;
  Mat3 Rb;
};

// _pose: centre of A phi Delta_a, of B d_tau + phi Delta_b, rotations fl(R_p E~(phi)), phi = t - tau.
ELLIPSIM_HD FloatPose pose(int piece, double t, const Mat3& Ra_p, const Mat3& Rb_p, const Rodrigues& rod_a,
                           const Rodrigues& rod_b, const Vec3& da, const Vec3& db, const Vec3& d_tau) {
  const double phi = t - double(piece);
  return {{phi * da.x, phi * da.y, phi * da.z}, matmul(Ra_p, rodrigues_matrix(rod_a)), affine(d_tau, phi, db),
          matmul(Rb_p, rodrigues_matrix(rod_b))};
}

struct ContactNormal {
  Vec3 n;
  double mu;
};

// _contact_normal: the Perram-Wertheim contact normal at a pose (from A to B), (0, 0, 0) when undefined.
ELLIPSIM_HD ContactNormal contact_normal(const Vec3& ca, const Mat3& Ra, const Vec3& ra, const Vec3& cb, const Mat3& Rb,
                                         const Vec3& rb, double mu0) {
  const exact::Offset<double> off = exact::offset(ca, Ra, ra, cb);
  const double ee = norm2(off.e);
  if (ee == 0.0) return {{0.0, 0.0, 0.0}, 0.0};
  const exact::Shape<double> sh = exact::shape(Ra, ra, Rb, reciprocal(rb), true);
  const Vec3 v = matvec(sh.W, off.e);
  const exact::Invariants inv = exact::invariants(sh.W, sh.mW, off.e, off.me, v, v).inv;
  if (inv.p1 == 0.0 || inv.t3 == 0.0) return {{0.0, 0.0, 0.0}, 0.0};
  const double mu =
      exact::pw_maximize(inv, sh.alpha, mu0 > 0.0 ? mu0 : exact::initial_mu(ee, inv.p1 / sh.alpha, sh.alpha), 1e-10);
  const Vec3 y = exact::witness(mu, sh.W, off.e, v, inv);
  return {matvec(Ra, {y.x / ra.x, y.y / ra.y, y.z / ra.z}), mu};  // R_a D_a^{-1} y: the gradient of q_A
}

// _witness_relation: CONTACT, CONTACT_AT_FLOAT_POSE, SEPARATED or UNDECIDED at a float pose near contact from
// one warm-started Perram-Wertheim solve, with room kappa for the pose's rounding.
ELLIPSIM_HD int witness_relation(const Vec3& ca, const Mat3& Ra, const Vec3& ra, const Vec3& cb, const Mat3& Rb,
                                 const Vec3& rb, double mu0, double kappa_a, double kappa_b) {
  const Vec3 d = {cb.x - ca.x, cb.y - ca.y, cb.z - ca.z};
  const double dd = norm2(d);
  if (dd == 0.0)  // concentric: the common centre is inside both, with room unless kappa >= 1
    return kappa_a < 1.0 && kappa_b < 1.0 ? CONTACT : CONTACT_AT_FLOAT_POSE;
  if (exact::bounding_spheres_apart(ra, rb, dd)) return SEPARATED;
  if (!exact::in_float_range(ra, rb)) return UNDECIDED;
  const exact::Offset<double> off = exact::offset(ca, Ra, ra, cb);
  const Vec3 &e = off.e, &me = off.me;
  const exact::Shape<double> sh = exact::shape(Ra, ra, Rb, reciprocal(rb), true);
  const Vec3 v = matvec(sh.W, e), mv = matvec(sh.mW, me);
  const exact::InvariantsWithMag<double> k = exact::invariants(sh.W, sh.mW, e, me, v, mv);
  if (!(k.inv.t3 > 0.0 && k.inv.p1 > 0.0)) return UNDECIDED;
  const double mu = exact::pw_maximize(
      k.inv, sh.alpha, mu0 > 0.0 ? mu0 : exact::initial_mu(norm2(e), k.inv.p1 / sh.alpha, sh.alpha), tol::PW_RTOL);
  if (exact::pw_value(mu, k.inv, sh.alpha) > 1.0)
    return exact::pencil_positive(mu, k.inv, k.minv, sh.alpha, sh.malpha) ? SEPARATED : UNDECIDED;
  const Vec3 y = exact::witness(mu, sh.W, e, v, k.inv);
  const double fa = 1.0 - (kappa_a + 4.0 * tol::U), fb = 1.0 - (kappa_b + 4.0 * tol::U);
  if (fa > 0.5 && fb > 0.5) {
    const double yy = norm2(y);
    const Vec3 u = {y.x - e.x, y.y - e.y, y.z - e.z};
    const Vec3 mu_ = {math::fabs(y.x) + me.x, math::fabs(y.y) + me.y, math::fabs(y.z) + me.z};
    if (exact::positive(fa * fa - yy, fa * fa + yy, tol::ERR_WITNESS) &&
        exact::positive(sh.alpha * (fb * fb) - norm2(matvec(sh.W, u)),
                        sh.malpha * (fb * fb) + norm2(matvec(sh.mW, mu_)), tol::ERR_WITNESS))
      return CONTACT;
  }
  return exact::inside_both(y, sh.W, sh.mW, e, me, sh.alpha, sh.malpha) ? CONTACT_AT_FLOAT_POSE : UNDECIDED;
}

// _lookup: the exact relation at t from the pair's oracle, or UNDECIDED.
ELLIPSIM_HD int lookup(double t, const double* ot, const int8_t* orel, int64_t ocount) {
  for (int64_t j = 0; j < ocount; ++j)
    if (ot[j] == t) return orel[j];
  return UNDECIDED;
}

// _pair_data's pair: the inputs, the power-of-two scale p, both halves' constants and _witness_relation's room.
struct Pair {
  Vec3 ca0;
  Mat3 Ra0;
  Vec3 ca1;
  Mat3 Ra1;
  Vec3 cb0;
  Mat3 Rb0;
  Vec3 cb1;
  Mat3 Rb1;
  Vec3 ra, rb, wa, wb;
  double p;
  Half half[2];
  double ka, kb;
};

// The float poses of A and B the kernel classifies at an instant.
struct PosePair {
  Ellipsoid A, B;
};

// _pose_at: the inputs at t = 0 and t = 1, elsewhere the float pose of the half t is on (unit-scaled, centres
// relative to c_a at tau).
ELLIPSIM_HD PosePair pose_at(double t, const Pair& pair) {
  if (t == 0.0) return {{pair.ca0, pair.Ra0, pair.ra}, {pair.cb0, pair.Rb0, pair.rb}};
  if (t == 1.0) return {{pair.ca1, pair.Ra1, pair.ra}, {pair.cb1, pair.Rb1, pair.rb}};
  const int piece = t <= 0.5 ? 0 : 1;
  const Half& half = pair.half[piece];
  const double phi = t - double(piece);
  const FloatPose P = pose(piece, t, piece == 0 ? pair.Ra0 : pair.Ra1, piece == 0 ? pair.Rb0 : pair.Rb1,
                           rodrigues(pair.wa, phi), rodrigues(pair.wb, phi), half.da, half.db, half.d_tau);
  return {{P.ca, P.Ra, half.ra}, {P.cb, P.Rb, half.rb}};
}

// _probe: what the pose at t proves, CONTACT, CONTACT_AT_FLOAT_POSE, SEPARATED or UNDECIDED (mu0 0: no warm start).
ELLIPSIM_HD int probe(double t, const Pair& pair, double mu0, const double* ot, const int8_t* orel,
                      int64_t ocount) {
  const PosePair P = pose_at(t, pair);
  const bool ends = t == 0.0 || t == 1.0;  // the inputs themselves: the motion there
  if (!ends) {
    const int rel = witness_relation(P.A.c, P.A.R, P.A.r, P.B.c, P.B.R, P.B.r, mu0, pair.ka, pair.kb);
    if (rel != UNDECIDED) return rel;
  }
  int rel = exact::certify_pair(P.A, P.B);
  if (rel == UNDECIDED) rel = lookup(t, ot, orel, ocount);
  if (rel == UNDECIDED || rel == SEPARATED) return rel;
  return ends ? CONTACT : CONTACT_AT_FLOAT_POSE;
}

// --- the search -------------------------------------------------------------------------------------------------

// _spheres_apart_on: n.d(t) > rho |n| (bounding spheres, rotation-free) for every t in [t_lo, t_hi].
ELLIPSIM_HD bool spheres_apart_on(const Vec3& n, double t_lo, double t_hi, const Vec3& d0, const Vec3& d1,
                                  const Vec3& v, double rho, double ball) {
  const double nn = norm(n);
  if (!(nn > 0.0)) return false;
  const Vec3 an = abs3(n);
  double worst = INFINITY;
  const double ends[2] = {t_lo, t_hi};
  for (int k = 0; k < 2; ++k) {
    const double t = ends[k];
    const bool near0 = t <= 0.5;
    const Vec3& dt = near0 ? d0 : d1;
    const double ph = near0 ? t : t - 1.0;
    const Vec3 x = affine(dt, ph, v);
    const double val = n.x * x.x + n.y * x.y + n.z * x.z;
    const double err = G8 * (an.x * (math::fabs(dt.x) + math::fabs(ph) * math::fabs(v.x)) +
                             an.y * (math::fabs(dt.y) + math::fabs(ph) * math::fabs(v.y)) +
                             an.z * (math::fabs(dt.z) + math::fabs(ph) * math::fabs(v.z)));
    worst = min2(worst, val - err);
  }
  return worst - rho * nn * (1.0 + 8.0 * tol::U) > ball * nn * (1.0 + 4.0 * tol::U) + tol::TAU;
}

// _pair_data's swept tuple: relative centres at 0 and 1, relative velocity, bounding radius and pose ball.
struct Swept {
  Vec3 d0, d1, v;
  double rho, ball;
};

struct PairData {
  Pair pair;
  Swept swept;
};

// _pair_data: per-pair constants, the pair scaled to unit size by a power of two (exact; t is unchanged).
ELLIPSIM_HD PairData pair_data(const Vec3& ca0, const Mat3& Ra0, const Vec3& ca1, const Mat3& Ra1, const Vec3& ra,
                               const Vec3& wa, const Vec3& cb0, const Mat3& Rb0, const Vec3& cb1, const Mat3& Rb1,
                               const Vec3& rb, const Vec3& wb) {
  const double p = unit_scale(ra, rb);
  const Vec3 ra_s = scaled(ra, p), rb_s = scaled(rb, p);
  const Vec3 da = {(ca1.x - ca0.x) * p, (ca1.y - ca0.y) * p, (ca1.z - ca0.z) * p};
  const Vec3 db = {(cb1.x - cb0.x) * p, (cb1.y - cb0.y) * p, (cb1.z - cb0.z) * p};
  const Vec3 d0 = {(cb0.x - ca0.x) * p, (cb0.y - ca0.y) * p, (cb0.z - ca0.z) * p};
  const Vec3 d1 = {(cb1.x - ca1.x) * p, (cb1.y - ca1.y) * p, (cb1.z - ca1.z) * p};
  const Vec3 v = {db.x - da.x, db.y - da.y, db.z - da.z};
  const Vec3 mv = {math::fabs(da.x) + math::fabs(db.x), math::fabs(da.y) + math::fabs(db.y),
                   math::fabs(da.z) + math::fabs(db.z)};
  const double rma = max3(ra_s), rmb = max3(rb_s);
  const double tha = norm(wa) * (1.0 + 8.0 * tol::U), thb = norm(wb) * (1.0 + 8.0 * tol::U);
  // the pose ball: rotations within DELTA_R (exactly R_p for a body that does not turn), centres within
  // 4.01u (|d_tau| + |Delta_a| + |Delta_b|) of the exact motion's
  const double dra = tha > 0.0 ? tol::DELTA_R : 0.0;
  const double drb = thb > 0.0 ? tol::DELTA_R : 0.0;
  const double turn = 1.00001 * (dra * rma + drb * rmb);
  const double ec0 = 4.01 * tol::U * (norm(d0) + norm(da) + norm(db));
  const double ec1 = 4.01 * tol::U * (norm(d1) + norm(da) + norm(db));
  PairData out;
  Pair& P = out.pair;
  P.ca0 = ca0, P.Ra0 = Ra0, P.ca1 = ca1, P.Ra1 = Ra1, P.cb0 = cb0, P.Rb0 = Rb0, P.cb1 = cb1, P.Rb1 = Rb1;
  P.ra = ra, P.rb = rb, P.wa = wa, P.wb = wb, P.p = p;
  P.half[0] = {exact::cofactors(Ra0), exact::cofactors(Rb0), wa, wb, ra_s, rb_s, rma, rmb, tha, thb, d0, abs3(d0), v,
               mv, ec0 + turn, da, db};
  P.half[1] = {exact::cofactors(Ra1), exact::cofactors(Rb1), wa, wb, ra_s, rb_s, rma, rmb, tha, thb, d1, abs3(d1), v,
               mv, ec1 + turn, da, db};
  // _witness_relation's room per body: (DELTA_R r_max (1 + 1e-5) + 1.00001 |c - c~|) / r_min, rounded up
  const double ec = max2(ec0, ec1) * 1.00001;
  P.ka = (dra * rma * (1.00001) + ec) / min3(ra_s) * 1.01;
  P.kb = (drb * rmb * (1.00001) + ec) / min3(rb_s) * 1.01;
  out.swept = {d0, d1, v, (rma + rmb) * tol::BOUNDING_INFLATION,
               4.01 * tol::U * (norm(d0) + norm(d1) + norm(da) + norm(db)) + turn};
  return out;
}

struct SweptSpheres {
  bool whole;
  double t_in, t_out;
};

// _swept_spheres: (proven whole, t_in, t_out) from rotation-free planes of the swept bounding spheres.
ELLIPSIM_HD SweptSpheres swept_spheres(const Swept& sw) {
  const Vec3 &d0 = sw.d0, &d1 = sw.d1, &v = sw.v;
  const double rho = sw.rho, ball = sw.ball;
  const double vv = norm2(v);
  double tc = 0.0;
  if (vv > 0.0) tc = min2(1.0, max2(0.0, -(d0.x * v.x + d0.y * v.y + d0.z * v.z) / vv));
  const Vec3 nc = affine(d0, tc, v);
  if (spheres_apart_on(nc, 0.0, 1.0, d0, d1, v, rho, ball)) return {true, 1.0, 1.0};
  double t_in = 0.0, t_out = 1.0;
  if (vv > 0.0) {
    const double rr = rho * (1.0 + 1e-6);
    const double r2 = rr * rr - norm2(nc);  // |d0 + t v| = rho (1 + 1e-6) at tc -+ sqrt(r2 / vv)
    if (r2 > 0.0) {
      const double h = math::sqrt(r2 / vv);
      if (tc - h > 0.0) {
        const double cand = (tc - h) * (1.0 - 1e-9);
        if (spheres_apart_on(affine(d0, cand, v), 0.0, cand, d0, d1, v, rho, ball)) t_in = cand;
      }
      if (tc + h < 1.0) {
        const double cand = 1.0 - (1.0 - (tc + h)) * (1.0 - 1e-9);
        if (spheres_apart_on(affine(d0, cand, v), cand, 1.0, d0, d1, v, rho, ball)) t_out = cand;
      }
    }
  }
  return {false, t_in, t_out};
}

// _good: a step that reached the end of the half, or a quarter of the rest (and more than TOI_STALL).
ELLIPSIM_HD bool good(double a, double b, double end) {
  return b == end || (b - a >= tol::TOI_STALL && b - a >= 0.25 * (end - a));
}

struct Step {
  double b, fail;
  Vec3 n_best;
  bool pw_first;
  double mu_last;
};

// _step: one sweep step from the proven end a on a half: (b, fail, normal used, pw_first, mu_last).
ELLIPSIM_HD Step step(double a, int piece, double end, bool first, bool carry, const Vec3& n_carry, bool pw_first,
                      double mu_last, const Pair& pair) {
  const Mat3& Ra_p = piece == 0 ? pair.Ra0 : pair.Ra1;
  const Mat3& Rb_p = piece == 0 ? pair.Rb0 : pair.Rb1;
  const Half& half = pair.half[piece];
  const Ctx ctx_a = ctx_at(a, piece, half);
  const bool use_mid = first && end - a > 1e-3;
  const double mid = use_mid ? a + 0.5 * (end - a) : a;
  const Ctx ctx_m = use_mid ? ctx_at(mid, piece, half) : ctx_a;
  double b = a, fail = end;
  Vec3 n_best = {0.0, 0.0, 0.0};
  for (int k = 0; k < 5; ++k) {
    if (k == 0 && !carry) continue;
    if ((k == 1 || k == 2) && !use_mid) continue;
    if (k >= 3 && good(a, b, end)) break;
    const bool at_mid = k == 1 || k == 2;
    const double m = at_mid ? mid : a;
    const Ctx& ctx = at_mid ? ctx_m : ctx_a;
    const bool use_pw = k == 2 || (k >= 3 && (k == 3) == pw_first);
    Vec3 n;
    if (k == 0) {
      n = n_carry;
    } else if (use_pw) {
      const FloatPose P = pose(piece, m, Ra_p, Rb_p, ctx.rod_a, ctx.rod_b, half.da, half.db, half.d_tau);
      const ContactNormal cn = contact_normal(P.ca, P.Ra, half.ra, P.cb, P.Rb, half.rb, k >= 3 ? mu_last : 0.0);
      n = cn.n;
      if (k >= 3) mu_last = cn.mu;
    } else {
      n = affine(half.d_tau, m - double(piece), half.v);
    }
    if (!(norm(n) > 0.0)) continue;
    const End e = largest_end(a, m, end, setup(n, m, ctx), k == 1);
    if (e.b > b) {
      b = e.b, fail = e.fail, n_best = n;
      if (k >= 3) pw_first = use_pw;
    }
    if (k <= 2 && b == end) break;
    if (k >= 3 && use_pw && e.b - a >= tol::TOI_STALL && e.fail - e.b <= 0.1 * (e.b - a))
      break;  // the contact normal's bound is tight at b: a contact ahead, not a poor normal
  }
  return {b, fail, n_best, pw_first, mu_last};
}

// toi_pair's tuple.
struct Impact {
  double toi;
  int status;
  double t_exact;  // with NEED_EXACT: the float time whose exact relation the search needs
  int64_t steps;
};

// toi_pair: (toi, status, t_exact, steps) for one pair; NEED_EXACT asks for the exact relation at the float pose
// at t_exact (then rerun with it in the oracle ot, orel[:ocount]).
ELLIPSIM_HD Impact toi_pair(const Vec3& ca0, const Mat3& Ra0, const Vec3& ca1, const Mat3& Ra1, const Vec3& ra,
                            const Vec3& wa, const Vec3& cb0, const Mat3& Rb0, const Vec3& cb1, const Mat3& Rb1,
                            const Vec3& rb, const Vec3& wb, const double* ot, const int8_t* orel,
                            int64_t ocount) {
  const PairData pd = pair_data(ca0, Ra0, ca1, Ra1, ra, wa, cb0, Rb0, cb1, Rb1, rb, wb);
  const Pair& pair = pd.pair;
  const SweptSpheres sw = swept_spheres(pd.swept);
  if (sw.whole) return {INFINITY, NO_CONTACT, 0.0, 0};
  if (sw.t_in == 0.0) {  // the bounding spheres meet at t = 0: classify the inputs
    const int rel = probe(0.0, pair, 0.0, ot, orel, ocount);
    if (rel == UNDECIDED) return {0.0, NEED_EXACT, 0.0, 0};
    if (rel != SEPARATED) return {0.0, rel, 0.0, 0};
  }
  const double t_out = sw.t_out;
  int stalls = 0;
  int64_t steps = 1;
  bool pw_first = true;  // the contact normal usually reaches farther than the centre line
  bool carry = false;
  bool first = true;
  Vec3 n_carry = {0.0, 0.0, 0.0};
  double mu_last = 0.0;
  double a = sw.t_in;
  while (a < t_out) {
    const int piece = a < 0.5 ? 0 : 1;
    const double end = min2(piece == 0 ? 0.5 : 1.0, t_out);
    steps += 1;
    if (steps > tol::TOI_MAX_STEPS) return {a, UNRESOLVED, 0.0, steps};
    const Step s = step(a, piece, end, first, carry, n_carry, pw_first, mu_last, pair);
    const double b = s.b, fail = s.fail;
    pw_first = s.pw_first, mu_last = s.mu_last;
    first = false;
    carry = b == end && piece == 0 && end == 0.5;
    if (carry) n_carry = s.n_best;
    if (b == end || (b - a >= tol::TOI_STALL && (fail - b > tol::TOI_PROBE || b - a > tol::TOI_PROBE_REACH))) {
      a = b;
      stalls = 0;
      continue;
    }
    // Stalled, or the certificate fails within TOI_PROBE of b near a: probe the pose just beyond the proven end.
    const bool stalled = b - a < tol::TOI_STALL;
    a = b;
    const double t1 = min2(a + tol::TOI_PROBE, 1.0);
    const int rel = probe(t1, pair, mu_last, ot, orel, ocount);
    if (rel == UNDECIDED) {
      // a deeper pose, still within TOI_TOL of the proven end, usually settles it in floats
      const double t2 = min2(a + tol::TOI_PROBE2, 1.0);
      const int rel2 = probe(t2, pair, mu_last, ot, orel, ocount);
      if (rel2 == CONTACT || rel2 == CONTACT_AT_FLOAT_POSE) return {t2, rel2, 0.0, steps};
      return {a, NEED_EXACT, t1, steps};
    }
    if (rel != SEPARATED) return {t1, rel, 0.0, steps};
    if (stalled) {
      stalls += 1;
      if (stalls >= tol::TOI_STALL_LIMIT) return {a, UNRESOLVED, 0.0, steps};
    } else {
      stalls = 0;
    }
  }
  return {INFINITY, NO_CONTACT, 0.0, steps};
}

// One body's two batches as the kernels read them (_check's tuples): (C0, R0, r) at t = 0, (C1, R1, W) at t = 1,
// C-contiguous (n, 3), (n, 3, 3), (n, 3), (n, 3), (n, 3, 3), (n, 3).
struct Motion {
  const double *C0, *R0, *r, *C1, *R1, *W;
  int64_t n;
};

// load_pair (with _loads): _pair_data of pair (ia, ib) of the two bodies' batches.
ELLIPSIM_HD PairData load_pair(const Motion& A, const Motion& B, int64_t ia, int64_t ib) {
  return pair_data(load3(A.C0, ia), load9(A.R0, ia), load3(A.C1, ia), load9(A.R1, ia), load3(A.r, ia),
                   load3(A.W, ia), load3(B.C0, ib), load9(B.R0, ib), load3(B.C1, ib), load9(B.R1, ib), load3(B.r, ib),
                   load3(B.W, ib));
}

// The oracle (caller-owned, (n, width) times and relations, n counts) and the kernel's four outputs, per pair.
struct Oracle {
  const double* t;
  const int8_t* rel;
  const int64_t* count;
  int64_t width;
};

struct Outputs {
  double* toi;
  int8_t* status;
  double* t_exact;
  int64_t* steps;
};

// _run_pair: toi_pair of pair i into the outputs' row i (sa, sb: 0 broadcasts a batch of one).
ELLIPSIM_HD void run_pair(int64_t i, const Motion& A, const Motion& B, int64_t sa, int64_t sb,
                          const Oracle& O, const Outputs& out) {
  const int64_t ia = i * sa, ib = i * sb;
  const Impact r = toi_pair(load3(A.C0, ia), load9(A.R0, ia), load3(A.C1, ia), load9(A.R1, ia), load3(A.r, ia),
                            load3(A.W, ia), load3(B.C0, ib), load9(B.R0, ib), load3(B.C1, ib), load9(B.R1, ib),
                            load3(B.r, ib), load3(B.W, ib), O.t + O.width * i, O.rel + O.width * i, O.count[i]);
  out.toi[i] = r.toi;
  out.status[i] = static_cast<int8_t>(r.status);
  out.t_exact[i] = r.t_exact;
  out.steps[i] = r.steps;
}

// _toi: the pairs idx[lo:hi].
ELLIPSIM_HD void toi(const Motion& A, const Motion& B, const int64_t* idx, const Oracle& O, const Outputs& out,
                     int64_t lo, int64_t hi) {
  const int64_t sa = A.n > 1, sb = B.n > 1;  // stride 0 broadcasts a batch of one
  for (int64_t k = lo; k < hi; ++k) run_pair(idx[k], A, B, sa, sb, O, out);
}

// _float_poses for entry k: the float pose the kernel classifies at t for pair i (centres (3), rotations (9),
// radii (3) of A and B into row k of the six outputs).
ELLIPSIM_HD void float_pose(const Motion& A, const Motion& B, int64_t i, double t, int64_t k, double* CA,
                            double* RA, double* ra, double* CB, double* RB, double* rb) {
  const int64_t sa = A.n > 1, sb = B.n > 1;
  const PairData pd = load_pair(A, B, i * sa, i * sb);
  const PosePair P = pose_at(t, pd.pair);
  const double a[3] = {P.A.c.x, P.A.c.y, P.A.c.z}, b[3] = {P.B.c.x, P.B.c.y, P.B.c.z};
  const double sa3[3] = {P.A.r.x, P.A.r.y, P.A.r.z}, sb3[3] = {P.B.r.x, P.B.r.y, P.B.r.z};
  for (int j = 0; j < 3; ++j) {
    CA[3 * k + j] = a[j], CB[3 * k + j] = b[j], ra[3 * k + j] = sa3[j], rb[3 * k + j] = sb3[j];
    for (int l = 0; l < 3; ++l) RA[9 * k + 3 * j + l] = P.A.R.m[3 * j + l], RB[9 * k + 3 * j + l] = P.B.R.m[3 * j + l];
  }
}

}  // namespace ellipsim::motion::time_of_impact
