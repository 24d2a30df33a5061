// sigma(n) = n.(c_B - c_A) - h_A(n) - h_B(-n) in A's principal frame, and its local maximisation on the
// unit sphere by Riemannian Newton: the narrow phase's building blocks (ellipsim/core/distance/sphere_newton.py).
//
// h(n) = |D R^T n| is an ellipsoid's support function (Schneider & Eberly, Geometric Tools 10.5.2).
// sigma is concave and positively homogeneous of degree 1 on R^3; its maximum over unit n is the signed
// distance (ellipsoid_pair.hpp), and a local maximum found here is proven global there.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"

namespace ellipsim::distance {

// How one Newton run ended: at a local maximum, not within its steps, or abandoned (its quadratic bound
// stays below a value another run already reached).
constexpr int CONVERGED = 0, NOT_CONVERGED = 1, ABANDONED = 2, REACHED = 3;

// A^T B for row-major matrices.
ELLIPSIM_HD Mat3 tmatmul(const Mat3& A, const Mat3& B) {
  const double* a = A.m;
  const double* b = B.m;
  return {{a[0] * b[0] + a[3] * b[3] + a[6] * b[6], a[0] * b[1] + a[3] * b[4] + a[6] * b[7],
           a[0] * b[2] + a[3] * b[5] + a[6] * b[8], a[1] * b[0] + a[4] * b[3] + a[7] * b[6],
           a[1] * b[1] + a[4] * b[4] + a[7] * b[7], a[1] * b[2] + a[4] * b[5] + a[7] * b[8],
           a[2] * b[0] + a[5] * b[3] + a[8] * b[6], a[2] * b[1] + a[5] * b[4] + a[8] * b[7],
           a[2] * b[2] + a[5] * b[5] + a[8] * b[8]}};
}

// The pair in A's principal frame: e = R_A^T (c_B - c_A), a2 = r_A^2, M = U diag(r_B^2) U^T (symmetric,
// full 3x3), U = R_A^T R_B (columns: B's axes in A's frame).
struct AFrame {
  Vec3 e, a2;
  Mat3 M, U;
};

ELLIPSIM_HD AFrame a_frame(const Ellipsoid& A, const Ellipsoid& B) {
  const Vec3 e = rotate_t(A.R, sub(B.c, A.c));
  const Mat3 U = tmatmul(A.R, B.R);
  const double b0 = B.r.x * B.r.x, b1 = B.r.y * B.r.y, b2 = B.r.z * B.r.z;
  const Sym3T<double> m = sandwich(U, b0, b1, b2);
  return {e,
          {A.r.x * A.r.x, A.r.y * A.r.y, A.r.z * A.r.z},
          {{m.s00, m.s01, m.s02, m.s01, m.s11, m.s12, m.s02, m.s12, m.s22}},
          U};
}

// sigma(n) for any nonzero n, scaled to unit length.
ELLIPSIM_HD double sigma(const Vec3& n, const Vec3& e, const Vec3& a2, const Mat3& M) {
  const double s = 1.0 / math::sqrt(norm2(n));
  const Vec3 u = {n.x * s, n.y * s, n.z * s};
  const double ha = math::sqrt(a2.x * u.x * u.x + a2.y * u.y * u.y + a2.z * u.z * u.z);
  const Vec3 mu = matvec(M, u);
  const double hb = math::sqrt(u.x * mu.x + u.y * mu.y + u.z * mu.z);
  return u.x * e.x + u.y * e.y + u.z * e.z - ha - hb;
}

ELLIPSIM_HD Vec3 unit(const Vec3& v) {
  double s = norm2(v);
  if (s == 0.0) return {1.0, 0.0, 0.0};
  s = 1.0 / math::sqrt(s);
  return {v.x * s, v.y * s, v.z * s};
}

// Two unit vectors completing the unit n to an orthonormal frame.
struct TangentBasis {
  Vec3 t1, t2;
};

ELLIPSIM_HD TangentBasis tangent_basis(const Vec3& n) {
  const Vec3 t = math::fabs(n.x) < 0.6 ? Vec3{0.0, n.z, -n.y}   // e_x x n
                                      : Vec3{-n.z, 0.0, n.x};  // e_y x n
  const double s = 1.0 / math::sqrt(norm2(t));
  const Vec3 t1 = {t.x * s, t.y * s, t.z * s};
  return {t1, {n.y * t1.z - n.z * t1.y, n.z * t1.x - n.x * t1.z, n.x * t1.y - n.y * t1.x}};
}

// (n*, sigma before the last step, status, steps) of one Newton run.
struct NewtonResult {
  Vec3 n;
  double value;
  int status, steps;
};

// Maximise sigma on the unit sphere from the unit vector n; the last step is below NEWTON_STEP_TOL, so
// sigma(n*) differs by O(tol^2).  Riemannian Newton with the retraction n <- (n + x) / |n + x|: a step of
// at most 0.5 rad, halved while it would decrease sigma (steps over 0.1 rad), a Levenberg shift where the
// tangent Hessian is not negative definite, and a 0.3 rad escape along the curvature direction from
// saddles.  target: a value another run already reached; a run whose quadratic bound
// sigma + |g|^2 / (2 lam) stays below it is ABANDONED (-inf for none).  apart: a run whose iterate's sigma
// reaches it stops there, REACHED (sigma at any unit n is a lower bound on the signed distance: the pair is
// proven at least that far apart; only with Stop, so the other callers' loop carries no test of it).
template <bool Stop = false>
ELLIPSIM_HD NewtonResult newton(Vec3 n, const Vec3& e, const Vec3& a2, const Mat3& M, double scale, double target,
                                int max_iter, double apart = INFINITY) {
  double value = 0.0;
  for (int it = 0; it < max_iter; ++it) {
    const Vec3 a = {a2.x * n.x, a2.y * n.y, a2.z * n.z};
    const Vec3 b = matvec(M, n);
    const double ha = math::sqrt(a.x * n.x + a.y * n.y + a.z * n.z);
    const double hb = math::sqrt(b.x * n.x + b.y * n.y + b.z * n.z);
    const double inv = 1.0 / (ha * hb);
    const double ia = hb * inv, ib = ha * inv;
    value = n.x * e.x + n.y * e.y + n.z * e.z - ha - hb;
    if (Stop && value >= apart) return {n, value, REACHED, it + 1};
    const TangentBasis tb = tangent_basis(n);
    const Vec3 &t1 = tb.t1, &t2 = tb.t2;
    // gradient e - a/ha - b/hb in the tangent basis
    const double at1 = a.x * t1.x + a.y * t1.y + a.z * t1.z, at2 = a.x * t2.x + a.y * t2.y + a.z * t2.z;
    const double bt1 = b.x * t1.x + b.y * t1.y + b.z * t1.z, bt2 = b.x * t2.x + b.y * t2.y + b.z * t2.z;
    const double g1 = e.x * t1.x + e.y * t1.y + e.z * t1.z - at1 * ia - bt1 * ib;
    const double g2 = e.x * t2.x + e.y * t2.y + e.z * t2.z - at2 * ia - bt2 * ib;
    const double gg = g1 * g1 + g2 * g2;
    // Hessian of sigma: -(diag(a2)/ha - a a^T/ha^3) - (M/hb - b b^T/hb^3), then minus sigma I
    const Vec3 m1 = matvec(M, t1), m2 = matvec(M, t2);
    const double ia3 = ia * ia * ia, ib3 = ib * ib * ib;
    const double d11 = a2.x * t1.x * t1.x + a2.y * t1.y * t1.y + a2.z * t1.z * t1.z;
    const double d12 = a2.x * t1.x * t2.x + a2.y * t1.y * t2.y + a2.z * t1.z * t2.z;
    const double d22 = a2.x * t2.x * t2.x + a2.y * t2.y * t2.y + a2.z * t2.z * t2.z;
    const double q11 = t1.x * m1.x + t1.y * m1.y + t1.z * m1.z;
    const double q12 = t2.x * m1.x + t2.y * m1.y + t2.z * m1.z;
    const double q22 = t2.x * m2.x + t2.y * m2.y + t2.z * m2.z;
    double h11 = -(d11 * ia - at1 * at1 * ia3) - (q11 * ib - bt1 * bt1 * ib3) - value;
    const double h12 = -(d12 * ia - at1 * at2 * ia3) - (q12 * ib - bt1 * bt2 * ib3);
    double h22 = -(d22 * ia - at2 * at2 * ia3) - (q22 * ib - bt2 * bt2 * ib3) - value;
    double det = h11 * h22 - h12 * h12;
    double shift = 0.0;
    if (h11 < -1e-12 * scale && det > 1e-24 * scale * scale) {  // negative definite
      if (value - 0.5 * gg * (h11 + h22) / det < target) return {n, value, ABANDONED, it + 1};
    } else {
      const double hd = h11 - h22;
      const double top = 0.5 * (h11 + h22) + math::sqrt(0.25 * (hd * hd) + h12 * h12);
      const double flat = 1e-14 * scale;
      if (gg <= flat * flat && top <= 1e-10 * scale)
        return {n, value, CONVERGED, it + 1};  // a flat maximum (concentric spheres): any n is optimal
      if (gg < 1e-4 * top * top) {
        // near a saddle or a minimum: leave along the direction of positive curvature, 0.3 rad to the
        // side where sigma is larger (gradient steps would stall here)
        double v1 = top - h22, v2 = h12;  // eigenvector of top: the larger of its two forms
        const double th = top - h11;
        if (v1 * v1 + v2 * v2 < h12 * h12 + th * th) {
          v1 = h12;
          v2 = top - h11;
        }
        if (!(v1 * v1 + v2 * v2 > 0.0)) {  // underflow: h is diagonal to rounding
          v1 = h11 >= h22 ? 1.0 : 0.0;
          v2 = h11 >= h22 ? 0.0 : 1.0;
        }
        const double vs = 0.3 / math::sqrt(v1 * v1 + v2 * v2);
        v1 = v1 * vs;
        v2 = v2 * vs;
        const Vec3 p = {n.x + v1 * t1.x + v2 * t2.x, n.y + v1 * t1.y + v2 * t2.y, n.z + v1 * t1.z + v2 * t2.z};
        const Vec3 q = {n.x - v1 * t1.x - v2 * t2.x, n.y - v1 * t1.y - v2 * t2.y, n.z - v1 * t1.z - v2 * t2.z};
        n = sigma(p, e, a2, M) >= sigma(q, e, a2, M) ? unit(p) : unit(q);
        continue;
      }
      shift = max2(top, 0.0) + 1e-3 * scale + math::sqrt(gg);
      h11 = h11 - shift;
      h22 = h22 - shift;
      det = h11 * h22 - h12 * h12;
    }
    const double idet = 1.0 / det;
    double x1 = -(h22 * g1 - h12 * g2) * idet;
    double x2 = -(h11 * g2 - h12 * g1) * idet;
    double step2 = x1 * x1 + x2 * x2;
    if (step2 > 0.25) {
      const double f = 0.5 / math::sqrt(step2);
      x1 = x1 * f;
      x2 = x2 * f;
      step2 = 0.25;
    }
    Vec3 m = {n.x + x1 * t1.x + x2 * t2.x, n.y + x1 * t1.y + x2 * t2.y, n.z + x1 * t1.z + x2 * t2.z};
    if (step2 > 1e-2) {  // beyond 0.1 rad the quadratic model may overshoot: backtrack until sigma grows
      for (int k = 0; k < 10; ++k) {
        if (sigma(m, e, a2, M) >= value) break;
        x1 = 0.5 * x1;
        x2 = 0.5 * x2;
        step2 = 0.25 * step2;
        m = {n.x + x1 * t1.x + x2 * t2.x, n.y + x1 * t1.y + x2 * t2.y, n.z + x1 * t1.z + x2 * t2.z};
      }
    }
    const double s = 1.0 / math::sqrt(1.0 + step2);  // |n + x|^2 = 1 + |x|^2: x is tangent, n unit
    n = {m.x * s, m.y * s, m.z * s};
    if (step2 <= tol::NEWTON_STEP_TOL * tol::NEWTON_STEP_TOL && shift == 0.0) return {n, value, CONVERGED, it + 1};
  }
  return {n, value, NOT_CONVERGED, max_iter};
}

// The bisector of Q_A d and Q_B d (the normals where the centre line leaves A and B), in A's frame: the
// start that needs the fewest Newton steps on touching pairs.  Q d is taken times det(D)^2 (no
// divisions) and the bisector of u and w is u |w| + w |u|.
ELLIPSIM_HD Vec3 bisector_seed(const Vec3& e, const Vec3& a2, const Mat3& U, const Vec3& rb2) {
  const Vec3 na = {e.x * a2.y * a2.z, e.y * a2.x * a2.z, e.z * a2.x * a2.y};
  const Vec3 z = rotate_t(U, e);  // in B's axes
  const Vec3 nb = matvec(U, {z.x * rb2.y * rb2.z, z.y * rb2.x * rb2.z, z.z * rb2.x * rb2.y});
  const double la = math::sqrt(norm2(na)), lb = math::sqrt(norm2(nb));
  return unit({na.x * lb + nb.x * la, na.y * lb + nb.y * la, na.z * lb + nb.z * la});
}

// Smallest radius of curvature of an ellipsoid, c^2 / a: a ball of this radius rolls freely inside it.
ELLIPSIM_HD double rolling_radius(const Vec3& r) {
  const double lo = min3(r), hi = max3(r);
  return lo * lo / hi;
}

}  // namespace ellipsim::distance
