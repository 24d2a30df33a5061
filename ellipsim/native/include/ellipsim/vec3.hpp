// 3-vectors, row-major 3x3 matrices and one ellipsoid as small value types, for the per-pair
// kernels (ellipsim/core/vec3.py).  Templates on the working precision T: double everywhere, float
// for the thesis's uncertified float32 tests.  Every expression keeps the Python kernels' order of
// operations, left to right, so the two give bit-identical results while both exist.
#pragma once

#include "math.hpp"

#include "config.hpp"

namespace ellipsim {

template <typename T>
struct Vec3T {
  T x, y, z;
};

// Row-major: m[3 * row + col].
template <typename T>
struct Mat3T {
  T m[9];
};

// E = { x : |diag(1/r) R^T (x - c)| <= 1 }, MuJoCo's geom_xpos, geom_xmat and geom_size.
template <typename T>
struct EllipsoidT {
  Vec3T<T> c;
  Mat3T<T> R;
  Vec3T<T> r;
};

using Vec3 = Vec3T<double>;
using Mat3 = Mat3T<double>;
using Ellipsoid = EllipsoidT<double>;

// Ellipsoid i of a batch of C-contiguous (n, 3) centres, (n, 3, 3) rotations and (n, 3) radii.
template <typename T>
ELLIPSIM_HD EllipsoidT<T> load(const T* C, const T* R, const T* r, int64_t i) {
  const T* c = C + 3 * i;
  const T* q = R + 9 * i;
  const T* s = r + 3 * i;
  return {{c[0], c[1], c[2]}, {{q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]}}, {s[0], s[1], s[2]}};
}

template <typename T>
ELLIPSIM_HD T dot3(T x0, T x1, T x2, T y0, T y1, T y2) {
  return x0 * y0 + x1 * y1 + x2 * y2;
}

template <typename T>
ELLIPSIM_HD Vec3T<T> sub(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}

template <typename T>
ELLIPSIM_HD Vec3T<T> cross3(const Vec3T<T>& x, const Vec3T<T>& y) {
  return {x.y * y.z - x.z * y.y, x.z * y.x - x.x * y.z, x.x * y.y - x.y * y.x};
}

// mag of cross3: every subtraction an addition, on |leaves|.
template <typename T>
ELLIPSIM_HD Vec3T<T> cross3_mag(const Vec3T<T>& mx, const Vec3T<T>& my) {
  return {mx.y * my.z + mx.z * my.y, mx.z * my.x + mx.x * my.z, mx.x * my.y + mx.y * my.x};
}

template <typename T>
ELLIPSIM_HD T norm2(const Vec3T<T>& x) {
  return x.x * x.x + x.y * x.y + x.z * x.z;
}

template <typename T>
ELLIPSIM_HD Vec3T<T> abs3(const Vec3T<T>& x) {
  return {math::fabs(x.x), math::fabs(x.y), math::fabs(x.z)};
}

// max and min of two finite numbers (Python's max and min; std::fmax's NaN rules cost a call).
template <typename T>
ELLIPSIM_HD T max2(T a, T b) {
  return b > a ? b : a;
}
template <typename T>
ELLIPSIM_HD T min2(T a, T b) {
  return b < a ? b : a;
}

template <typename T>
ELLIPSIM_HD T max3(const Vec3T<T>& x) {
  return max2(max2(x.x, x.y), x.z);
}

template <typename T>
ELLIPSIM_HD T min3(const Vec3T<T>& x) {
  return min2(min2(x.x, x.y), x.z);
}

template <typename T>
ELLIPSIM_HD Vec3T<T> column(const Mat3T<T>& M, int j) {
  return {M.m[j], M.m[3 + j], M.m[6 + j]};
}

template <typename T>
ELLIPSIM_HD Vec3T<T> matvec(const Mat3T<T>& M, const Vec3T<T>& x) {
  return {M.m[0] * x.x + M.m[1] * x.y + M.m[2] * x.z, M.m[3] * x.x + M.m[4] * x.y + M.m[5] * x.z,
          M.m[6] * x.x + M.m[7] * x.y + M.m[8] * x.z};
}

// R^T d for a row-major matrix, a rotation or not [depth of d + 3].
template <typename T>
ELLIPSIM_HD Vec3T<T> rotate_t(const Mat3T<T>& R, const Vec3T<T>& d) {
  return {R.m[0] * d.x + R.m[3] * d.y + R.m[6] * d.z, R.m[1] * d.x + R.m[4] * d.y + R.m[7] * d.z,
          R.m[2] * d.x + R.m[5] * d.y + R.m[8] * d.z};
}

// mag of rotate_t: |R|^T md.
template <typename T>
ELLIPSIM_HD Vec3T<T> rotate_t_mag(const Mat3T<T>& R, const Vec3T<T>& md) {
  return {math::fabs(R.m[0]) * md.x + math::fabs(R.m[3]) * md.y + math::fabs(R.m[6]) * md.z,
          math::fabs(R.m[1]) * md.x + math::fabs(R.m[4]) * md.y + math::fabs(R.m[7]) * md.z,
          math::fabs(R.m[2]) * md.x + math::fabs(R.m[5]) * md.y + math::fabs(R.m[8]) * md.z};
}

template <typename T>
ELLIPSIM_HD Vec3T<T> reciprocal(const Vec3T<T>& r) {
  return {T(1) / r.x, T(1) / r.y, T(1) / r.z};
}

// R diag(w) R^T for a row-major R: its upper triangle (s00, s01, s02, s11, s12, s22).
template <typename T>
struct Sym3T {
  T s00, s01, s02, s11, s12, s22;
};

template <typename T>
ELLIPSIM_HD Sym3T<T> sandwich(const Mat3T<T>& R, T w0, T w1, T w2) {
  const T* r = R.m;
  return {r[0] * r[0] * w0 + r[1] * r[1] * w1 + r[2] * r[2] * w2, r[0] * r[3] * w0 + r[1] * r[4] * w1 + r[2] * r[5] * w2,
          r[0] * r[6] * w0 + r[1] * r[7] * w1 + r[2] * r[8] * w2, r[3] * r[3] * w0 + r[4] * r[4] * w1 + r[5] * r[5] * w2,
          r[3] * r[6] * w0 + r[4] * r[7] * w1 + r[5] * r[8] * w2, r[6] * r[6] * w0 + r[7] * r[7] * w1 + r[8] * r[8] * w2};
}

// 1.0, or for a pair whose largest semi-axis is beyond 2^+-50 the power of two that brings it into
// [0.5, 1): scaling a pair by a power of two is exact, and keeps products such as r^10 and q(x)^2
// inside float64's normal range.  1.0 (semi-axes from 1e-15 to 1e15) leaves results bit-identical.
ELLIPSIM_HD double unit_scale(const Vec3& ra, const Vec3& rb) {
  const double m = max2(max3(ra), max3(rb));
  if (0x1p-51 <= m && m < 0x1p50) return 1.0;
  int exponent = 0;
  math::frexp(m, &exponent);
  return math::ldexp(1.0, -exponent);
}

template <typename T>
ELLIPSIM_HD Vec3T<T> scaled(const Vec3T<T>& r, T p) {
  return {r.x * p, r.y * p, r.z * p};
}

// max_ij |(R^T R - I)_ij| of a row-major matrix (ellipsoids.orthonormality_defect, one matrix).
ELLIPSIM_HD double rotation_defect(const Mat3& R) {
  double d = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int j = i; j < 3; ++j) {
      const double v = R.m[i] * R.m[j] + R.m[3 + i] * R.m[3 + j] + R.m[6 + i] * R.m[6 + j] - (i == j ? 1.0 : 0.0);
      d = max2(d, math::fabs(v));
    }
  }
  return d;
}

}  // namespace ellipsim
