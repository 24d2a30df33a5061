// Exact first derivatives of the signed distance of an ellipsoid E and a capsule, box or cylinder K, of its normal
// and of its contact point, on the feature of K that carries the contact (ellipsim/core/pairs/derivatives.py,
// issue 24).
//
// sigma(n) = n.d - h_E(n) - h_K(n), d = c_K - c_E (box.hpp, capsule.hpp, cylinder), is smooth except on the kinks
// of h_K.  The maximiser n* lies on one stratum, where (Rockafellar & Wets, Variational Analysis, 10.C: a
// piecewise-smooth max is smooth on each stratum)
//     h_K(n) = n.w + rho |n|_P   subject to   G n = 0   (G: k orthonormal rows, all orthogonal to n*)
//     box    VERTEX  w = sum_j s_j r_j v_j                        k = 0
//            EDGE    w = the sum over the two free axes            k = 1, G = (v_i)     (n* along no v_i)
//            FACE    w = s_i r_i v_i                               k = 2, G = the other two axes
//     capsule END    w = s L u, rho = r, P = I (the end's ball)    k = 0
//            SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
//     cylinder RIM   w = s L u, rho = r, P = I - u u^T            k = 0
//            SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
//            CAP     w = s L u, rho = 0                            k = 2, G = a basis of u^perp
// (s: the sign of n*.v on the free axes; |n|_P = sqrt(n^T P n).)  KKT on {|n| = 1, G n = 0}: grad sigma = sigma n
// + G^T mu.  Implicit function theorem on it: the part of dn along G's rows is -G^T (dG n); the rest, in the
// stratum's tangent space T (2 - k dimensions), solves (T^T H T) a = -T^T (b + H dn_G), H = hess sigma - sigma I,
// b = d grad sigma / d theta - dG^T mu.  The envelope theorem with the constraints' multipliers: d dist / d theta
// = d sigma / d theta (n* held) - mu . (dG n*).  The contact point, pos = c_E + g_E(n*) + dist n* / 2, follows by
// the chain rule.  Parameters, 18 columns: E's centre, rotation vector and semi-axes, K's centre, rotation vector
// and MuJoCo's geom_size (box: half-sizes; capsule and cylinder: radius, half-length, and a third column that is
// zero).
//
// Status (status.hpp's DerivativeStatus): ONE_SIDED where a multiplier lies within DERIV_KINK_REL S of its bound
// (the contact where two features meet: the named feature's derivatives, held); otherwise SMOOTH (separated) or
// BRANCH (touching or penetrating); FLAT (a reduced Hessian not negative definite to DERIV_FLAT_REL S) and
// UNPROVEN (an unproven maximum): NaN.  n* is first polished by Newton's method on the stratum, as
// distance/derivatives.hpp does.  Every expression keeps the Python's order of operations: bit for bit the
// numba kernel (tests/test_native_pair_derivatives.py).
#pragma once

#include "../math.hpp"

#include "../distance/derivatives.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "box.hpp"
#include "polytope.hpp"

namespace ellipsim::pairs::derivatives {

using box::Axes;
using distance::TangentBasis;
using distance::derivatives::at;
using distance::derivatives::BRANCH;
using distance::derivatives::COLUMNS;
using distance::derivatives::cross;
using distance::derivatives::dot;
using distance::derivatives::FLAT;
using distance::derivatives::hess;
using distance::derivatives::Reduced;
using distance::derivatives::SMOOTH;
using distance::derivatives::Support;
using distance::derivatives::support;
using distance::derivatives::tangent;
using distance::derivatives::top_eigenvalue;
using distance::derivatives::UNPROVEN;
using distance::derivatives::write_nan;

// A fifth DerivativeStatus code (ONE_SIDED): the feature held, at the edge of its normal cone.
constexpr int ONE_SIDED = 4;
// The feature of K that carries the contact (status.hpp's ContactFeature by name).
constexpr int FACE = 0, EDGE = 1, VERTEX = 2, SIDE = 3, END = 4, CAP = 5, RIM = 6;
// The kernel's codes for K's type (MESH: a convex hull, mesh_pair).
constexpr int CAPSULE = 0, BOX = 1, CYLINDER = 2, MESH = 3;

// _Z: the zero vector.
ELLIPSIM_HD Vec3 zero() { return {0.0, 0.0, 0.0}; }

// _unit: v / |v| (no guard: a zero v gives NaN, as the Python).
ELLIPSIM_HD Vec3 unit(const Vec3& v) {
  const double s = 1.0 / math::sqrt(norm2(v));
  return {v.x * s, v.y * s, v.z * s};
}

// _axpy: a x + y.
ELLIPSIM_HD Vec3 axpy(double a, const Vec3& x, const Vec3& y) { return {a * x.x + y.x, a * x.y + y.y, a * x.z + y.z}; }

// (|n|_P, P n).
struct PNorm {
  double npn;
  Vec3 Pn;
};

// _pnorm: (|n|_P, P n) for P = I (pt 1) or I - u u^T (pt 2); (1, 0) for no such term (pt 0).
ELLIPSIM_HD PNorm pnorm(const Vec3& n, int pt, const Vec3& u) {
  if (pt == 1) return {math::sqrt(norm2(n)), n};
  if (pt == 2) {
    const double c = dot(n, u);
    const Vec3 p = {n.x - c * u.x, n.y - c * u.y, n.z - c * u.z};
    return {math::sqrt(norm2(p)), p};
  }
  return {1.0, zero()};
}

// The stratum holding a unit n (the header's table): its feature, k, rows g0 and g1, w, rho, pt, axis u and the
// bounds of the rows' multipliers.
struct Stratum {
  int f, k;
  Vec3 g0, g1, w;
  double rho;
  int pt;
  Vec3 u;
  double bound0, bound1;
};

// _stratum: the stratum holding the unit n, in the units of V and sk.
ELLIPSIM_HD Stratum stratum(int kind, const Vec3& n, const Axes& V, const Vec3& sk) {
  const Vec3 Z = zero();
  if (kind == BOX) {
    const double c[3] = {dot(n, V.v[0]), dot(n, V.v[1]), dot(n, V.v[2])};
    const double s[3] = {sk.x, sk.y, sk.z};
    const bool a0 = math::fabs(c[0]) <= tol::DERIV_KINK_COS, a1 = math::fabs(c[1]) <= tol::DERIV_KINK_COS,
               a2 = math::fabs(c[2]) <= tol::DERIV_KINK_COS;
    const int k = int(a0) + int(a1) + int(a2);
    Vec3 w = Z;
    for (int j = 0; j < 3; ++j) {
      if (math::fabs(c[j]) > tol::DERIV_KINK_COS) w = axpy(math::copysign(s[j], c[j]), V.v[j], w);
    }
    if (k == 0) return {VERTEX, 0, Z, Z, w, 0.0, 0, Z, 0.0, 0.0};
    if (k == 1) {
      const int i = a0 ? 0 : (a1 ? 1 : 2);
      return {EDGE, 1, V.v[i], Z, w, 0.0, 0, Z, s[i], 0.0};
    }
    const int i = !a0 ? 0 : (!a1 ? 1 : 2);  // the free axis (k = 3 cannot hold for a unit n)
    const int j0 = (i + 1) % 3, j1 = (i + 2) % 3;
    return {FACE, 2, V.v[j0], V.v[j1], w, 0.0, 0, Z, s[j0], s[j1]};
  }
  const double r = sk.x, L = sk.y;
  const Vec3& u = V.v[2];
  const double c = dot(n, u);
  const Vec3 w = {math::copysign(L, c) * u.x, math::copysign(L, c) * u.y, math::copysign(L, c) * u.z};
  if (math::fabs(c) <= tol::DERIV_KINK_COS) return {SIDE, 1, u, Z, Z, r, 1, u, L, 0.0};
  if (kind == CAPSULE) return {END, 0, Z, Z, w, r, 1, u, 0.0, 0.0};
  if (math::sqrt(norm2(cross(n, u))) <= tol::DERIV_KINK_COS) {
    const TangentBasis t = tangent(u);
    return {CAP, 2, t.t1, t.t2, w, 0.0, 0, u, r, r};
  }
  return {RIM, 0, Z, Z, w, r, 2, u, 0.0, 0.0};
}

// _entry: one entry of H = -J - rho hess|n|_P - sigma I (local).
ELLIPSIM_HD double entry(double Jab, double dab, double ua, double ub, double Qa, double Qb, double rp, double al,
                         double qq, double s) {
  return -Jab - rp * (dab - al * ua * ub - Qa * Qb * qq) - s * dab;
}

// Everything at a unit n: sigma, grad sigma, E's (h, g, z, J), H = hess sigma - sigma I, the stratum's tangent
// basis (t1, t2: zero beyond its 2 - k dimensions) and the reduced Hessian (h11, h12, h22).
struct Local {
  double s;
  Vec3 grad;
  double h;
  Vec3 g, z;
  Mat3 J, H;
  Vec3 t1, t2;
  Reduced R;
};

// _local: everything at the unit n.
ELLIPSIM_HD Local local(const Vec3& n, const Vec3& dw, const Mat3& Re, const Vec3& re, double rho, int pt,
                        const Vec3& u, const Vec3& g0, int k) {
  const Support E = support(Re, re, n);
  const double h = E.h;
  const Vec3& g = E.g;
  const Mat3 J = hess(Re, re, g, h);
  const PNorm p = pnorm(n, pt, u);
  const double npn = p.npn;
  const Vec3& Pn = p.Pn;
  const double s = dot(n, dw) - h - rho * npn;
  const double rp = rho / npn;
  const Vec3 grad = {dw.x - g.x - rp * Pn.x, dw.y - g.y - rp * Pn.y, dw.z - g.z - rp * Pn.z};
  // hess (rho |n|_P) = rho (P - P n n^T P / |n|_P^2) / |n|_P: P = I - al u u^T, P n = Q
  const double al = pt == 2 ? 1.0 : 0.0;
  const Vec3& Q = pt == 2 ? Pn : n;
  const double qq = 1.0 / (npn * npn);
  const Mat3 H = {{entry(J.m[0], 1.0, u.x, u.x, Q.x, Q.x, rp, al, qq, s),
                   entry(J.m[1], 0.0, u.x, u.y, Q.x, Q.y, rp, al, qq, s),
                   entry(J.m[2], 0.0, u.x, u.z, Q.x, Q.z, rp, al, qq, s),
                   entry(J.m[3], 0.0, u.y, u.x, Q.y, Q.x, rp, al, qq, s),
                   entry(J.m[4], 1.0, u.y, u.y, Q.y, Q.y, rp, al, qq, s),
                   entry(J.m[5], 0.0, u.y, u.z, Q.y, Q.z, rp, al, qq, s),
                   entry(J.m[6], 0.0, u.z, u.x, Q.z, Q.x, rp, al, qq, s),
                   entry(J.m[7], 0.0, u.z, u.y, Q.z, Q.y, rp, al, qq, s),
                   entry(J.m[8], 1.0, u.z, u.z, Q.z, Q.z, rp, al, qq, s)}};
  Vec3 t1 = zero(), t2 = zero();
  if (k == 0) {
    const TangentBasis t = tangent(n);
    t1 = t.t1, t2 = t.t2;
  } else if (k == 1) {
    t1 = unit(cross(n, g0));
  }
  const Vec3 Ht1 = matvec(H, t1), Ht2 = matvec(H, t2);
  return {s, grad, h, g, E.z, J, H, t1, t2, {dot(t1, Ht1), dot(t1, Ht2), dot(t2, Ht2)}};
}

// _top: the larger eigenvalue of the reduced Hessian (-inf when the stratum is a point).
ELLIPSIM_HD double top(const Reduced& R, int k) {
  if (k == 0) return top_eigenvalue(R);
  if (k == 1) return R.h11;
  return -INFINITY;
}

// A step in the stratum's tangent coordinates.
struct Step {
  double a1, a2;
};

// _reduced_solve: -(T^T H T)^-1 (r1, r2) in the stratum's tangent coordinates.
ELLIPSIM_HD Step reduced_solve(const Reduced& R, int k, double r1, double r2) {
  if (k == 0) {
    const double det = R.h11 * R.h22 - R.h12 * R.h12;
    return {-(R.h22 * r1 - R.h12 * r2) / det, -(R.h11 * r2 - R.h12 * r1) / det};
  }
  if (k == 1) return {-r1 / R.h11, 0.0};
  return {0.0, 0.0};
}

// What _pair gives: the DerivativeStatus and the ContactFeature.
struct Result {
  int status, feature;
};

// _pair's common part: the derivatives at the maximiser `normal` (world, unit) on the stratum st, in the units
// scaled by sc (re, sk, d = sc (c_K - c_E)); V K's axes (a box's size columns), one_sided(mu0, mu1, slack): the
// multipliers at the edge of the feature's normal cone (the header's ONE_SIDED).
template <typename OneSided>
ELLIPSIM_HD Result pair_on(const Mat3& Re, const Vec3& re, const Vec3& d, double sc, int kind, const Axes& V,
                           const Vec3& sk, const Stratum& st, const Vec3& normal, bool proven, double* grad, double* jn,
                           double* jp, OneSided&& one_sided) {
  Vec3 n = normal;
  const int f = st.f, k = st.k, pt = st.pt;
  const Vec3 &g0 = st.g0, &g1 = st.g1, &w = st.w, &u = st.u;
  const double rho = st.rho;
  if (!proven) {
    write_nan(grad, jn, jp);
    return {UNPROVEN, f};
  }
  if (k == 2) {  // a face or cap: n* is the feature's normal itself
    n = unit(cross(g0, g1));
    if (dot(n, normal) < 0.0) n = {-n.x, -n.y, -n.z};
  } else if (k == 1) {  // an edge or side: onto its great circle
    const double c = dot(n, g0);
    n = unit({n.x - c * g0.x, n.y - c * g0.y, n.z - c * g0.z});
  }
  const double S = math::sqrt(norm2(d)) + max3(re) + max3(sk);
  const Vec3 dw = {d.x - w.x, d.y - w.y, d.z - w.z};
  Local L = local(n, dw, Re, re, rho, pt, u, g0, k);
  for (int it = 0; it < (k < 2 ? tol::DERIV_POLISH_STEPS : 0); ++it) {  // Newton on the stratum
    if (!(top(L.R, k) < -tol::DERIV_FLAT_REL * S)) break;
    const Step a = reduced_solve(L.R, k, dot(L.t1, L.grad), dot(L.t2, L.grad));
    const Vec3 m = unit({n.x + a.a1 * L.t1.x + a.a2 * L.t2.x, n.y + a.a1 * L.t1.y + a.a2 * L.t2.y,
                         n.z + a.a1 * L.t1.z + a.a2 * L.t2.z});
    const Local next = local(m, dw, Re, re, rho, pt, u, g0, k);
    if (next.s < L.s - tol::DERIV_POLISH_SLACK_ULPS * tol::U * S) break;
    n = m;
    L = next;
    if (a.a1 * a.a1 + a.a2 * a.a2 < 1e-32) break;
  }
  if (!(top(L.R, k) < -tol::DERIV_FLAT_REL * S)) {
    write_nan(grad, jn, jp);
    return {FLAT, f};
  }
  const double s = L.s, h = L.h;
  const Vec3 &gs = L.grad, &g = L.g, &z = L.z, &t1 = L.t1, &t2 = L.t2;
  const Mat3 &J = L.J, &H = L.H;
  const Reduced& R = L.R;
  const double mu0 = dot(g0, gs), mu1 = dot(g1, gs);  // grad sigma = sigma n + G^T mu
  int status = s > 0.0 ? SMOOTH : BRANCH;
  if (one_sided(mu0, mu1, tol::DERIV_KINK_REL * S)) status = ONE_SIDED;
  const PNorm p = pnorm(n, pt, u);
  const double npn = p.npn;
  const Vec3& Pn = p.Pn;
  const double iu = 1.0 / sc;
  const Vec3 Z = zero();
  ELLIPSIM_UNROLL_COLUMNS
  for (int j = 0; j < COLUMNS; ++j) {
    const int body = j / 9, kd = (j % 9) / 3, axis = j % 3;
    const Vec3 e = {axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
    // dv: d sigma (n held); b: d grad sigma - dG^T mu; q: pos's explicit part; dg0, dg1: (dG n)_i
    double dv = 0.0, dg0 = 0.0, dg1 = 0.0;
    Vec3 b = Z, q = Z;
    double c0 = 1.0, c1 = sc, c2 = 1.0;  // scales back to world units: dist, normal, pos
    if (body == 0 && kd == 0) {          // E's centre: d -= e
      dv = -at(n, axis), b = {-e.x, -e.y, -e.z}, q = e;
    } else if (body == 0 && kd == 1) {  // E's rotation: dh = -(n x g).e, dg = e x g - J (e x n)
      dv = at(cross(n, g), axis);
      const Vec3 Jn = matvec(J, cross(e, n));
      const Vec3 exg = cross(e, g);
      q = {exg.x - Jn.x, exg.y - Jn.y, exg.z - Jn.z};
      b = {-q.x, -q.y, -q.z};
      c0 = iu, c1 = 1.0, c2 = iu;
    } else if (body == 0) {  // E's semi-axis: as distance/derivatives.hpp
      const double rk = at(re, axis), zk = at(z, axis);
      dv = -rk * zk * zk / h;
      const Vec3 c = {Re.m[axis], Re.m[3 + axis], Re.m[6 + axis]};
      const double t = rk * zk * zk / h;
      q = {(2.0 * rk * zk * c.x - g.x * t) / h, (2.0 * rk * zk * c.y - g.y * t) / h,
           (2.0 * rk * zk * c.z - g.z * t) / h};
      b = {-q.x, -q.y, -q.z};
    } else if (kd == 0) {  // K's centre: d += e
      dv = at(n, axis), b = e;
    } else if (kd == 1) {  // K's rotation about its centre: w, the rows, u turn by e x .
      const Vec3 dwk = cross(e, w);
      dv = -dot(n, dwk);
      b = {-dwk.x, -dwk.y, -dwk.z};
      if (pt == 2) {  // d (rho |n|_P) with dP = -(du u^T + u du^T)
        const Vec3 du = cross(e, u);
        const double cu = dot(u, n), cd = dot(du, n);
        const double dnpn = -cd * cu / npn;  // n^T dP n / (2 |n|_P)
        dv -= rho * dnpn;
        const Vec3 dPn = {-(du.x * cu + u.x * cd), -(du.y * cu + u.y * cd), -(du.z * cu + u.z * cd)};
        b = {b.x - rho * (dPn.x - Pn.x * dnpn / npn) / npn, b.y - rho * (dPn.y - Pn.y * dnpn / npn) / npn,
             b.z - rho * (dPn.z - Pn.z * dnpn / npn) / npn};
      }
      if (k >= 1) {
        const Vec3 dr0 = cross(e, g0);
        dg0 = dot(dr0, n);
        b = axpy(-mu0, dr0, b);
      }
      if (k == 2) {
        const Vec3 dr1 = cross(e, g1);
        dg1 = dot(dr1, n);
        b = axpy(-mu1, dr1, b);
      }
      c0 = iu, c1 = 1.0, c2 = iu;
    } else if (kind == MESH) {  // (a mesh has no size columns: zero)
    } else if (kind == BOX) {  // a half-size: w moves along a free axis
      const Vec3& va = V.v[axis];
      const double cj = dot(n, va);
      if (math::fabs(cj) > tol::DERIV_KINK_COS) {
        const double sg = math::copysign(1.0, cj);
        dv = -math::fabs(cj), b = {-sg * va.x, -sg * va.y, -sg * va.z};
      }
    } else if (axis == 0 && f != CAP) {  // a radius: d rho
      dv = -npn, b = {-Pn.x / npn, -Pn.y / npn, -Pn.z / npn};
    } else if (axis == 1 && f != SIDE) {  // a half-length: w = s L u
      const double cu = dot(n, u);
      const double sg = math::copysign(1.0, cu);
      dv = -math::fabs(cu), b = {-sg * u.x, -sg * u.y, -sg * u.z};
    }
    const double dd = dv - mu0 * dg0 - mu1 * dg1;
    // dn: -G^T (dG n) along the rows, the reduced solve in the tangent space
    const Vec3 dnG = {-(dg0 * g0.x + dg1 * g1.x), -(dg0 * g0.y + dg1 * g1.y), -(dg0 * g0.z + dg1 * g1.z)};
    const Vec3 Hg = matvec(H, dnG);
    const Vec3 r = {b.x + Hg.x, b.y + Hg.y, b.z + Hg.z};
    const Step a = reduced_solve(R, k, dot(t1, r), dot(t2, r));
    const Vec3 dn = {dnG.x + a.a1 * t1.x + a.a2 * t2.x, dnG.y + a.a1 * t1.y + a.a2 * t2.y,
                     dnG.z + a.a1 * t1.z + a.a2 * t2.z};
    const Vec3 Jdn = matvec(J, dn);
    grad[j] = dd * c0;
    jn[j] = dn.x * c1;
    jn[COLUMNS + j] = dn.y * c1;
    jn[2 * COLUMNS + j] = dn.z * c1;
    jp[j] = (q.x + Jdn.x + 0.5 * (dd * n.x + s * dn.x)) * c2;
    jp[COLUMNS + j] = (q.y + Jdn.y + 0.5 * (dd * n.y + s * dn.y)) * c2;
    jp[2 * COLUMNS + j] = (q.z + Jdn.z + 0.5 * (dd * n.z + s * dn.z)) * c2;
  }
  return {status, f};
}

// _pair: the derivatives of one pair at its maximiser `normal` (world, unit) into its rows grad (18), jn and jp
// (3 x 18, row-major); E and K as MuJoCo's geoms (K's sizes geom_size), kind CAPSULE, BOX or CYLINDER.
ELLIPSIM_HD Result pair(const Ellipsoid& E, const Ellipsoid& K, int kind, const Vec3& normal, bool proven, double* grad,
                        double* jn, double* jp) {
  const Vec3 &ce = E.c, &ck = K.c;
  const Mat3& Rk = K.R;
  Vec3 sk = K.r;
  if (kind != BOX) sk = {sk.x, sk.y, 0.0};  // (a capsule's or cylinder's third size is not theirs)
  const double sc = unit_scale(E.r, sk);     // a power of two (exact), as distance/derivatives.hpp
  const Vec3 re = scaled(E.r, sc);
  sk = scaled(sk, sc);
  const Vec3 d = {(ck.x - ce.x) * sc, (ck.y - ce.y) * sc, (ck.z - ce.z) * sc};
  Axes V = {{column(Rk, 0), column(Rk, 1), column(Rk, 2)}};
  if (kind != BOX) V.v[2] = unit(V.v[2]);
  const Stratum st = stratum(kind, normal, V, sk);
  return pair_on(E.R, re, d, sc, kind, V, sk, st, normal, proven, grad, jn, jp,
                 [&](double mu0, double mu1, double slack) {
                   const int f = st.f, k = st.k;
                   if (k == 2 && f == CAP) return math::sqrt(mu0 * mu0 + mu1 * mu1) >= st.bound0 - slack;
                   return (k >= 1 && math::fabs(mu0) >= st.bound0 - slack) ||
                          (k == 2 && math::fabs(mu1) >= st.bound1 - slack);
                 });
}

// --- a convex hull (issue 48): sigma(n) = n.d - h_E(n) - h_P(-n), h_P(-n) = -min_i n.q_i (q_i = R_P v_i, P's
// vertices about its centre): on a stratum h_P(-n) = n.w, w = -q at the feature (the header's form, rho 0).

// The hull's stratum at the unit n (world), q_i = sc R_P v_i: the lowest vertex i0 in n.q, its edges whose
// direction is within DERIV_KINK_COS of normal to n: none, a VERTEX (w = -q_i0); one, an EDGE (w = minus its
// midpoint, g0 its direction, bound0 half its length: the multiplier is the witness's offset along it); more, a
// FACE (the triangle through i0 whose normal is nearest -n: w = -q_i0, rows g0 along one of its edges and
// g1 = m x g0; its one-sided test is mesh_pair's, in the face's polygon).
struct HullStratum {
  Stratum st;
  int i0, face;
};

ELLIPSIM_HD Vec3 hull_point(const Mat3& RP, const polytope::Hull& H, int i, double sc) {
  const Vec3 q = matvec(RP, {H.v[3 * i], H.v[3 * i + 1], H.v[3 * i + 2]});
  return {q.x * sc, q.y * sc, q.z * sc};
}

ELLIPSIM_HD HullStratum hull_stratum(const Vec3& n, const Mat3& RP, const polytope::Hull& H, double sc) {
  const Vec3 Z = zero();
  int i0 = 0;
  double lo = INFINITY;
  for (int i = 0; i < H.nv; ++i) {
    const double v = dot(n, hull_point(RP, H, i, sc));
    if (v < lo) lo = v, i0 = i;
  }
  const Vec3 q0 = hull_point(RP, H, i0, sc);
  int active = 0, j0 = -1;
  for (int a = H.adj_start[i0]; a < H.adj_start[i0 + 1]; ++a) {
    const Vec3 u = unit(sub(hull_point(RP, H, H.adj[a], sc), q0));
    if (math::fabs(dot(n, u)) <= tol::DERIV_KINK_COS) ++active, j0 = H.adj[a];
  }
  if (active == 0) return {{VERTEX, 0, Z, Z, {-q0.x, -q0.y, -q0.z}, 0.0, 0, Z, 0.0, 0.0}, i0, -1};
  if (active == 1) {
    const Vec3 q1 = hull_point(RP, H, j0, sc);
    const Vec3 e = sub(q1, q0);
    const Vec3 mid = {0.5 * (q0.x + q1.x), 0.5 * (q0.y + q1.y), 0.5 * (q0.z + q1.z)};
    return {{EDGE, 1, unit(e), Z, {-mid.x, -mid.y, -mid.z}, 0.0, 0, Z, 0.5 * math::sqrt(norm2(e)), 0.0}, i0, -1};
  }
  int face = -1;
  double best = -INFINITY;
  for (int a = H.vface_start[i0]; a < H.vface_start[i0 + 1]; ++a) {
    const int fc = H.vface[a];
    const Vec3 m = matvec(RP, {H.normal[3 * fc], H.normal[3 * fc + 1], H.normal[3 * fc + 2]});
    if (-dot(m, n) > best) best = -dot(m, n), face = fc;
  }
  const Vec3 m = matvec(RP, {H.normal[3 * face], H.normal[3 * face + 1], H.normal[3 * face + 2]});
  const int other = H.face[3 * face] == i0 ? H.face[3 * face + 1] : H.face[3 * face];
  const Vec3 g0 = unit(sub(hull_point(RP, H, other, sc), q0));
  return {{FACE, 2, g0, cross(m, g0), {-q0.x, -q0.y, -q0.z}, 0.0, 0, Z, 0.0, 0.0}, i0, face};
}

// The distance of the point y (in the face's plane) from the boundary of the face polygon: the triangles
// coplanar with `face` (normals within 1e-9), their edges that only one of them has; negative outside it.
ELLIPSIM_HD double face_margin(const Mat3& RP, const polytope::Hull& H, int face, double sc, const Vec3& y) {
  const Vec3 m0 = {H.normal[3 * face], H.normal[3 * face + 1], H.normal[3 * face + 2]};
  auto coplanar = [&](int g) {
    return H.normal[3 * g] * m0.x + H.normal[3 * g + 1] * m0.y + H.normal[3 * g + 2] * m0.z >= 1.0 - 1e-9;
  };
  const Vec3 m = matvec(RP, m0);
  double edge_min = INFINITY;
  bool inside = false;
  for (int g = 0; g < H.nf; ++g) {
    if (!coplanar(g)) continue;
    const int* t = H.face + 3 * g;
    bool in_g = true;
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3];
      const Vec3 pa = hull_point(RP, H, a, sc), pb = hull_point(RP, H, b, sc), pc = hull_point(RP, H, t[(c + 2) % 3], sc);
      const Vec3 e = sub(pb, pa);
      Vec3 out = cross(e, m);  // in the plane, normal to the edge: turned away from the third vertex
      if (dot(out, sub(pc, pa)) > 0.0) out = {-out.x, -out.y, -out.z};
      const double side = dot(unit(out), sub(y, pa));  // > 0: beyond this edge
      in_g = in_g && side <= 0.0;
      bool shared = false;  // an edge of two coplanar triangles is inside the polygon
      for (int h = 0; h < H.nf && !shared; ++h) {
        if (h == g || !coplanar(h)) continue;
        const int* u = H.face + 3 * h;
        for (int c2 = 0; c2 < 3; ++c2)
          shared = shared || ((u[c2] == a && u[(c2 + 1) % 3] == b) || (u[c2] == b && u[(c2 + 1) % 3] == a));
      }
      if (!shared) {  // the distance to this boundary segment
        const double tt = max2(0.0, min2(1.0, dot(sub(y, pa), e) / norm2(e)));
        const Vec3 x = {pa.x + tt * e.x, pa.y + tt * e.y, pa.z + tt * e.z};
        edge_min = min2(edge_min, math::sqrt(norm2(sub(y, x))));
      }
    }
    inside = inside || in_g;
  }
  return inside ? edge_min : -edge_min;
}

// The derivatives of the ellipsoid E and the hull H posed at (cP, RP) at their maximiser `normal` (from E to P), as
// pair's (P's size columns zero): the feature VERTEX, EDGE or FACE of P; ONE_SIDED where the witness is within
// DERIV_KINK_REL S of the feature's boundary (an edge's end, the face polygon's boundary).
ELLIPSIM_HD Result mesh_pair(const Ellipsoid& E, const Vec3& cP, const Mat3& RP, const polytope::Hull& H,
                             const Vec3& normal, bool proven, double* grad, double* jn, double* jp) {
  double rb = 0.0;
  for (int i = 0; i < H.nv; ++i) rb = max2(rb, math::sqrt(norm2(Vec3{H.v[3 * i], H.v[3 * i + 1], H.v[3 * i + 2]})));
  Vec3 sk = {rb, rb, rb};
  const double sc = unit_scale(E.r, sk);
  const Vec3 re = scaled(E.r, sc);
  sk = scaled(sk, sc);
  const Vec3 d = {(cP.x - E.c.x) * sc, (cP.y - E.c.y) * sc, (cP.z - E.c.z) * sc};
  const Axes V = {{column(RP, 0), column(RP, 1), column(RP, 2)}};
  const HullStratum hs = hull_stratum(normal, RP, H, sc);
  const Stratum& st = hs.st;
  return pair_on(E.R, re, d, sc, MESH, V, sk, st, normal, proven, grad, jn, jp,
                 [&](double mu0, double mu1, double slack) {
                   if (st.k == 1) return math::fabs(mu0) >= st.bound0 - slack;
                   if (st.k < 2) return false;
                   const Vec3 q0 = {-st.w.x, -st.w.y, -st.w.z};  // the witness: q_i0 - mu0 g0 - mu1 g1 in the plane
                   const Vec3 y = {q0.x - mu0 * st.g0.x - mu1 * st.g1.x, q0.y - mu0 * st.g0.y - mu1 * st.g1.y,
                                   q0.z - mu0 * st.g0.z - mu1 * st.g1.z};
                   return face_margin(RP, H, hs.face, sc, y) <= slack;
                 });
}

}  // namespace ellipsim::pairs::derivatives
