// Exact first derivatives of the signed distance of two ellipsoids, of its normal and of its contact point, with
// respect to both poses and semi-axes (ellipsim/core/distance/derivatives.py).
//
// At a unique, nondegenerate maximiser n* of sigma(n; theta) = n.d - h_A(n) - h_B(n) over the unit sphere
// (ellipsoid_pair.hpp; h(n) = |D R^T n|, h_B(-n) = h_B(n)), the distance is differentiable and (envelope theorem,
// Danskin; Bertsekas, Nonlinear Programming, Prop. B.25)
//     d dist / d theta = d sigma(n*; theta) / d theta   at n* held fixed;
// n* follows from the implicit function theorem on the stationarity condition P grad sigma = 0 on the sphere
// (P = I - n n^T): with the Riemannian Hessian H = P hess(sigma) P - sigma P and a tangent basis T,
//     d n* / d theta = -T (T^T H T)^-1 T^T d grad sigma / d theta,
// and the contact point, the midpoint of the support points c_A + g_A(n*) and c_B - g_B(n*) with
// g = grad h = R D^2 R^T n / h, by the chain rule through n*.  hess h = (R D^2 R^T - g g^T) / h.
//
// Parameters, 9 per body, 18 columns in this order: the centre (metres), a rotation vector omega (radians:
// R -> expm([omega]_x) R, MuJoCo's mj_jac convention), the semi-axes (metres).  Status per pair (status.hpp's
// DerivativeStatus): SMOOTH (a unique nondegenerate maximiser: max sigma > -(rho_A + rho_B) and a negative
// definite Hessian), BRANCH (a deeper proven maximum, or concentric bodies: the derivatives of the maximum found,
// one active branch where another maximiser ties), FLAT (the Hessian singular to within rounding: NaN),
// UNPROVEN (the maximum itself is not proven: NaN).  Before differentiating, n* is polished by Newton's method
// on the sphere (at most DERIV_POLISH_STEPS steps, kept only when sigma does not drop by more than rounding).
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "sphere_newton.hpp"

// The 18 columns' loop unrolled, as numba's LLVM does it: each column's kind, body and axis become constants
// (GCC leaves the loop rolled otherwise, 10 % slower than numba).  A hint only: the results are the same.
#if defined(__CUDACC__)
#define ELLIPSIM_UNROLL_COLUMNS _Pragma("unroll")
#elif defined(__clang__)
#define ELLIPSIM_UNROLL_COLUMNS _Pragma("clang loop unroll(full)")
#elif defined(__GNUC__)
#define ELLIPSIM_UNROLL_COLUMNS _Pragma("GCC unroll 18")
#else
#define ELLIPSIM_UNROLL_COLUMNS
#endif

namespace ellipsim::distance {

namespace derivatives {

// The kernels' codes, status.hpp's DerivativeStatus by name.
constexpr int SMOOTH = 0, BRANCH = 1, FLAT = 2, UNPROVEN = 3;

// The 18 columns of each derivative, 3 each.
constexpr int COLUMNS = 18;

// (h, g, z) of an ellipsoid at unit n, about its centre: h = |D R^T n|, g = grad h = R D^2 R^T n / h, z = R^T n.
struct Support {
  double h;
  Vec3 g, z;
};

ELLIPSIM_HD Support support(const Mat3& R, const Vec3& r, const Vec3& n) {
  const Vec3 z = rotate_t(R, n);
  const Vec3 x = {r.x * z.x, r.y * z.y, r.z * z.z};
  const double h = math::sqrt(norm2(x));
  const Vec3 g = matvec(R, {r.x * x.x / h, r.y * x.y / h, r.z * x.z / h});
  return {h, g, z};
}

// hess h = (R D^2 R^T - g g^T) / h as a symmetric row-major matrix.
ELLIPSIM_HD Mat3 hess(const Mat3& R, const Vec3& r, const Vec3& g, double h) {
  const Sym3T<double> s = sandwich(R, r.x * r.x, r.y * r.y, r.z * r.z);
  const double k = 1.0 / h;
  const double m00 = (s.s00 - g.x * g.x) * k, m01 = (s.s01 - g.x * g.y) * k, m02 = (s.s02 - g.x * g.z) * k;
  const double m11 = (s.s11 - g.y * g.y) * k, m12 = (s.s12 - g.y * g.z) * k, m22 = (s.s22 - g.z * g.z) * k;
  return {{m00, m01, m02, m01, m11, m12, m02, m12, m22}};
}

// An orthonormal basis (t1, t2) of the plane normal to the unit n.
ELLIPSIM_HD TangentBasis tangent(const Vec3& n) {
  const Vec3 v = math::fabs(n.x) < 0.6 ? Vec3{0.0, -n.z, n.y}   // e_x x n
                                      : Vec3{n.z, 0.0, -n.x};  // e_y x n
  const double s = 1.0 / math::sqrt(norm2(v));
  const Vec3 t1 = {v.x * s, v.y * s, v.z * s};
  return {t1, {n.y * t1.z - n.z * t1.y, n.z * t1.x - n.x * t1.z, n.x * t1.y - n.y * t1.x}};
}

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

ELLIPSIM_HD Vec3 cross(const Vec3& x, const Vec3& y) {
  return {x.y * y.z - x.z * y.y, x.z * y.x - x.x * y.z, x.x * y.y - x.y * y.x};
}

// The reduced Hessian (h11, h12, h22).
struct Reduced {
  double h11, h12, h22;
};

// Everything at the unit n: (sigma, grad sigma, h_A, g_A, z_A, J_A, h_B, g_B, z_B, J_B, t1, t2, the reduced
// Hessian (h11, h12, h22)).
struct Local {
  double s;
  Vec3 grad;
  double ha;
  Vec3 ga, za;
  Mat3 Ja;
  double hb;
  Vec3 gb, zb;
  Mat3 Jb;
  Vec3 t1, t2;
  Reduced H;
};

ELLIPSIM_HD Local local(const Vec3& n, const Vec3& d, const Mat3& Ra, const Vec3& ra, const Mat3& Rb, const Vec3& rb) {
  const Support A = support(Ra, ra, n);
  const Support B = support(Rb, rb, n);
  const Mat3 Ja = hess(Ra, ra, A.g, A.h), Jb = hess(Rb, rb, B.g, B.h);
  const double s = dot(n, d) - A.h - B.h;
  const Vec3 grad = {d.x - A.g.x - B.g.x, d.y - A.g.y - B.g.y, d.z - A.g.z - B.g.z};
  const TangentBasis t = tangent(n);
  Mat3 J;
  for (int k = 0; k < 9; ++k) J.m[k] = Ja.m[k] + Jb.m[k];
  const Vec3 Jt1 = matvec(J, t.t1), Jt2 = matvec(J, t.t2);
  const Reduced H = {-dot(t.t1, Jt1) - s, -dot(t.t1, Jt2), -dot(t.t2, Jt2) - s};
  return {s, grad, A.h, A.g, A.z, Ja, B.h, B.g, B.z, Jb, t.t1, t.t2, H};
}

// The larger eigenvalue of the symmetric 2x2 (h11, h12, h22).
ELLIPSIM_HD double top_eigenvalue(const Reduced& H) {
  const double m = 0.5 * (H.h11 + H.h22), q = 0.5 * (H.h11 - H.h22);
  return m + math::sqrt(q * q + H.h12 * H.h12);
}

// NaN into one pair's rows: grad (18), jn and jp (3 x 18, row-major).
ELLIPSIM_HD void write_nan(double* grad, double* jn, double* jp) {
  for (int j = 0; j < COLUMNS; ++j) {
    grad[j] = NAN;
    for (int k = 0; k < 3; ++k) {
      jn[COLUMNS * k + j] = NAN;
      jp[COLUMNS * k + j] = NAN;
    }
  }
}

ELLIPSIM_HD double at(const Vec3& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

}  // namespace derivatives

// The derivatives of one pair at its maximiser `normal` (world, unit) into its rows grad (18), jn and jp
// (3 x 18, row-major); returns the DerivativeStatus.
ELLIPSIM_HD int pair_derivatives(const Ellipsoid& A, const Ellipsoid& B, const Vec3& normal, int dist_status,
                                 double* grad, double* jn, double* jp) {
  using namespace derivatives;
  const Vec3 &ca = A.c, &cb = B.c;
  const Mat3 &Ra = A.R, &Rb = B.R;
  if (dist_status != 0) {
    write_nan(grad, jn, jp);
    return UNPROVEN;
  }
  // a power of two (exact): lengths in units where the largest semi-axis is < 2^50
  const double u = unit_scale(A.r, B.r);
  const Vec3 ra = scaled(A.r, u), rb = scaled(B.r, u);
  const Vec3 d = {(cb.x - ca.x) * u, (cb.y - ca.y) * u, (cb.z - ca.z) * u};
  const double S = math::sqrt(norm2(d)) + max3(ra) + max3(rb);
  Vec3 n = normal;
  Local L = local(n, d, Ra, ra, Rb, rb);
  for (int it = 0; it < tol::DERIV_POLISH_STEPS; ++it) {  // Newton on the sphere (the header's comment)
    if (!(top_eigenvalue(L.H) < -tol::DERIV_FLAT_REL * S)) break;
    const Reduced& H = L.H;
    const double r1 = dot(L.t1, L.grad), r2 = dot(L.t2, L.grad);
    const double det = H.h11 * H.h22 - H.h12 * H.h12;
    const double a1 = -(H.h22 * r1 - H.h12 * r2) / det, a2 = -(H.h11 * r2 - H.h12 * r1) / det;
    Vec3 m = {n.x + a1 * L.t1.x + a2 * L.t2.x, n.y + a1 * L.t1.y + a2 * L.t2.y, n.z + a1 * L.t1.z + a2 * L.t2.z};
    const double k = 1.0 / math::sqrt(norm2(m));
    m = {m.x * k, m.y * k, m.z * k};
    const Local next = local(m, d, Ra, ra, Rb, rb);
    if (next.s < L.s - tol::DERIV_POLISH_SLACK_ULPS * tol::U * S) break;
    n = m;
    L = next;
    if (a1 * a1 + a2 * a2 < 1e-32) break;
  }
  if (!(top_eigenvalue(L.H) < -tol::DERIV_FLAT_REL * S)) {
    write_nan(grad, jn, jp);
    return FLAT;
  }
  const double rho = rolling_radius(ra) + rolling_radius(rb);
  const int status = L.s > -rho && (d.x != 0.0 || d.y != 0.0 || d.z != 0.0) ? SMOOTH : BRANCH;
  const Reduced& H = L.H;
  const Vec3 &t1 = L.t1, &t2 = L.t2;
  const double det = H.h11 * H.h22 - H.h12 * H.h12;
  const double i11 = H.h22 / det, i12 = -H.h12 / det, i22 = H.h11 / det;  // (T^T H T)^-1
  const double iu = 1.0 / u;
  ELLIPSIM_UNROLL_COLUMNS
  for (int j = 0; j < COLUMNS; ++j) {
    const int body = j / 9, kind = (j % 9) / 3, axis = j % 3;
    const Vec3 e = {axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
    const double sign = body == 0 ? -1.0 : 1.0;
    const Mat3& R = body == 0 ? Ra : Rb;
    const Vec3& r = body == 0 ? ra : rb;
    const double h = body == 0 ? L.ha : L.hb;
    const Vec3& g = body == 0 ? L.ga : L.gb;
    const Vec3& z = body == 0 ? L.za : L.zb;
    const Mat3& Jm = body == 0 ? L.Ja : L.Jb;
    // dv: d dist; b: d grad sigma; q: the contact point's explicit part (without n*'s motion)
    double dv, c0, c1, c2;
    Vec3 b, q;
    if (kind == 0) {  // centre: sigma has sign * n.c, the contact point half of it
      dv = sign * at(n, axis);
      b = {sign * e.x, sign * e.y, sign * e.z};
      q = {0.5 * e.x, 0.5 * e.y, 0.5 * e.z};
      c0 = 1.0, c1 = u, c2 = 1.0;  // scales back to world units: dist, normal, pos
    } else if (kind == 1) {
      // rotation: d g / d omega = -[g]x + J [n]x, d h / d omega = g x n
      const Vec3 nxg = cross(n, g);
      dv = at(nxg, axis);
      const Vec3 Jn = matvec(Jm, cross(n, e));
      const Vec3 gxe = cross(g, e);
      b = {gxe.x - Jn.x, gxe.y - Jn.y, gxe.z - Jn.z};  // -d g / d omega
      q = {-0.5 * b.x * -sign, -0.5 * b.y * -sign, -0.5 * b.z * -sign};
      c0 = iu, c1 = 1.0, c2 = iu;
    } else {  // semi-axis: d h / d r_k = r_k z_k^2 / h, d g / d r_k = (2 r_k z_k R e_k - g r_k z_k^2 / h) / h
      const double rk = at(r, axis), zk = at(z, axis);
      dv = -rk * zk * zk / h;
      const Vec3 c = {R.m[axis], R.m[3 + axis], R.m[6 + axis]};
      const double w = rk * zk * zk / h;
      b = {-(2.0 * rk * zk * c.x - g.x * w) / h, -(2.0 * rk * zk * c.y - g.y * w) / h,
           -(2.0 * rk * zk * c.z - g.z * w) / h};
      q = {-0.5 * b.x * -sign, -0.5 * b.y * -sign, -0.5 * b.z * -sign};
      c0 = 1.0, c1 = u, c2 = 1.0;
    }
    // dn = -T (T^T H T)^-1 T^T b
    const double b1 = dot(t1, b), b2 = dot(t2, b);
    const double a1 = -(i11 * b1 + i12 * b2), a2 = -(i12 * b1 + i22 * b2);
    const Vec3 dn = {a1 * t1.x + a2 * t2.x, a1 * t1.y + a2 * t2.y, a1 * t1.z + a2 * t2.z};
    // the contact point moves with n* through (J_A - J_B) / 2
    const Vec3 pa = matvec(L.Ja, dn), pb = matvec(L.Jb, dn);
    grad[j] = dv * c0;
    jn[j] = dn.x * c1;
    jn[COLUMNS + j] = dn.y * c1;
    jn[2 * COLUMNS + j] = dn.z * c1;
    jp[j] = (q.x + 0.5 * (pa.x - pb.x)) * c2;
    jp[COLUMNS + j] = (q.y + 0.5 * (pa.y - pb.y)) * c2;
    jp[2 * COLUMNS + j] = (q.z + 0.5 * (pa.z - pb.z)) * c2;
  }
  return status;
}

}  // namespace ellipsim::distance
