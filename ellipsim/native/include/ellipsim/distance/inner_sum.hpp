// A one-shot proof that a deep local maximum of sigma is global: the internal ellipsoid of A + (-B) tangent in
// the contact direction (Kurzhanski & Valyi, Ellipsoidal Calculus for Estimation and Control, 1997, sec. 2.3:
// internal approximations of a sum of ellipsoids; ellipsim/core/distance/inner_sum.py has the argument).
//
// In A's principal frame (as branch_and_bound.hpp) sigma(n) = n.e - |F_A n| - |F_B n| with F_A = diag(a),
// F_B = diag(b) U^T, and max over unit n of sigma is the signed distance of the point e to the centred
// Minkowski sum M = A + B.  For any orthogonal S, X = S F_A + F_B has |X n| <= |F_A n| + |F_B n|, so the
// ellipsoid Q = X^T (unit ball) lies inside M and max sigma <= sd(e, Q) = -dist(e, boundary of Q).  S turns
// F_A n* / h_A(n*) onto F_B n* / h_B(n*) at the local maximum n* (Q touches M there), its remaining freedom
// (8 turns and 8 reflections) chosen for the largest smallest curvature radius of Q at the contact;
// dist(e, boundary Q)^2 >= g(t) = t (e^T (W + t I)^-1 e - 1) (Lagrangian weak duality), equality at
// t* = sigma(n*) (h_A(n*) + h_B(n*)) when the bound is tight.  Every rounding is taken outwards (Higham,
// Accuracy and Stability of Numerical Algorithms, 2nd ed., Thm 10.3 and 8.5).
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "sphere_newton.hpp"

namespace ellipsim::distance {

namespace inner_sum {

// Turns (and as many reflections) of S tried about the contact direction: 8, 45 degrees apart; the values
// Python's math.cos(2 pi k / 8) and math.sin(2 pi k / 8) gave inner_sum.py's _COS and _SIN (shortest repr),
// as local arrays (host-and-device code reads no global table).
ELLIPSIM_HD double COS(int k) {
  const double v[8] = {1.0,  0.7071067811865476,  6.123233995736766e-17,   -0.7071067811865475,
                       -1.0, -0.7071067811865477, -1.8369701987210297e-16, 0.7071067811865474};
  return v[k];
}

ELLIPSIM_HD double SIN(int k) {
  const double v[8] = {0.0,  0.7071067811865475, 1.0, 0.7071067811865476, 1.2246467991473532e-16, -0.7071067811865475,
                       -1.0, -0.7071067811865477};
  return v[k];
}

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

// Row i of bh ah^T + q1 c1^T + q2 c2^T.
ELLIPSIM_HD Vec3 row(double bi, double q1i, double q2i, const Vec3& ah, const Vec3& c1, const Vec3& c2) {
  return {bi * ah.x + q1i * c1.x + q2i * c2.x, bi * ah.y + q1i * c1.y + q2i * c2.y,
          bi * ah.z + q1i * c1.z + q2i * c2.z};
}

// The smallest eigenvalue of Z^T Z for the 2x2 Z (its smallest singular value squared).
ELLIPSIM_HD double lambda_min2(double z00, double z01, double z10, double z11) {
  const double f = z00 * z00 + z01 * z01 + z10 * z10 + z11 * z11;
  const double d = z00 * z11 - z01 * z10;
  const double r = f * f - 4.0 * d * d;
  return f > 0.0 ? 2.0 * d * d / (f + math::sqrt(max2(r, 0.0))) : 0.0;
}

}  // namespace inner_sum

// An upper bound on max over unit m of sigma(m) = m.e - |diag(a) m| - |diag(b) Ub^T m| (the float data's sigma,
// exactly), from the internal ellipsoid of A + B tangent at the unit n with sigma(n) = value < 0 (the header's
// comment); inf where it gives none (e not inside it by the bounds).
ELLIPSIM_HD double inner_sum_bound(const Vec3& n, const Vec3& e, const Vec3& a, const Mat3& Ub, const Vec3& b,
                                   double value) {
  using inner_sum::dot;
  using math::fabs;
  constexpr double U = tol::U;
  if (!(value < 0.0)) return INFINITY;
  const Vec3 ua = {a.x * n.x, a.y * n.y, a.z * n.z};
  const Vec3 w = rotate_t(Ub, n);
  const Vec3 ub_ = {b.x * w.x, b.y * w.y, b.z * w.z};
  const double ha = math::sqrt(dot(ua, ua)), hb = math::sqrt(dot(ub_, ub_));
  if (!(ha > 0.0 && hb > 0.0)) return INFINITY;
  const Vec3 ah = {ua.x / ha, ua.y / ha, ua.z / ha};
  const Vec3 bh = {ub_.x / hb, ub_.y / hb, ub_.z / hb};
  const TangentBasis tn = tangent_basis(n), tp = tangent_basis(ah), tq = tangent_basis(bh);
  const Vec3 &t1 = tn.t1, &t2 = tn.t2, &p1 = tp.t1, &p2 = tp.t2, &q1 = tq.t1, &q2 = tq.t2;
  const Vec3 fa1 = {a.x * t1.x, a.y * t1.y, a.z * t1.z};
  const Vec3 fa2 = {a.x * t2.x, a.y * t2.y, a.z * t2.z};
  const Vec3 w1 = rotate_t(Ub, t1), w2 = rotate_t(Ub, t2);
  const Vec3 fb1 = {b.x * w1.x, b.y * w1.y, b.z * w1.z};
  const Vec3 fb2 = {b.x * w2.x, b.y * w2.y, b.z * w2.z};
  const double ma00 = dot(p1, fa1), ma01 = dot(p1, fa2), ma10 = dot(p2, fa1), ma11 = dot(p2, fa2);
  const double mb00 = dot(q1, fb1), mb01 = dot(q1, fb2), mb10 = dot(q2, fb1), mb11 = dot(q2, fb2);
  // S' (p-coordinates to q-coordinates): the turn or reflection with the largest smallest curvature
  double best = -1.0, bc = 1.0, bs = 0.0, bsign = 1.0;
  for (int k = 0; k < 8; ++k) {
    const double c = inner_sum::COS(k), s = inner_sum::SIN(k);
    for (int si = 0; si < 2; ++si) {  // [[c, -s], [s, c]] or [[c, s], [s, -c]]
      const double sign = si == 0 ? 1.0 : -1.0;
      const double s01 = -sign * s, s11 = sign * c;
      const double lm = inner_sum::lambda_min2(c * ma00 + s01 * ma10 + mb00, c * ma01 + s01 * ma11 + mb01,
                                               s * ma00 + s11 * ma10 + mb10, s * ma01 + s11 * ma11 + mb11);
      if (lm > best) {
        best = lm;
        bc = c;
        bs = s;
        bsign = sign;
      }
    }
  }
  const double s00 = bc, s01 = -bsign * bs, s10 = bs, s11 = bsign * bc;
  // S = bh ah^T + sum_ij S'_ij q_i p_j^T, row by row
  const Vec3 c1 = {s00 * p1.x + s01 * p2.x, s00 * p1.y + s01 * p2.y, s00 * p1.z + s01 * p2.z};  // row q1 of S'
  const Vec3 c2 = {s10 * p1.x + s11 * p2.x, s10 * p1.y + s11 * p2.y, s10 * p1.z + s11 * p2.z};
  const Vec3 S0 = inner_sum::row(bh.x, q1.x, q2.x, ah, c1, c2);
  const Vec3 S1 = inner_sum::row(bh.y, q1.y, q2.y, ah, c1, c2);
  const Vec3 S2 = inner_sum::row(bh.z, q1.z, q2.z, ah, c1, c2);
  // |S x| <= (1 + eta) |x|: eta >= |S^T S - I|_2, from its entries (+ their rounding, 4 u each)
  const Vec3 cols[3] = {{S0.x, S1.x, S2.x}, {S0.y, S1.y, S2.y}, {S0.z, S1.z, S2.z}};
  double defect = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double g = dot(cols[i], cols[j]) - (i == j ? 1.0 : 0.0);
      defect += g * g;
    }
  }
  const double eta = math::sqrt(defect) + 12.0 * U;
  const double amax = max3(a), bmax = max3(b);
  // X = S diag(a) + diag(b) Ub^T: X_ij = S_ij a_j + b_i Ub_ji
  const double* u = Ub.m;
  const Vec3 X0 = {S0.x * a.x + b.x * u[0], S0.y * a.y + b.x * u[3], S0.z * a.z + b.x * u[6]};
  const Vec3 X1 = {S1.x * a.x + b.y * u[1], S1.y * a.y + b.y * u[4], S1.z * a.z + b.y * u[7]};
  const Vec3 X2 = {S2.x * a.x + b.z * u[2], S2.y * a.y + b.z * u[5], S2.z * a.z + b.z * u[8]};
  const double eps1 = eta * (1.0 + eta) * amax + 6.1 * U * ((1.0 + eta) * amax + bmax);
  const Vec3 xc0 = {X0.x, X1.x, X2.x}, xc1 = {X0.y, X1.y, X2.y}, xc2 = {X0.z, X1.z, X2.z};
  const double t = value * (ha + hb);
  const double k00 = dot(xc0, xc0) + t;
  const double k11 = dot(xc1, xc1) + t;
  const double k22 = dot(xc2, xc2) + t;
  const double k10 = dot(xc1, xc0), k20 = dot(xc2, xc0), k21 = dot(xc2, xc1);
  const double xf2 = dot(xc0, xc0) + dot(xc1, xc1) + dot(xc2, xc2);
  // Cholesky K = L L^T
  if (!(k00 > 0.0)) return INFINITY;
  const double l00 = math::sqrt(k00);
  const double l10 = k10 / l00, l20 = k20 / l00;
  double r = k11 - l10 * l10;
  if (!(r > 0.0)) return INFINITY;
  const double l11 = math::sqrt(r);
  const double l21 = (k21 - l20 * l10) / l11;
  r = k22 - l20 * l20 - l21 * l21;
  if (!(r > 0.0)) return INFINITY;
  const double l22 = math::sqrt(r);
  const double lf2 = l00 * l00 + l10 * l10 + l20 * l20 + l11 * l11 + l21 * l21 + l22 * l22;
  // |L^-1|_F from the explicit inverse, each entry taken outwards
  const double i00 = 1.0 / l00, i11 = 1.0 / l11, i22 = 1.0 / l22;
  const double i10 = fabs(l10) / (l00 * l11);
  const double i21 = fabs(l21) / (l11 * l22);
  const double i20 = (fabs(l10 * l21 - l11 * l20) + 4.0 * U * (fabs(l10 * l21) + fabs(l11 * l20))) / (l00 * l11 * l22);
  const double N = math::sqrt(i00 * i00 + i11 * i11 + i22 * i22 + i10 * i10 + i21 * i21 + i20 * i20) * (1.0 + 16.0 * U);
  const double lam_lo = (1.0 - 4.0 * U) / (N * N);
  // |E| <= gamma_4 |L|_F^2 (factor) + gamma_4 |X|_F^2 + u (|diag K| + |t|) (forming K)
  const double epsk = 4.1 * U * (lf2 + xf2) + 2.0 * U * (fabs(k00) + fabs(k11) + fabs(k22) + 3.0 * fabs(t));
  if (!(epsk < 0.5 * lam_lo)) return INFINITY;
  const double lam = lam_lo - epsk;  // <= lambda_min(K), K = X^T X + t I exactly for the float X and t
  // z ~ K^-1 e by the factor; then e^T K^-1 e = 2 z.e - z^T K z + r^T K^-1 r exactly, r = e - K z, whose
  // rounding enters once (z^T K z = |X z|^2 + t |z|^2 with the float X) or squared (r): no cond(K) factor
  const double y0 = e.x / l00;
  const double y1 = (e.y - l10 * y0) / l11;
  const double y2 = (e.z - l20 * y0 - l21 * y1) / l22;
  const double z2 = y2 / l22;
  const double z1 = (y1 - l21 * z2) / l11;
  const double z0 = (y0 - l10 * z1 - l20 * z2) / l00;
  const Vec3 z = {z0, z1, z2};
  const Vec3 az = {fabs(z0), fabs(z1), fabs(z2)};
  const double ze = dot(z, e);
  const double ze_err = 3.1 * U * (az.x * fabs(e.x) + az.y * fabs(e.y) + az.z * fabs(e.z));
  const Vec3 xz = {dot(X0, z), dot(X1, z), dot(X2, z)};
  const Vec3 mx = {fabs(X0.x) * az.x + fabs(X0.y) * az.y + fabs(X0.z) * az.z,
                   fabs(X1.x) * az.x + fabs(X1.y) * az.y + fabs(X1.z) * az.z,
                   fabs(X2.x) * az.x + fabs(X2.y) * az.y + fabs(X2.z) * az.z};
  const double lo0 = max2(fabs(xz.x) - 3.1 * U * mx.x, 0.0);
  const double lo1 = max2(fabs(xz.y) - 3.1 * U * mx.y, 0.0);
  const double lo2 = max2(fabs(xz.z) - 3.1 * U * mx.z, 0.0);
  const double xx_lo = (lo0 * lo0 + lo1 * lo1 + lo2 * lo2) * (1.0 - 4.0 * U);
  const double zz_up = dot(z, z) * (1.0 + 4.0 * U);
  const double tz = -t * zz_up * (1.0 + U);  // -t |z|^2 >= 0
  double body = 2.0 * (ze + ze_err) - xx_lo + tz;
  body += 3.1 * U * (2.0 * (fabs(ze) + ze_err) + xx_lo + tz);
  // r = e - X^T (X z) - t z, each component outwards
  const double r0 = e.x - (X0.x * xz.x + X1.x * xz.y + X2.x * xz.z) - t * z0;
  const double r1 = e.y - (X0.y * xz.x + X1.y * xz.y + X2.y * xz.z) - t * z1;
  const double r2 = e.z - (X0.z * xz.x + X1.z * xz.y + X2.z * xz.z) - t * z2;
  const Vec3 mxx = {fabs(X0.x) * mx.x + fabs(X1.x) * mx.y + fabs(X2.x) * mx.z,
                    fabs(X0.y) * mx.x + fabs(X1.y) * mx.y + fabs(X2.y) * mx.z,
                    fabs(X0.z) * mx.x + fabs(X1.z) * mx.y + fabs(X2.z) * mx.z};
  const double re0 = fabs(r0) + 9.1 * U * (fabs(e.x) + mxx.x + fabs(t) * az.x);
  const double re1 = fabs(r1) + 9.1 * U * (fabs(e.y) + mxx.y + fabs(t) * az.y);
  const double re2 = fabs(r2) + 9.1 * U * (fabs(e.z) + mxx.z + fabs(t) * az.z);
  const double v = (body + (re0 * re0 + re1 * re1 + re2 * re2) * (1.0 + 4.0 * U) / lam) * (1.0 + 2.0 * U);
  if (!(v < 1.0)) return INFINITY;
  const double g = -t * ((1.0 - v) * (1.0 - 2.0 * U)) * (1.0 - 2.0 * U);
  return -math::sqrt(g) * (1.0 - 2.0 * U) + eps1 * (1.0 + 2.0 * U);
}

}  // namespace ellipsim::distance
