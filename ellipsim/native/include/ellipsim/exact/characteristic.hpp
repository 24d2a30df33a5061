// The characteristic polynomial det(lambda A + B) of two ellipsoids, set up the thesis's two ways
// (ellipsim/core/exact/characteristic.py).
//
// A and B are the 4x4 homogeneous quadrics X^T A X <= 0, A = [[Q, -Q c], [-c^T Q, c^T Q c - 1]] with
// Q = R diag(1/r^2) R^T.  "cofactor" (thesis 4.1.2): A and B in world coordinates, the pencil's
// determinant by 2x2 minors of its first and last column pairs, each minor computed once (4.1.2.2).
// "rearranged" (thesis 4.1.3): det(lambda I + A^{-1} B) in A's frame (pair_frame.hpp), scaled back.
// Both assume R^{-1} = R^T, as the thesis does; both run in float64 or float32 (T).
#pragma once

#include "../vec3.hpp"
#include "pair_frame.hpp"

namespace ellipsim::exact {

// The 10 distinct entries of the world quadric (row-major upper triangle of the 4x4), then the
// full 4x4 as a 16-array (row-major).
template <typename T>
struct Quadric4 {
  T m[16];
};

template <typename T>
ELLIPSIM_HD Quadric4<T> world_quadric(const EllipsoidT<T>& E) {
  const Vec3T<T>& c = E.c;
  const Vec3T<T>& r = E.r;
  const T w0 = T(1) / (r.x * r.x), w1 = T(1) / (r.y * r.y), w2 = T(1) / (r.z * r.z);
  const Sym3T<T> q = sandwich(E.R, w0, w1, w2);
  const T g0 = -(q.s00 * c.x + q.s01 * c.y + q.s02 * c.z);
  const T g1 = -(q.s01 * c.x + q.s11 * c.y + q.s12 * c.z);
  const T g2 = -(q.s02 * c.x + q.s12 * c.y + q.s22 * c.z);
  const T k = -(g0 * c.x + g1 * c.y + g2 * c.z) - T(1);
  return {{q.s00, q.s01, q.s02, g0, q.s01, q.s11, q.s12, g1, q.s02, q.s12, q.s22, g2, g0, g1, g2, k}};
}

// A quadratic in lambda: (lambda^2, lambda, 1) coefficients.
template <typename T>
struct Quadratic {
  T q2, q1, q0;
};

// 2x2 minor (rows i, j; columns a, b) of lambda X + Y.
template <typename T>
ELLIPSIM_HD Quadratic<T> pencil_minor(T xai, T xbj, T xaj, T xbi, T yai, T ybj, T yaj, T ybi) {
  return {xai * xbj - xaj * xbi, (xai * ybj - xaj * ybi) + (yai * xbj - yaj * xbi), yai * ybj - yaj * ybi};
}

template <typename T>
ELLIPSIM_HD Quartic<T> product(const Quadratic<T>& a, const Quadratic<T>& b) {
  return {a.q2 * b.q2, a.q2 * b.q1 + a.q1 * b.q2, a.q2 * b.q0 + a.q1 * b.q1 + a.q0 * b.q2, a.q1 * b.q0 + a.q0 * b.q1,
          a.q0 * b.q0};
}

// Coefficients (lambda^4 ... 1) of det(lambda A + B) by Laplace expansion on the column pairs (0, 1) and
// (2, 3): det M = sum over row pairs (i < j) of sign * M[ij; 01] * M[kl; 23], (k, l) the complementary rows,
// the sign taken into the minor by swapping k and l (thesis 4.1.2.2).
template <typename T>
ELLIPSIM_HD Quartic<T> cofactor_coefficients(const EllipsoidT<T>& A, const EllipsoidT<T>& B) {
  const Quadric4<T> x = world_quadric(A), y = world_quadric(B);
  const T* X = x.m;
  const T* Y = y.m;
  const Quadratic<T> a[6] = {
      pencil_minor(X[0], X[5], X[4], X[1], Y[0], Y[5], Y[4], Y[1]),
      pencil_minor(X[0], X[9], X[8], X[1], Y[0], Y[9], Y[8], Y[1]),
      pencil_minor(X[0], X[13], X[12], X[1], Y[0], Y[13], Y[12], Y[1]),
      pencil_minor(X[4], X[9], X[8], X[5], Y[4], Y[9], Y[8], Y[5]),
      pencil_minor(X[4], X[13], X[12], X[5], Y[4], Y[13], Y[12], Y[5]),
      pencil_minor(X[8], X[13], X[12], X[9], Y[8], Y[13], Y[12], Y[9]),
  };
  const Quadratic<T> b[6] = {
      pencil_minor(X[10], X[15], X[14], X[11], Y[10], Y[15], Y[14], Y[11]),
      pencil_minor(X[14], X[7], X[6], X[15], Y[14], Y[7], Y[6], Y[15]),
      pencil_minor(X[6], X[11], X[10], X[7], Y[6], Y[11], Y[10], Y[7]),
      pencil_minor(X[2], X[15], X[14], X[3], Y[2], Y[15], Y[14], Y[3]),
      pencil_minor(X[10], X[3], X[2], X[11], Y[10], Y[3], Y[2], Y[11]),
      pencil_minor(X[2], X[7], X[6], X[3], Y[2], Y[7], Y[6], Y[3]),
  };
  Quartic<T> p[6];
  for (int k = 0; k < 6; ++k) p[k] = product(a[k], b[k]);
  return {p[0].c4 + p[1].c4 + p[2].c4 + p[3].c4 + p[4].c4 + p[5].c4,
          p[0].c3 + p[1].c3 + p[2].c3 + p[3].c3 + p[4].c3 + p[5].c3,
          p[0].c2 + p[1].c2 + p[2].c2 + p[3].c2 + p[4].c2 + p[5].c2,
          p[0].c1 + p[1].c1 + p[2].c1 + p[3].c1 + p[4].c1 + p[5].c1,
          p[0].c0 + p[1].c0 + p[2].c0 + p[3].c0 + p[4].c0 + p[5].c0};
}

// Coefficients of det(lambda A_y + B_y) in A's frame (pair_frame.hpp), assuming R_a^{-1} = R_a^T.
template <typename T>
ELLIPSIM_HD Quartic<T> rearranged_frame_coefficients(const EllipsoidT<T>& A, const EllipsoidT<T>& B) {
  const Offset<T> off = offset(A.c, A.R, A.r, B.c);
  const Shape<T> sh = shape(A.R, A.r, B.R, reciprocal(B.r), false);
  const Vec3T<T> v = matvec(sh.W, off.e), mv = matvec(sh.mW, off.me);
  return coefficients(invariants(sh.W, sh.mW, off.e, off.me, v, mv).inv, sh.alpha);
}

// det(lambda A + B) = det(lambda A_y + B_y) * det(R_a)^2 / (r_a0 r_a1 r_a2)^2, R_a orthonormal.
template <typename T>
ELLIPSIM_HD Quartic<T> rearranged_coefficients(const EllipsoidT<T>& A, const EllipsoidT<T>& B) {
  const Quartic<T> c = rearranged_frame_coefficients(A, B);
  T s = T(1) / (A.r.x * A.r.y * A.r.z);
  s = s * s;
  return {c.c4 * s, c.c3 * s, c.c2 * s, c.c1 * s, c.c0 * s};
}

}  // namespace ellipsim::exact
