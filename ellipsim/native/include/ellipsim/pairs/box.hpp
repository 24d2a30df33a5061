// Signed distance of an ellipsoid and a box with a proven global maximum (MuJoCo's ellipsoid x box narrow
// phase; ellipsim/core/pairs/box.py).
//
// Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair), split into the smooth strata of
// the box's support function, each solved globally by Eberly's secular equation (point_ellipsoid.hpp; Eberly,
// "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", sec. 2-3; GTCG 10.5.2), certified
// by two convex-duality bounds or by enumerating every critical point.  Same contract and conventions as
// capsule.hpp.
//
// The box K = sum_j r_j [-1, 1] v_j centred at e (v_j its axes in E's principal frame; orthonormal to rounding
// from MuJoCo C's float64 rotations, only to ~1e-7 from MuJoCo Warp's float32 ones: K is then the
// parallelepiped they span, and face_normal, edge_plane, sd_point_box and upper_bound2 compute for it), so
// h_K(n) = sum_j r_j |n.v_j| and sigma is smooth except on the three great circles n.v_j = 0.  Its strata: the
// 8 open octants (vertex contacts: sigma = f_q(n) = n.q - h_E(n), q = e minus the box vertex facing E), the 12
// open quarter circles (edge contacts: the 2-D point-ellipse problem in the plane of the other two axes, q = e
// minus the edge's midpoint) and the 6 face normals (face contacts).
//
// Local solve (an active set): per box axis, either n.v_j = 0 is imposed (the contact feature extends along
// v_j) or the sign of n.v_j is fixed; each state's piece is solved globally (foot3, the projected ellipse's
// foot2, or a face normal).  KKT at the result: a free axis whose sign flipped becomes active; an active axis
// whose witness coordinate y_j = (e - s_E(n) - sigma n).v_j leaves [-r_j, r_j] is freed with the sign of y_j.
// It starts at the best face normal, so a flush face (the usual resting contact) costs one support evaluation
// per face.
//
// Certificates (global upper bounds on max sigma, any unit n; concavity of h on R^3):
// * ub1 = sd(e - s_E(n) + rho n, K) - rho, rho the rolling radius of E (E = E' + ball(rho)): the exact
//   point-box signed distance.  Tight when separated or shallow.
// * ub2 = sd(e - c, E) - t for a ball(c, t) inside K, c the witness clamped into K (t > 0 only for a face
//   contact: the largest ball in K tangent to that face at c), sd bounded above by weak duality.
// When neither closes (deep crossings), a branch and bound over the 26 pieces (enumerate_max): a piece whose
// extended smooth function's certified maximum does not beat the incumbent is skipped, one whose maximiser
// lies inside it is taken whole, the others have every critical point evaluated: a complete case analysis,
// status ENUMERATED.  Before that, a negative incumbent lets whole closed octants (a vertex piece with its
// three edges and corners) and edge arcs be skipped by tangent planes of h_E (tangent_cones.hpp): three dot
// products a node.
//
// E and K are Ellipsoid values (centre, rotation row-major, sizes): K's sizes its half-sizes, as MuJoCo's box
// geom.
#pragma once

#include "../math.hpp"

#include "../distance/sphere_newton.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "point_ellipsoid.hpp"
#include "tangent_cones.hpp"

namespace ellipsim::pairs::box {

using distance::rolling_radius;
using distance::unit;
using point_ellipsoid::at;
using point_ellipsoid::circle_max_bound;
using point_ellipsoid::contact_in_world;
using point_ellipsoid::foot2;
using point_ellipsoid::foot3;
using point_ellipsoid::from_plane;
using point_ellipsoid::project_ellipse;
using point_ellipsoid::sd_upper;
using point_ellipsoid::sd_upper2;
using point_ellipsoid::support;
using tangent_cones::arc_below;
using tangent_cones::cone_below;
using tangent_cones::tangent_point;

// How box_ellipsoid proved its maximum (as capsule.hpp): CERTIFIED or ENUMERATED, both proofs.
constexpr int CERTIFIED = 0, ENUMERATED = 1;
// state value of an axis in the local solve: n.v_j = 0 imposed (else the sign +1 / -1 of n.v_j)
constexpr int ACTIVE = 0;
// active-set switches of the local solve before it hands over to the certificates / enumeration
constexpr int MAX_SWITCHES = 8;
// the tangent-plane tests' disc axis: none (r = 0, a box has no disc part); a function, as a constant of class
// type is not reachable from device code
ELLIPSIM_HD Vec3 no_axis() { return {0.0, 0.0, 1.0}; }

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

// The box's axes v_0, v_1, v_2 in E's frame (V[j] in the Python).
struct Axes {
  Vec3 v[3];
};

// (e, a2, V): K's centre in E's principal frame, E's squared semi-axes, K's axes (its local x, y, z) in E's
// frame.
struct Frame {
  Vec3 e, a2;
  Axes V;
};

ELLIPSIM_HD Frame to_frame(const Ellipsoid& E, const Ellipsoid& K) {
  const Vec3 e = rotate_t(E.R, sub(K.c, E.c));
  return {e,
          {E.r.x * E.r.x, E.r.y * E.r.y, E.r.z * E.r.z},
          {{rotate_t(E.R, column(K.R, 0)), rotate_t(E.R, column(K.R, 1)), rotate_t(E.R, column(K.R, 2))}}};
}

// sigma at the unit n (E's frame).
ELLIPSIM_HD double sigma_box(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, const Vec3& n) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  return n.x * e.x + n.y * e.y + n.z * e.z - h - r.x * math::fabs(dot(n, V.v[0])) - r.y * math::fabs(dot(n, V.v[1])) -
         r.z * math::fabs(dot(n, V.v[2]));
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
  const double scale = math::sqrt(ee) + max2(max2(max2(max2(max2(ra.x, ra.y), ra.z), rk.x), rk.y), rk.z);
  const double v = sigma_box(f.a2, e, f.V, rk, {e.x * s, e.y * s, e.z * s});
  return v - tol::PAIR_SIGMA_SLACK_ULPS * tol::U * scale;
}

// The outward unit normal of the face +v_i: v_j x v_k turned to v_i's side (v_i itself for orthonormal axes;
// for axes orthonormal only to ~1e-7, as float32 rotations give, v_i misses the face's point of the sphere by
// that angle, and sigma by ~1e-7 of the box's size).
ELLIPSIM_HD Vec3 face_normal(const Axes& V, int i) {
  const Vec3 m = unit(cross3(V.v[(i + 1) % 3], V.v[(i + 2) % 3]));
  if (dot(m, V.v[i]) < 0.0) return {-m.x, -m.y, -m.z};
  return m;
}

// An orthonormal basis (b1, b2) of a plane.
struct Plane {
  Vec3 b1, b2;
};

// An orthonormal basis (b1, b2) of the plane n.v_i = 0 (the smooth piece of an edge along v_i), b1 along v_j's
// part in it (j = i + 1): (v_j, v_k) for orthonormal axes.
ELLIPSIM_HD Plane edge_plane(const Axes& V, int i) {
  const Vec3 u = unit(V.v[i]);
  const Vec3& vj = V.v[(i + 1) % 3];
  const double d = dot(vj, u);
  const Vec3 b1 = unit({vj.x - d * u.x, vj.y - d * u.y, vj.z - d * u.z});
  return {b1, cross3(u, b1)};
}

// |v_j . face normal j| per axis (1 for orthonormal axes): face planes j lie 2 r_j times it apart.
ELLIPSIM_HD Vec3 face_cosines(const Axes& V) {
  return {math::fabs(dot(V.v[0], face_normal(V, 0))), math::fabs(dot(V.v[1], face_normal(V, 1))),
          math::fabs(dot(V.v[2], face_normal(V, 2)))};
}

// A state of the local solve: per axis ACTIVE, +1 or -1.
struct State {
  int s[3];
};

// The maximiser of the smooth piece of the state st.
ELLIPSIM_HD Vec3 solve_state(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, const State& st) {
  double q0 = e.x, q1 = e.y, q2 = e.z;
  int nact = 0;
  for (int j = 0; j < 3; ++j) {
    if (st.s[j] == ACTIVE) {
      nact += 1;
    } else {
      q0 -= double(st.s[j]) * at(r, j) * V.v[j].x;
      q1 -= double(st.s[j]) * at(r, j) * V.v[j].y;
      q2 -= double(st.s[j]) * at(r, j) * V.v[j].z;
    }
  }
  const Vec3 q = {q0, q1, q2};
  if (nact == 0) return foot3(a2, q).n;
  if (nact == 1) {
    const int i = st.s[0] == ACTIVE ? 0 : (st.s[1] == ACTIVE ? 1 : 2);
    const Plane p = edge_plane(V, i);
    return circle_max_bound(a2, q, p.b1, p.b2).n;
  }
  const int i = st.s[0] != ACTIVE ? 0 : (st.s[1] != ACTIVE ? 1 : 2);
  const Vec3 v = face_normal(V, i);
  const double sg = double(st.s[i]);
  return {sg * v.x, sg * v.y, sg * v.z};
}

// (new state of axis j, changed).
struct Kkt {
  int st;
  bool changed;
};

// An active axis whose witness coordinate leaves [-r_j, r_j] is freed with its sign; a free axis whose sign
// flipped becomes active.
ELLIPSIM_HD Kkt kkt(int stj, const Vec3& y, const Vec3& n, const Vec3& v, double rj) {
  if (stj == ACTIVE) {
    const double yj = dot(y, v);
    if (math::fabs(yj) > rj) return {yj > 0.0 ? 1 : -1, true};
    return {stj, false};
  }
  if (dot(n, v) * double(stj) < 0.0) return {ACTIVE, true};
  return {stj, false};
}

// The unit n of the active-set iteration from the best face normal (top comment).
ELLIPSIM_HD Vec3 local_max(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r) {
  double best = -INFINITY;
  State st = {{ACTIVE, ACTIVE, 1}};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 2; ++k) {
      const int sg = k == 0 ? 1 : -1;
      const Vec3 v = face_normal(V, i);
      const double val = sigma_box(a2, e, V, r, {double(sg) * v.x, double(sg) * v.y, double(sg) * v.z});
      if (val > best) {
        best = val;
        st = {{i == 0 ? sg : ACTIVE, i == 1 ? sg : ACTIVE, i == 2 ? sg : ACTIVE}};
      }
    }
  }
  Vec3 n = solve_state(a2, e, V, r, st);
  for (int it = 0; it < MAX_SWITCHES; ++it) {
    const double value = sigma_box(a2, e, V, r, n);
    const Vec3 s = support(a2, n).s;
    const Vec3 y = {e.x - s.x - value * n.x, e.y - s.y - value * n.y, e.z - s.z - value * n.z};
    const Kkt k0 = kkt(st.s[0], y, n, V.v[0], r.x);
    const Kkt k1 = kkt(st.s[1], y, n, V.v[1], r.y);
    const Kkt k2 = kkt(st.s[2], y, n, V.v[2], r.z);
    if (!(k0.changed || k1.changed || k2.changed) || (k0.st == ACTIVE && k1.st == ACTIVE && k2.st == ACTIVE)) return n;
    st = {{k0.st, k1.st, k2.st}};
    n = solve_state(a2, e, V, r, st);
  }
  return n;
}

// The coordinates c of the point w along axes orthonormal to rounding or only to ~1e-7 (float32 rotations, where
// w.v_j is off by that much of |w|): c = G^-1 V w by one correction step (G = V V^T, error O(defect^2)).
ELLIPSIM_HD Vec3 coordinates(const Vec3& w, const Axes& V) {
  const Vec3 &V0 = V.v[0], &V1 = V.v[1], &V2 = V.v[2];
  const double v0 = dot(w, V0), v1 = dot(w, V1), v2 = dot(w, V2);
  const double g01 = dot(V0, V1), g02 = dot(V0, V2), g12 = dot(V1, V2);
  const double g00 = dot(V0, V0), g11 = dot(V1, V1), g22 = dot(V2, V2);
  return {2.0 * v0 - (g00 * v0 + g01 * v1 + g02 * v2), 2.0 * v1 - (g01 * v0 + g11 * v1 + g12 * v2),
          2.0 * v2 - (g02 * v0 + g12 * v1 + g22 * v2)};
}

// Signed distance of the point w to the box {sum_j c_j v_j : |c_j| <= r_j}, for axes orthonormal to rounding or
// only to ~1e-7 (the formula |w.v_j| - r_j is then off by that much of the box's size): w's coordinates c
// (coordinates); outside, |w - x| for the box's point x = sum_j clamp(c_j) v_j (a point of the body: a bound
// whatever the rounding); inside, minus the distance to the nearest face plane, (r_j - |c_j|) face_cosines_j.
ELLIPSIM_HD double sd_point_box(const Vec3& w, const Axes& V, const Vec3& r) {
  const Vec3 &V0 = V.v[0], &V1 = V.v[1], &V2 = V.v[2];
  const Vec3 c = coordinates(w, V);
  const double c0 = c.x, c1 = c.y, c2 = c.z;
  const double d0 = math::fabs(c0) - r.x, d1 = math::fabs(c1) - r.y, d2 = math::fabs(c2) - r.z;
  if (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0) {
    const Vec3 f = face_cosines(V);
    return max2(max2(d0 * f.x, d1 * f.y), d2 * f.z);
  }
  const double k0 = min2(max2(c0, -r.x), r.x), k1 = min2(max2(c1, -r.y), r.y), k2 = min2(max2(c2, -r.z), r.z);
  const double z0 = w.x - (k0 * V0.x + k1 * V1.x + k2 * V2.x);
  const double z1 = w.y - (k0 * V0.y + k1 * V1.y + k2 * V2.y);
  const double z2 = w.z - (k0 * V0.z + k1 * V1.z + k2 * V2.z);
  return math::sqrt(z0 * z0 + z1 * z1 + z2 * z2);
}

// ub1 of the top comment at the unit n.
ELLIPSIM_HD double upper_bound1(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, double rho,
                                const Vec3& n) {
  const Vec3 s = support(a2, n).s;
  const Vec3 w = {e.x - s.x + rho * n.x, e.y - s.y + rho * n.y, e.z - s.z + rho * n.z};
  return sd_point_box(w, V, r) - rho;
}

// ub2 of the top comment: the witness e - s - value n clamped into the box (its coordinates along the axes:
// with axes orthonormal only to ~1e-7, y.v_j misses a vertex witness's r_j by ~1e-7 of the size, and the ball
// then sits that far inside the vertex); for a face contact the largest ball inside the box tangent to that face
// there.
ELLIPSIM_HD double upper_bound2(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, const Vec3& n,
                                double value) {
  const Vec3 &V0 = V.v[0], &V1 = V.v[1], &V2 = V.v[2];
  const Vec3 s = support(a2, n).s;
  const Vec3 y = {e.x - s.x - value * n.x, e.y - s.y - value * n.y, e.z - s.z - value * n.z};
  const Vec3 cy = coordinates(y, V);
  double c0 = min2(max2(cy.x, -r.x), r.x);
  double c1 = min2(max2(cy.y, -r.y), r.y);
  double c2 = min2(max2(cy.z, -r.z), r.z);
  const double m0 = math::fabs(dot(n, V0)), m1 = math::fabs(dot(n, V1)), m2 = math::fabs(dot(n, V2));
  double t = 0.0;
  if (m1 + m2 < 1e-12) {  // a face contact: n along one axis, the others within rounding of zero
    t = min2(min2(r.x, r.y - math::fabs(c1)), r.z - math::fabs(c2));
    c0 = math::copysign(r.x - t, dot(n, V0));
  } else if (m0 + m2 < 1e-12) {
    t = min2(min2(r.y, r.x - math::fabs(c0)), r.z - math::fabs(c2));
    c1 = math::copysign(r.y - t, dot(n, V1));
  } else if (m0 + m1 < 1e-12) {
    t = min2(min2(r.z, r.x - math::fabs(c0)), r.y - math::fabs(c1));
    c2 = math::copysign(r.z - t, dot(n, V2));
  }
  const Vec3 q = {e.x - c0 * V0.x - c1 * V1.x - c2 * V2.x, e.y - c0 * V0.y - c1 * V1.y - c2 * V2.y,
                  e.z - c0 * V0.z - c1 * V1.z - c2 * V2.z};
  // the ball of radius t about c fits an orthonormal box; the one of radius t min_j face_cosines_j fits the
  // parallelepiped of axes orthonormal only to ~1e-7 (its distance to each face plane)
  const Vec3 f = face_cosines(V);
  const double tt = foot3(a2, q).t;
  return sd_upper(a2, q, tt) - t * min2(min2(f.x, f.y), f.z);
}

// ub1 when it is within tol of value, else the smaller of ub1 and ub2.
ELLIPSIM_HD double upper_bound(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, double rho, const Vec3& n,
                               double value, double tol) {
  const double ub = upper_bound1(a2, e, V, r, rho, n);
  if (ub - value <= tol) return ub;
  return min2(ub, upper_bound2(a2, e, V, r, n, value));
}

// e minus the box vertex sum_j s_j r_j v_j.
ELLIPSIM_HD Vec3 vertex_q(const Vec3& e, const Axes& V, const Vec3& r, double s0, double s1, double s2) {
  const Vec3 &V0 = V.v[0], &V1 = V.v[1], &V2 = V.v[2];
  return {e.x - s0 * r.x * V0.x - s1 * r.y * V1.x - s2 * r.z * V2.x,
          e.y - s0 * r.x * V0.y - s1 * r.y * V1.y - s2 * r.z * V2.y,
          e.z - s0 * r.x * V0.z - s1 * r.y * V1.z - s2 * r.z * V2.z};
}

// The rounding allowance of the tangent tests: the support point and the node corners are off by ulps, sigma by
// that times its Lipschitz bound |q| + max a.
ELLIPSIM_HD double below_slack(const Vec3& q, const Vec3& a2, double best) {
  return tol::PAIR_SIGMA_SLACK_ULPS * tol::U *
         (math::sqrt(dot(q, q)) + math::sqrt(max2(max2(a2.x, a2.y), a2.z)) + math::fabs(best));
}

// The best (value, n) found.
struct Best {
  double value;
  Vec3 n;
};

ELLIPSIM_HD void consider(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, const Vec3& n, Best& best) {
  const double v = sigma_box(a2, e, V, r, n);
  if (v > best.value) best = {v, n};
}

// Branch and bound over the 26 smooth pieces from the incumbent (best, bn): faces are points; a closed octant
// (bit 4 (s0 < 0) + 2 (s1 < 0) + (s2 < 0) of `done`) whose tangent planes prove f_q below the incumbent is
// skipped with its edges and corners, an edge arc likewise (top comment); for the other edge or vertex pieces,
// the global maximiser of the extended smooth function is the piece's maximum when it lies in the piece;
// otherwise the piece is skipped when the certified bound on that global maximum (weak duality) does not beat
// the incumbent by tol, else its interior local maxima are the candidates (secular_roots, pole_normal) -- its
// boundary is made of the other pieces.  An edge's 2-D problem runs through the 3-D enumeration with a third
// axis longer than both (a2 = (lam, mu, 2 max), q_3 = 0): its term vanishes and the kept roots are the 2-D
// ones.  Returns (value, n).
ELLIPSIM_HD Best enumerate_max(const Vec3& a2, const Vec3& e, const Axes& V, const Vec3& r, double best, const Vec3& bn,
                               double tol) {
  Best b = {best, bn};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 2; ++k) {
      const double sg = k == 0 ? 1.0 : -1.0;
      const Vec3 v = face_normal(V, i);
      consider(a2, e, V, r, {sg * v.x, sg * v.y, sg * v.z}, b);
    }
  }
  const Vec3 NO_AXIS = no_axis();
  const Vec3 xb = tangent_point(a2, NO_AXIS, 0.0, b.n);
  const Vec3 f[3] = {face_normal(V, 0), face_normal(V, 1), face_normal(V, 2)};
  int done = 0;
  int k = 0;
  for (int i0 = 0; i0 < 2; ++i0) {
    for (int i1 = 0; i1 < 2; ++i1) {
      for (int i2 = 0; i2 < 2; ++i2) {
        const double s0 = i0 == 0 ? 1.0 : -1.0, s1 = i1 == 0 ? 1.0 : -1.0, s2 = i2 == 0 ? 1.0 : -1.0;
        const Vec3 q = vertex_q(e, V, r, s0, s1, s2);
        const Vec3 a = {s0 * f[0].x, s0 * f[0].y, s0 * f[0].z};
        const Vec3 bb = {s1 * f[1].x, s1 * f[1].y, s1 * f[1].z};
        const Vec3 c = {s2 * f[2].x, s2 * f[2].y, s2 * f[2].z};
        if (cone_below(a2, q, NO_AXIS, 0.0, b.n, xb, a, bb, c, b.value + tol - below_slack(q, a2, b.value)))
          done |= 1 << k;
        k += 1;
      }
    }
  }
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, kk = (i + 2) % 3;
    const Vec3 &w1 = V.v[j], &w2 = V.v[kk];
    const Plane pl = edge_plane(V, i);
    const Vec3 &b1 = pl.b1, &b2 = pl.b2;
    const point_ellipsoid::Ellipse el = project_ellipse(a2, b1, b2);
    const double lam = el.lam, mu = el.mu, c = el.c, s = el.s;
    for (int ij = 0; ij < 2; ++ij) {
      for (int ik = 0; ik < 2; ++ik) {
        const double sj = ij == 0 ? 1.0 : -1.0, sk = ik == 0 ? 1.0 : -1.0;
        const int side = (sj < 0.0 ? 1 << (2 - j) : 0) + (sk < 0.0 ? 1 << (2 - kk) : 0);
        // both octants on this edge closed
        if (((done >> side) & 1) && ((done >> (side + (1 << (2 - i)))) & 1)) continue;
        const double rj = at(r, j), rk = at(r, kk);
        const Vec3 q = {e.x - sj * rj * w1.x - sk * rk * w2.x, e.y - sj * rj * w1.y - sk * rk * w2.y,
                        e.z - sj * rj * w1.z - sk * rk * w2.z};
        const Vec3 fa = {sj * f[j].x, sj * f[j].y, sj * f[j].z};
        const Vec3 fb = {sk * f[kk].x, sk * f[kk].y, sk * f[kk].z};
        if (arc_below(a2, q, NO_AXIS, 0.0, b.n, xb, fa, fb, b.value + tol - below_slack(q, a2, b.value))) continue;
        const double p1 = dot(q, b1), p2 = dot(q, b2);
        const Vec3 p = {c * p1 + s * p2, -s * p1 + c * p2, 0.0};
        const point_ellipsoid::Foot2 ft = foot2(lam, mu, p.x, p.y);
        const Vec3 n = from_plane(ft.n0, ft.n1, c, s, b1, b2);
        if (dot(n, w1) * sj >= 0.0 && dot(n, w2) * sk >= 0.0) {
          consider(a2, e, V, r, n, b);
          continue;
        }
        if (sd_upper2(lam, mu, p.x, p.y, ft.t) <= b.value + tol) continue;
        point_ellipsoid::other_critical_normals2(el, p, b1, b2, [&](const Vec3& n) { consider(a2, e, V, r, n, b); });
      }
    }
  }
  k = -1;
  for (int i0 = 0; i0 < 2; ++i0) {
    for (int i1 = 0; i1 < 2; ++i1) {
      for (int i2 = 0; i2 < 2; ++i2) {
        k += 1;
        if ((done >> k) & 1) continue;
        const double s0 = i0 == 0 ? 1.0 : -1.0, s1 = i1 == 0 ? 1.0 : -1.0, s2 = i2 == 0 ? 1.0 : -1.0;
        const Vec3 q = vertex_q(e, V, r, s0, s1, s2);
        const point_ellipsoid::Foot3 ft = foot3(a2, q);
        const Vec3& n = ft.n;
        if (dot(n, V.v[0]) * s0 >= 0.0 && dot(n, V.v[1]) * s1 >= 0.0 && dot(n, V.v[2]) * s2 >= 0.0) {
          consider(a2, e, V, r, n, b);
          continue;
        }
        if (sd_upper(a2, q, ft.t) <= b.value + tol) continue;
        point_ellipsoid::other_critical_normals(a2, q, [&](const Vec3& n) { consider(a2, e, V, r, n, b); });
      }
    }
  }
  return b;
}

// (status, dist, normal, pos, ub).
struct Result {
  int status;
  double dist;
  Vec3 normal, pos;
  double ub;
};

// For the ellipsoid E and the box K (centre metres, rotation row-major, sizes metres; K's sizes its half-sizes,
// as MuJoCo's box geom).  dist: the signed distance, metres (sigma at the returned normal, a lower bound of the
// exact maximum); normal: unit, from E to K; pos: the midpoint of the witness points (MuJoCo's contact
// position); ub: the certified upper bound (inf when ENUMERATED); status: CERTIFIED or ENUMERATED.
ELLIPSIM_HD Result box_ellipsoid(const Ellipsoid& E, const Ellipsoid& K) {
  const Frame fr = to_frame(E, K);
  const Vec3 &e = fr.e, &a2 = fr.a2;
  const Axes& V = fr.V;
  const Vec3& r = K.r;
  const Vec3& ra = E.r;
  const double rho = rolling_radius(ra);
  Vec3 n = local_max(a2, e, V, r);
  double value = sigma_box(a2, e, V, r, n);
  const double tol = ellipsim::tol::PAIR_CERT_REL * min2(min2(min2(min2(min2(ra.x, ra.y), ra.z), r.x), r.y), r.z);
  double ub = upper_bound(a2, e, V, r, rho, n, value, tol);
  int status = CERTIFIED;
  if (ub - value > tol) {
    const Best found = enumerate_max(a2, e, V, r, value, n, tol);
    // the same maximiser gives the same ub, which did not close: skip recomputing it
    const bool same = found.value == value && found.n.x == n.x && found.n.y == n.y && found.n.z == n.z;
    value = found.value;
    n = found.n;
    const double ub2 = same ? INFINITY : upper_bound(a2, e, V, r, rho, n, value, tol);
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

}  // namespace ellipsim::pairs::box
