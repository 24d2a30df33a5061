// The Perram-Wertheim contact function: how far two ellipsoids are from touching.
//
// Perram & Wertheim, J. Comput. Phys. 58 (1985): F = max_s min_x [s q_A(x) + (1 - s) q_B(x)].  Scaling
// both ellipsoids about their centres by sqrt(F) makes them touch.  In A's frame (pair_frame.hpp) with
// mu = alpha s / (1 - s), F(mu) = mu N(mu) / ((mu + alpha) P(mu)), maximised by Newton's method on the
// logarithmic slope G = d log F / d log mu, safeguarded by its sign bracket (~4 steps;
// ellipsim/core/exact/contact_scale.py).
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "pair_frame.hpp"

namespace ellipsim::exact {

// Starting point alpha * sqrt(q_B(c_a) / q_A(c_b)): exact for two spheres (mu* = alpha r_a / r_b).
ELLIPSIM_HD double initial_mu(double ee, double qb, double alpha) { return alpha * math::sqrt(qb / ee); }

// G = d log F / d log mu = 1 + mu N'/N - mu / (mu + alpha) - mu P'/P, dG/dmu, and F(mu).
struct LogSlope {
  double g, dg, value;
};

ELLIPSIM_HD LogSlope log_slope(double mu, const Invariants& k, double alpha) {
  const double n = (k.p1 * mu + k.q) * mu + k.s3;
  const double p = ((mu + k.t1) * mu + k.t2) * mu + k.t3;
  const double dn = 2.0 * k.p1 * mu + k.q;
  const double dp = (3.0 * mu + 2.0 * k.t1) * mu + k.t2;
  const double i_n = 1.0 / n, i_p = 1.0 / p, i_m = 1.0 / (mu + alpha);
  const double a = dn * i_n;
  const double b = dp * i_p;
  const double g = 1.0 + mu * (a - i_m - b);
  const double dg =
      a - b - alpha * i_m * i_m + mu * (2.0 * k.p1 * i_n - a * a - (6.0 * mu + 2.0 * k.t1) * i_p + b * b);
  return {g, dg, mu * n * i_p * i_m};
}

// One safeguarded Newton step on G from mu; (lo, hi) brackets mu* (G > 0 left of it, G < 0 right).
struct PwStep {
  double mu, lo, hi, value;  // next mu, the updated bracket, F at the old mu
};

ELLIPSIM_HD PwStep pw_step(double mu, const Invariants& k, double alpha, double lo, double hi) {
  const LogSlope s = log_slope(mu, k, alpha);
  if (s.g > 0.0) {
    lo = mu;
  } else if (s.g < 0.0) {
    hi = mu;
  } else {
    return {mu, mu, mu, s.value};
  }
  double next = mu - s.g / s.dg;
  if (!(lo < next && next < hi)) {  // also catches dg == 0 and NaN: bisect (geometrically) instead
    if (hi == INFINITY) {
      next = 4.0 * mu;
    } else if (lo == 0.0) {
      next = 0.25 * mu;
    } else {
      next = math::sqrt(lo * hi);
    }
  }
  return {next, lo, hi, s.value};
}

// mu* maximising F on (0, inf), to relative step rtol.
ELLIPSIM_HD double pw_maximize(const Invariants& k, double alpha, double mu, double rtol) {
  double lo = 0.0, hi = INFINITY;
  for (int it = 0; it < tol::PW_MAX_ITER; ++it) {
    const PwStep s = pw_step(mu, k, alpha, lo, hi);
    lo = s.lo;
    hi = s.hi;
    if (math::fabs(s.mu - mu) <= rtol * mu) return s.mu;
    mu = s.mu;
  }
  return mu;
}

// F(mu) = mu N(mu) / ((mu + alpha) P(mu)); all terms are nonnegative, so it is accurate.
ELLIPSIM_HD double pw_value(double mu, const Invariants& k, double alpha) {
  const double n = (k.p1 * mu + k.q) * mu + k.s3;
  const double p = ((mu + k.t1) * mu + k.t2) * mu + k.t3;
  return mu * n / ((mu + alpha) * p);
}

// sqrt(F) for one pair: > 1 separated, < 1 overlapping, 0 concentric.  F is quadratic in the centre
// offset d, so it is computed for d / max|d_i| and scaled back; the pair is first scaled by
// unit_scale, so semi-axes of 1e-200 or 1e200 neither underflow nor overflow.
ELLIPSIM_HD double contact_scale_pair(const Ellipsoid& A, const Ellipsoid& B) {
  const double p = unit_scale(A.r, B.r);
  const Vec3 ra = scaled(A.r, p), rb = scaled(B.r, p);
  const Vec3 d = {(B.c.x - A.c.x) * p, (B.c.y - A.c.y) * p, (B.c.z - A.c.z) * p};
  const double k = max3(abs3(d));
  if (k == 0.0) return 0.0;
  const Offset off = offset({0.0, 0.0, 0.0}, A.R, ra, {d.x / k, d.y / k, d.z / k});
  const double ee = norm2(off.e);
  const Shape sh = shape(A.R, ra, B.R, reciprocal(rb), true);
  const Vec3 v = matvec(sh.W, off.e);
  const Invariants inv = invariants(sh.W, sh.mW, off.e, off.me, v, v).inv;
  const double mu = pw_maximize(inv, sh.alpha, initial_mu(ee, inv.p1 / sh.alpha, sh.alpha), tol::PW_RTOL);
  return k * math::sqrt(pw_value(mu, inv, sh.alpha));
}

}  // namespace ellipsim::exact
