// The certified float64 filter: decides a pair of ellipsoids only when a rigorous error bound
// proves it (ellipsim/core/exact/certified_filter.py has the proofs).
//
// * separated: a separating direction (bounding spheres, the centre line, the bisector of the exit
//   normals, each against the exact support functions), or some mu > 0 with f(mu) > 0: f(0) < 0 and
//   f(+inf) < 0, so f(mu) > 0 forces two distinct positive roots of det(lambda A + B), separated by
//   the theorem of Wang, Wang & Kim (thesis ch. 4, Theorem 1).
// * overlapping: a point strictly inside both, on the centre segment or the Perram-Wertheim point
//   y(mu*) in A's frame.
//
// Each test compares a computed value with gamma_n * mag + TAU (pair_frame.hpp, tolerances.hpp).
// Touching pairs, and pairs too close to touching for float64, come back UNDECIDED for exact
// arithmetic: a decision here is never wrong; an ill-conditioned float only makes it slower.
#pragma once

#include "../math.hpp"

#include "../relation.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "contact_scale.hpp"
#include "pair_frame.hpp"

namespace ellipsim::exact {

// True when value, computed with error at most err * mag + TAU, is certainly > 0.
ELLIPSIM_HD bool positive(double value, double mag, double err) { return value > err * mag + tol::TAU; }

// |c_b - c_a|^2 = dd [4] beyond (rho_a + rho_b)^2: |x - c| <= r_max * BOUNDING_INFLATION on E.
ELLIPSIM_HD bool bounding_spheres_apart(const Vec3& ra, const Vec3& rb, double dd) {
  const double rho = (max3(ra) + max3(rb)) * tol::BOUNDING_INFLATION;
  const double rr = rho * rho;
  return positive(dd - rr, dd + rr, tol::ERR_SHORT) || (dd == INFINITY && rr < 1e300);
}

// n . d > h_A(n) + h_B(-n): the plane normal to n separates A and B.  nd = n . (c_b - c_a) with its
// mag mnd, nn = |n|^2, za = R_a^T n, zb = R_b^T n.  The exact support h(n) = |D R^{-1} n| is taken as
// |D R^T n| plus SUPPORT_SLACK * (r_max,a + r_max,b) * |n| (tolerances.hpp).
ELLIPSIM_HD bool axis_separates(double nd, double mnd, double nn, const Vec3& za, const Vec3& ra, const Vec3& zb,
                                const Vec3& rb, double rsum) {
  const double ax = ra.x * za.x, ay = ra.y * za.y, az = ra.z * za.z;
  const double bx = rb.x * zb.x, by = rb.y * zb.y, bz = rb.z * zb.z;
  const double ha = math::sqrt(ax * ax + ay * ay + az * az);
  const double hb = math::sqrt(bx * bx + by * by + bz * bz);
  const double bound = ha + hb + tol::SUPPORT_SLACK * rsum * math::sqrt(nn);
  return positive(nd - bound, mnd + bound, tol::ERR_SHORT);
}

// The bisector of Q_A d and Q_B d, the normals where the centre line leaves A and B (za = R_a^T d,
// zb = R_b^T d), scaled by det(D)^2 > 0.  Any float vector is a valid candidate: the test is rigorous.
ELLIPSIM_HD Vec3 bisector_axis(const Mat3& Ra, const Vec3& ra, const Vec3& za, const Mat3& Rb, const Vec3& rb,
                               const Vec3& zb) {
  const double a0 = ra.x * ra.x, a1 = ra.y * ra.y, a2 = ra.z * ra.z;
  const double b0 = rb.x * rb.x, b1 = rb.y * rb.y, b2 = rb.z * rb.z;
  const Vec3 na = matvec(Ra, {za.x * a1 * a2, za.y * a0 * a2, za.z * a0 * a1});
  const Vec3 nb = matvec(Rb, {zb.x * b1 * b2, zb.y * b0 * b2, zb.z * b0 * b1});
  const double la = math::sqrt(norm2(na)), lb = math::sqrt(norm2(nb));
  return {na.x * lb + nb.x * la, na.y * lb + nb.y * la, na.z * lb + nb.z * la};
}

ELLIPSIM_HD bool bisector_separates(const Vec3& d, const Mat3& Ra, const Vec3& ra, const Vec3& za, const Mat3& Rb,
                                    const Vec3& rb, const Vec3& zb, double rsum) {
  const Vec3 n = bisector_axis(Ra, ra, za, Rb, rb, zb);
  const double nd = n.x * d.x + n.y * d.y + n.z * d.z;
  const double mnd = math::fabs(n.x * d.x) + math::fabs(n.y * d.y) + math::fabs(n.z * d.z);
  return axis_separates(nd, mnd, norm2(n), rotate_t(Ra, n), ra, rotate_t(Rb, n), rb, rsum);
}

// A point c_a + t d of the centre segment strictly inside both: t^2 q_A(c_b) < 1 and
// (1 - t)^2 q_B(c_a) < 1, with q_A(c_b) = ee [8], q_B(c_a) = qb [8] and t equalising the two.
ELLIPSIM_HD bool centre_segment_overlaps(double ee, double mee, double qb, double mqb) {
  const double sa = math::sqrt(ee), sb = math::sqrt(qb);
  const double t = sb / (sa + sb);
  const double s = 1.0 - t;  // [1]
  return positive(1.0 - t * t * ee, 1.0 + t * t * mee, tol::ERR_SHORT) &&
         positive(1.0 - s * s * qb, 1.0 + s * s * mqb, tol::ERR_SHORT);
}

// y(mu) = (mu I + K_c)^{-1} K_c e = (mu^2 g1 + mu (t1 g1 - g2) + t3 e) / P(mu), g_k = K_c^k e: a
// candidate point only; inside_both checks it rigorously.
ELLIPSIM_HD Vec3 witness(double mu, const Mat3& W, const Vec3& e, const Vec3& v, const Invariants& k) {
  const Vec3 g1 = rotate_t(W, v);  // W^T v
  const Vec3 g2 = rotate_t(W, matvec(W, g1));
  const double ip = 1.0 / (((mu + k.t1) * mu + k.t2) * mu + k.t3);
  return {(mu * mu * g1.x + mu * (k.t1 * g1.x - g2.x) + k.t3 * e.x) * ip,
          (mu * mu * g1.y + mu * (k.t1 * g1.y - g2.y) + k.t3 * e.y) * ip,
          (mu * mu * g1.z + mu * (k.t1 * g1.z - g2.z) + k.t3 * e.z) * ip};
}

// |y|^2 < 1 [4] and alpha - |W_c (y - e)|^2 > 0 [13], both certified.
ELLIPSIM_HD bool inside_both(const Vec3& y, const Mat3& W, const Mat3& mW, const Vec3& e, const Vec3& me, double alpha,
                             double malpha) {
  const double yy = norm2(y);
  if (!positive(1.0 - yy, 1.0 + yy, tol::ERR_WITNESS)) return false;
  const Vec3 u = sub(y, e);  // [6]
  const Vec3 mu = {math::fabs(y.x) + me.x, math::fabs(y.y) + me.y, math::fabs(y.z) + me.z};
  return positive(alpha - norm2(matvec(W, u)), malpha + norm2(matvec(mW, mu)), tol::ERR_WITNESS);
}

// f(mu) > 0 certified: then the pencil has two distinct positive roots (separated).
ELLIPSIM_HD bool pencil_positive(double mu, const Invariants& inv, const Invariants& minv, double alpha,
                                 double malpha) {
  mu = min2(max2(mu, tol::MU_MIN), tol::MU_MAX);
  return positive(pencil(mu, inv, alpha), pencil_mag(mu, minv, malpha), tol::ERR_POLY);
}

// The Perram-Wertheim iteration in A's frame, trying a certificate whenever it is likely to hold:
// f(mu) > 0 as soon as F(mu) > 1, the point y(mu) once Newton's step is small against 1 - F.
ELLIPSIM_HD int8_t pencil_certificates(const Mat3& Ra, const Vec3& ra, const Mat3& Rb, const Vec3& ib,
                                            const Vec3& e, const Vec3& me, double ee, double qb) {
  const Shape sh = shape(Ra, ra, Rb, ib, true);
  const Vec3 v = matvec(sh.W, e), mv = matvec(sh.mW, me);
  const InvariantsWithMag k = invariants(sh.W, sh.mW, e, me, v, mv);
  double mu = initial_mu(ee, qb, sh.alpha);
  // The sphere-exact starting point alone settles ~80% of the pairs that get here.
  if (pw_value(mu, k.inv, sh.alpha) > 1.0 + tol::PW_TRY_SEPARATED) {
    if (pencil_positive(mu, k.inv, k.minv, sh.alpha, sh.malpha)) return SEPARATED;
  } else if (inside_both(witness(mu, sh.W, e, v, k.inv), sh.W, sh.mW, e, me, sh.alpha, sh.malpha)) {
    return OVERLAPPING;
  }
  double lo = 0.0, hi = INFINITY;
  for (int it = 0; it < tol::PW_MAX_ITER; ++it) {
    const PwStep s = pw_step(mu, k.inv, sh.alpha, lo, hi);
    lo = s.lo;
    hi = s.hi;
    const double step = math::fabs(s.mu - mu);
    const bool last = step <= tol::PW_RTOL * mu || it == tol::PW_MAX_ITER - 1;
    if ((s.value > 1.0 + tol::PW_TRY_SEPARATED || last) && pencil_positive(mu, k.inv, k.minv, sh.alpha, sh.malpha))
      return SEPARATED;
    if ((s.value < 1.0 && step < 0.1 * (1.0 - s.value) * mu) || last) {
      if (inside_both(witness(mu, sh.W, e, v, k.inv), sh.W, sh.mW, e, me, sh.alpha, sh.malpha)) return OVERLAPPING;
    }
    if (last) break;
    mu = s.mu;
  }
  return UNDECIDED;
}

// The float path's domain (tolerances.hpp: RATIO_MAX, SCALE_MIN, SCALE_MAX).
ELLIPSIM_HD bool in_float_range(const Vec3& ra, const Vec3& rb) {
  const double rmax = max2(max3(ra), max3(rb));
  return rmax <= tol::RATIO_MAX * min2(min3(ra), min3(rb)) && tol::SCALE_MIN <= rmax && rmax <= tol::SCALE_MAX;
}

// SEPARATED or OVERLAPPING when certain, else UNDECIDED.
ELLIPSIM_HD int8_t certify_pair(const Ellipsoid& A, const Ellipsoid& B) {
  const Vec3& ra = A.r;
  const Vec3& rb = B.r;
  const Vec3 d = sub(B.c, A.c);  // [1]
  const double dd = norm2(d);    // [4]
  if (dd == 0.0) return OVERLAPPING;  // concentric: the common centre is inside both
  if (bounding_spheres_apart(ra, rb, dd)) return SEPARATED;
  if (!in_float_range(ra, rb)) return UNDECIDED;
  const double rsum = max3(ra) + max3(rb);
  const Vec3 za = rotate_t(A.R, d), zb = rotate_t(B.R, d);  // [4]
  if (axis_separates(dd, dd, dd, za, ra, zb, rb, rsum)) return SEPARATED;  // the centre line
  const Vec3 md = abs3(d);
  const Vec3 mza = rotate_t_mag(A.R, md), mzb = rotate_t_mag(B.R, md);
  const Vec3 ia = reciprocal(ra), ib = reciprocal(rb);  // [1]
  const Vec3 e = {za.x * ia.x, za.y * ia.y, za.z * ia.z};  // [5]: q_A(c_b) = |e|^2
  const Vec3 me = {mza.x * ia.x, mza.y * ia.y, mza.z * ia.z};
  const Vec3 f = {zb.x * ib.x, zb.y * ib.y, zb.z * ib.z};  // q_B(c_a) = |f|^2
  const Vec3 mf = {mzb.x * ib.x, mzb.y * ib.y, mzb.z * ib.z};
  const double ee = norm2(e), qb = norm2(f);  // [8]
  if (centre_segment_overlaps(ee, norm2(me), qb, norm2(mf))) return OVERLAPPING;
  if (bisector_separates(d, A.R, ra, za, B.R, rb, zb, rsum)) return SEPARATED;
  return pencil_certificates(A.R, ra, B.R, ib, e, me, ee, qb);
}

// The first two of separated_by_axes's axes: the bounding spheres, then the centre line.
ELLIPSIM_HD bool centre_line_separates(const Ellipsoid& A, const Ellipsoid& B) {
  const Vec3 d = sub(B.c, A.c);
  const double dd = norm2(d);
  if (dd == 0.0) return false;
  if (bounding_spheres_apart(A.r, B.r, dd)) return true;
  if (!in_float_range(A.r, B.r)) return false;
  const double rsum = max3(A.r) + max3(B.r);
  return axis_separates(dd, dd, dd, rotate_t(A.R, d), A.r, rotate_t(B.R, d), B.r, rsum);
}

// The last of separated_by_axes's axes, the bisector of the exit normals.
ELLIPSIM_HD bool bisector_separates_pair(const Ellipsoid& A, const Ellipsoid& B) {
  const Vec3 d = sub(B.c, A.c);
  if (norm2(d) == 0.0 || !in_float_range(A.r, B.r)) return false;
  const double rsum = max3(A.r) + max3(B.r);
  return bisector_separates(d, A.R, A.r, rotate_t(A.R, d), B.R, B.r, rotate_t(B.R, d), rsum);
}

// A separating plane normal to one of three cheap axes, certified: the contact filter's test.
ELLIPSIM_HD bool separated_by_axes(const Ellipsoid& A, const Ellipsoid& B) {
  return centre_line_separates(A, B) || bisector_separates_pair(A, B);
}

}  // namespace ellipsim::exact
