// 3-vectors, row-major 3x3 matrices and one ellipsoid as small value types, for the per-pair
// kernels (ellipsim/core/vec3.py).  Every expression keeps the Python kernels' order of operations
// left to right, so the two give bit-identical results while both exist.
#pragma once

#include <cmath>
#include <cstdint>

#include "config.hpp"

namespace ellipsim {

struct Vec3 {
  double x, y, z;
  ELLIPSIM_HD double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

// Row-major: m[3 * row + col].
struct Mat3 {
  double m[9];
  ELLIPSIM_HD double operator[](int i) const { return m[i]; }
};

// E = { x : |diag(1/r) R^T (x - c)| <= 1 }, MuJoCo's geom_xpos, geom_xmat and geom_size.
struct Ellipsoid {
  Vec3 c;
  Mat3 R;
  Vec3 r;
};

// Ellipsoid i of a batch of C-contiguous (n, 3) centres, (n, 3, 3) rotations and (n, 3) radii.
ELLIPSIM_HD Ellipsoid load(const double* C, const double* R, const double* r, std::int64_t i) {
  const double* c = C + 3 * i;
  const double* q = R + 9 * i;
  const double* s = r + 3 * i;
  return {{c[0], c[1], c[2]}, {{q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]}}, {s[0], s[1], s[2]}};
}

ELLIPSIM_HD double dot3(double x0, double x1, double x2, double y0, double y1, double y2) {
  return x0 * y0 + x1 * y1 + x2 * y2;
}

ELLIPSIM_HD Vec3 sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }

ELLIPSIM_HD Vec3 cross3(const Vec3& x, const Vec3& y) {
  return {x.y * y.z - x.z * y.y, x.z * y.x - x.x * y.z, x.x * y.y - x.y * y.x};
}

// mag of cross3: every subtraction an addition, on |leaves|.
ELLIPSIM_HD Vec3 cross3_mag(const Vec3& mx, const Vec3& my) {
  return {mx.y * my.z + mx.z * my.y, mx.z * my.x + mx.x * my.z, mx.x * my.y + mx.y * my.x};
}

ELLIPSIM_HD double norm2(const Vec3& x) { return x.x * x.x + x.y * x.y + x.z * x.z; }

ELLIPSIM_HD Vec3 abs3(const Vec3& x) { return {std::fabs(x.x), std::fabs(x.y), std::fabs(x.z)}; }

// max and min of two finite numbers (Python's max and min; std::fmax's NaN rules cost a call).
ELLIPSIM_HD double max2(double a, double b) { return b > a ? b : a; }
ELLIPSIM_HD double min2(double a, double b) { return b < a ? b : a; }

ELLIPSIM_HD double max3(const Vec3& x) { return max2(max2(x.x, x.y), x.z); }

ELLIPSIM_HD double min3(const Vec3& x) { return min2(min2(x.x, x.y), x.z); }

ELLIPSIM_HD Vec3 column(const Mat3& M, int j) { return {M.m[j], M.m[3 + j], M.m[6 + j]}; }

ELLIPSIM_HD Vec3 matvec(const Mat3& M, const Vec3& x) {
  return {M.m[0] * x.x + M.m[1] * x.y + M.m[2] * x.z, M.m[3] * x.x + M.m[4] * x.y + M.m[5] * x.z,
          M.m[6] * x.x + M.m[7] * x.y + M.m[8] * x.z};
}

// R^T d for a row-major matrix, a rotation or not [depth of d + 3].
ELLIPSIM_HD Vec3 rotate_t(const Mat3& R, const Vec3& d) {
  return {R.m[0] * d.x + R.m[3] * d.y + R.m[6] * d.z, R.m[1] * d.x + R.m[4] * d.y + R.m[7] * d.z,
          R.m[2] * d.x + R.m[5] * d.y + R.m[8] * d.z};
}

// mag of rotate_t: |R|^T md.
ELLIPSIM_HD Vec3 rotate_t_mag(const Mat3& R, const Vec3& md) {
  using std::fabs;
  return {fabs(R.m[0]) * md.x + fabs(R.m[3]) * md.y + fabs(R.m[6]) * md.z,
          fabs(R.m[1]) * md.x + fabs(R.m[4]) * md.y + fabs(R.m[7]) * md.z,
          fabs(R.m[2]) * md.x + fabs(R.m[5]) * md.y + fabs(R.m[8]) * md.z};
}

ELLIPSIM_HD Vec3 reciprocal(const Vec3& r) { return {1.0 / r.x, 1.0 / r.y, 1.0 / r.z}; }

// 1.0, or for a pair whose largest semi-axis is beyond 2^+-50 the power of two that brings it into
// [0.5, 1): scaling a pair by a power of two is exact, and keeps products such as r^10 and q(x)^2
// inside float64's normal range.  1.0 (semi-axes from 1e-15 to 1e15) leaves results bit-identical.
ELLIPSIM_HD double unit_scale(const Vec3& ra, const Vec3& rb) {
  const double m = max2(max3(ra), max3(rb));
  if (0x1p-51 <= m && m < 0x1p50) return 1.0;
  int exponent = 0;
  std::frexp(m, &exponent);
  return std::ldexp(1.0, -exponent);
}

ELLIPSIM_HD Vec3 scaled(const Vec3& r, double p) { return {r.x * p, r.y * p, r.z * p}; }

}  // namespace ellipsim
