// Proving f(n) <= floor < 0 over a whole cone of directions by tangent planes, cheaply: the pruning step of the
// box's and the cylinder's branch and bound (box.hpp enumerate_max, cylinder's rim; ellipsim/core/pairs/
// tangent_cones.py).
//
// f(n) = n.q - h_E(n) - r |P n| (P = I - u u^T; r = 0 for the box's pieces, r |P n| the support of the
// cylinder's disc for its rim) is concave and 1-homogeneous, and for any point x of E and y of the disc,
// h_E(n) + r |P n| >= n.(x + y), so f(n) <= g.n with g = q - x - y, linear.  A linear function below floor < 0
// at every corner c_k of a cone is below it on all of the cone's unit directions: g.sum l_k c_k <=
// floor sum l_k |c_k| <= floor |sum l_k c_k| (triangle inequality, floor < 0), so a node costs a support point
// and three dot products, the corners need not be unit, and a cone splits at its flat midpoints (sums of
// corners).  x + y is the support point of E + disc at the node's centre, or, for the box (r = 0), at the
// incumbent's normal when the node holds it (there the bound is exact at the incumbent and falls with f as
// long as f falls: a kink of sigma, as a flush face; a cylinder's rim incumbent is a smooth maximum, where the
// plane rises: 5% slower to try).  The planes are the same weak-duality step as the point-ellipsoid bounds
// (Schneider & Eberly, GTCG 10.5.2; Boyd & Vandenberghe 5.1), taken on pieces of the sphere instead of its
// whole.
#pragma once

#include "../math.hpp"

#include "../vec3.hpp"
#include "point_ellipsoid.hpp"

namespace ellipsim::pairs::tangent_cones {

// levels of halvings of an arc before arc_below gives up (a cone gets 4 levels of quarters)
constexpr int ARC_DEPTH = 5;

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

ELLIPSIM_HD Vec3 add(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }

ELLIPSIM_HD Vec3 twice(const Vec3& a) { return {2.0 * a.x, 2.0 * a.y, 2.0 * a.z}; }

// The support point of E + disc(r, perpendicular to the unit u) at the nonzero n (the disc's part 0 where
// P n = 0, or for r = 0).
ELLIPSIM_HD Vec3 tangent_point(const Vec3& a2, const Vec3& u, double r, const Vec3& n) {
  const Vec3 s = point_ellipsoid::support(a2, n).s;
  if (r == 0.0) return s;
  const double d = dot(n, u);
  const Vec3 pn = {n.x - d * u.x, n.y - d * u.y, n.z - d * u.z};
  const double pp = dot(pn, pn);
  const double k = pp > 0.0 ? r / math::sqrt(pp) : 0.0;
  return {s.x + k * pn.x, s.y + k * pn.y, s.z + k * pn.z};
}

// g.c / |c| <= floor (< 0), without a square root.
ELLIPSIM_HD bool corner_below(const Vec3& g, const Vec3& c, double floor) {
  const double d = dot(g, c);
  return d <= 0.0 && d * d >= floor * floor * dot(c, c);
}

// (q - x).n <= floor on the cone of a, b, c (c = a for an arc).
ELLIPSIM_HD bool plane_below(const Vec3& q, const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c, double floor) {
  const Vec3 g = {q.x - x.x, q.y - x.y, q.z - x.z};
  return corner_below(g, a, floor) && corner_below(g, b, floor) && corner_below(g, c, floor);
}

// n in the cone of a, b, c (counter-clockwise), to a margin that lets a corner or an edge count: only the
// choice of tangent point hangs on it.
ELLIPSIM_HD bool holds(const Vec3& n, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double eps = -1e-9 * (dot(a, a) + dot(b, b) + dot(c, c));
  return dot(cross3(a, b), n) >= eps && dot(cross3(b, c), n) >= eps && dot(cross3(c, a), n) >= eps;
}

// The rolling-ball plane of the point q at the direction c (E = E' + ball(k), node_below's): g = q - x + k c / |c|, x
// E's support point at c, so that f_q(n) <= g.n - k for unit n.
ELLIPSIM_HD Vec3 ball_plane(const Vec3& a2, const Vec3& q, const Vec3& c, double k) {
  const Vec3 x = point_ellipsoid::support(a2, c).s;
  const double s = k / math::sqrt(dot(c, c));
  return {q.x - x.x + s * c.x, q.y - x.y + s * c.y, q.z - x.z + s * c.z};
}

// f <= floor on the cone a, b, c: the plane at the incumbent bn (xb its tangent point; r > 0 or bn = 0: not
// tried, the cylinder's rim incumbent is smooth) when the cone holds it, else (or then) the plane at the cone's
// centre.
// rho > 0 (r = 0 only; E = E' + ball(rho), rho its rolling radius, so E holds the ball of radius rho tangent at
// each boundary point x, centre x - rho m, m the unit normal there): h_E(n) >= n.(x - rho m) + rho for unit n,
// f(n) <= (q - x + rho m).n - rho, the plane's test against floor + rho when that is < 0.  It never loses to the
// bare plane (at a corner it asks rho (|c| - m.c) >= 0 less) and gains rho (1 - cos) away from m: the second
// order a plane misses (box.hpp's ub1, E' + ball(rho)).
ELLIPSIM_HD bool node_below(const Vec3& a2, const Vec3& q, const Vec3& u, double r, const Vec3& bn, const Vec3& xb,
                            const Vec3& a, const Vec3& b, const Vec3& c, double floor, double rho = 0.0) {
  const double k = r == 0.0 && floor + rho < 0.0 ? rho : 0.0;
  const bool incumbent = bn.x != 0.0 || bn.y != 0.0 || bn.z != 0.0;  // bn = 0: none (a caller's cones miss it)
  if (r == 0.0 && incumbent && holds(bn, a, b, c) &&
      plane_below({q.x + k * bn.x, q.y + k * bn.y, q.z + k * bn.z}, xb, a, b, c, floor + k))
    return true;
  const Vec3 m = add(add(a, b), c);
  if (k == 0.0) return plane_below(q, tangent_point(a2, u, r, m), a, b, c, floor);
  const Vec3 g = ball_plane(a2, q, m, k);  // (k > 0 only for r = 0: the support point is the tangent point)
  const Vec3* w = &a;  // the first corner the centre's plane leaves above the floor, if any
  if (corner_below(g, a, floor + k)) {
    w = &b;
    if (corner_below(g, b, floor + k)) {
      w = &c;
      if (corner_below(g, c, floor + k)) return true;
    }
  }
  // else the plane tangent at that corner (where f is highest near a maximum, the centre's plane is furthest off:
  // bench meshes, deep, 10-17% fewer instructions than quartering at once)
  const Vec3 xw = tangent_point(a2, u, r, *w);
  const double sw = k / math::sqrt(dot(*w, *w));
  return plane_below({q.x + sw * w->x, q.y + sw * w->y, q.z + sw * w->z}, xw, a, b, c, floor + k);
}

// A cone by its three corners.
struct Cone {
  Vec3 a, b, c;
};

// Child k of the cone a, b, c split at its flat midpoints (corners doubled: the test is scale-free; children
// share their computed corners, so they tile the parent).
ELLIPSIM_HD Cone quarter(const Vec3& a, const Vec3& b, const Vec3& c, int k) {
  if (k == 0) return {twice(a), add(a, b), add(c, a)};
  if (k == 1) return {add(a, b), twice(b), add(b, c)};
  if (k == 2) return {add(c, a), add(b, c), twice(c)};
  return {add(a, b), add(b, c), add(c, a)};
}

// True when f <= floor on the whole closed cone of a, b, c (top comment), proven on up to 4 levels of quarters;
// false when floor >= 0 or a leaf does not close.  xb = tangent_point(bn), unused when r > 0; rho: node_below's.
ELLIPSIM_HD bool cone_below(const Vec3& a2, const Vec3& q, const Vec3& u, double r, const Vec3& bn, const Vec3& xb,
                            const Vec3& a, Vec3 b, Vec3 c, double floor, double rho = 0.0) {
  if (!(floor < 0.0)) return false;
  if (dot(cross3(a, b), c) < 0.0) {
    const Vec3 t = b;
    b = c;
    c = t;
  }
  if (node_below(a2, q, u, r, bn, xb, a, b, c, floor, rho)) return true;
  for (int k1 = 0; k1 < 4; ++k1) {  // the 4 levels written out (no recursion in a kernel)
    const Cone n1 = quarter(a, b, c, k1);
    if (node_below(a2, q, u, r, bn, xb, n1.a, n1.b, n1.c, floor, rho)) continue;
    for (int k2 = 0; k2 < 4; ++k2) {
      const Cone n2 = quarter(n1.a, n1.b, n1.c, k2);
      if (node_below(a2, q, u, r, bn, xb, n2.a, n2.b, n2.c, floor, rho)) continue;
      for (int k3 = 0; k3 < 4; ++k3) {
        const Cone n3 = quarter(n2.a, n2.b, n2.c, k3);
        if (node_below(a2, q, u, r, bn, xb, n3.a, n3.b, n3.c, floor, rho)) continue;
        for (int k4 = 0; k4 < 4; ++k4) {
          const Cone n4 = quarter(n3.a, n3.b, n3.c, k4);
          if (!node_below(a2, q, u, r, bn, xb, n4.a, n4.b, n4.c, floor, rho)) return false;
        }
      }
    }
  }
  return true;
}

// f <= floor on the arc of the corners a, b: as node_below, a cone of two corners.
ELLIPSIM_HD bool arc_node_below(const Vec3& a2, const Vec3& q, const Vec3& u, double r, const Vec3& bn, const Vec3& xb,
                                const Vec3& a, const Vec3& b, double floor) {
  const Vec3 m = cross3(a, b);
  const double mm = dot(m, m);
  const double mn = dot(m, bn);
  if (r == 0.0 && mn * mn <= 1e-18 * mm && dot(cross3(a, bn), m) >= -1e-9 * mm && dot(cross3(bn, b), m) >= -1e-9 * mm) {
    if (plane_below(q, xb, a, b, a, floor)) return true;
  }
  return plane_below(q, tangent_point(a2, u, r, add(a, b)), a, b, a, floor);
}

// True when f <= floor on the whole arc from a to b, proven on dyadic pieces of the chord a..b down to
// 2^-ARC_DEPTH, depth first (t0 the piece's start, w its width, in finest pieces); false when floor >= 0 or a
// finest piece does not close.
ELLIPSIM_HD bool arc_below(const Vec3& a2, const Vec3& q, const Vec3& u, double r, const Vec3& bn, const Vec3& xb,
                           const Vec3& a, const Vec3& b, double floor) {
  if (!(floor < 0.0)) return false;
  const int full = 1 << ARC_DEPTH;
  int t0 = 0, w = full;
  while (t0 < full) {
    const double u0 = double(t0) / double(full), u1 = double(t0 + w) / double(full);
    const Vec3 pa = {(1.0 - u0) * a.x + u0 * b.x, (1.0 - u0) * a.y + u0 * b.y, (1.0 - u0) * a.z + u0 * b.z};
    const Vec3 pb = {(1.0 - u1) * a.x + u1 * b.x, (1.0 - u1) * a.y + u1 * b.y, (1.0 - u1) * a.z + u1 * b.z};
    if (arc_node_below(a2, q, u, r, bn, xb, pa, pb, floor)) {
      t0 += w;
      while (w < full && t0 % (2 * w) == 0) w *= 2;
    } else if (w > 1) {
      w /= 2;
    } else {
      return false;
    }
  }
  return true;
}

}  // namespace ellipsim::pairs::tangent_cones
