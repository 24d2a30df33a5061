// Signed distance of an ellipsoid and a cylinder (MuJoCo's ellipsoid x cylinder narrow phase;
// ellipsim/core/pairs/cylinder.py, whose docstrings have the derivations): the maximum proven global, or
// reported UNPROVEN (a rim branch and bound out of budget; the MuJoCo glue then falls back to MuJoCo's own
// function and counts it).
//
// Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair), with the cylinder
// K = segment [-L, L] u + disc(r) (the disc perpendicular to u) centred at e in E's principal frame:
// h_K(n) = L |n.u| + r |P n|, P = I - u u^T, so
//
//     sigma(n) = n.e - h_E(n) - L |n.u| - r |P n|.
//
// Strata: the caps n = +-u (face contacts: no unknown), the side circle n.u = 0 (sigma = f_e(n) - r, the 2-D
// point-ellipse problem in E's projection along u; point_ellipsoid.hpp, after Eberly, "Distance from a point to
// an ellipse, an ellipsoid, or a hyperellipsoid", and GTCG 10.5.2), and the two rim regions sign(n.u) = s where
// sigma = f_rim(n) = n.(e - s L u) - h_E(n) - r |P n| is smooth (rim-circle contacts).  Local solve: Newton on
// the rim facing E, in polar coordinates about its cap (the cone point of r |P n| at the cap is then just the
// boundary b = 0); if it leaves its region, the caps and the side, checked by KKT, hand back to the rim the
// violation points to.
//
// Certificates (global upper bounds on max sigma):
// * ub1 = sd(e - s_E(n) + rho n, K) - rho (rho the rolling radius of E; the exact point-cylinder sd);
// * ub2 = sd(e - c, E) - t for a ball(c, t) inside K at the witness (t > 0 for cap and side contacts);
// * ub3 (side contacts of a cylinder crossing E): the ball of radius delta + r around e lies in E + K when the
//   chords of E along u, lengthened by L, cover it (sweep_bound);
// * ub4 (side contacts): a capsule inside K with K's support at the contact normal bounds sigma above
//   everywhere; its maximum is proven by capsule.hpp (capsule_bound).
// When none closes: caps and side are exact; a rim piece is bounded above by the maximum of f_{q - r c} over
// lunes of azimuths about u, bisected until each bound is within the tolerance of the incumbent (rim_bb); near
// the incumbent a lune is split at its polar band (split_settles: a second-order certificate on the band,
// cert_model / cert_region, f_{q - r c} over spherical polygons elsewhere, poly_bound); a lune that tangent
// planes of h_E + r |P n| close (tangent_cones.hpp) is skipped.  A rim whose branch and bound runs out of
// budget leaves the pair UNPROVEN; a flat rim (E a spheroid about the cylinder's axis) gets a second chance
// from spheroids' axis_bb (axis_max).
//
// Namespace ellipsim::pairs::cylinder; the Python's private helpers keep their names without the leading
// underscore.  Every expression keeps the Python's order of operations, for bit-identical results.  Numba
// quirks: Python's float % (fmod, moved to the divisor's sign: py_mod), x ** 2 as x * x (numba's power by
// a constant integer), min / max as vec3.hpp's min2 / max2 (the first argument on NaN ties, chained left to
// right), math.copysign, atan2, sin, cos and ldexp as the same libm calls.
#pragma once

#include "../math.hpp"

#include "../distance/sphere_newton.hpp"
#include "../distance/spheroids.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "capsule.hpp"
#include "point_ellipsoid.hpp"
#include "tangent_cones.hpp"

namespace ellipsim::pairs::cylinder {

using distance::rolling_radius;
using distance::tangent_basis;
using distance::TangentBasis;
using distance::unit;
using distance::spheroids::PI;
using point_ellipsoid::circle_max_bound;
using point_ellipsoid::contact_in_world;
using point_ellipsoid::foot3;
using point_ellipsoid::from_plane;
using point_ellipsoid::pole_normal;
using point_ellipsoid::project_ellipse;
using point_ellipsoid::sd_upper;
using point_ellipsoid::secular_roots;
using point_ellipsoid::support;
using tangent_cones::cone_below;
using tangent_cones::dot;  // cylinder.py's _dot: x0 y0 + x1 y1 + x2 y2

// How cylinder_ellipsoid ended: CERTIFIED (an upper bound within PAIR_CERT_REL of the smaller shortest
// half-size of the value), ENUMERATED (every piece bounded or solved) or UNPROVEN.
constexpr int CERTIFIED = 0, ENUMERATED = 1, UNPROVEN = 2;

constexpr int NEWTON_MAX_ITER = 30;
// Newton's last step: below this many radians the next would be ~1e-18 (quadratic convergence).
constexpr double NEWTON_STEP_TOL = 1e-8;
// A polar angle from the axis below this many radians is the cap (the rim function's cone point).
constexpr double CAP_TOL = 1e-12;

constexpr int SIDE = 0, CAP_P = 1, CAP_M = 2, RIM_P = 3, RIM_M = 4;
constexpr int CONVERGED = 0, AT_CAP = 1, STALLED = 2;

// ub4 is not tried when its capsule's radius t is below this fraction of the cylinder's (cylinder.py).
constexpr double CAPSULE_MIN_FIT = 0.5;
// The split certificate's reach multiple, its band tries, the skip prediction's excess, the rim's first lunes,
// the third-derivative constant and _reach's fixed-point steps (cylinder.py has each one's measurements).
constexpr double SPLIT_REACH = 1.4;
constexpr int SPLIT_TRIES = 3;
constexpr double SKIP_EXCESS = 64.0;
constexpr int RIM_LUNES = 6;
constexpr double D3_NORM = 1.1548;
constexpr int REACH_STEPS = 5;

// Python's float x % y (numba's real_mod: fmod, then moved to y's sign; a zero remainder takes y's sign).
ELLIPSIM_HD double py_mod(double x, double y) {
  double mod = math::fmod(x, y);
  if (mod != 0.0 || mod != mod) {
    if ((y < 0.0) != (mod < 0.0)) mod = mod + y;
  } else {
    mod = y < 0.0 ? -0.0 : 0.0;
  }
  return mod;
}

ELLIPSIM_HD Vec3 neg(const Vec3& v) { return {-v.x, -v.y, -v.z}; }

// sg v: a sign times a vector (cylinder.py's (sg * v[0], sg * v[1], sg * v[2])).
ELLIPSIM_HD Vec3 times(double s, const Vec3& v) { return {s * v.x, s * v.y, s * v.z}; }

// A 2-vector (the gnomonic chart's coordinates, a plane gradient).
struct V2 {
  double x, y;
};

// (e, a2, u): K's centre in E's principal frame, E's squared semi-axes, K's unit axis (its local z, normalised:
// rotations orthonormal only to ~1e-7 leave it that far from unit) (cylinder.py to_frame).
struct Frame {
  Vec3 e, a2, u;
};

// cylinder.py to_frame.
ELLIPSIM_HD Frame to_frame(const Ellipsoid& E, const Ellipsoid& K) {
  const Vec3 e = rotate_t(E.R, sub(K.c, E.c));
  const Vec3 u = unit(rotate_t(E.R, column(K.R, 2)));
  return {e, {E.r.x * E.r.x, E.r.y * E.r.y, E.r.z * E.r.z}, u};
}

// |P n| = |n x u| for the unit u (cylinder.py perp).
ELLIPSIM_HD double perp(const Vec3& n, const Vec3& u) {
  const Vec3 x = cross3(n, u);
  return math::sqrt(x.x * x.x + x.y * x.y + x.z * x.z);
}

// sigma at the unit n (cylinder.py sigma_cylinder).
ELLIPSIM_HD double sigma_cylinder(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  const double nu = dot(n, u);
  return dot(n, e) - h - L * math::fabs(nu) - r * perp(n, u);
}

// f_rim(n) = n.q - h_E(n) - r |P n| for the unit n (cylinder.py sigma_rim).
ELLIPSIM_HD double sigma_rim(const Vec3& a2, const Vec3& q, const Vec3& u, double r, const Vec3& n) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  return dot(n, q) - h - r * perp(n, u);
}

// H = -(A/h - an an^T/h^3) applied to x, y (cylinder.py _rim_newton's hq).
ELLIPSIM_HD double hq(const Vec3& a2, const Vec3& an, double ih, const Vec3& x, const Vec3& y) {
  return -(a2.x * x.x * y.x + a2.y * x.y * y.y + a2.z * x.z * y.z) * ih + dot(an, x) * dot(an, y) * ih * ih * ih;
}

// (n, value, code) of a rim Newton run.
struct RimNewton {
  Vec3 n;
  double value;
  int code;
};

// Newton for max of f_rim (the rim sg = +-1) from the unit n, in polar coordinates about the cap sg u
// (cylinder.py _rim_newton): CONVERGED, AT_CAP (b reached 0) or STALLED.
ELLIPSIM_HD_CALL RimNewton rim_newton(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double sg, Vec3 n) {
  const Vec3 q = {e.x - sg * L * u.x, e.y - sg * L * u.y, e.z - sg * L * u.z};
  const TangentBasis w = tangent_basis(u);
  const Vec3 &w1 = w.t1, &w2 = w.t2;
  double b = math::atan2(perp(n, u), sg * dot(n, u));
  double p = math::atan2(dot(n, w2), dot(n, w1));
  b = min2(max2(b, 1e-6), 0.5 * PI - 1e-6);
  double value = -INFINITY;
  for (int it = 0; it < NEWTON_MAX_ITER; ++it) {
    double cb = math::cos(b), sb = math::sin(b);
    const double cp = math::cos(p), sp = math::sin(p);
    const Vec3 c = {cp * w1.x + sp * w2.x, cp * w1.y + sp * w2.y, cp * w1.z + sp * w2.z};
    const Vec3 dc = {-sp * w1.x + cp * w2.x, -sp * w1.y + cp * w2.y, -sp * w1.z + cp * w2.z};
    n = {sg * cb * u.x + sb * c.x, sg * cb * u.y + sb * c.y, sg * cb * u.z + sb * c.z};
    const Vec3 nb = {-sg * sb * u.x + cb * c.x, -sg * sb * u.y + cb * c.y, -sg * sb * u.z + cb * c.z};
    const Vec3 npp = {sb * dc.x, sb * dc.y, sb * dc.z};
    const Vec3 an = {a2.x * n.x, a2.y * n.y, a2.z * n.z};
    const double h = math::sqrt(dot(an, n));
    const double ih = 1.0 / h;
    const Vec3 G = {q.x - an.x * ih, q.y - an.y * ih, q.z - an.z * ih};
    value = dot(n, q) - h - r * sb;
    const double fb = dot(G, nb) - r * cb;
    const double fp = dot(G, npp);
    double fbb = hq(a2, an, ih, nb, nb) - dot(G, n) + r * sb;
    double fpp = hq(a2, an, ih, npp, npp) - sb * dot(G, c);
    const double fbp = hq(a2, an, ih, nb, npp) + cb * dot(G, dc);
    double det = fbb * fpp - fbp * fbp;
    double shift = 0.0;
    if (!(fbb < 0.0 && det > 0.0)) {
      const double hd = fbb - fpp;
      const double top = 0.5 * (fbb + fpp) + math::sqrt(0.25 * (hd * hd) + fbp * fbp);
      shift = max2(top, 0.0) + 1e-3 * (math::fabs(fbb) + math::fabs(fpp)) + math::sqrt(fb * fb + fp * fp);
      fbb = fbb - shift;
      fpp = fpp - shift;
      det = fbb * fpp - fbp * fbp;
    }
    const double idet = 1.0 / det;
    double db = -(fpp * fb - fbp * fp) * idet;
    double dp = -(fbb * fp - fbp * fb) * idet;
    double arc2 = db * db + sb * sb * dp * dp;
    if (arc2 > 0.25) {
      const double f = 0.5 / math::sqrt(arc2);
      db = db * f;
      dp = dp * f;
      arc2 = 0.25;
    }
    if (b + db <= 0.0) {  // towards the cap: at most halfway there (the optimum may sit just off it)
      const double f = 0.5 * b / (-db);
      db = db * f;
      dp = dp * f;
      arc2 = arc2 * f * f;
    }
    for (int k = 0; k < 12; ++k) {  // backtrack until f grows
      const double bn_ = b + db;
      const Vec3 m = {
          sg * math::cos(bn_) * u.x + math::sin(bn_) * (math::cos(p + dp) * w1.x + math::sin(p + dp) * w2.x),
          sg * math::cos(bn_) * u.y + math::sin(bn_) * (math::cos(p + dp) * w1.y + math::sin(p + dp) * w2.y),
          sg * math::cos(bn_) * u.z + math::sin(bn_) * (math::cos(p + dp) * w1.z + math::sin(p + dp) * w2.z)};
      if (arc2 < 1e-12 || sigma_rim(a2, q, u, r, m) >= value) break;
      db = 0.5 * db;
      dp = 0.5 * dp;
      arc2 = 0.25 * arc2;
    }
    b = b + db;
    p = p + dp;
    if (b <= CAP_TOL) {
      const Vec3 m = times(sg, u);
      return {m, sigma_rim(a2, q, u, r, m), AT_CAP};
    }
    if (arc2 <= NEWTON_STEP_TOL * NEWTON_STEP_TOL && shift == 0.0) {
      cb = math::cos(b);
      sb = math::sin(b);
      const Vec3 m = {sg * cb * u.x + sb * (math::cos(p) * w1.x + math::sin(p) * w2.x),
                      sg * cb * u.y + sb * (math::cos(p) * w1.y + math::sin(p) * w2.y),
                      sg * cb * u.z + sb * (math::cos(p) * w1.z + math::sin(p) * w2.z)};
      return {m, sigma_rim(a2, q, u, r, m), CONVERGED};
    }
  }
  return {n, value, STALLED};
}

// K's support point in direction +n relative to K's centre: e - s_E(n) - value n (cylinder.py _witness).
ELLIPSIM_HD Vec3 witness(const Vec3& a2, const Vec3& e, const Vec3& n, double value) {
  const Vec3 s = support(a2, n).s;
  return {e.x - s.x - value * n.x, e.y - s.y - value * n.y, e.z - s.z - value * n.z};
}

// (n, stratum, converged) of the local solve.
struct LocalMax {
  Vec3 n;
  int stratum;
  bool converged;
};

// Rim first, then the caps and the side by KKT (cylinder.py local_max).
ELLIPSIM_HD LocalMax local_max(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r) {
  const double eu = dot(e, u);
  const Vec3 ep = {e.x - eu * u.x, e.y - eu * u.y, e.z - eu * u.z};
  const double pe = math::sqrt(dot(ep, ep));
  Vec3 c;
  if (pe > 0.0) {
    c = {ep.x / pe, ep.y / pe, ep.z / pe};
  } else {
    c = tangent_basis(u).t1;
  }
  // K's support point in direction +n ~ +e: sg L u + r c, with sg = sign(e.u), c along e_perp
  double sg = eu >= 0.0 ? 1.0 : -1.0;
  const Vec3 q = {e.x - sg * L * u.x - r * c.x, e.y - sg * L * u.y - r * c.y, e.z - sg * L * u.z - r * c.z};
  Vec3 start = foot3(a2, q).n;
  if (sg * dot(start, u) > 0.0 && math::fabs(dot(start, u)) < 1.0 - 1e-9) {
    const RimNewton rn = rim_newton(a2, e, u, L, r, sg, start);
    if (rn.code == CONVERGED && sg * dot(rn.n, u) > 0.0) return {rn.n, sg > 0.0 ? RIM_P : RIM_M, true};
  }
  // the caps and the side, then their KKT
  double best = sigma_cylinder(a2, e, u, L, r, u);
  Vec3 n = u;
  int st = CAP_P;
  const Vec3 mu_ = neg(u);
  double v = sigma_cylinder(a2, e, u, L, r, mu_);
  if (v > best) best = v, n = mu_, st = CAP_M;
  const TangentBasis w = tangent_basis(u);
  const Vec3 ns = circle_max_bound(a2, e, w.t1, w.t2).n;
  v = sigma_cylinder(a2, e, u, L, r, ns);
  if (v > best) best = v, n = ns, st = SIDE;
  for (int k = 0; k < 4; ++k) {
    const Vec3 y = witness(a2, e, n, best);
    const double ya = dot(y, u);
    double f = 0.0;
    Vec3 yr = {0.0, 0.0, 0.0};
    if (st == SIDE) {
      if (math::fabs(ya) <= L) return {n, st, true};
      sg = ya > 0.0 ? 1.0 : -1.0;
      start = unit({n.x + 0.1 * sg * u.x, n.y + 0.1 * sg * u.y, n.z + 0.1 * sg * u.z});
    } else {
      sg = st == CAP_P ? 1.0 : -1.0;
      yr = {y.x - ya * u.x, y.y - ya * u.y, y.z - ya * u.z};
      const double rad = math::sqrt(dot(yr, yr));
      if (rad <= r) return {n, st, true};
      // the rim optimum sits off the cap by about (rad - r) / curvature: start there, on the azimuth of the
      // violation (a far start may crawl along the cap's degenerate azimuth)
      f = min2(0.3, max2(1e-6, 10.0 * (rad - r) / rad)) / rad;
      start = unit({sg * u.x + f * yr.x, sg * u.y + f * yr.y, sg * u.z + f * yr.z});
    }
    RimNewton rn = rim_newton(a2, e, u, L, r, sg, start);
    if (rn.code != CONVERGED && st != SIDE) {  // a second start closer to the cap
      const double f2 = 0.01 * f;
      start = unit({sg * u.x + f2 * yr.x, sg * u.y + f2 * yr.y, sg * u.z + f2 * yr.z});
      const RimNewton r2 = rim_newton(a2, e, u, L, r, sg, start);
      if (r2.code == CONVERGED || r2.value > rn.value) rn = r2;
    }
    if (rn.code == CONVERGED && sg * dot(rn.n, u) > 0.0) return {rn.n, sg > 0.0 ? RIM_P : RIM_M, true};
    if (rn.code == AT_CAP) {
      n = times(sg, u);
      st = sg > 0.0 ? CAP_P : CAP_M;
    } else if (rn.code == CONVERGED) {  // crossed to the other hemisphere: the side
      n = ns;
      st = SIDE;
    } else {
      return {rn.n, sg > 0.0 ? RIM_P : RIM_M, false};
    }
    best = sigma_cylinder(a2, e, u, L, r, n);
  }
  return {n, st, false};
}

// The exact signed distance of the point w to K centred at 0 (cylinder.py sd_point_cylinder).
ELLIPSIM_HD double sd_point_cylinder(const Vec3& w, const Vec3& u, double L, double r) {
  const double z = dot(w, u);
  const double rad = perp(w, u);  // |w x u|: sqrt(|w|^2 - z^2) would lose half the digits near the axis
  const double dz = math::fabs(z) - L, dr = rad - r;
  if (dz <= 0.0 && dr <= 0.0) return max2(dz, dr);
  const double oz = max2(dz, 0.0), orr = max2(dr, 0.0);
  return math::sqrt(oz * oz + orr * orr);
}

// ub1 of the top comment at the unit n (cylinder.py upper_bound1).
ELLIPSIM_HD double upper_bound1(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double rho,
                                const Vec3& n) {
  const Vec3 s = support(a2, n).s;
  const Vec3 w = {e.x - s.x + rho * n.x, e.y - s.y + rho * n.y, e.z - s.z + rho * n.z};
  return sd_point_cylinder(w, u, L, r) - rho;
}

// ub2: the witness clamped into K, with the largest ball inside K tangent there for cap and side contacts
// (cylinder.py upper_bound2).
ELLIPSIM_HD double upper_bound2(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n,
                                double value) {
  const Vec3 y = witness(a2, e, n, value);
  const double ya = dot(y, u);
  Vec3 yr = {y.x - ya * u.x, y.y - ya * u.y, y.z - ya * u.z};
  const double rad = math::sqrt(dot(yr, yr));
  const double nu = dot(n, u);
  const double pn = perp(n, u);
  double za = min2(max2(ya, -L), L);
  double t = 0.0;
  if (pn < 1e-12) {  // cap: centre axial sign(nu)(L - t), radial the witness's (within r)
    const double f = rad > 0.0 ? min2(1.0, r / rad) : 1.0;
    yr = {yr.x * f, yr.y * f, yr.z * f};
    t = min2(L, r - rad * f);
    za = math::copysign(L - t, nu);
  } else if (math::fabs(nu) < 1e-12) {  // side: centre radial (r - t) n, axial the witness's (within L)
    t = min2(r, L - math::fabs(za));
    const double pr = r - t;
    yr = {pr * n.x, pr * n.y, pr * n.z};
  } else {  // rim: the rim point
    const double f = rad > 0.0 ? r / rad : 0.0;
    yr = {yr.x * f, yr.y * f, yr.z * f};
    za = math::copysign(L, ya);
  }
  const Vec3 q = {e.x - za * u.x - yr.x, e.y - za * u.y - yr.y, e.z - za * u.z - yr.z};
  const double tt = foot3(a2, q).t;
  return sd_upper(a2, q, tt) - t;
}

// ub3 for a side contact n: -(delta2 + r) when the chords of E along u, lengthened by L, cover the ball of that
// radius around e; inf when the test fails (cylinder.py _sweep_bound).
ELLIPSIM_HD double sweep_bound(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n) {
  (void)n;
  const TangentBasis w = tangent_basis(u);
  const double ub2d = circle_max_bound(a2, e, w.t1, w.t2).ub;
  if (ub2d > 0.0) return INFINITY;
  const double d2 = -ub2d;
  const Vec3 g = {u.x / a2.x, u.y / a2.y, u.z / a2.z};
  const double kappa = dot(g, u);
  const double tau = dot(e, u);
  const Vec3 ep = {e.x - tau * u.x, e.y - tau * u.y, e.z - tau * u.z};
  const double c0 = tau + dot(g, ep) / kappa;
  const double gam2 = max2(dot(g, g) - kappa * kappa, 0.0) / (kappa * kappa);
  const double dd = d2 + r;
  if (math::fabs(c0) + math::sqrt(dd * dd + gam2 * d2 * d2) <= L) return -dd;
  return INFINITY;
}

// ub4 (side contacts): the maximum of the capsule inside K with K's support at n, proven by capsule.hpp; inf
// when its radius is at most CAPSULE_MIN_FIT r (cylinder.py _capsule_bound).
ELLIPSIM_HD_CALL double capsule_bound(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double rho,
                                 const Vec3& n, double value, double tol, double slack) {
  (void)slack;
  const double ya = dot(witness(a2, e, n, value), u);
  const double t = min2(r, L - math::fabs(ya));
  if (!(t > CAPSULE_MIN_FIT * r)) return INFINITY;  // (a thinner capsule's round end rarely fits under the rim)
  const Vec3 ec = {e.x - (r - t) * n.x, e.y - (r - t) * n.y, e.z - (r - t) * n.z};
  const double lc = L - t;
  const double ub = capsule::upper_bound(a2, ec, u, lc, t, rho, n, value, tol);
  if (ub - value <= tol) return ub;
  const double best = capsule::enumerate_max(a2, ec, u, lc, t, value, n, 0.5 * tol).value;
  return min2(ub, best + 0.5 * tol);  // tol / 2 >= 96 u S covers the critical points' slack (64 u S)
}

// The first of ub1, ub2 (then ub3, ub4 for side contacts) within tol of value, else their minimum (cylinder.py
// upper_bound).
ELLIPSIM_HD double upper_bound(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double rho,
                               const Vec3& n, double value, double tol, double slack) {
  double ub = upper_bound1(a2, e, u, L, r, rho, n);
  if (ub - value <= tol) return ub;
  ub = min2(ub, upper_bound2(a2, e, u, L, r, n, value));
  if (ub - value <= tol) return ub;
  if (math::fabs(dot(n, u)) < 1e-12) {
    ub = min2(ub, sweep_bound(a2, e, u, L, r, n));
    if (ub - value > tol) ub = min2(ub, capsule_bound(a2, e, u, L, r, rho, n, value, tol, slack));
  }
  return ub;
}

// --- the rim's branch and bound: f_p over arcs and spherical polygons ------------------------------------------

// f_p(m) = m.p - h_E(m) (cylinder.py _f).
ELLIPSIM_HD double f(const Vec3& a2, const Vec3& p, const Vec3& m) {
  return dot(m, p) - math::sqrt(a2.x * m.x * m.x + a2.y * m.y * m.y + a2.z * m.z * m.z);
}

// Whether the unit m of the plane span(v1, v2) lies on the arc [0, span] (cylinder.py _on_arc).
ELLIPSIM_HD bool on_arc(const Vec3& m, const Vec3& v1, const Vec3& v2, double cs, double sn) {
  const double x = dot(m, v1), y = dot(m, v2);
  return y >= 0.0 && x * sn - y * cs >= 0.0;
}

// cos t v1 + sin t v2 (cylinder.py _turn).
ELLIPSIM_HD Vec3 turn(const Vec3& v1, const Vec3& v2, double t) {
  const double ct = math::cos(t), st = math::sin(t);
  return {ct * v1.x + st * v2.x, ct * v1.y + st * v2.y, ct * v1.z + st * v2.z};
}

// A value and where it is attained: (bound, m), (best, bm).
struct Top {
  double v;
  Vec3 m;
};

// (best, bm) raised by f_p(m) + slack when the unit m lies on the arc (cylinder.py _arc_top).
ELLIPSIM_HD Top arc_top(const Vec3& a2, const Vec3& p, const Vec3& m, const Vec3& v1, const Vec3& v2, double cs,
                        double sn, double slack, const Top& best) {
  if (on_arc(m, v1, v2, cs, sn)) {
    const double v = f(a2, p, m) + slack;
    if (v > best.v) return {v, m};
  }
  return best;
}

// (ok, n_a, n_b) of the 2-D point-ellipse problem's limit point at its pole -la (cylinder.py _plane_pole).
struct PlanePole {
  bool ok;
  double na, nb;
};

// cylinder.py _plane_pole.
ELLIPSIM_HD PlanePole plane_pole(double la, double lb, double qb) {
  const double xb = lb * qb / (lb - la);
  const double rest = 1.0 - xb * xb / lb;
  if (!(rest >= 0.0)) return {false, 0.0, 0.0};
  return {true, math::sqrt(rest * la) / la, xb / lb};
}

// max of g.(x, y) over the unit directions from (x0, y0) to (x1, y1) (cylinder.py _sub_max).
ELLIPSIM_HD double sub_max(const V2& g, double x0, double y0, double x1, double y1) {
  if (x0 * g.y - y0 * g.x >= 0.0 && g.x * y1 - g.y * x1 >= 0.0) return math::sqrt(g.x * g.x + g.y * g.y);
  return max2(g.x * x0 + g.y * y0, g.x * x1 + g.y * y1);
}

// An upper bound of min(ga.x, gb.x) over the unit directions x from (x0, y0) to (x1, y1) (cylinder.py
// _split_max).
ELLIPSIM_HD double split_max(const V2& ga, const V2& gb, double x0, double y0, double x1, double y1) {
  double dx = gb.y - ga.y, dy = ga.x - gb.x;  // ga.x = gb.x where x is perpendicular to ga - gb
  if (x0 * dy - y0 * dx < 0.0) dx = -dx, dy = -dy;
  if (!(x0 * dy - y0 * dx >= 0.0 && dx * y1 - dy * x1 >= 0.0)) {
    dx = x0 + x1;  // no crossing inside (rounding): the bisector
    dy = y0 + y1;
  }
  const double nd = math::sqrt(dx * dx + dy * dy);
  if (!(nd > 0.0)) return max2(sub_max(ga, x0, y0, x1, y1), sub_max(gb, x0, y0, x1, y1));
  dx = dx / nd;
  dy = dy / nd;
  return max2(sub_max(ga, x0, y0, dx, dy), sub_max(gb, dx, dy, x1, y1));
}

// An upper bound of min_k g_k.(cos t, sin t) over t in [0, span] (cylinder.py _envelope).
ELLIPSIM_HD double envelope(const V2& g0, const V2& gm, const V2& g2, double cs, double sn) {
  const double nm = math::sqrt(2.0 + 2.0 * cs);
  if (!(nm > 0.0)) return max2(sub_max(g0, 1.0, 0.0, cs, sn), sub_max(g2, 1.0, 0.0, cs, sn));
  const double xm = (1.0 + cs) / nm, ym = sn / nm;
  return max2(split_max(g0, gm, 1.0, 0.0, xm, ym), split_max(gm, g2, xm, ym, cs, sn));
}

// (bound, m): the maximum of f_p over the arc {cos t v1 + sin t v2 : t in [0, span]} and where it is attained,
// or the tangent planes' bound when that is below floor, or an end above stop (cylinder.py _arc_max).
ELLIPSIM_HD_CALL Top arc_max(const Vec3& a2, const Vec3& p, const Vec3& v1, const Vec3& v2, double cs, double sn,
                        const Vec3& end, double slack, double floor, double stop) {
  const double p1 = dot(p, v1), p2 = dot(p, v2);
  // tangent planes at the arc's ends and middle: f_p(m) <= m.(p - s_E(m_k)) everywhere (weak duality)
  const point_ellipsoid::Support S0 = support(a2, v1);
  const point_ellipsoid::Support S2 = support(a2, end);
  const Vec3 mid = {v1.x + end.x, v1.y + end.y, v1.z + end.z};
  const Vec3 sm = support(a2, mid).s;
  const double lin = envelope({p1 - dot(S0.s, v1), p2 - dot(S0.s, v2)}, {p1 - dot(sm, v1), p2 - dot(sm, v2)},
                              {p1 - dot(S2.s, v1), p2 - dot(S2.s, v2)}, cs, sn);
  if (lin + slack <= floor) return {lin + slack, v1};
  const point_ellipsoid::Ellipse el = project_ellipse(a2, v1, v2);
  const double lam = el.lam, mu = el.mu, c = el.c, s = el.s;
  const Vec3 q = {c * p1 + s * p2, -s * p1 + c * p2, 0.0};
  Top best = {p1 - S0.h, v1};
  const double v = dot(p, end) - S2.h;
  if (v > best.v) best = {v, end};
  if (best.v > stop) return best;
  const Vec3 b3 = {lam, mu, 2.0 * max2(lam, mu)};
  const point_ellipsoid::Roots roots = secular_roots(b3, q, true);
  for (int k = 0; k < 3; ++k) {
    const double t = roots.t[k];
    if (t == t)
      best = arc_top(a2, p, from_plane(q.x / (t + lam), q.y / (t + mu), c, s, v1, v2), v1, v2, cs, sn, slack, best);
  }
  // the limit points at the poles -lam, -mu (pole_normal of b3 in the plane: its third axis is not E's)
  if (lam != mu) {
    const PlanePole pa = plane_pole(lam, mu, q.y);
    const PlanePole pb = plane_pole(mu, lam, q.x);
    for (int k = 0; k < 2; ++k) {  // (the order of the written-out blocks before: ties keep their point)
      const double sign = k == 0 ? 1.0 : -1.0;
      if (pa.ok) best = arc_top(a2, p, from_plane(sign * pa.na, pa.nb, c, s, v1, v2), v1, v2, cs, sn, slack, best);
    }
    for (int k = 0; k < 2; ++k) {
      const double sign = k == 0 ? 1.0 : -1.0;
      if (pb.ok) best = arc_top(a2, p, from_plane(pb.nb, sign * pb.na, c, s, v1, v2), v1, v2, cs, sn, slack, best);
    }
  }
  return best;
}

// a x b, pointing to the side of cen (cylinder.py _edge_normal).
ELLIPSIM_HD Vec3 edge_normal(const Vec3& a, const Vec3& b, const Vec3& cen) {
  const Vec3 k = cross3(a, b);
  if (dot(k, cen) < 0.0) return neg(k);
  return k;
}

// arc_max over the great-circle arc from the unit a to the unit b (cylinder.py _edge_max).
ELLIPSIM_HD Top edge_max(const Vec3& a2, const Vec3& p, const Vec3& a, const Vec3& b, double slack, double floor,
                         double stop) {
  const Vec3 k = cross3(a, b);
  const double sn = math::sqrt(norm2(k));
  if (sn == 0.0) return {-INFINITY, a};
  const double cs = dot(a, b);
  Vec3 w = {b.x - cs * a.x, b.y - cs * a.y, b.z - cs * a.z};
  const double nw = math::sqrt(norm2(w));
  if (!(nw > 0.0)) return {-INFINITY, a};
  w = {w.x / nw, w.y / nw, w.z / nw};
  return arc_max(a2, p, a, w, cs, nw, b, slack, floor, stop);
}

// Whether m lies on the inner side of the four edge normals.
ELLIPSIM_HD bool inside4(const Vec3& m, const Vec3& k0, const Vec3& k1, const Vec3& k2, const Vec3& k3) {
  return dot(m, k0) >= 0.0 && dot(m, k1) >= 0.0 && dot(m, k2) >= 0.0 && dot(m, k3) >= 0.0;
}

// (bound, m): the maximum of f_p over the convex spherical quadrilateral v0 v1 v2 v3 and where it is attained
// (cylinder.py _poly_bound).
ELLIPSIM_HD_CALL Top poly_bound(const Vec3& a2, const Vec3& p, const Vec3& v0, const Vec3& v1, const Vec3& v2,
                           const Vec3& v3, double slack, double floor, double stop, double edge12) {
  const Vec3 cen = {v0.x + v1.x + v2.x + v3.x, v0.y + v1.y + v2.y + v3.y, v0.z + v1.z + v2.z + v3.z};
  const Vec3 k0 = edge_normal(v0, v1, cen), k1 = edge_normal(v1, v2, cen);
  const Vec3 k2 = edge_normal(v2, v3, cen), k3 = edge_normal(v3, v0, cen);
  Top best = edge_max(a2, p, v0, v1, slack, floor, stop);
  Top v = {edge12, v1};
  if (!(edge12 <= floor)) v = edge_max(a2, p, v1, v2, slack, floor, stop);
  if (v.v > best.v) best = v;
  v = edge_max(a2, p, v2, v3, slack, floor, stop);
  if (v.v > best.v) best = v;
  v = edge_max(a2, p, v3, v0, slack, floor, stop);
  if (v.v > best.v) best = v;
  if (best.v > stop) return best;
  const point_ellipsoid::Roots roots = secular_roots(a2, p, true);
  for (int k = 0; k < 3; ++k) {
    const double t = roots.t[k];
    if (t == t) {
      const Vec3 m = unit({p.x / (t + a2.x), p.y / (t + a2.y), p.z / (t + a2.z)});
      if (inside4(m, k0, k1, k2, k3)) {
        const double fv = f(a2, p, m) + slack;
        if (fv > best.v) best = {fv, m};
      }
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 2; ++k) {
      const point_ellipsoid::PoleNormal pn = pole_normal(a2, p, i, k == 0 ? 1.0 : -1.0);
      if (pn.ok && inside4(pn.n, k0, k1, k2, k3)) {
        const double fv = f(a2, p, pn.n) + slack;
        if (fv > best.v) best = {fv, pn.n};
      }
    }
  }
  return best;
}

// --- the second-order certificate about the incumbent --------------------------------------------------------

// The second-order model of the rim function at the unit n (cylinder.py _cert_model's tuple): ok, the tangent
// basis (t1, t2), G's gradient g and Hessian H = (H11, H12, H22) on the plane, G(n), h_E(n), |P n|, the largest
// |B y| of a unit y of the plane, the errors eg and eh of g and H, and _reach's chart radius.
struct CertModel {
  bool ok;
  Vec3 t1, t2;
  V2 g;
  double H11, H12, H22;
  double value, h, ss, bt, eg, eh, reach;
};

// A chart radius within which cert_region is likely to hold (cylinder.py _reach).
ELLIPSIM_HD double reach(const V2& g, double H0, double H1, double H2, double value, double h, double ss, double bt,
                         double r, double s1, double s2) {
  const double c = min2(value, 0.0);
  const double ns = math::sqrt(s1 * s1 + s2 * s2);
  if (!(ns > 0.0)) return 0.0;
  const V2 s = {s1 / ns, s2 / ns};  // the chart direction towards the cap
  const V2 a = {-s.y, s.x};         // along the rim
  const double qaa = H0 * a.x * a.x + 2.0 * H1 * a.x * a.y + H2 * a.y * a.y - c;
  const double qss = H0 * s.x * s.x + 2.0 * H1 * s.x * s.y + H2 * s.y * s.y - c;
  if (!(qaa < 0.0)) return 0.0;
  const double mu = qss < 0.0 ? min2(-qaa, -qss) : -qaa;
  const double rho0 = 0.5 * min2(h / bt, ss);
  double rho = rho0;
  for (int k = 0; k < REACH_STEPS; ++k) {  // odd steps end below the fixed point: M(rho) rho <= 1.5 mu holds there
    const double dh = h - bt * rho, ds = ss - rho;
    const double M = D3_NORM * (bt * bt * bt / (dh * dh) + r / (ds * ds));
    rho = min2(rho0, 1.5 * mu / M);
  }
  if (qss > 0.0) rho = min2(rho, max2(-(g.x * s.x + g.y * s.y), 0.0) / qss);
  return rho;
}

// cylinder.py _cert_model.
ELLIPSIM_HD CertModel cert_model(const Vec3& a2, const Vec3& q, const Vec3& su, double r, const Vec3& n) {
  const Vec3 an = {a2.x * n.x, a2.y * n.y, a2.z * n.z};
  const double h = math::sqrt(dot(an, n));
  const double ss = perp(n, su);
  const TangentBasis tb = tangent_basis(n);
  const Vec3 &t1 = tb.t1, &t2 = tb.t2;
  const double nu = dot(n, su);
  if (!(ss > 0.0)) return {false, t1, t2, {0.0, 0.0}, 0.0, 0.0, 0.0, 0.0, h, ss, 0.0, 0.0, 0.0, 0.0};
  const Vec3 pn = {n.x - nu * su.x, n.y - nu * su.y, n.z - nu * su.z};
  const double ih = 1.0 / h, iss = 1.0 / ss;
  const Vec3 grad = {q.x - an.x * ih - r * pn.x * iss, q.y - an.y * ih - r * pn.y * iss,
                     q.z - an.z * ih - r * pn.z * iss};
  const V2 at = {dot(an, t1), dot(an, t2)};
  const V2 ut = {dot(su, t1), dot(su, t2)};
  const V2 pt = {-nu * ut.x, -nu * ut.y};  // P n . t_i = n.t_i - (n.u)(u.t_i), n.t_i = 0
  const double a11 = a2.x * t1.x * t1.x + a2.y * t1.y * t1.y + a2.z * t1.z * t1.z;
  const double a12 = a2.x * t1.x * t2.x + a2.y * t1.y * t2.y + a2.z * t1.z * t2.z;
  const double a22 = a2.x * t2.x * t2.x + a2.y * t2.y * t2.y + a2.z * t2.z * t2.z;
  const double ih2 = ih * ih, iss2 = iss * iss;
  const double h11 = -(a11 - at.x * at.x * ih2) * ih - r * ((1.0 - ut.x * ut.x) - pt.x * pt.x * iss2) * iss;
  const double h12 = -(a12 - at.x * at.y * ih2) * ih - r * (-ut.x * ut.y - pt.x * pt.y * iss2) * iss;
  const double h22 = -(a22 - at.y * at.y * ih2) * ih - r * ((1.0 - ut.y * ut.y) - pt.y * pt.y * iss2) * iss;
  const double ad = a11 - a22;
  const double bt = math::sqrt(0.5 * (a11 + a22) + math::sqrt(0.25 * (ad * ad) + a12 * a12));
  const double amax = max2(max2(a2.x, a2.y), a2.z);
  const double eg = 64.0 * tol::U * (math::sqrt(norm2(q)) + math::sqrt(amax) + r);
  // |P n| near 0: 1 - ut^2 and pt lose U / |P n|^2
  const double eh = 256.0 * tol::U * (amax * ih + r * iss) + 64.0 * tol::U * r * iss2;
  const double value = dot(n, q) - h - r * ss;
  const V2 g = {dot(grad, t1), dot(grad, t2)};
  return {true, t1,  t2, g,  h11, h12, h22, value, h, ss, bt, eg, eh,
          reach(g, h11, h12, h22, value, h, ss, bt, r, dot(su, t1), dot(su, t2))};
}

// (ok, y): the gnomonic coordinates of the unit v about the unit n (cylinder.py _chart).
struct Chart {
  bool ok;
  V2 y;
};

// cylinder.py _chart.
ELLIPSIM_HD Chart chart(const Vec3& n, const Vec3& t1, const Vec3& t2, const Vec3& v) {
  const double d = dot(v, n);
  if (!(d > 0.0)) return {false, {0.0, 0.0}};
  return {true, {dot(v, t1) / d, dot(v, t2) / d}};
}

// max over the segment y z of Phi(w) = g.w + w^T Q w / 2 (cylinder.py _quad_edge).
ELLIPSIM_HD double quad_edge(const V2& g, double Q0, double Q1, double Q2, const V2& y, const V2& z) {
  const V2 d = {z.x - y.x, z.y - y.y};
  const V2 qy = {g.x + Q0 * y.x + Q1 * y.y, g.y + Q1 * y.x + Q2 * y.y};
  const double dqd = Q0 * d.x * d.x + 2.0 * Q1 * d.x * d.y + Q2 * d.y * d.y;
  const double s = qy.x * d.x + qy.y * d.y;
  const double phi = g.x * y.x + g.y * y.y + 0.5 * (Q0 * y.x * y.x + 2.0 * Q1 * y.x * y.y + Q2 * y.y * y.y);
  double best = max2(phi, phi + s + 0.5 * dqd);
  if (dqd < 0.0) {
    const double tau = -s / dqd;
    if (0.0 < tau && tau < 1.0) best = max2(best, phi + 0.5 * s * tau);
  }
  return best;
}

// Whether sigma stays below G(n) + slack + room on the convex spherical quadrilateral v0..v3, from the model cm
// at n (cylinder.py _cert_region).
ELLIPSIM_HD bool cert_region(const CertModel& cm, const Vec3& n, double r, const Vec3& v0, const Vec3& v1,
                             const Vec3& v2, const Vec3& v3, double room) {
  const Chart c0 = chart(n, cm.t1, cm.t2, v0), c1 = chart(n, cm.t1, cm.t2, v1);
  const Chart c2 = chart(n, cm.t1, cm.t2, v2), c3 = chart(n, cm.t1, cm.t2, v3);
  if (!(cm.ok && c0.ok && c1.ok && c2.ok && c3.ok)) return false;
  const V2 &y0 = c0.y, &y1 = c1.y, &y2 = c2.y, &y3 = c3.y;
  double rho = math::sqrt(max2(max2(max2(y0.x * y0.x + y0.y * y0.y, y1.x * y1.x + y1.y * y1.y),
                                   y2.x * y2.x + y2.y * y2.y),
                              y3.x * y3.x + y3.y * y3.y));
  rho = rho * (1.0 + 1e-9);  // the chart's own rounding
  const double hl = cm.h - cm.bt * rho, sl = cm.ss - rho;
  if (!(hl > 0.0 && sl > 0.0)) return false;
  const double bt = cm.bt;
  const double M = D3_NORM * (bt * bt * bt / (hl * hl) + r / (sl * sl));
  const double V = cm.value + room;
  const double shift = cm.eh + M * rho / 3.0 - min2(V, 0.0);
  const double Q0 = cm.H11 + shift, Q1 = cm.H12, Q2 = cm.H22 + shift;
  const double d = room - cm.eg * (rho + 1.0);  // eg: also the O(u) slivers of the quadrilateral the chart misses
  if (d <= 0.0) return false;
  const V2& g = cm.g;
  double best = max2(max2(max2(quad_edge(g, Q0, Q1, Q2, y0, y1), quad_edge(g, Q0, Q1, Q2, y1, y2)),
                          quad_edge(g, Q0, Q1, Q2, y2, y3)),
                     quad_edge(g, Q0, Q1, Q2, y3, y0));
  const double det = Q0 * Q2 - Q1 * Q1;
  if (Q0 < 0.0 && det > 0.0) {  // negative definite: the stationary point y* = -Q^-1 g, Phi(y*) = g.y* / 2
    const V2 ys = {-(Q2 * g.x - Q1 * g.y) / det, -(Q0 * g.y - Q1 * g.x) / det};
    const double s0 = (y1.x - y0.x) * (ys.y - y0.y) - (y1.y - y0.y) * (ys.x - y0.x);
    const double s1 = (y2.x - y1.x) * (ys.y - y1.y) - (y2.y - y1.y) * (ys.x - y1.x);
    const double s2 = (y3.x - y2.x) * (ys.y - y2.y) - (y3.y - y2.y) * (ys.x - y2.x);
    const double s3 = (y0.x - y3.x) * (ys.y - y3.y) - (y0.y - y3.y) * (ys.x - y3.x);
    if ((s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0 && s3 <= 0.0))
      best = max2(best, 0.5 * (g.x * ys.x + g.y * ys.y));
  }
  return best <= d;
}

// Whether the lune between the meridians of ca and cb holds no sigma above floor: the incumbent's polar band by
// its second-order model, the rest by poly_bound (cylinder.py _split_settles).
ELLIPSIM_HD bool split_settles(const Vec3& a2, const Vec3& p, const Vec3& su, const Vec3& ca, const Vec3& cb, double b,
                               const CertModel& cm, const Vec3& n, double theta, double r, double room, double floor,
                               double slack, double equator) {
  double ta = 0.0, tb = 0.0;
  Vec3 va = su, vb = su, wa = ca, wb = cb;
  bool settled = false;
  for (int k = 0; k < SPLIT_TRIES; ++k) {  // a band too wide for the model's concavity: halve it
    ta = max2(theta - b, 0.0);
    tb = min2(theta + b, 0.5 * PI);
    va = turn(su, ca, ta);  // su itself at ta = 0
    vb = turn(su, cb, ta);
    if (tb == 0.5 * PI) {
      wa = ca;
      wb = cb;
    } else {
      wa = turn(su, ca, tb);
      wb = turn(su, cb, tb);
    }
    if (cert_region(cm, n, r, va, wa, wb, vb, room)) {
      settled = true;
      break;
    }
    b = b * 0.5;
  }
  if (!settled) return false;
  if (ta > 0.0 && poly_bound(a2, p, su, va, vb, su, slack, floor, floor, INFINITY).v > floor) return false;
  return !(tb < 0.5 * PI && poly_bound(a2, p, wa, ca, cb, wb, slack, floor, floor, equator).v > floor);
}

// An upper bound of f_p (p = q - r c) on the equator arc from ca to cb of a rim lune (cylinder.py
// _equator_bound).
ELLIPSIM_HD double equator_bound(double side_ub, double r, const Vec3& ca, const Vec3& cb, const Vec3& c,
                                 double slack) {
  return side_ub + r * (1.0 - min2(dot(ca, c), dot(cb, c))) + slack;
}

// (best, bn, proven) of a rim's branch and bound.
struct RimBB {
  double best;
  Vec3 bn;
  bool proven;
};

// Branch and bound over the azimuth of the rim piece sg (cylinder.py _rim_bb): RIM_LUNES lunes from the
// incumbent's azimuth, each split in two depth first (a node is its level and index) until its bound is within
// tol of the incumbent; proven false when RIM_BB_NODES lunes or RIM_BB_LEVELS levels did not settle it.
ELLIPSIM_HD_CALL RimBB rim_bb(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double sg, double best,
                         Vec3 bn, double tol, double slack, double side_ub) {
  const Vec3 q = {e.x - sg * L * u.x, e.y - sg * L * u.y, e.z - sg * L * u.z};
  const Vec3 su = times(sg, u);
  const TangentBasis w = tangent_basis(su);
  const Vec3 &w1 = w.t1, &w2 = w.t2;
  const double first = 2.0 * PI / RIM_LUNES;
  double phi = 0.0;
  bool has = perp(bn, u) > 0.0;  // an azimuth: on this rim, on the side circle, or on the other rim
  if (has) phi = math::atan2(dot(bn, w2), dot(bn, w1));
  Vec3 ci = turn(w1, w2, phi);
  CertModel cm = cert_model(a2, q, su, r, bn);
  double theta = math::atan2(perp(bn, u), dot(bn, su));
  const double start = phi - 0.5 * first;
  int64_t nodes = 0;
  double xs = 0.0;  // the last failed bound of a lune holding the incumbent: its excess and level
  int64_t xl = 0;
  const Vec3 e0 = turn(w1, w2, start);
  Vec3 cb = e0;
  for (int k = 0; k < RIM_LUNES; ++k) {
    const double a0 = start + double(k) * first;
    const Vec3 end = k == RIM_LUNES - 1 ? e0 : turn(w1, w2, a0 + first);  // the last closes the circle on e0
    int64_t lev = 0, idx = 0;
    Vec3 ca = cb;  // the next lune starts where the last one ended
    while (true) {
      const double width = math::ldexp(first, int(-lev));
      const double a = a0 + double(idx) * width;
      cb = idx + 1 == (int64_t(1) << lev) ? end : turn(w1, w2, a + width);  // the lune's far end
      const double off = py_mod(phi - a, 2.0 * PI);
      Vec3 c;
      if (!has) {
        c = turn(w1, w2, a + 0.5 * width);
      } else if (off <= width) {
        c = ci;  // the incumbent's azimuth
      } else {  // the end nearer the incumbent: the bound is sigma itself along that meridian
        c = off - width < 2.0 * PI - off ? cb : ca;
      }
      const Vec3 p = {q.x - r * c.x, q.y - r * c.y, q.z - r * c.z};
      const double equator = equator_bound(side_ub, r, ca, cb, c, slack);
      nodes += 1;
      const double room = best + tol - cm.value - slack;
      const double reach = SPLIT_REACH * cm.reach;
      const double far = off <= width ? max2(off, width - off) : min2(off, 2.0 * PI - off + width);
      const bool near = reach > 0.0 && far * cm.ss <= reach && room > 0.0;  // within the incumbent's reach
      const bool holds = has && off <= width && !near;
      double bound;
      Vec3 m;
      if (holds && math::ldexp(xs, int(2 * (xl - lev))) > SKIP_EXCESS * tol) {
        bound = INFINITY;  // its bound would fail too (SKIP_EXCESS): split it unbounded
        m = bn;
      } else if (!near && !(holds && sg * dot(bn, u) >= -1e-12) &&
                 cone_below(a2, q, u, r, bn, bn, su, ca, cb, best + tol - slack)) {
        bound = -INFINITY;  // closed by tangent planes (tangent_cones.hpp)
        m = bn;
      } else if (near && split_settles(a2, p, su, ca, cb, reach, cm, bn, theta, r, room, best + tol, slack, equator)) {
        bound = -INFINITY;
        m = bn;
      } else {
        const Top t = poly_bound(a2, p, su, ca, cb, su, slack, best + tol, best + tol, equator);
        bound = t.v;
        m = t.m;
        if (holds && bound > best + tol) {
          xs = bound - best;
          xl = lev;
        }
      }
      if (bound > best + tol) {
        double v = sigma_cylinder(a2, e, u, L, r, m);
        if (v > best && sg * dot(m, u) > 0.0 && perp(m, u) > 0.0) {
          const Vec3 mn = rim_newton(a2, e, u, L, r, sg, m).n;
          const double vn = sigma_cylinder(a2, e, u, L, r, mn);
          if (vn > v) v = vn, m = mn;
        }
        if (v > best) {  // the children take c and the second-order model from the new incumbent
          best = v;
          bn = m;
          xs = 0.0;  // no prediction for the new incumbent's lunes
          has = perp(bn, u) > 0.0;
          if (has) {
            phi = math::atan2(dot(bn, w2), dot(bn, w1));
            ci = turn(w1, w2, phi);
          }
          cm = cert_model(a2, q, su, r, bn);
          theta = math::atan2(perp(bn, u), dot(bn, su));
        }
      }
      if (bound > best + tol) {
        if (nodes >= tol::RIM_BB_NODES || lev >= tol::RIM_BB_LEVELS) return {best, bn, false};
        lev = lev + 1;  // the first child: its parent's start ca
        idx = 2 * idx;
        continue;
      }
      while (lev > 0 && idx % 2 == 1) {
        lev = lev - 1;
        idx = idx / 2;
      }
      if (lev == 0) break;
      idx += 1;
      ca = cb;  // the next node starts where this one ended
    }
  }
  return {best, bn, true};
}

// Whether sigma on the rim facing away from E's centre is nowhere above its value at the mirror image (cylinder.py
// _mirrored): |e.u| >= h_E(u), with 64 u of margin on each side.
ELLIPSIM_HD bool mirrored(const Vec3& a2, const Vec3& e, const Vec3& u) {
  const double eu = dot(e, u);
  const double spread = math::fabs(e.x * u.x) + math::fabs(e.y * u.y) + math::fabs(e.z * u.z);
  const double hu = math::sqrt(a2.x * u.x * u.x + a2.y * u.y * u.y + a2.z * u.z * u.z);
  return math::fabs(eu) - 64.0 * tol::U * spread >= hu * (1.0 + 64.0 * tol::U);
}

// (value, n, proven) of the enumeration.
struct DeepSearch {
  double value;
  Vec3 n;
  bool proven;
};

// Caps and side exactly, then each rim piece by its azimuth branch and bound, the rim facing E's centre first;
// the other skipped once that one is proven when E lies on its side of K's mid-plane (cylinder.py deep_search).
ELLIPSIM_HD_CALL DeepSearch deep_search(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double best,
                                   Vec3 bn, double tol, double slack) {
  for (int k = 0; k < 2; ++k) {
    const Vec3 m = times(k == 0 ? 1.0 : -1.0, u);
    const double v = sigma_cylinder(a2, e, u, L, r, m);
    if (v > best) best = v, bn = m;
  }
  const TangentBasis w = tangent_basis(u);
  const point_ellipsoid::CircleMax cmb = circle_max_bound(a2, e, w.t1, w.t2);
  const double v = sigma_cylinder(a2, e, u, L, r, cmb.n);
  if (v > best) best = v, bn = cmb.n;
  const double s0 = dot(e, u) < 0.0 ? -1.0 : 1.0;
  RimBB rb = rim_bb(a2, e, u, L, r, s0, best, bn, tol, slack, cmb.ub - r);
  bool proven = rb.proven;
  if (!(proven && mirrored(a2, e, u))) {
    rb = rim_bb(a2, e, u, L, r, -s0, rb.best, rb.bn, tol, slack, cmb.ub - r);
    proven = proven && rb.proven;
  }
  return {rb.best, rb.bn, proven};
}

// (proven, n, value) of axis_max.
struct AxisMax {
  bool ok;
  Vec3 n;
  double value;
};

// A second chance for a rim left unproven when E is a spheroid whose axis is (nearly) along the cylinder's:
// spheroids' axis_bb about u in the frame (u, w1, w2) (cylinder.py axis_max).
ELLIPSIM_HD_CALL AxisMax axis_max(const Vec3& a2, const Vec3& e, Vec3 u, double L, double r, double tol, double scale,
                             const Vec3& n0) {
  using distance::spheroids::at;
  const Vec3 ra = {math::sqrt(a2.x), math::sqrt(a2.y), math::sqrt(a2.z)};
  const distance::spheroids::AxisOf ax = distance::spheroids::axis_of(ra);
  const int j = ax.k;
  const double db = ax.half;
  const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  const double qb = at(ra, j), pb = 0.5 * (at(ra, j1) + at(ra, j2));
  const double uu = math::sqrt(dot(u, u));  // u from to_frame is unit to ~1e-15: the model's axis is u / |u|
  const Vec3 u0 = u;
  u = {u.x / uu, u.y / uu, u.z / uu};
  const TangentBasis w = tangent_basis(u);
  const Vec3 &w1 = w.t1, &w2 = w.t2;
  double dfu = max2(max2(math::fabs(dot(u, u) - 1.0), math::fabs(dot(w1, w1) - 1.0)), math::fabs(dot(w2, w2) - 1.0));
  // + the dots' rounding
  dfu = max2(max2(max2(dfu, math::fabs(dot(u, w1))), math::fabs(dot(u, w2))), math::fabs(dot(w1, w2))) + 3.0 * tol::U;
  double delta0 = db * (1.0 + 3.0 * dfu) + 3.0 * pb * pb * dfu / min2(qb, pb) + 3.0 * dfu * scale;
  delta0 += 3.0 * (L + r) * (math::fabs(uu - 1.0) + 2.0 * tol::U) + 12.0 * tol::U * scale;
  delta0 += 4.0 * tol::U * L;  // the cells at t = T/2 reach ~2e-16 past pi / 2
  const double tol1 =
      tol - 2.0 * delta0 - (distance::spheroids::ERR_C_ULPS + tol::BB_ERR_SIGMA_ULPS + 8.0) * tol::U * scale;
  const Vec3 nu = {dot(n0, u), dot(n0, w1), dot(n0, w2)};
  const double t0 = math::atan2(math::sqrt(nu.y * nu.y + nu.z * nu.z), nu.x), p0 = math::atan2(nu.z, nu.y);
  const distance::AxisBB bb = distance::axis_bb(dot(e, u), dot(e, w1), dot(e, w2), 1, L, r, qb * qb - pb * pb, pb * pb,
                                                at(u, j), at(w1, j), at(w2, j), tol1, scale, 0.0, t0, p0);
  Vec3 n = n0;
  if (bb.moved) {
    const double ct = math::cos(bb.t), st = math::sin(bb.t), cp = math::cos(bb.p), sp = math::sin(bb.p);
    n = unit({ct * u.x + st * (cp * w1.x + sp * w2.x), ct * u.y + st * (cp * w1.y + sp * w2.y),
              ct * u.z + st * (cp * w1.z + sp * w2.z)});
  }
  return {bb.proven, n, sigma_cylinder(a2, e, u0, L, r, n)};
}

// The pair's length scale (|e| + the largest size), the certificates' tolerance (the contract's 1e-12 of the smallest
// size, floored by what float64 evaluates sigma to; cylinder.py) and sigma's rounding slack at that scale.
struct Scales {
  double scale, tol, slack;
};

ELLIPSIM_HD Scales scales(const Vec3& e, const Vec3& ra, double r, double L) {
  const double scale = math::sqrt(norm2(e)) + max2(max2(max2(max2(ra.x, ra.y), ra.z), r), L);
  const double tol = max2(tol::PAIR_CERT_REL * min2(min2(min2(min2(ra.x, ra.y), ra.z), r), L),
                          2.0 * tol::BB_TOL_ULPS * tol::U * scale);
  return {scale, tol, tol::PAIR_SIGMA_SLACK_ULPS * tol::U * scale};
}

// (status, dist, normal, pos, ub).
struct Result {
  int status;
  double dist;
  Vec3 normal, pos;
  double ub;
};

// For the ellipsoid E and the cylinder K (centre metres, rotation row-major, sizes metres; K's sizes (radius,
// half-length, unused), its axis its local z, as MuJoCo's cylinder geom).  dist: sigma at the returned normal (a
// lower bound of the exact signed distance); normal: unit, from E to K; pos: the midpoint of the witness points;
// ub: the certified upper bound (inf unless CERTIFIED); status: CERTIFIED, ENUMERATED or UNPROVEN (cylinder.py
// cylinder_ellipsoid).
ELLIPSIM_HD Result cylinder_ellipsoid(const Ellipsoid& E, const Ellipsoid& K) {
  const Frame fr = to_frame(E, K);
  const Vec3 &e = fr.e, &a2 = fr.a2, &u = fr.u;
  const double r = K.r.x, L = K.r.y;
  const Vec3& ra = E.r;
  const double rho = rolling_radius(ra);
  const Scales sc = scales(e, ra, r, L);
  const double scale = sc.scale, tol = sc.tol, slack = sc.slack;
  Vec3 n = local_max(a2, e, u, L, r).n;
  double value = sigma_cylinder(a2, e, u, L, r, n);
  double ub = upper_bound(a2, e, u, L, r, rho, n, value, tol, slack);
  int status = CERTIFIED;
  if (ub - value > tol) {
    const double v0 = value;
    const Vec3 n0 = n;
    const DeepSearch ds = deep_search(a2, e, u, L, r, value, n, tol, slack);
    value = ds.value;
    n = ds.n;
    double ub2 = ub;  // the same incumbent: the same certificates, already failed
    if (value != v0 || n.x != n0.x || n.y != n0.y || n.z != n0.z)
      ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol, slack);
    bool by_axis = false;
    if (!ds.proven && ub2 - value > tol) {  // a flat rim: E a spheroid about (nearly) the cylinder's axis
      const AxisMax am = axis_max(a2, e, u, L, r, tol, scale, n);
      by_axis = am.ok;
      if (by_axis && am.value > value) {  // (else proven from the incumbent itself)
        value = am.value;
        n = am.n;
      }
    }
    if (by_axis) {
      ub = value + tol;
    } else if (ub2 - value <= tol) {
      ub = ub2;
    } else {
      status = ds.proven ? ENUMERATED : UNPROVEN;
      ub = INFINITY;
    }
  }
  const point_ellipsoid::Contact c = contact_in_world(E, a2, n, value);
  return {status, value, c.normal, c.pos, ub};
}

// A lower bound on the signed distance: sigma along the centre line minus its rounding allowance
// (PAIR_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies (cylinder.py centre_line_bound).
ELLIPSIM_HD double centre_line_bound(const Ellipsoid& E, const Ellipsoid& K) {
  const Frame fr = to_frame(E, K);
  const Vec3& e = fr.e;
  const double ee = norm2(e);
  if (!(ee > 0.0)) return -INFINITY;
  const double s = 1.0 / math::sqrt(ee);
  const Vec3 &ra = E.r, &rk = K.r;
  const double scale = math::sqrt(ee) + max2(max2(max2(max2(ra.x, ra.y), ra.z), rk.x), rk.y);
  const double v = sigma_cylinder(fr.a2, e, fr.u, rk.y, rk.x, {e.x * s, e.y * s, e.z * s});
  return v - tol::PAIR_SIGMA_SLACK_ULPS * tol::U * scale;
}

}  // namespace ellipsim::pairs::cylinder
