// Signed distance of an ellipsoid and a capsule with a proven global maximum (MuJoCo's capsule x ellipsoid
// narrow phase; ellipsim/core/pairs/capsule.py).
//
// Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair), split into the smooth strata of
// the capsule's support function, each solved globally by Eberly's secular equation ("Distance from a point to
// an ellipse, an ellipsoid, or a hyperellipsoid", Geometric Tools, sec. 2-3; GTCG 10.5.2), certified by the two
// convex-duality bounds below or by enumerating every critical point.
//
// The pair in E's principal frame: E = {x : sum x_i^2 / a2_i <= 1} (a2 the squared semi-axes), the capsule
// K = segment [-L, L] u + ball(r) centred at e, so
//
//     sigma(n) = n.e - h_E(n) - L |n.u| - r = min(f_{e+Lu}(n), f_{e-Lu}(n)) - r,   f_q(n) = n.q - h_E(n),
//
// n pointing from E to K, smooth except on the great circle n.u = 0 (the contact on the capsule's side).
// Strata and their maximisers:
// * side (n.u = 0): the 2-D point-ellipse problem of e projected along u onto the plane u^perp, against E's
//   projection (an ellipse); valid when the segment parameter t = (s_E(n) - e).u lies in [-L, L];
// * end point e + sL u (s = +-1, region s n.u <= 0): the point-ellipsoid problem for q = e + sL u.
// The local solve takes the side stratum when its segment parameter is admissible, else the end it points to.
//
// Certificates (global upper bounds on max sigma, from concavity of h on R^3; any unit n):
// * ub1 = sd(e - s_E(n) + rho n, K) - rho with rho the rolling radius of E (E = E' + ball(rho)):
//   h_E(m) >= rho + m.(s_E(n) - rho n) for unit m, so sigma(m) <= m.w - h_K(m) - rho <= sd(w, K) - rho.
//   Tight when separated or shallow.
// * ub2 = sd(e - c, E) - r, c the segment point at the contact: h_K(m) >= m.c + r (ball(c, r) in K), so
//   sigma(m) <= f_{e-c}(m) - r <= sd(e - c, E) - r, bounded above by weak duality (sd_upper).
//   Tight when the capsule's axis point is deep in E.
// When neither closes (deep crossings), a branch and bound over the three smooth pieces (enumerate_max): a
// piece whose extended smooth function's certified maximum does not beat the incumbent is skipped, one whose
// maximiser lies inside it is taken whole, and the rest have every critical point evaluated (secular_roots,
// pole_normal): a complete case analysis, status ENUMERATED.
//
// The point-ellipsoid primitives (secular equation, certified bounds, critical points) are in
// point_ellipsoid.hpp, shared with box.hpp.  E and K are Ellipsoid values (centre, rotation row-major, sizes):
// K's sizes (radius, half-length, unused) as MuJoCo's capsule geom, its axis its local z.
#pragma once

#include "../math.hpp"

#include "../distance/sphere_newton.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "point_ellipsoid.hpp"

namespace ellipsim::pairs::capsule {

using distance::rolling_radius;
using distance::tangent_basis;
using distance::unit;
using point_ellipsoid::circle_max_bound;
using point_ellipsoid::contact_in_world;
using point_ellipsoid::foot3;
using point_ellipsoid::pole_normal;
using point_ellipsoid::sd_upper;
using point_ellipsoid::secular_roots;
using point_ellipsoid::support;

// How capsule_ellipsoid proved its maximum: CERTIFIED (an upper bound within PAIR_CERT_REL of the smaller
// shortest half-size of the value) or ENUMERATED (every critical point of every smooth piece evaluated).  Both
// are proofs; the MuJoCo glue falls back to MuJoCo only on a non-finite result.
constexpr int CERTIFIED = 0, ENUMERATED = 1;

// --- the pair, sigma, and the way back to world coordinates -----------------------------------------------------

// (e, a2, u): K's centre in E's principal frame, E's squared semi-axes, K's axis (its local z) in E's frame.
struct Frame {
  Vec3 e, a2, u;
};

ELLIPSIM_HD Frame to_frame(const Ellipsoid& E, const Ellipsoid& K) {
  const Vec3 e = rotate_t(E.R, sub(K.c, E.c));
  const Vec3 u = rotate_t(E.R, column(K.R, 2));
  return {e, {E.r.x * E.r.x, E.r.y * E.r.y, E.r.z * E.r.z}, u};
}

// sigma at the unit n (E's frame).
ELLIPSIM_HD double sigma_capsule(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  return n.x * e.x + n.y * e.y + n.z * e.z - h - L * math::fabs(n.x * u.x + n.y * u.y + n.z * u.z) - r;
}

// A lower bound on the signed distance: sigma along the centre line minus its rounding allowance
// (PAIR_SIGMA_SLACK_ULPS of |e| + the largest size); -inf for concentric bodies.
ELLIPSIM_HD double centre_line_bound(const Ellipsoid& E, const Ellipsoid& K) {
  const Frame f = to_frame(E, K);
  const Vec3& e = f.e;
  const double ee = norm2(e);
  if (!(ee > 0.0)) return -INFINITY;
  const double s = 1.0 / math::sqrt(ee);
  const Vec3 &ra = E.r, &rk = K.r;
  const double scale = math::sqrt(ee) + max2(max2(max2(max2(ra.x, ra.y), ra.z), rk.x), rk.y);
  const double v = sigma_capsule(f.a2, e, f.u, rk.y, rk.x, {e.x * s, e.y * s, e.z * s});
  return v - tol::PAIR_SIGMA_SLACK_ULPS * tol::U * scale;
}

// --- the kernel ----------------------------------------------------------------------------------------------

// (n, stratum): 0 side, +1 / -1 the end e + L u / e - L u.
struct LocalMax {
  Vec3 n;
  int stratum;
};

ELLIPSIM_HD LocalMax local_max(const Vec3& a2, const Vec3& e, const Vec3& u, double L) {
  const distance::TangentBasis w = tangent_basis(u);
  const Vec3 n = circle_max_bound(a2, e, w.t1, w.t2).n;
  const Vec3 s = support(a2, n).s;
  const double t = dot3(s.x, s.y, s.z, u.x, u.y, u.z) - dot3(e.x, e.y, e.z, u.x, u.y, u.z);
  if (math::fabs(t) <= L) return {n, 0};
  const double sg = t > 0.0 ? 1.0 : -1.0;
  const Vec3 q = {e.x + sg * L * u.x, e.y + sg * L * u.y, e.z + sg * L * u.z};
  return {foot3(a2, q).n, sg > 0.0 ? 1 : -1};
}

// ub1 of the top comment at the unit n.
ELLIPSIM_HD double upper_bound1(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double rho,
                                const Vec3& n) {
  const Vec3 s = support(a2, n).s;
  const Vec3 w = {e.x - s.x + rho * n.x, e.y - s.y + rho * n.y, e.z - s.z + rho * n.z};
  const double t = min2(max2(dot3(w.x, w.y, w.z, u.x, u.y, u.z), -L), L);
  const Vec3 z = {w.x - t * u.x, w.y - t * u.y, w.z - t * u.z};
  return math::sqrt(norm2(z)) - r - rho;
}

// ub2 of the top comment: the axis point c = e - s - (value + r) n, clamped to the segment.
ELLIPSIM_HD double upper_bound2(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n,
                                double value) {
  const Vec3 s = support(a2, n).s;
  const Vec3 d = {e.x - s.x - (value + r) * n.x, e.y - s.y - (value + r) * n.y, e.z - s.z - (value + r) * n.z};
  const double tc = min2(max2(dot3(d.x, d.y, d.z, u.x, u.y, u.z), -L), L);
  const Vec3 q = {e.x - tc * u.x, e.y - tc * u.y, e.z - tc * u.z};
  const double t2 = foot3(a2, q).t;
  return sd_upper(a2, q, t2) - r;
}

// The first of ub1, ub2 that is within tol of value, else their minimum.
ELLIPSIM_HD double upper_bound(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double rho,
                               const Vec3& n, double value, double tol) {
  const double ub = upper_bound1(a2, e, u, L, r, rho, n);
  if (ub - value <= tol) return ub;
  return min2(ub, upper_bound2(a2, e, u, L, r, n, value));
}

// The best (value, n) found.
struct Best {
  double value;
  Vec3 n;
};

ELLIPSIM_HD void consider(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, const Vec3& n, Best& best) {
  const double v = sigma_capsule(a2, e, u, L, r, n);
  if (v > best.value) best = {v, n};
}

// Branch and bound over the three smooth pieces, from the incumbent (best, bn): a piece is skipped when the
// global maximum of its extended smooth function (a certified upper bound) does not beat the incumbent by tol;
// taken whole when that maximiser lies in the piece; otherwise every critical point of the piece is evaluated.
// Returns the best (value, n).
ELLIPSIM_HD Best enumerate_max(const Vec3& a2, const Vec3& e, const Vec3& u, double L, double r, double best,
                               const Vec3& bn, double tol) {
  Best b = {best, bn};
  for (int k = 0; k < 2; ++k) {
    const double sg = k == 0 ? 1.0 : -1.0;
    const Vec3 q = {e.x + sg * L * u.x, e.y + sg * L * u.y, e.z + sg * L * u.z};
    const point_ellipsoid::Foot3 f = foot3(a2, q);
    if (sd_upper(a2, q, f.t) - r <= b.value + tol) continue;
    if (sg * dot3(f.n.x, f.n.y, f.n.z, u.x, u.y, u.z) <= 0.0) {  // the maximiser lies in this end's region
      consider(a2, e, u, L, r, f.n, b);
      continue;
    }
    const point_ellipsoid::Roots roots = secular_roots(a2, q);
    for (int j = 0; j < 3; ++j) {
      const double t = roots.t[j];
      if (t == t) consider(a2, e, u, L, r, unit({q.x / (t + a2.x), q.y / (t + a2.y), q.z / (t + a2.z)}), b);
    }
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 2; ++j) {
        const point_ellipsoid::PoleNormal p = pole_normal(a2, q, i, j == 0 ? 1.0 : -1.0);
        if (p.ok) consider(a2, e, u, L, r, p.n, b);
      }
    }
  }
  // the side circle: its global maximum is the maximum of the piece (the circle is the whole piece)
  const distance::TangentBasis w = tangent_basis(u);
  consider(a2, e, u, L, r, circle_max_bound(a2, e, w.t1, w.t2).n, b);
  return b;
}

// (status, dist, normal, pos, ub).
struct Result {
  int status;
  double dist;
  Vec3 normal, pos;
  double ub;
};

// For the ellipsoid E and the capsule K (centre metres, rotation row-major, sizes metres; K's sizes (radius,
// half-length, unused), its axis its local z, as MuJoCo's capsule geom).  dist: the signed distance, metres
// (sigma at the returned normal, a lower bound of the exact maximum); normal: unit, from E to K; pos: the
// midpoint of the witness points (MuJoCo's contact position); ub: the certified upper bound (inf when
// ENUMERATED); status: CERTIFIED or ENUMERATED.
ELLIPSIM_HD Result capsule_ellipsoid(const Ellipsoid& E, const Ellipsoid& K) {
  const Frame f = to_frame(E, K);
  const Vec3 &e = f.e, &a2 = f.a2, &u = f.u;
  const double r = K.r.x, L = K.r.y;
  const Vec3& ra = E.r;
  const double rho = rolling_radius(ra);
  Vec3 n = local_max(a2, e, u, L).n;
  double value = sigma_capsule(a2, e, u, L, r, n);
  const double tol = ellipsim::tol::PAIR_CERT_REL * min2(min2(min2(ra.x, ra.y), ra.z), r);
  double ub = upper_bound(a2, e, u, L, r, rho, n, value, tol);
  int status = CERTIFIED;
  if (ub - value > tol) {
    const Best b = enumerate_max(a2, e, u, L, r, value, n, tol);
    value = b.value;
    n = b.n;
    const double ub2 = upper_bound(a2, e, u, L, r, rho, n, value, tol);
    if (ub2 - value <= tol) {
      ub = ub2;
    } else {
      status = ENUMERATED;
      ub = INFINITY;
    }
  }
  const point_ellipsoid::Contact c = contact_in_world(E, a2, n, value);
  return {status, value, c.normal, c.pos, ub};
}

}  // namespace ellipsim::pairs::capsule
