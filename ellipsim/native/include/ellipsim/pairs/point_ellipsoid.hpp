// The point-ellipsoid and point-ellipse problems, with certified bounds and every critical point: the
// primitives of the ellipsoid x {capsule, box, cylinder} kernels (capsule.hpp, box.hpp;
// ellipsim/core/pairs/point_ellipsoid.py).
//
// E = {x : sum x_i^2 / a2_i <= 1} in its principal frame (a2 the squared semi-axes); support function
// h(n) = sqrt(n^T A n), support point s(n) = A n / h(n).  f_q(n) = n.q - h(n) is maximised over unit n at
// the outward normal of E at the boundary point nearest to q (inside or outside).
//
// The nearest boundary point is the largest root t > -min(a2) of S(t) = sum_i a2_i q_i^2 / (t + a2_i)^2 = 1,
// solved as psi(t) = S^(-1/2) - 1 = 0 by Newton: psi is a power mean of exponent -2 of the affine
// (t + a2_i) / (a_i |q_i|), concave and increasing, so Newton from the left climbs monotonically to the root
// (Eberly, "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", Geometric Tools,
// sec. 2-3; Schneider & Eberly, GTCG 10.5.2).  Weak duality gives dist(q, boundary E)^2 >= g(t) =
// t (sum_i q_i^2 / (a2_i + t) - 1) for every t > -min(a2), with equality at the root: the certified bound
// sd(q, E) <= -sqrt(g(t)) for q inside E.  The 2-D problem (an ellipse in a plane) is solved the same way.
//
// Namespace ellipsim::pairs::point_ellipsoid (one namespace per Python module: capsule and box share
// names); the Python's private helpers keep their names without the leading underscore.
#pragma once

#include "../math.hpp"

#include "../distance/sphere_newton.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"

namespace ellipsim::pairs::point_ellipsoid {

using distance::unit;

// Component i (0, 1 or 2) of a 3-vector: Python's x[i] on a tuple, with a loop's index.
ELLIPSIM_HD double at(const Vec3& v, int i) { return i == 0 ? v.x : (i == 1 ? v.y : v.z); }

// (h(n), s(n)): E's support function and support point, any nonzero n.
struct Support {
  double h;
  Vec3 s;
};

ELLIPSIM_HD Support support(const Vec3& a2, const Vec3& n) {
  const double an0 = a2.x * n.x, an1 = a2.y * n.y, an2 = a2.z * n.z;
  const double h = math::sqrt(an0 * n.x + an1 * n.y + an2 * n.z);
  const double ih = 1.0 / h;
  return {h, {an0 * ih, an1 * ih, an2 * ih}};
}

// (normal, pos) in world coordinates for the ellipsoid E (centre, rotation row-major, sizes) of a pair, the
// maximiser n in E's principal frame and the signed distance value: E's witness s(n) and the other body's
// s(n) + value n, pos their midpoint (MuJoCo's contact position, mjc_penetration).
struct Contact {
  Vec3 normal, pos;
};

ELLIPSIM_HD Contact contact_in_world(const Ellipsoid& E, const Vec3& a2, const Vec3& n, double value) {
  const Vec3 s = support(a2, n).s;
  const double half = 0.5 * value;
  const Vec3 p = matvec(E.R, Vec3{s.x + half * n.x, s.y + half * n.y, s.z + half * n.z});
  return {matvec(E.R, n), {E.c.x + p.x, E.c.y + p.y, E.c.z + p.z}};
}

// --- the point-ellipsoid and point-ellipse problems (top comment) -------------------------------------------

// (S(t), Newton step of psi = S^(-1/2) - 1).
struct Psi {
  double S, step;
};

// psi/psi' = S (1 - sqrt(S)) / T with T = -S'/2; one division for the three 1/(t + a2_i).
ELLIPSIM_HD Psi psi3(const Vec3& a2, const Vec3& q, double t) {
  const double p0 = t + a2.x, p1 = t + a2.y, p2 = t + a2.z;
  const double p01 = p0 * p1;
  const double inv = 1.0 / (p01 * p2);
  const double d0 = p1 * p2 * inv, d1 = p0 * p2 * inv, d2 = p01 * inv;
  const double w0 = q.x * d0, w1 = q.y * d1, w2 = q.z * d2;
  const double s0 = a2.x * w0 * w0, s1 = a2.y * w1 * w1, s2 = a2.z * w2 * w2;
  const double S = s0 + s1 + s2;
  const double T = s0 * d0 + s1 * d1 + s2 * d2;
  return {S, S * (1.0 - math::sqrt(S)) / T};
}

// The largest root of S(t) = 1, or nan when it lies within POLE_RTOL * amin of the pole -amin.
// Start: the largest -a2_i + a_i |q_i| right of the pole, where term i of S alone is 1.
ELLIPSIM_HD double secular_root3(const Vec3& a2, const Vec3& q, double amin, double amax, double qq) {
  const double lo = -amin + tol::POLE_RTOL * amin;
  double t = lo;
  for (int i = 0; i < 3; ++i) t = max2(t, -at(a2, i) + math::sqrt(at(a2, i)) * math::fabs(at(q, i)));
  const double hi = math::sqrt(amax * qq);  // S(hi) <= 1
  Psi p = psi3(a2, q, t);
  if (!(p.S > 1.0)) return p.S == 1.0 || t > lo ? t : NAN;
  for (int it = 0; it < tol::SECULAR_MAX_ITER; ++it) {
    const double tn = min2(t - p.step, hi);
    // converged relative to the root's distance from the pole -amin (the normal's q_i / (t + a2_i) is as
    // accurate as that), down to what t's float resolution allows
    if (tn - t <= max2(tol::SECULAR_LAST * (tn + amin), 4.0 * tol::U * (math::fabs(tn) + amin))) return tn;
    t = tn;
    p = psi3(a2, q, t);
    if (!(p.S > 1.0)) return t;
  }
  return t;
}

// The normal at the degenerate root -amin: coordinates with a2_i > amin from the formula, the others share
// what is left of the unit quadric along q's direction among them (Eberly, q_k = 0).
ELLIPSIM_HD Vec3 pole_limit(const Vec3& a2, const Vec3& q, double amin) {
  const bool d0 = a2.x - amin <= tol::POLE_RTOL * amin, d1 = a2.y - amin <= tol::POLE_RTOL * amin,
             d2 = a2.z - amin <= tol::POLE_RTOL * amin;
  double x0 = d0 ? 0.0 : a2.x * q.x / (a2.x - amin);
  double x1 = d1 ? 0.0 : a2.y * q.y / (a2.y - amin);
  double x2 = d2 ? 0.0 : a2.z * q.z / (a2.z - amin);
  const double rest = max2(1.0 - x0 * x0 / a2.x - x1 * x1 / a2.y - x2 * x2 / a2.z, 0.0);
  const double qd = (d0 ? q.x * q.x / a2.x : 0.0) + (d1 ? q.y * q.y / a2.y : 0.0) + (d2 ? q.z * q.z / a2.z : 0.0);
  if (qd > 0.0) {
    const double f = math::sqrt(rest / qd);
    x0 = d0 ? q.x * f : x0;
    x1 = d1 ? q.y * f : x1;
    x2 = d2 ? q.z * f : x2;
  } else if (d0) {
    x0 = math::sqrt(rest * a2.x);
  } else if (d1) {
    x1 = math::sqrt(rest * a2.y);
  } else {
    x2 = math::sqrt(rest * a2.z);
  }
  return unit({x0 / a2.x, x1 / a2.y, x2 / a2.z});
}

// (t, n): the largest secular root (t = -min(a2) for the degenerate limit) and the outward unit normal at the
// boundary point of E nearest to q.  max over unit m of m.q - h(m) is attained at n.
struct Foot3 {
  double t;
  Vec3 n;
};

ELLIPSIM_HD Foot3 foot3(const Vec3& a2, const Vec3& q) {
  const double amin = min2(min2(a2.x, a2.y), a2.z);
  const double amax = max2(max2(a2.x, a2.y), a2.z);
  const double qq = norm2(q);
  double t = NAN;
  if (qq > 0.0) t = secular_root3(a2, q, amin, amax, qq);
  if (t == t) return {t, unit({q.x / (t + a2.x), q.y / (t + a2.y), q.z / (t + a2.z)})};
  return {-amin, pole_limit(a2, q, amin)};
}

// -sqrt(g(t)) (top comment) for q inside the d-dimensional ellipse/ellipsoid a2, at foot's secular value t; at
// a degenerate root, at the dual's best point just right of the pole, where the pole terms c / delta^2 make up
// what the others leave of S = 1 (g' = S - 1).
ELLIPSIM_HD double dual_bound(const Vec3& a2, const Vec3& q, double t, int d) {
  const double amin = d == 3 ? min2(min2(a2.x, a2.y), a2.z) : min2(a2.x, a2.y);
  double tt = t;
  if (!(tt > -amin * (1.0 - 1e-15))) {
    double c = 0.0, srest = 0.0;
    for (int i = 0; i < d; ++i) {
      const double den = at(a2, i) - amin;
      if (den > tol::POLE_RTOL * amin) {
        srest += at(a2, i) * at(q, i) * at(q, i) / (den * den);
      } else {
        c += at(a2, i) * at(q, i) * at(q, i);
      }
    }
    const double delta = srest < 1.0 ? math::sqrt(c / (1.0 - srest)) : tol::POLE_RTOL * amin;
    tt = -amin + max2(delta, 1e-15 * amin);
  }
  double g = 0.0;
  for (int i = 0; i < d; ++i) g += at(q, i) * at(q, i) / (at(a2, i) + tt);
  g = tt * (g - 1.0);
  if (!(g > 0.0)) return 0.0;
  return -math::sqrt(g);
}

// |q - x| for the foot point x at t (pulled onto the body if rounding left it outside: a point of the body is
// all the bound needs).
ELLIPSIM_HD double outside_bound(const Vec3& a2, const Vec3& q, double t, int d) {
  const double amin = d == 3 ? min2(min2(a2.x, a2.y), a2.z) : min2(a2.x, a2.y);
  const bool ok = t > -amin * (1.0 - tol::POLE_RTOL);
  Vec3 x = {ok ? a2.x * q.x / (t + a2.x) : 0.0, ok ? a2.y * q.y / (t + a2.y) : 0.0,
            ok && d == 3 ? a2.z * q.z / (t + a2.z) : 0.0};
  const double k = x.x * x.x / a2.x + x.y * x.y / a2.y + (d == 3 ? x.z * x.z / a2.z : 0.0);
  if (k > 1.0) {
    const double f = 1.0 / math::sqrt(k) * (1.0 - 4e-16);
    x = {x.x * f, x.y * f, x.z * f};
  }
  const double d0 = q.x - x.x, d1 = q.y - x.y, d2 = d == 3 ? q.z - x.z : 0.0;
  return math::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

// An upper bound on the signed distance of q to E (negative inside) from foot3's secular value t: outside,
// |q - x| for a point x of E; inside, -sqrt(g(t)) by weak duality.
ELLIPSIM_HD double sd_upper(const Vec3& a2, const Vec3& q, double t) {
  if (q.x * q.x / a2.x + q.y * q.y / a2.y + q.z * q.z / a2.z < 1.0) return dual_bound(a2, q, t, 3);
  return outside_bound(a2, q, t, 3);
}

ELLIPSIM_HD Psi psi2(double b0, double b1, double p0, double p1, double t) {
  const double r0 = t + b0, r1 = t + b1;
  const double inv = 1.0 / (r0 * r1);
  const double d0 = r1 * inv, d1 = r0 * inv;
  const double w0 = p0 * d0, w1 = p1 * d1;
  const double s0 = b0 * w0 * w0, s1 = b1 * w1 * w1;
  const double S = s0 + s1;
  const double T = s0 * d0 + s1 * d1;
  return {S, S * (1.0 - math::sqrt(S)) / T};
}

// A normal of the ellipse in its own axes (not unit).
struct Normal2 {
  double n0, n1;
};

// foot2's normal when the largest root lies within POLE_RTOL bmin of the pole -bmin, where t itself cannot
// resolve it: the root in delta = t + bmin of S = c0 / (delta + d0)^2 + c1 / (delta + d1)^2 = 1 (c_i =
// b_i p_i^2, d_i = b_i - bmin exact by Sterbenz), by Newton on the concave increasing S^(-1/2) - 1 (its first
// step from the right lands left of the root, or is cut to 1e-3 of delta; from the left it rises
// monotonically), then n ~ p_i / (delta + d_i): on a (near-)circle it follows p, where Eberly's limit formula
// would put it on an axis whatever p is (2 |p| below the maximum).  When S stays at most 1 as delta -> 0 (p
// zero on the pole's axis), Eberly's limit point (his q_k = 0 case, GTCG 10.5.2).
ELLIPSIM_HD Normal2 pole_normal2(double b0, double b1, double p0, double p1, double bmin) {
  const double d0 = b0 - bmin, d1 = b1 - bmin;
  const double c0 = b0 * p0 * p0, c1 = b1 * p1 * p1;
  const bool at_pole = (c0 > 0.0 && d0 == 0.0) || (c1 > 0.0 && d1 == 0.0);
  const double s0 = (d0 > 0.0 ? c0 / (d0 * d0) : 0.0) + (d1 > 0.0 ? c1 / (d1 * d1) : 0.0);
  if (at_pole || s0 > 1.0) {
    double delta = tol::POLE_RTOL * bmin;
    for (int it = 0; it < tol::SECULAR_MAX_ITER; ++it) {
      const double r0 = delta + d0, r1 = delta + d1;
      const double S = c0 / (r0 * r0) + c1 / (r1 * r1);
      const double dS = -2.0 * (c0 / (r0 * r0 * r0) + c1 / (r1 * r1 * r1));
      const double step = (1.0 / math::sqrt(S) - 1.0) / (-0.5 * dS / (S * math::sqrt(S)));
      double dn = delta - step;
      if (!(dn > 0.0)) dn = 1e-3 * delta;
      if (math::fabs(dn - delta) <= 4.0 * tol::U * delta) {
        delta = dn;
        break;
      }
      delta = dn;
    }
    return {p0 / (delta + d0), p1 / (delta + d1)};
  }
  double x0 = d0 > 0.0 ? b0 * p0 / d0 : 0.0;
  double x1 = d1 > 0.0 ? b1 * p1 / d1 : 0.0;
  const double rest = max2(1.0 - x0 * x0 / b0 - x1 * x1 / b1, 0.0);
  if (d0 == 0.0) {
    x0 = math::sqrt(rest * b0);
  } else {
    x1 = math::sqrt(rest * b1);
  }
  return {x0 / b0, x1 / b1};
}

// (t, n0, n1): the secular value and the outward unit normal at the ellipse's boundary point nearest to p.
struct Foot2 {
  double t, n0, n1;
};

// 2-D point-ellipse (squared semi-axes b0, b1), by the same Newton as foot3.
ELLIPSIM_HD Foot2 foot2(double b0, double b1, double p0, double p1) {
  const double bmin = min2(b0, b1);
  const double bmax = max2(b0, b1);
  const double pp = p0 * p0 + p1 * p1;
  double t = NAN;
  if (pp > 0.0) {
    const double lo = -bmin + tol::POLE_RTOL * bmin;
    t = max2(max2(lo, -b0 + math::sqrt(b0) * math::fabs(p0)), -b1 + math::sqrt(b1) * math::fabs(p1));
    const double hi = math::sqrt(bmax * pp);
    Psi p = psi2(b0, b1, p0, p1, t);
    if (!(p.S > 1.0)) {
      if (!(p.S == 1.0 || t > lo)) t = NAN;
    } else {
      for (int it = 0; it < tol::SECULAR_MAX_ITER; ++it) {
        const double tn = min2(t - p.step, hi);
        if (tn - t <= max2(tol::SECULAR_LAST * (tn + bmin), 4.0 * tol::U * (math::fabs(tn) + bmin))) {
          t = tn;
          break;
        }
        t = tn;
        p = psi2(b0, b1, p0, p1, t);
        if (!(p.S > 1.0)) break;
      }
    }
  }
  double n0, n1;
  if (t == t) {
    n0 = p0 / (t + b0);
    n1 = p1 / (t + b1);
  } else {
    const Normal2 m = pole_normal2(b0, b1, p0, p1, bmin);
    n0 = m.n0;
    n1 = m.n1;
  }
  const double s = math::sqrt(n0 * n0 + n1 * n1);
  return {t == t ? t : -bmin, n0 / s, n1 / s};
}

// sd_upper for the ellipse (squared semi-axes b0, b1) and the point p, from foot2's t.
ELLIPSIM_HD double sd_upper2(double b0, double b1, double p0, double p1, double t) {
  const Vec3 b = {b0, b1, 1.0}, p = {p0, p1, 0.0};
  if (p0 * p0 / b0 + p1 * p1 / b1 < 1.0) return dual_bound(b, p, t, 2);
  return outside_bound(b, p, t, 2);
}

// The projection of E onto span(w1, w2) (orthonormal): support matrix W^T A W = lam c c^T + mu s s^T with
// c = (cs, sn) in (w1, w2) coordinates, lam >= mu.
struct Ellipse {
  double lam, mu, c, s;
};

ELLIPSIM_HD Ellipse project_ellipse(const Vec3& a2, const Vec3& w1, const Vec3& w2) {
  const double m11 = a2.x * w1.x * w1.x + a2.y * w1.y * w1.y + a2.z * w1.z * w1.z;
  const double m12 = a2.x * w1.x * w2.x + a2.y * w1.y * w2.y + a2.z * w1.z * w2.z;
  const double m22 = a2.x * w2.x * w2.x + a2.y * w2.y * w2.y + a2.z * w2.z * w2.z;
  const double half = 0.5 * (m11 - m22);
  const double rad = math::sqrt(half * half + m12 * m12);
  const double lam = 0.5 * (m11 + m22) + rad;
  // the smaller eigenvalue as det / lam, det = m11 m22 - m12^2 by Cauchy-Binet: a sum of positive terms
  // a_i a_j (w1 x w2)_k^2, where the difference cancels for a thin projection (aspect 100: 1e4 u)
  const double x0 = w1.y * w2.z - w1.z * w2.y;
  const double x1 = w1.z * w2.x - w1.x * w2.z;
  const double x2 = w1.x * w2.y - w1.y * w2.x;
  const double mu = (a2.y * a2.z * x0 * x0 + a2.x * a2.z * x1 * x1 + a2.x * a2.y * x2 * x2) / lam;
  double c, s;
  if (rad > 0.0) {
    if (half >= 0.0) {
      c = half + rad;
      s = m12;
    } else {
      c = m12;
      s = rad - half;
    }
    const double f = 1.0 / math::sqrt(c * c + s * s);
    c = c * f;
    s = s * f;
  } else {
    c = 1.0;
    s = 0.0;
  }
  return {lam, mu, c, s};
}

// The 3-D unit vector with coordinates (n0, n1) along the projected ellipse's axes (c, s), (-s, c).
ELLIPSIM_HD Vec3 from_plane(double n0, double n1, double c, double s, const Vec3& w1, const Vec3& w2) {
  const double k1 = c * n0 - s * n1, k2 = s * n0 + c * n1;
  return unit({k1 * w1.x + k2 * w2.x, k1 * w1.y + k2 * w2.y, k1 * w1.z + k2 * w2.z});
}

// (n, ub): the unit n in span(w1, w2) (orthonormal) maximising n.q - h(n) -- the normal at the point of E's
// projection onto that plane nearest to the projected q -- and an upper bound on that maximum (sd_upper2).
struct CircleMax {
  Vec3 n;
  double ub;
};

ELLIPSIM_HD CircleMax circle_max_bound(const Vec3& a2, const Vec3& q, const Vec3& w1, const Vec3& w2) {
  const Ellipse el = project_ellipse(a2, w1, w2);
  const double p1 = dot3(q.x, q.y, q.z, w1.x, w1.y, w1.z), p2 = dot3(q.x, q.y, q.z, w2.x, w2.y, w2.z);
  const double r0 = el.c * p1 + el.s * p2, r1 = -el.s * p1 + el.c * p2;
  const Foot2 f = foot2(el.lam, el.mu, r0, r1);
  return {from_plane(f.n0, f.n1, el.c, el.s, w1, w2), sd_upper2(el.lam, el.mu, r0, r1, f.t)};
}

// --- every critical point of f_q on the sphere: the deep-penetration enumeration ------------------------------
// The critical points of f_q are E's normals at the feet of the normal lines through q: the real roots of
// S(t) = 1 (at most 6) and, where some q_i vanish, the limit points at the poles t = -a2_i (Eberly, sec. 2-3).
// Between consecutive poles S is convex, so it has 0 or 2 roots there, split by any point where S < 1; beyond
// the outer poles S is monotone with one root.  The limit points at every pole are added whatever q is: exact
// when q_i = 0, within O(|q_i|) of the roots that hug the pole otherwise.

// S(t), S'(t), S''(t).
struct Secular {
  double S, dS, ddS;
};

// c_i = a_i q_i; zero c_i contribute nothing.
ELLIPSIM_HD Secular S3(const Vec3& a2, const Vec3& c, double t) {
  double S = 0.0, dS = 0.0, ddS = 0.0;
  for (int i = 0; i < 3; ++i) {
    if (at(c, i) != 0.0) {
      const double r = 1.0 / (t + at(a2, i));
      const double w = at(c, i) * r;
      const double w2 = w * w;
      S += w2;
      dS -= 2.0 * w2 * r;
      ddS += 6.0 * w2 * r * r;
    }
  }
  return {S, dS, ddS};
}

// The root of psi = S^(-1/2) - 1 in [lo, hi], by Newton from t (S(t) > 1, on the side of the root away from
// psi's maximum): psi is concave between poles, so the iterates move monotonically to the root; a step
// leaving [lo, hi] (rounding) ends at the bound.
ELLIPSIM_HD double root(const Vec3& a2, const Vec3& c, double t, double lo, double hi, double scale) {
  for (int it = 0; it < tol::CRITICAL_MAX_ITER; ++it) {
    const Secular s = S3(a2, c, t);
    if (!(s.S > 1.0)) return t;
    const double step = -2.0 * s.S * (1.0 - math::sqrt(s.S)) / s.dS;  // psi / psi' with psi' = -S' / (2 S^1.5)
    const double tn = min2(max2(t - step, lo), hi);
    if (math::fabs(tn - t) <= 1e-15 * scale) return tn;
    t = tn;
  }
  return t;
}

// A point of (lo, hi) where S < 1, or nan when S >= 1 on the whole interval (no root there): from the minimiser
// of the two pole terms alone, cl^2/(t-lo)^2 + cr^2/(hi-t)^2, safeguarded Newton on S' towards the minimiser of
// the convex S while S stays >= 1.  cl ** (2/3) is Python's float power: pow (numba's llvm.pow, the libm call).
ELLIPSIM_HD double split(const Vec3& a2, const Vec3& c, double lo, double hi, double cl, double cr, double scale) {
  const double wl = math::pow(cl, 2.0 / 3.0), wr = math::pow(cr, 2.0 / 3.0);
  double t = lo + (hi - lo) * (wl + wr > 0.0 ? wl / (wl + wr) : 0.5);
  for (int it = 0; it < tol::CRITICAL_MAX_ITER; ++it) {
    const Secular s = S3(a2, c, t);
    if (s.S < 1.0) return t;
    if (s.dS == 0.0) return NAN;
    if (s.dS < 0.0) {
      lo = t;
    } else {
      hi = t;
    }
    double tn = s.ddS > 0.0 ? t - s.dS / s.ddS : 0.5 * (lo + hi);
    if (!(lo < tn && tn < hi)) tn = 0.5 * (lo + hi);
    if (math::fabs(tn - t) <= 1e-15 * scale || hi - lo <= 1e-15 * scale) return S3(a2, c, tn).S < 1.0 ? tn : NAN;
    t = tn;
  }
  return NAN;
}

// Up to three secular roots, nan where there is none.
struct Roots {
  double t[3];
};

// The roots of S(t) = 1 that can be local maxima of f_q on the sphere (local minima of the distance from q to
// E's boundary), nan where there is none: the largest root (nan unless `largest`: foot3's root, for callers
// that have it) and the two between the two largest poles.  (The Lagrangian |x - q|^2 + t (x^T A^-1 x - 1)
// has the tangent Hessian 2 (I + t A^-1), with a descent direction of the distance for t < -a2_mid.)
ELLIPSIM_HD Roots secular_roots(const Vec3& a2, const Vec3& q, bool largest = true) {
  int i0 = 0, i1 = 1, i2 = 2;  // poles -a2_i ascending
  if (at(a2, i1) > at(a2, i0)) {
    const int k = i0;
    i0 = i1;
    i1 = k;
  }
  if (at(a2, i2) > at(a2, i1)) {
    const int k = i1;
    i1 = i2;
    i2 = k;
  }
  if (at(a2, i1) > at(a2, i0)) {
    const int k = i0;
    i0 = i1;
    i1 = k;
  }
  const Vec3 c = {math::sqrt(a2.x) * q.x, math::sqrt(a2.y) * q.y, math::sqrt(a2.z) * q.z};
  const double scale = max2(max2(a2.x, a2.y), a2.z) + math::fabs(c.x) + math::fabs(c.y) + math::fabs(c.z);
  double r1 = NAN, ra = NAN, rb = NAN;
  // right of the rightmost pole: psi increasing to +inf; start where the largest single term is 1
  const double p = -at(a2, i2);
  double t = p + 1e-300;
  for (int i = 0; i < 3; ++i) t = max2(t, -at(a2, i) + math::fabs(at(c, i)));
  if (largest) {
    const double S = S3(a2, c, t).S;
    if (S > 1.0) {
      r1 = root(a2, c, t, p, INFINITY, scale);
    } else if (S == 1.0 || t > p + 1e-300) {
      r1 = t;
    }
  }
  // between the two rightmost poles: psi concave, 0 or 2 roots around its maximum
  const double pl = -at(a2, i1), pr = -at(a2, i2);
  const double cl = math::fabs(at(c, i1)), cr = math::fabs(at(c, i2));
  // S >= cl^2/(t-pl)^2 + cr^2/(pr-t)^2 >= (cl^(2/3) + cr^(2/3))^3 / (pr-pl)^2: no root if >= 1
  // (cl + cr)^2 <= g^3 (the 2/3-power mean): far enough beyond, g^3 is not computed
  if ((cl + cr) * (cl + cr) >= (pr - pl) * (pr - pl) * (1.0 + 1e-9)) return {{r1, ra, rb}};
  const double g = math::pow(cl, 2.0 / 3.0) + math::pow(cr, 2.0 / 3.0);
  if (pr > pl && g * g * g < (pr - pl) * (pr - pl) * (1.0 + 1e-12)) {
    const double eps = 1e-15 * scale;
    const double m = split(a2, c, pl + eps, pr - eps, cl, cr, scale);
    if (m == m) {
      if (cl != 0.0) {
        t = min2(pl + cl, m);
        // towards the pole until S > 1 (term l alone is 1 at pl + cl)
        for (int it = 0; it < tol::CRITICAL_MAX_ITER; ++it) {
          if (S3(a2, c, t).S > 1.0) break;
          t = pl + 0.5 * (t - pl);
        }
        ra = root(a2, c, t, pl, m, scale);
      }
      if (cr != 0.0) {
        t = max2(pr - cr, m);
        for (int it = 0; it < tol::CRITICAL_MAX_ITER; ++it) {
          if (S3(a2, c, t).S > 1.0) break;
          t = pr - 0.5 * (pr - t);
        }
        rb = root(a2, c, t, m, pr, scale);
      }
    }
  }
  return {{r1, ra, rb}};
}

// (ok, unit normal ~ x / a2).
struct PoleNormal {
  bool ok;
  Vec3 n;
};

// The limit critical point at the pole t = -a2_i (exact when q_i = 0): x_j = a2_j q_j / (a2_j - a2_i) for
// j != i, x_i = sign * sqrt(a2_i (1 - sum_j x_j^2 / a2_j)).  PoleFoot: the x_j and the rest 1 - sum (ok false
// where a denominator vanishes), shared by both signs.
struct PoleFoot {
  bool ok;
  double x0, x1, x2, rest;
};

ELLIPSIM_HD PoleFoot pole_foot(const Vec3& a2, const Vec3& q, int i) {
  const double ai = at(a2, i);
  double x0 = 0.0, x1 = 0.0, x2 = 0.0;
  double rest = 1.0;
  bool ok = true;
  if (i != 0) {
    const double den = a2.x - ai;
    ok = ok && den != 0.0;
    x0 = den != 0.0 ? a2.x * q.x / den : 0.0;
    rest -= x0 * x0 / a2.x;
  }
  if (i != 1) {
    const double den = a2.y - ai;
    ok = ok && den != 0.0;
    x1 = den != 0.0 ? a2.y * q.y / den : 0.0;
    rest -= x1 * x1 / a2.y;
  }
  if (i != 2) {
    const double den = a2.z - ai;
    ok = ok && den != 0.0;
    x2 = den != 0.0 ? a2.z * q.z / den : 0.0;
    rest -= x2 * x2 / a2.z;
  }
  return {ok && !(rest < 0.0), x0, x1, x2, rest};
}

// The unit normal ~ x / a2 at the pole foot with x_i = xi.
ELLIPSIM_HD PoleNormal pole_at(const Vec3& a2, const PoleFoot& p, int i, double xi) {
  const double x0 = i == 0 ? xi : p.x0, x1 = i == 1 ? xi : p.x1, x2 = i == 2 ? xi : p.x2;
  const Vec3 n = {x0 / a2.x, x1 / a2.y, x2 / a2.z};
  if (!(norm2(n) > 0.0)) return {false, {1.0, 0.0, 0.0}};
  return {true, unit(n)};
}

ELLIPSIM_HD PoleNormal pole_normal(const Vec3& a2, const Vec3& q, int i, double sign) {
  const PoleFoot p = pole_foot(a2, q, i);
  if (!p.ok) return {false, {1.0, 0.0, 0.0}};
  return pole_at(a2, p, i, sign * math::sqrt(p.rest * at(a2, i)));
}

// f at both of pole i's limit points that exist, the + sign's first (pole_normal's, the foot computed once).
template <typename F>
ELLIPSIM_HD void pole_normals(const Vec3& a2, const Vec3& q, int i, F&& f) {
  const PoleFoot p = pole_foot(a2, q, i);
  if (!p.ok) return;
  const double r = math::sqrt(p.rest * at(a2, i));
  const PoleNormal plus = pole_at(a2, p, i, r);
  if (plus.ok) f(plus.n);
  const PoleNormal minus = pole_at(a2, p, i, -r);
  if (minus.ok) f(minus.n);
}

// --- every critical point a piece's maximum may be (box.hpp's and polytope.hpp's enumerations) -----------------

// f(n) at every other critical point of f_q on the sphere that can be a local maximum: the roots of the secular
// equation (secular_roots; the largest, foot3's, only if `largest`: a caller that has considered foot3's normal
// leaves it out) and the pole limits (pole_normal), in that order.
template <typename F>
ELLIPSIM_HD void other_critical_normals(const Vec3& a2, const Vec3& q, F&& f, bool largest = true) {
  const Roots roots = secular_roots(a2, q, largest);
  for (int m = 0; m < 3; ++m) {
    const double t = roots.t[m];
    if (t == t) f(unit({q.x / (t + a2.x), q.y / (t + a2.y), q.z / (t + a2.z)}));
  }
  for (int i = 0; i < 3; ++i) pole_normals(a2, q, i, f);
}

// The same in a plane (w1, w2), for E's projection there (ellipse: project_ellipse) and the projected point p
// (along the ellipse's axes, third coordinate 0): the 2-D roots through the 3-D enumeration with a third axis
// longer than both (its term vanishes, the kept roots are the 2-D ones); f gets 3-D unit normals.  largest: as
// other_critical_normals' (foot2's root).
template <typename F>
ELLIPSIM_HD void other_critical_normals2(const Ellipse& el, const Vec3& p, const Vec3& w1, const Vec3& w2, F&& f,
                                         bool largest = true) {
  const double lam = el.lam, mu = el.mu;
  const Vec3 b3 = {lam, mu, 2.0 * max2(lam, mu)};
  const Roots roots = secular_roots(b3, p, largest);
  for (int m = 0; m < 3; ++m) {
    const double t = roots.t[m];
    if (t == t) {
      const Vec3 u = unit({p.x / (t + lam), p.y / (t + mu), 0.0});
      f(from_plane(u.x, u.y, el.c, el.s, w1, w2));
    }
  }
  for (int i = 0; i < 2; ++i)
    pole_normals(b3, p, i, [&](const Vec3& n) { f(from_plane(n.x, n.y, el.c, el.s, w1, w2)); });
}

}  // namespace ellipsim::pairs::point_ellipsoid
