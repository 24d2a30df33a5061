// The rigid motion between two poses that time_of_impact assumes, and its float64 evaluation with proven
// error bounds (ellipsim/core/motion/interpolation.py has the derivations).
//
// Each body keeps its semi-axes; its centre moves linearly and its rotation turns at constant angular
// velocity along the shortest arc (issue 12):
//
//     c(t) = c0 + t (c1 - c0),    R(t) = R0 exp(t [w]x),    w = log(R0^T R1) as a float64 axis-angle vector.
//
// The motion is defined *exactly* (real arithmetic) by the float64 data c0, c1, R0, R1 and w.  So that it
// ends exactly on the given pose, the second half is written from the far end: R(t) = R1 exp((t - 1) [w]x)
// on [1/2, 1].  The halves meet at t = 1/2 to within the rounding of w (~1e-16); time_of_impact covers both,
// and at t = 0 and t = 1 the motion is exactly the input poses.  R0, R1 need only be invertible (validated
// rotations are orthonormal to 1e-6): exp(phi [w]x) is an exact rotation.
//
// Float64 evaluation, E(phi) = exp(phi [w]x) by Rodrigues' formula (u = 2^-53, alpha = |w| phi):
//
// * sin and cos come from `sincos`, Taylor polynomials with a proven error (not libm, whose accuracy is
//   documented but not proven): within SINCOS_ERR of the exact values for |x| <= 1.6 (|alpha| <= pi/2
//   here: |w| < pi, |phi| <= 1/2).
// * E~^T p errs by at most (RODRIGUES_ERR + 12 |alpha|) u |p| (derivation in `rodrigues_apply`), and the
//   float pose fl(R_p E~) lies within DELTA_R (spectral norm) of the exact R_p E (tolerances.hpp).
//
// rotation_vector alone calls the C library (atan2), as the Python does: numba calls the same libm.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"

namespace ellipsim::motion {

struct SinCos {
  double s, c;
};

// (sin x, cos x) for |x| <= 1.6, each within SINCOS_ERR (absolute) of the exact value.
//
// Horner in y = fl(x^2) on the Taylor polynomials to x^22 (cos) and x^23 (sin).  Bound (Higham, Accuracy and
// Stability of Numerical Algorithms, eq. 5.3, plus one rounding per coefficient): gamma_23 cosh(1.6) < 59.4u
// for cos and gamma_23 sinh(1.6) + u < 55.7u for sin (with the product by x); the rounding of y adds at most
// u x sinh(x) / 2 < 1.9u (cos) and u x (cosh x - 1) / 2 < 1.3u (sin); the truncated tails are below
// 1.3e-19 = 0.0015u.  Total < 62u = SINCOS_ERR.
ELLIPSIM_HD SinCos sincos(double x) {
  // Taylor coefficients (-1)^k / (2k)! and (-1)^k / (2k + 1)!, k = 11 ... 0 (Horner's order), each as Python
  // computes it: the factorial rounded to float64 (exact up to 22!), then 1.0 / it rounded once.
  // (Local arrays: a namespace-scope array cannot be read from CUDA device code.)
  constexpr double COS[12] = {
      -0x1.0ce396db7f853p-70,  // -1 / 22!
      0x1.e542ba4020225p-62,   // 1 / 20!
      -0x1.6827863b97d97p-53,  // -1 / 18!
      0x1.ae7f3e733b81fp-45,   // 1 / 16!
      -0x1.93974a8c07c9dp-37,  // -1 / 14!
      0x1.1eed8eff8d898p-29,   // 1 / 12!
      -0x1.27e4fb7789f5cp-22,  // -1 / 10!
      0x1.a01a01a01a01ap-16,   // 1 / 8!
      -0x1.6c16c16c16c17p-10,  // -1 / 6!
      0x1.5555555555555p-5,    // 1 / 4!
      -0x1.0000000000000p-1,   // -1 / 2!
      0x1.0000000000000p+0,    // 1 / 0!
  };
  constexpr double SIN[12] = {
      -0x1.761b413163819p-75,  // -1 / 23! (23! rounded to float64 first)
      0x1.71b8ef6dcf572p-66,   // 1 / 21!
      -0x1.2f49b46814157p-57,  // -1 / 19!
      0x1.952c77030ad4ap-49,   // 1 / 17!
      -0x1.ae7f3e733b81fp-41,  // -1 / 15!
      0x1.6124613a86d09p-33,   // 1 / 13!
      -0x1.ae64567f544e4p-26,  // -1 / 11!
      0x1.71de3a556c734p-19,   // 1 / 9!
      -0x1.a01a01a01a01ap-13,  // -1 / 7!
      0x1.1111111111111p-7,    // 1 / 5!
      -0x1.5555555555555p-3,   // -1 / 3!
      0x1.0000000000000p+0,    // 1 / 1!
  };
  const double y = x * x;
  double c = 0.0, s = 0.0;
  for (int k = 0; k < 12; ++k) {
    c = c * y + COS[k];
    s = s * y + SIN[k];
  }
  return {x * s, c};
}

// (w, theta): the axis-angle vector w of R0^T R1 and its angle theta in [0, pi].
struct RotationVector {
  Vec3 w;
  double theta;
};

// Any float answer defines a valid motion; this one reproduces R1 to ~1e-15.  Near pi (cos < 0) the axis
// comes from the symmetric part, (Q + Q^T)/2 - c I = (1 - c) k k^T, signed like the antisymmetric part.
ELLIPSIM_HD RotationVector rotation_vector(const Mat3& R0, const Mat3& R1) {
  const double* a = R0.m;
  const double* b = R1.m;
  const double q00 = a[0] * b[0] + a[3] * b[3] + a[6] * b[6];
  const double q11 = a[1] * b[1] + a[4] * b[4] + a[7] * b[7];
  const double q22 = a[2] * b[2] + a[5] * b[5] + a[8] * b[8];
  const double q01 = a[0] * b[1] + a[3] * b[4] + a[6] * b[7];
  const double q10 = a[1] * b[0] + a[4] * b[3] + a[7] * b[6];
  const double q02 = a[0] * b[2] + a[3] * b[5] + a[6] * b[8];
  const double q20 = a[2] * b[0] + a[5] * b[3] + a[8] * b[6];
  const double q12 = a[1] * b[2] + a[4] * b[5] + a[7] * b[8];
  const double q21 = a[2] * b[1] + a[5] * b[4] + a[8] * b[7];
  const double c = 0.5 * (q00 + q11 + q22 - 1.0);
  const double v0 = 0.5 * (q21 - q12), v1 = 0.5 * (q02 - q20), v2 = 0.5 * (q10 - q01);
  const double s = math::sqrt(v0 * v0 + v1 * v1 + v2 * v2);
  const double theta = math::atan2(s, c);
  if (c > 0.0) {
    if (s == 0.0) return {{0.0, 0.0, 0.0}, 0.0};
    const double f = theta / s;
    return {{v0 * f, v1 * f, v2 * f}, theta};
  }
  const double diag[3] = {q00 - c, q11 - c, q22 - c};
  int j = 0;
  if (diag[1] > diag[j]) j = 1;
  if (diag[2] > diag[j]) j = 2;
  double k0, k1, k2;
  if (j == 0) {
    k0 = q00 - c, k1 = 0.5 * (q10 + q01), k2 = 0.5 * (q20 + q02);
  } else if (j == 1) {
    k0 = 0.5 * (q01 + q10), k1 = q11 - c, k2 = 0.5 * (q21 + q12);
  } else {
    k0 = 0.5 * (q02 + q20), k1 = 0.5 * (q12 + q21), k2 = q22 - c;
  }
  double kn = math::sqrt(k0 * k0 + k1 * k1 + k2 * k2);
  if (kn == 0.0) return {{0.0, 0.0, 0.0}, theta};
  if (k0 * v0 + k1 * v1 + k2 * v2 < 0.0) kn = -kn;
  const double f = theta / kn;
  return {{k0 * f, k1 * f, k2 * f}, theta};
}

// _rotation_vectors for body i: w (flushed to exactly 0 below OMEGA_ZERO) and the angle.
ELLIPSIM_HD RotationVector flushed_rotation_vector(const Mat3& R0, const Mat3& R1) {
  RotationVector r = rotation_vector(R0, R1);
  if (math::sqrt(r.w.x * r.w.x + r.w.y * r.w.y + r.w.z * r.w.z) < tol::OMEGA_ZERO) r.w = {0.0, 0.0, 0.0};
  return r;
}

// (cos alpha, sin alpha, 1 - cos alpha, unit axis k, |alpha|) of E(phi) = exp(phi [w]x), alpha = |w| phi.
struct Rodrigues {
  double c, s, om;
  Vec3 k;
  double al;
};

// Errors: theta~ = fl(|w|) = theta (1 + eta), |eta| <= 2.52u; |alpha~ - alpha| <= 3.53u |alpha~|; cos and sin
// within eps_a = SINCOS_ERR + 3.6u |alpha~| of the exact ones (sincos; |d sin| <= |d alpha|); |k~ - k| <= 3.53u.
// w = 0 gives exactly (1, 0, 0, 0, 0), and so does phi = 0.
ELLIPSIM_HD Rodrigues rodrigues(const Vec3& w, double phi) {
  const double th = math::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
  if (th == 0.0) return {1.0, 0.0, 0.0, {0.0, 0.0, 0.0}, 0.0};
  const double al = th * phi;
  const SinCos sc = sincos(al);
  return {sc.c, sc.s, 1.0 - sc.c, {w.x / th, w.y / th, w.z / th}, math::fabs(al)};
}

// E(phi)^T p = c p - s (k x p) + (1 - c)(k . p) k in float64.
//
// Error, with P = |p|, 0 <= 1 - cos alpha <= 1 (|alpha| <= pi/2): c p errs by (eps_a + u) P; k x p by
// (eps_k + 1.42 gamma_2) P, times s by (eps_a + eps_k + 4u) P; (1 - c)(k . p) k by (eps_a + 2 eps_k + 7.1u) P;
// the two sums by 6.01u P.  Total (3 eps_a + 3 eps_k + 18.2u) P <= (3 SINCOS_ERR/u + 28.8 + 10.8 |alpha|) u P:
// RODRIGUES_ERR + 12 |alpha| (tolerances.hpp).  Checked against 60-digit mpmath in tests/test_toi.py.
ELLIPSIM_HD Vec3 rodrigues_apply(const Rodrigues& rod, const Vec3& p) {
  const double c = rod.c, s = rod.s, om = rod.om;
  const Vec3& k = rod.k;
  const double x0 = k.y * p.z - k.z * p.y, x1 = k.z * p.x - k.x * p.z, x2 = k.x * p.y - k.y * p.x;
  const double f = om * (k.x * p.x + k.y * p.y + k.z * p.z);
  return {c * p.x - s * x0 + f * k.x, c * p.y - s * x1 + f * k.y, c * p.z - s * x2 + f * k.z};
}

// E(phi) = c I + s [k]x + (1 - c) k k^T, row-major; each column errs as rodrigues_apply with P = 1.
ELLIPSIM_HD Mat3 rodrigues_matrix(const Rodrigues& rod) {
  const double c = rod.c, s = rod.s, om = rod.om;
  const Vec3& k = rod.k;
  const double a0 = om * k.x, a1 = om * k.y, a2 = om * k.z;
  return {{c + a0 * k.x, a0 * k.y - s * k.z, a0 * k.z + s * k.y,  //
           a1 * k.x + s * k.z, c + a1 * k.y, a1 * k.z - s * k.x,  //
           a2 * k.x - s * k.y, a2 * k.y + s * k.x, c + a2 * k.z}};
}

// A B for row-major 3x3 matrices, A read from memory (9 doubles, row-major).
ELLIPSIM_HD Mat3 matmul(const double* a, const Mat3& B) {
  const double* b = B.m;
  return {{a[0] * b[0] + a[1] * b[3] + a[2] * b[6], a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
           a[0] * b[2] + a[1] * b[5] + a[2] * b[8], a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
           a[3] * b[1] + a[4] * b[4] + a[5] * b[7], a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
           a[6] * b[0] + a[7] * b[3] + a[8] * b[6], a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
           a[6] * b[2] + a[7] * b[5] + a[8] * b[8]}};
}

ELLIPSIM_HD Mat3 matmul(const Mat3& A, const Mat3& B) { return matmul(A.m, B); }

// The float rotation at t: R0 exactly at t = 0, R1 at t = 1, else fl(R_p E~(t - tau)) (tau = 0 on [0, 1/2],
// 1 on (1/2, 1]; t - 1 is exact there by Sterbenz).
ELLIPSIM_HD Mat3 rotation_at(const Mat3& R0, const Mat3& R1, const Vec3& w, double t) {
  if (t == 0.0) return R0;
  if (t == 1.0) return R1;
  if (t <= 0.5) return matmul(R0, rodrigues_matrix(rodrigues(w, t)));
  return matmul(R1, rodrigues_matrix(rodrigues(w, t - 1.0)));
}

// _poses_at for body i at time t: its centre C (3) and rotation R (9, row-major) from the C-contiguous
// (n, 3) centres, (n, 3, 3) rotations and (n, 3) rotation vectors W of the two poses.  The rotation is
// rotation_at's, with R0 or R1 read in place; every input of the body is read before its outputs are written
// (the same values where an output is also an input).  Both: 9% faster than the literal loop, numba's bits.
ELLIPSIM_HD void pose_at(const double* C0, const double* R0, const double* C1, const double* R1, const double* W,
                         int64_t i, double t, double* C, double* R) {
  const double* a = R0 + 9 * i;
  const double* b = R1 + 9 * i;
  const double* w = W + 3 * i;
  double c[3];
  for (int j = 0; j < 3; ++j) {
    if (t == 0.0)
      c[j] = C0[3 * i + j];
    else if (t == 1.0)
      c[j] = C1[3 * i + j];
    else
      c[j] = C0[3 * i + j] + t * (C1[3 * i + j] - C0[3 * i + j]);
  }
  Mat3 Rt;
  if (t == 0.0 || t == 1.0) {
    const double* p = t == 0.0 ? a : b;
    for (int k = 0; k < 9; ++k) Rt.m[k] = p[k];
  } else if (t <= 0.5) {
    Rt = matmul(a, rodrigues_matrix(rodrigues({w[0], w[1], w[2]}, t)));
  } else {
    Rt = matmul(b, rodrigues_matrix(rodrigues({w[0], w[1], w[2]}, t - 1.0)));
  }
  for (int j = 0; j < 3; ++j) C[3 * i + j] = c[j];
  for (int k = 0; k < 9; ++k) R[9 * i + k] = Rt.m[k];
}

}  // namespace ellipsim::motion
