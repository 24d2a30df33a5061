// Signed distance of an ellipsoid and a convex polytope (a mesh's convex hull, as MuJoCo collides a mesh), its
// maximum proven by a certificate or by a complete case analysis (issue 48; box.hpp is the polytope with 8
// vertices, and its method).
//
// sigma(n) = min_i n.p_i - h_E(n) over unit n (p_i the hull's vertices in E's principal frame, from E's centre;
// Schneider & Eberly 10.5.2: support functions; the normal n from E to P).  sigma is smooth except where the
// minimising vertex changes, so the sphere splits into strata: each vertex's open region (sigma = f_q(n) =
// n.q - h_E(n), q = p_i), each edge's open arc (n normal to the edge, sigma = f_q in that plane, q the edge's
// midpoint) and each face's normal point.
//
// Certified path: a local maximum and ub1 = sd(x', P) - rho, x' the support point at n of E shrunk by its rolling
// radius rho (E = E' + ball(rho): sigma(n) <= min_i n.(p_i - x') - rho <= sd(x', P) - rho for every n; tight when
// the maximum is at n and no deeper than rho), sd the point-hull signed distance (the nearest triangle outside).
// With the hull's adjacency the local maximum is found by walking: the lowest vertex by descent along the edges
// (the simplex method's test), the pieces of the contact feature only, ub1 over the feature's triangles (each
// point of a triangle is a point of P): no pass over the hull for apart and touching pairs.  Otherwise, or when
// that does not close, the best face normal and its feature's pieces, a wider band's, the full ub1.  Status
// CERTIFIED when ub1 is within tol, or else ub2 (box.hpp's): sd(c, E) - t for a ball(c, t) inside P, the largest
// tangent to P's supporting plane at the witness (closes deep face contacts, and vertex contacts).
//
// Otherwise (deep crossings) the case analysis: the global maximum lies in one stratum, an interior critical
// point of its f_q (a 3-D or 2-D point-ellipsoid problem: point_ellipsoid.hpp's foot3 / foot2, every other root of
// the secular equation, the pole limits; Eberly, "Distance from a point to an ellipse, an ellipsoid, or a
// hyperellipsoid", sec. 2-3), or a face normal.  Every candidate is evaluated with sigma itself (a candidate
// outside its stratum only gives a lower bound), so the largest is the maximum: status ENUMERATED.  A stratum's
// other roots are skipped when the certified bound on its f_q's global maximum (sd_upper, weak duality) does not
// beat the incumbent by tol, a piece altogether when |q| - r_min does not.
//
// The hull: vertices in P's local frame, its edges (vertex pairs), its triangles and their outward normals.  Extra
// edges (a flat face's diagonals) only add candidates; every edge and face of the hull must be among them.  A
// candidate's sigma, which reads every vertex, is computed only where its piece's f_q beats the incumbent.  Before
// the pieces are solved, each vertex's closed stratum (the negated normal cone at p_i, spanned by the -m_f of
// its triangles) is tested against the incumbent with one tangent plane of h_E (tangent_cones.hpp), then by its
// f_q's global bound, then on the fan of its cone (cone_below's subdivided planes): a vertex below is skipped
// with every edge through it, so deep crossings solve only the pieces near the maximum.
#pragma once

#include "../math.hpp"

#include "../distance/sphere_newton.hpp"
#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "point_ellipsoid.hpp"
#include "tangent_cones.hpp"

namespace ellipsim::pairs::polytope {

using distance::unit;
using point_ellipsoid::at;
using point_ellipsoid::contact_in_world;
using point_ellipsoid::foot2;
using point_ellipsoid::foot3;
using point_ellipsoid::from_plane;
using point_ellipsoid::project_ellipse;
using point_ellipsoid::sd_upper;
using point_ellipsoid::sd_upper2;

// How polytope_ellipsoid proved its maximum (box.hpp's): CERTIFIED (ub1 within tol), ENUMERATED (every critical
// point evaluated); or, with a cutoff, APART: a sigma (a lower bound) proves the pair beyond it, dist that bound.
constexpr int CERTIFIED = 0, ENUMERATED = 1, APART = 2;

// A convex polytope in its local frame: nv vertices (3 nv numbers), ne edges (2 ne vertex indices), nf triangular
// faces (3 nf vertex indices; a flat face may be several) and their outward unit normals (3 nf numbers).
// Optionally (nullptr: none) its adjacency, for the fast start and the fans: each vertex i's neighbours
// adj[adj_start[i] .. adj_start[i + 1]) along the edges and every triangle vface[vface_start[i] ..
// vface_start[i + 1]) through it, exactly those of edge and face (the descent and the fans' proofs rest on them:
// the binding builds them from edge and face).
struct Hull {
  int nv, ne, nf;
  const double* v;
  const int* edge;
  const double* normal;
  const int* face;
  const int* adj_start = nullptr;
  const int* adj = nullptr;
  const int* vface_start = nullptr;
  const int* vface = nullptr;
};

// The scratch polytope_ellipsoid takes for a hull of nv vertices and nf triangles (numbers): the hull and its
// normals in E's frame, the no-adjacency path's cone centres (3 nv each), then two bytes a vertex (flags).
ELLIPSIM_HD constexpr int scratch_size(int nv, int nf) { return 6 * nv + 3 * nf + (2 * nv + 7) / 8; }

// The bytes polytope_ellipsoid_posed takes for a hull of nv vertices (its only scratch: two flags a vertex).
ELLIPSIM_HD constexpr int posed_flags_size(int nv) { return 2 * nv; }

// The hull's adjacency from its edges and triangles, by two counting sorts in place (no allocation): adj_start and
// vface_start nv + 1 numbers, adj 2 ne, vface 3 nf; each vertex's neighbours in the order of the edges naming it,
// its triangles in the order of the triangles.  The one builder of every caller (the bindings, the MuJoCo glue's
// hull table, the height field's prisms' table is its output), so one hull has one adjacency.
ELLIPSIM_HD void build_adjacency(int nv, int ne, int nf, const int* edge, const int* face, int* adj_start, int* adj,
                                 int* vface_start, int* vface) {
  for (int i = 0; i <= nv; ++i) adj_start[i] = vface_start[i] = 0;
  for (int k = 0; k < 2 * ne; ++k) ++adj_start[edge[k] + 1];
  for (int k = 0; k < 3 * nf; ++k) ++vface_start[face[k] + 1];
  for (int i = 0; i < nv; ++i) adj_start[i + 1] += adj_start[i], vface_start[i + 1] += vface_start[i];
  for (int k = 0; k < ne; ++k) {  // adj_start[i] runs to the end of i's range ...
    const int i = edge[2 * k], j = edge[2 * k + 1];
    adj[adj_start[i]++] = j;
    adj[adj_start[j]++] = i;
  }
  for (int f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) vface[vface_start[face[3 * f + c]]++] = f;
  for (int i = nv; i > 0; --i) adj_start[i] = adj_start[i - 1], vface_start[i] = vface_start[i - 1];  // ... and back
  adj_start[0] = vface_start[0] = 0;
}

ELLIPSIM_HD double dot(const Vec3& x, const Vec3& y) { return x.x * y.x + x.y * y.y + x.z * y.z; }

// The hull in E's principal frame: p_i = e + T v_i, e = R_E^T (c_P - c_E) and T = R_E^T R_P (P's axes in E's
// frame), written into p (3 nv numbers): one product a vertex.  Returns max_i |p_i|_1 (the rounding scale of a
// sigma over them).
ELLIPSIM_HD double to_frame(const Ellipsoid& E, const Vec3& cP, const Mat3& T, const Hull& H, double* p) {
  const Vec3 e = rotate_t(E.R, sub(cP, E.c));
  double far = 0.0;
  for (int i = 0; i < H.nv; ++i) {
    const Vec3 w = matvec(T, {H.v[3 * i], H.v[3 * i + 1], H.v[3 * i + 2]});
    p[3 * i] = e.x + w.x;
    p[3 * i + 1] = e.y + w.y;
    p[3 * i + 2] = e.z + w.z;
    far = max2(far, math::fabs(p[3 * i]) + math::fabs(p[3 * i + 1]) + math::fabs(p[3 * i + 2]));
  }
  return far;
}

ELLIPSIM_HD Vec3 vertex(const double* p, int i) { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }

// The hull in E's frame without storing it (polytope_ellipsoid_posed: two bytes of scratch a vertex, so a large
// hull fits a MuJoCo Warp thread): vertex i computed as to_frame writes it (the same bits), a face's normal as
// face_normal computes it.  Every function below takes either the stored arrays (p, m: const double*) or this.
struct Posed {
  Vec3 e;
  Mat3 T;
  const Hull* H;
};

ELLIPSIM_HD Vec3 vertex(const Posed& P, int i) {
  const double* v = P.H->v;
  const Vec3 w = matvec(P.T, {v[3 * i], v[3 * i + 1], v[3 * i + 2]});
  return {P.e.x + w.x, P.e.y + w.y, P.e.z + w.z};
}

// Face f's outward normal from the stored normals (m: 3 nf numbers).
ELLIPSIM_HD Vec3 normal_of(const double* m, int f) { return {m[3 * f], m[3 * f + 1], m[3 * f + 2]}; }

// Face f's outward unit normal in E's frame (T: P's axes there), as polytope_ellipsoid writes it into m.
template <class V>
ELLIPSIM_HD Vec3 face_normal(const Mat3& T, const Hull& H, const V& p, int f) {
  // from the triangle's vertices in E's frame: its true plane there whatever T (a float32 rotation is orthonormal
  // only to ~6e-8, and T n_f then misses the face's normal by that much: the inside test and the bounds need the
  // plane itself), turned as T n_f
  const Vec3 a = vertex(p, H.face[3 * f]), b = vertex(p, H.face[3 * f + 1]), c = vertex(p, H.face[3 * f + 2]);
  const Vec3 m = unit(cross3(sub(b, a), sub(c, a)));
  const Vec3 t = matvec(T, {H.normal[3 * f], H.normal[3 * f + 1], H.normal[3 * f + 2]});
  return dot(m, t) < 0.0 ? Vec3{-m.x, -m.y, -m.z} : m;
}

// Face f's outward normal, posed: face_normal's.
ELLIPSIM_HD Vec3 normal_of(const Posed& P, int f) { return face_normal(P.T, *P.H, P, f); }

ELLIPSIM_HD Vec3 flip(const Vec3& w) { return {-w.x, -w.y, -w.z}; }

// sigma at the unit n (E's frame).
ELLIPSIM_HD double sigma_hull(const Vec3& a2, const double* p, int nv, const Vec3& n) {
  // four running minima (a minimum of the same rounded products whatever the order: the same result)
  double l0 = INFINITY, l1 = INFINITY, l2 = INFINITY, l3 = INFINITY;
  int i = 0;
  for (; i + 4 <= nv; i += 4) {
    l0 = min2(l0, n.x * p[3 * i] + n.y * p[3 * i + 1] + n.z * p[3 * i + 2]);
    l1 = min2(l1, n.x * p[3 * i + 3] + n.y * p[3 * i + 4] + n.z * p[3 * i + 5]);
    l2 = min2(l2, n.x * p[3 * i + 6] + n.y * p[3 * i + 7] + n.z * p[3 * i + 8]);
    l3 = min2(l3, n.x * p[3 * i + 9] + n.y * p[3 * i + 10] + n.z * p[3 * i + 11]);
  }
  for (; i < nv; ++i) l0 = min2(l0, n.x * p[3 * i] + n.y * p[3 * i + 1] + n.z * p[3 * i + 2]);
  return min2(min2(l0, l1), min2(l2, l3)) - math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
}

ELLIPSIM_HD double sigma_hull(const Vec3& a2, const Posed& P, int nv, const Vec3& n) {
  double lo = INFINITY;
  for (int i = 0; i < nv; ++i) {
    const Vec3 q = vertex(P, i);
    lo = min2(lo, n.x * q.x + n.y * q.y + n.z * q.z);
  }
  return lo - math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
}

struct Best {
  double value;
  Vec3 n;
};

// A candidate n of a piece whose point is q (a vertex, an edge's midpoint, a face's vertex): sigma(n) <= f_q(n) =
// n.q - h_E(n) (the minimum over the vertices is at most the one at q), so sigma, which reads every vertex, is
// evaluated only where f_q beats the incumbent.
template <class V>
ELLIPSIM_HD void consider(const Vec3& a2, const V& p, int nv, const Vec3& q, const Vec3& n, Best& best) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  if (!(n.x * q.x + n.y * q.y + n.z * q.z - h > best.value)) return;
  const double v = sigma_hull(a2, p, nv, n);
  if (v > best.value) best = {v, n};
}

// The plane normal to an edge: an orthonormal basis (b1, b2).
struct Plane {
  Vec3 b1, b2;
};

ELLIPSIM_HD Plane normal_plane(const Vec3& d) {
  const Vec3 u = unit(d);
  const Vec3 a = math::fabs(u.x) < 0.6 ? Vec3{1.0, 0.0, 0.0} : Vec3{0.0, 1.0, 0.0};
  const Vec3 b1 = unit(cross3(u, a));
  return {b1, cross3(u, b1)};
}

// An edge's 2-D problem: the projected ellipse and the projected midpoint.
struct EdgeProblem {
  Plane pl;
  point_ellipsoid::Ellipse el;
  Vec3 p;  // the midpoint projected, along the ellipse's axes (third coordinate 0)
  Vec3 q;  // the midpoint
};

template <class V>
ELLIPSIM_HD EdgeProblem edge_problem(const Vec3& a2, const V& p, int i, int j) {
  const Vec3 pi = vertex(p, i), pj = vertex(p, j);
  const Plane pl = normal_plane(sub(pj, pi));
  const point_ellipsoid::Ellipse el = project_ellipse(a2, pl.b1, pl.b2);
  const Vec3 q = {0.5 * (pi.x + pj.x), 0.5 * (pi.y + pj.y), 0.5 * (pi.z + pj.z)};
  const double p1 = dot(q, pl.b1), p2 = dot(q, pl.b2);
  return {pl, el, {el.c * p1 + el.s * p2, -el.s * p1 + el.c * p2, 0.0}, q};
}

// Upper bounds on a piece's maximum before it is solved: f_q's maximum over the sphere is the signed distance of q
// from E, at most |q| - r_min (q outside E: its distance is at most |q| - r_min; inside: its depth at least
// r_min - |q|); an edge's, over its great circle, the 2-D one of q's projection from E's projection (semi-axes
// >= r_min), at most |q_perp| - r_min, q_perp q's part normal to the edge.  Inflated by their rounding (a few u
// of |q|): a piece whose bound does not beat the incumbent by tol is not solved.
ELLIPSIM_HD bool vertex_beaten(const Vec3& q, double rmin, double best) {
  return math::sqrt(dot(q, q)) * (1.0 + 8.0 * tol::U) - rmin * (1.0 - 8.0 * tol::U) <= best;
}

template <class V>
ELLIPSIM_HD bool edge_beaten(const V& p, int i, int j, double rmin, double best) {
  const Vec3 pi = vertex(p, i), pj = vertex(p, j);
  const Vec3 u = unit(sub(pj, pi));
  const Vec3 q = {0.5 * (pi.x + pj.x), 0.5 * (pi.y + pj.y), 0.5 * (pi.z + pj.z)};
  const double qu = dot(q, u);
  const Vec3 w = {q.x - qu * u.x, q.y - qu * u.y, q.z - qu * u.z};
  return math::sqrt(dot(w, w)) * (1.0 + 8.0 * tol::U) + 8.0 * tol::U * math::sqrt(dot(q, q)) -
             rmin * (1.0 - 8.0 * tol::U) <= best;
}

// The rounding allowance of the tangent tests (box.hpp's below_slack): the support points and the cone corners
// are off by ulps, sigma by that times its Lipschitz bound, the hull's size + max a.
ELLIPSIM_HD double below_slack(double size, const Vec3& a2, double best) {
  return tol::PAIR_SIGMA_SLACK_ULPS * tol::U * (size + math::sqrt(max2(max2(a2.x, a2.y), a2.z)) + math::fabs(best));
}

// A plane's level at the corner c (floor <= floor2 < 0): CLOSED when g.c / |c| <= floor, CONVEX when only
// <= floor2, else OPEN (enumerate_max's vertex states); worse and better of two levels.
constexpr unsigned char OPEN = 0, CLOSED = 1, CONVEX = 2;

ELLIPSIM_HD unsigned char corner_level(const Vec3& g, const Vec3& c, double floor, double floor2) {
  const double d = dot(g, c);
  if (d > 0.0) return OPEN;
  const double dd = d * d, cc = dot(c, c);
  return dd >= floor * floor * cc ? CLOSED : dd >= floor2 * floor2 * cc ? CONVEX : OPEN;
}

// corner_level at a face normal (unit to a few ulps: distance::unit) against floors deflated by unit_floor: no |c|
// (g.c <= floor (1 + 16u) puts g.c / |c| below floor for any |c| <= 1 + 8u).
ELLIPSIM_HD unsigned char unit_level(const Vec3& g, const Vec3& c, double floor, double floor2) {
  const double d = dot(g, c);
  return d <= floor ? CLOSED : d <= floor2 ? CONVEX : OPEN;
}

ELLIPSIM_HD double unit_floor(double floor) { return floor * (1.0 + 16.0 * tol::U); }

ELLIPSIM_HD unsigned char worse(unsigned char x, unsigned char y) { return x == OPEN || y == OPEN ? OPEN : max2(x, y); }

ELLIPSIM_HD unsigned char better(unsigned char x, unsigned char y) { return x == OPEN ? y : y == OPEN ? x : min2(x, y); }

// closed[i] = CLOSED when f_{p_i} <= floor (< 0) on vertex i's whole closed stratum, the cone of the -m_f over
// the triangles f through i (the normal cone of P at p_i, negated: Schneider, Convex Bodies 2.2), CONVEX when
// only <= floor2 (floor <= floor2 < 0; enumerate_max's convexity floor), else OPEN.  One tangent plane a vertex:
// f_{p_i}(n) <= (p_i - x_i).n for any x_i in E (h_E(n) >= n.x_i), below the level at every corner, so on the cone
// (tangent_cones.hpp's argument); x_i E's support point at the sum of the corners, with the rolling ball of
// radius rho there (tangent_cones.hpp node_below).  With the adjacency, vertex by vertex over its triangles;
// without, by passes over the triangles with ctr (3 nv numbers of scratch; the same sums, in the same order).
// O(nf) and nv support points.
template <class V, class M>
ELLIPSIM_HD void close_vertices(const Vec3& a2, const V& p, const Hull& H, const M& m, double floor, double floor2,
                                double rho, double* ctr, unsigned char* closed) {
  for (int i = 0; i < H.nv; ++i) closed[i] = floor2 < 0.0 ? CLOSED : OPEN;
  if (!(floor2 < 0.0)) return;
  const double ball = floor2 + rho < 0.0 ? rho : 0.0;
  const double f1 = unit_floor(floor + ball), f2 = unit_floor(floor2 + ball);  // the corners: face normals
  // the plane of vertex i at the direction c (its cone's centre, or a corner), with the rolling ball's term
  const auto plane = [&](int i, const Vec3& c) { return tangent_cones::ball_plane(a2, vertex(p, i), c, ball); };
  if (H.vface_start != nullptr) {
    for (int i = 0; i < H.nv; ++i) {
      const int k0 = H.vface_start[i], k1 = H.vface_start[i + 1];
      Vec3 c = {0.0, 0.0, 0.0};
      for (int k = k0; k < k1; ++k) {
        const Vec3 mf = normal_of(m, H.vface[k]);
        c = {c.x - mf.x, c.y - mf.y, c.z - mf.z};
      }
      if (!(dot(c, c) > 0.0)) {  // no triangle through i: its cone is unknown, solved
        closed[i] = OPEN;
        continue;
      }
      const Vec3 g = plane(i, c);
      int miss = -1;  // the first corner not below floor
      unsigned char level = CLOSED;
      for (int k = k0; k < k1 && level != OPEN; ++k) {
        const unsigned char l = unit_level(g, flip(normal_of(m, H.vface[k])), f1, f2);
        if (l != CLOSED && miss < 0) miss = k;
        level = worse(level, l);
      }
      closed[i] = level;
      if (miss < 0 || ball == 0.0) continue;
      // with the rolling ball, the plane tangent at that corner as well (tangent_cones node_below's retry)
      const Vec3 w = flip(normal_of(m, H.vface[miss]));
      const Vec3 gw = plane(i, w);
      unsigned char lw = CLOSED;
      for (int k = k0; k < k1 && lw != OPEN; ++k)
        lw = worse(lw, unit_level(gw, flip(normal_of(m, H.vface[k])), f1, f2));
      closed[i] = better(level, lw);
      if (closed[i] != OPEN) continue;
      // then both planes: f <= min(g.n, gw.n).  The plane d.n = 0 (d = g - gw) splits the cone in two, each below
      // its lower plane where that plane is below the level at the part's extreme rays: its own corners and the
      // crossings of the boundary arcs; every crossing of a pair of corners (opposite sides) is tested, under both
      // planes, so the boundary's are among them whatever the corners' order (tangent_cones.hpp's argument on each
      // part; bench meshes, deep: 11% fewer instructions on 8 points, 0-1.5% on 40 to 500)
      const Vec3 d = sub(g, gw);
      unsigned char ls = CLOSED;
      for (int k = k0; k < k1 && ls != OPEN; ++k) {
        const Vec3 ck = flip(normal_of(m, H.vface[k]));
        const double dk = dot(d, ck);
        ls = worse(ls, unit_level(dk <= 0.0 ? g : gw, ck, f1, f2));
        for (int l = k0; l < k && ls != OPEN; ++l) {
          const Vec3 cl = flip(normal_of(m, H.vface[l]));
          const double dl = dot(d, cl);
          if ((dk <= 0.0) == (dl <= 0.0)) continue;
          const double sg = dl < 0.0 ? -1.0 : 1.0;  // dl ck - dk cl: a positive combination, on the plane
          const Vec3 x = {sg * (dl * ck.x - dk * cl.x), sg * (dl * ck.y - dk * cl.y), sg * (dl * ck.z - dk * cl.z)};
          ls = worse(ls, worse(corner_level(g, x, floor + ball, floor2 + ball),
                               corner_level(gw, x, floor + ball, floor2 + ball)));
        }
      }
      closed[i] = ls;
    }
    return;
  }
  for (int i = 0; i < 3 * H.nv; ++i) ctr[i] = 0.0;
  for (int f = 0; f < H.nf; ++f) {
    const Vec3 mf = normal_of(m, f);
    for (int k = 0; k < 3; ++k) {
      const int i = H.face[3 * f + k];
      ctr[3 * i] -= mf.x;
      ctr[3 * i + 1] -= mf.y;
      ctr[3 * i + 2] -= mf.z;
    }
  }
  for (int i = 0; i < H.nv; ++i) {
    const Vec3 c = vertex(ctr, i);
    if (!(dot(c, c) > 0.0)) {
      closed[i] = OPEN;
      continue;
    }
    const Vec3 g = plane(i, c);
    ctr[3 * i] = g.x;
    ctr[3 * i + 1] = g.y;
    ctr[3 * i + 2] = g.z;
  }
  for (int f = 0; f < H.nf; ++f) {
    const Vec3 mf = normal_of(m, f);
    const Vec3 c = {-mf.x, -mf.y, -mf.z};
    for (int k = 0; k < 3; ++k) {
      const int i = H.face[3 * f + k];
      if (closed[i] != OPEN) closed[i] = worse(closed[i], unit_level(vertex(ctr, i), c, f1, f2));
    }
  }
}

// f_{p_i} <= floor (< 0) on vertex i's closed stratum, proven on the fan of its cone: for each edge (i, j), the
// spherical triangle of the cone's centre c (the sum of the corners, inside it) and the normals -m_f, -m_g of two
// triangles through i and j (every such pair: the cone's boundary arcs are among them, so the fan covers the cone,
// and every triangle of corners lies in it), each by tangent_cones.hpp's cone_below (up to 4 levels of quarters;
// rho E's rolling radius, for its second-order planes; no incumbent plane: a vertex not tied at the incumbent
// has it outside its cone).  Needs the triangles through i (vface).
template <class V, class M>
ELLIPSIM_HD_CALL bool fan_below(const Vec3& a2, const V& p, const Hull& H, const M& m, int i, double floor,
                                double rho) {
  const int k0 = H.vface_start[i], k1 = H.vface_start[i + 1];
  Vec3 c = {0.0, 0.0, 0.0};
  for (int k = k0; k < k1; ++k) {
    const Vec3 w = normal_of(m, H.vface[k]);
    c = {c.x - w.x, c.y - w.y, c.z - w.z};
  }
  const Vec3 q = vertex(p, i);
  const Vec3 axis = {0.0, 0.0, 1.0}, none = {0.0, 0.0, 0.0};  // no disc (r = 0), no incumbent
  for (int k = k0; k < k1; ++k) {
    const int f = H.vface[k];
    const Vec3 wf = normal_of(m, f);
    const Vec3 mf = {-wf.x, -wf.y, -wf.z};
    for (int e = 0; e < 3; ++e) {
      const int j = H.face[3 * f + e];
      if (j == i) continue;
      for (int l = k + 1; l < k1; ++l) {
        const int g = H.vface[l];
        if (H.face[3 * g] != j && H.face[3 * g + 1] != j && H.face[3 * g + 2] != j) continue;
        const Vec3 wg = normal_of(m, g);
        const Vec3 mg = {-wg.x, -wg.y, -wg.z};
        if (!tangent_cones::cone_below(a2, q, axis, 0.0, none, none, c, mf, mg, floor, rho)) return false;
      }
    }
  }
  return k1 > k0;
}

// The arc of the edge (i, j) through a CONVEX end (f <= -rconvex on it) has no interior local maximum of f
// (enumerate_max): when its largest radius of curvature across the edge, R_arc = lam / sqrt(mu) (E's projection,
// squared semi-axes lam >= mu), is at most rconvex, or when the arc's planes (tangent_cones arc_below, the
// incumbent's plane at bn where the arc holds it) put f below -R_arc, or below floor (the arc then closed
// outright), whichever is higher; slack the planes' rounding allowance.  The arc runs between the normals of the
// two triangles through the edge (found through vface; none or one: not proven).
template <class V, class M>
ELLIPSIM_HD bool arc_convex(const Vec3& a2, const V& p, const Hull& H, const M& m, int i, int j, double lam, double mu,
                            double rconvex, double floor, double slack, const Vec3& bn, const Vec3& xb) {
  const double rarc = lam / math::sqrt(mu) * (1.0 + 1e-9);
  if (rarc <= rconvex) return true;
  if (H.vface_start == nullptr) return false;
  int g = -1, h = -1;
  for (int k = H.vface_start[i]; k < H.vface_start[i + 1]; ++k) {
    const int f = H.vface[k];
    if (H.face[3 * f] == j || H.face[3 * f + 1] == j || H.face[3 * f + 2] == j) (g < 0 ? g : h) = f;
  }
  return h >= 0 && tangent_cones::arc_below(a2, vertex(p, i), {0.0, 0.0, 1.0}, 0.0, bn, xb, flip(normal_of(m, g)),
                                            flip(normal_of(m, h)), max2(floor, -rarc - slack));
}

// The maximum of sigma (top comment) over the hull p (E's frame, nv vertices) and its edges and face normals
// (normals in E's frame, nf of them), from the incumbent start (at least sigma at every face normal: local_max's):
// (value, n).  A vertex whose closed stratum is below the incumbent (CLOSED) is skipped with every edge through it
// (an edge's arc lies in both its vertices' closed strata, where sigma = f_{p_i}): by one tangent plane
// (close_vertices), by its f's global bound (|q| - r_min, sd_upper), or by the fan of its cone (fan_below, with
// the adjacency).
//
// Deep crossings, by convexity: along a unit-speed great circle f_q'' = -f_q - R, R = t^T (A^2 - x x^T) t / h_E(n)
// the radius of curvature of E's section in the circle's direction t (the Hessian of the 1-homogeneous h_E; for
// a sphere of radius r, f'' = -n.q).  An interior local maximum of f_q has f_q'' <= 0 in every direction, so
// f_q >= -R_min(n) >= -a_mid^2 / a_min there (min over t perpendicular to n of t^T A^2 t is at most a_mid^2,
// Courant-Fischer; h_E >= a_min).  A vertex whose f is below -a_mid^2 / a_min on its whole stratum (CONVEX, the
// same planes at that floor) has no interior maximum there: its maximum is on its edges' arcs, and its own
// critical points are not solved.  An arc through a CONVEX vertex has no interior maximum either where f <= -R_arc
// on it, R_arc = lam / sqrt(mu) the largest radius of curvature of E's projection across the edge (its squared
// semi-axes lam >= mu): when R_arc <= a_mid^2 / a_min, or proven by the arc's planes (tangent_cones arc_below, at
// -R_arc or the incumbent's floor, whichever is higher); then its maximum is at its ends, face normals, at most
// the incumbent.  Otherwise its critical points are solved.  scratch: 4 nv numbers.
template <class V, class M>
ELLIPSIM_HD_CALL Best enumerate_max(const Vec3& a2, const V& p, const Hull& H, const M& m, double tol, double rolling,
                                    const Best& start, double* ctr, unsigned char* closed) {
  const int nv = H.nv;
  const double rho = rolling * (1.0 - 4.0 * tol::U);  // inside E whatever its rounding
  const double rmin = math::sqrt(min2(min2(a2.x, a2.y), a2.z));
  Best b = start;
  double size = 0.0;
  for (int i = 0; i < nv; ++i) size = max2(size, math::sqrt(dot(vertex(p, i), vertex(p, i))));
  const double floor = b.value + tol - below_slack(size, a2, b.value);
  // the convexity floor, -a_mid^2 / a_min (rounded up in magnitude) less the planes' rounding allowance: used
  // where it is above the incumbent's floor (a crossing deeper than that)
  const double a2lo = min2(min2(a2.x, a2.y), a2.z);
  const double a2mid = max2(min2(a2.x, a2.y), min2(max2(a2.x, a2.y), a2.z));
  const double rconvex = a2mid / math::sqrt(a2lo) * (1.0 + 1e-9);
  const double floor2 = max2(floor, -rconvex - below_slack(size, a2, rconvex));
  close_vertices(a2, p, H, m, floor, floor2, rho, ctr, closed);
  // vertices closed by their f's global bound |q| - r_min, or by their fan (deep crossings: a vertex's own
  // global bound, sd(q, E) >= 0 for a vertex outside E, never closes it; its stratum's fan does; a vertex tied
  // at the incumbent holds it in its cone, so its fan cannot close).  Not the fans at the convexity floor: they
  // cost more than the roots they save (bench meshes, deep: 0.2-3.5% more instructions a pair)
  double lowest = INFINITY;
  for (int i = 0; i < nv; ++i) lowest = min2(lowest, dot(b.n, vertex(p, i)));
  for (int i = 0; i < nv; ++i) {
    if (closed[i] == CLOSED) continue;
    const Vec3 q = vertex(p, i);
    if (vertex_beaten(q, rmin, b.value + tol) ||
        (closed[i] == OPEN && H.vface_start != nullptr && floor < 0.0 && dot(b.n, q) > lowest + 1e-9 * size &&
         fan_below(a2, p, H, m, i, floor, rho)))
      closed[i] = CLOSED;
  }
  // every open vertex's global maximiser (the incumbent only rises, so what closed stays closed), its f's global
  // bound sd_upper kept for the first OPEN_KEPT open vertices (recomputed for any further one)
  constexpr int OPEN_KEPT = 16;
  double kept[OPEN_KEPT];
  int nopen = 0;
  for (int i = 0; i < nv; ++i)
    if (closed[i] == OPEN) {
      const Vec3 q = vertex(p, i);
      const point_ellipsoid::Foot3 ft = foot3(a2, q);
      if (nopen < OPEN_KEPT) kept[nopen] = sd_upper(a2, q, ft.t);
      ++nopen;
      consider(a2, p, nv, q, ft.n, b);
    }
  // every other critical point of the open vertices whose f could beat it
  for (int i = 0, k = 0; i < nv; ++i) {
    if (closed[i] != OPEN) continue;
    const Vec3 q = vertex(p, i);
    const double bound = k < OPEN_KEPT ? kept[k] : sd_upper(a2, q, foot3(a2, q).t);
    ++k;
    if (vertex_beaten(q, rmin, b.value + tol) || bound <= b.value + tol) continue;
    point_ellipsoid::other_critical_normals(a2, q, [&](const Vec3& n) { consider(a2, p, nv, q, n, b); }, false);
  }
  // each edge between vertices not CLOSED, unless its arc is convex through a CONVEX end (above): its great
  // circle's maximiser, then every other critical point there when the circle's bound sd_upper2 beats the
  // incumbent
  const Vec3 xb = point_ellipsoid::support(a2, b.n).s;
  for (int k = 0; k < H.ne; ++k) {
    const int i = H.edge[2 * k], j = H.edge[2 * k + 1];
    if (closed[i] == CLOSED || closed[j] == CLOSED || edge_beaten(p, i, j, rmin, b.value + tol)) continue;
    const EdgeProblem ep = edge_problem(a2, p, i, j);
    const double lam = ep.el.lam, mu = ep.el.mu;
    if ((closed[i] == CONVEX || closed[j] == CONVEX) && arc_convex(a2, p, H, m, i, j, lam, mu, rconvex, floor,
                                                                    below_slack(size, a2, lam / math::sqrt(mu)), b.n, xb))
      continue;
    const point_ellipsoid::Foot2 ft = foot2(lam, mu, ep.p.x, ep.p.y);
    consider(a2, p, nv, ep.q, from_plane(ft.n0, ft.n1, ep.el.c, ep.el.s, ep.pl.b1, ep.pl.b2), b);
    if (sd_upper2(lam, mu, ep.p.x, ep.p.y, ft.t) <= b.value + tol) continue;
    point_ellipsoid::other_critical_normals2(ep.el, ep.p, ep.pl.b1, ep.pl.b2,
                                             [&](const Vec3& n) { consider(a2, p, nv, ep.q, n, b); }, false);
  }
  return b;
}

// --- the certified path (box.hpp's ub1): a local maximum from the face normals, then one bound --------------

// The incumbent b refined on the pieces active at it: the vertices lowest in n.p (at most 16, within band times
// the hull's size of the lowest) and the edges between them, their global maximisers, for up to `rounds` rounds
// while it improves.  Only a start: the proof is ub1's, ub2's or the enumeration's.  mark: nv numbers of scratch,
// all 0 on entry and on return.
template <class V>
ELLIPSIM_HD_CALL Best refine(const Vec3& a2, const V& p, const Hull& H, Best b, double band, int rounds,
                             unsigned char* mark) {
  const int nv = H.nv;
  double scale = 0.0;
  for (int i = 0; i < nv; ++i)
    scale = max2(scale, math::fabs(vertex(p, i).x) + math::fabs(vertex(p, i).y) + math::fabs(vertex(p, i).z));
  for (int round = 0; round < rounds; ++round) {
    const Best before = b;
    // the (at most 16) vertices lowest in n.p, by insertion into a sorted list
    int active[16];
    double key[16];
    int na = 0;
    for (int i = 0; i < nv; ++i) {
      const double v = dot(b.n, vertex(p, i));
      if (na == 16 && v >= key[15]) continue;
      int k = na < 16 ? na++ : 15;
      while (k > 0 && key[k - 1] > v) {
        key[k] = key[k - 1];
        active[k] = active[k - 1];
        --k;
      }
      key[k] = v;
      active[k] = i;
    }
    while (na > 1 && key[na - 1] > key[0] + band * scale) --na;  // within a band of the lowest
    for (int k = 0; k < na; ++k) {
      mark[active[k]] = 1;
      consider(a2, p, nv, vertex(p, active[k]), foot3(a2, vertex(p, active[k])).n, b);
    }
    if (na > 1)
      for (int k = 0; k < H.ne; ++k) {
        const int i = H.edge[2 * k], j = H.edge[2 * k + 1];
        if (mark[i] == 0 || mark[j] == 0) continue;
        const EdgeProblem ep = edge_problem(a2, p, i, j);
        const point_ellipsoid::Foot2 ft = foot2(ep.el.lam, ep.el.mu, ep.p.x, ep.p.y);
        consider(a2, p, nv, ep.q, from_plane(ft.n0, ft.n1, ep.el.c, ep.el.s, ep.pl.b1, ep.pl.b2), b);
      }
    for (int k = 0; k < na; ++k) mark[active[k]] = 0;
    if (b.value == before.value) break;
  }
  return b;
}

// The best face normal (n = -m_f: the face's vertices minimise n.p), refined (refine) on a band of rounding width
// (1e-6 of the size: the contact feature, a face, an edge or a vertex, and its ties); polytope_ellipsoid widens
// the band when ub1 does not close there.  mark: as refine's.
template <class V, class M>
ELLIPSIM_HD_CALL Best local_max(const Vec3& a2, const V& p, const Hull& H, const M& m, unsigned char* mark) {
  Best b = {-INFINITY, {0.0, 0.0, 1.0}};
  for (int f = 0; f < H.nf; ++f)
    consider(a2, p, H.nv, vertex(p, H.face[3 * f]), flip(normal_of(m, f)), b);
  for (int i = 0; i < H.nv; ++i) mark[i] = 0;
  return refine(a2, p, H, b, 1e-6, 16, mark);
}

// The point of the triangle (a, b, c) nearest to w (Ericson, Real-Time Collision Detection 5.1.5: by the Voronoi
// regions of its vertices, edges and face).
ELLIPSIM_HD Vec3 nearest_on_triangle(const Vec3& w, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = sub(b, a), ac = sub(c, a), aw = sub(w, a);
  const double d1 = dot(ab, aw), d2 = dot(ac, aw);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bw = sub(w, b);
  const double d3 = dot(ab, bw), d4 = dot(ac, bw);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double t = d1 / (d1 - d3);
    return {a.x + t * ab.x, a.y + t * ab.y, a.z + t * ab.z};
  }
  const Vec3 cw = sub(w, c);
  const double d5 = dot(ab, cw), d6 = dot(ac, cw);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double t = d2 / (d2 - d6);
    return {a.x + t * ac.x, a.y + t * ac.y, a.z + t * ac.z};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {b.x + t * (c.x - b.x), b.y + t * (c.y - b.y), b.z + t * (c.z - b.z)};
  }
  const double den = 1.0 / (va + vb + vc);
  const double v = vb * den, u = vc * den;
  return {a.x + v * ab.x + u * ac.x, a.y + v * ab.y + u * ac.y, a.z + v * ab.z + u * ac.z};
}

// The signed distance of the point w from the hull (E's frame): inside (below every face plane), minus the
// distance to the nearest face plane; outside, the distance to the nearest triangle (its nearest point a point
// of the hull, to rounding: an upper bound whatever the case, exact to rounding).  Outside, only the triangles
// whose plane w is above: the nearest point y of P lies on one (w - y is in P's normal cone at y, a non-negative
// sum of the normals m_g of the faces through y, and |w - y|^2 > 0 makes some m_g.(w - y) > 0; Ericson 5.1.2),
// and a triangle left out only loosens the bound (each candidate is a point of P).
template <class V, class M>
ELLIPSIM_HD double sd_point_hull(const Vec3& w, const V& p, const Hull& H, const M& m) {
  double smax = -INFINITY, best = INFINITY;
  for (int f = 0; f < H.nf; ++f) {
    const Vec3 mf = normal_of(m, f);
    const Vec3 a = vertex(p, H.face[3 * f]);
    const double d = dot(mf, w) - dot(mf, a);
    smax = max2(smax, d);
    if (!(d > 0.0)) continue;
    const Vec3 x = nearest_on_triangle(w, a, vertex(p, H.face[3 * f + 1]), vertex(p, H.face[3 * f + 2]));
    const Vec3 z = sub(w, x);
    best = min2(best, dot(z, z));
  }
  if (smax <= 0.0) return smax;
  return math::sqrt(best);
}

// ub1 (box.hpp): E = E' + ball(rho), rho its rolling radius; for any x' in E', sigma(n) <= sd(x', P) - rho
// for every n; x' = E''s support point at n (tight when the maximum is there and no deeper than rho).
template <class V, class M>
ELLIPSIM_HD_CALL double upper_bound1(const Vec3& a2, const V& p, const Hull& H, const M& m, double rho,
                                     const Vec3& n) {
  const Vec3 s = point_ellipsoid::support(a2, n).s;
  return sd_point_hull({s.x - rho * n.x, s.y - rho * n.y, s.z - rho * n.z}, p, H, m) - rho;
}

// The smallest principal radius of curvature of E at its support point s for the unit normal n (h = h_E(n)):
// the smaller eigenvalue of h_E's Hessian (A^2 - s s^T) / h on the plane normal to n.  Along E's inward normal
// at s, s stops being the nearest boundary point beyond this depth (the nearest focal point).
ELLIPSIM_HD double min_radius(const Vec3& a2, const Vec3& n, const Vec3& s, double h) {
  const Plane pl = normal_plane(n);
  const Vec3 &u = pl.b1, &w = pl.b2;
  const double su = dot(s, u), sw = dot(s, w);
  const double w11 = (a2.x * u.x * u.x + a2.y * u.y * u.y + a2.z * u.z * u.z - su * su) / h;
  const double w22 = (a2.x * w.x * w.x + a2.y * w.y * w.y + a2.z * w.z * w.z - sw * sw) / h;
  const double w12 = (a2.x * u.x * w.x + a2.y * u.y * w.y + a2.z * u.z * w.z - su * sw) / h;
  return 0.5 * (w11 + w22) - math::sqrt(0.25 * (w11 - w22) * (w11 - w22) + w12 * w12);
}

// ub2 (box.hpp's): for a ball(c, t) inside P, sigma(n) <= sd(c, E) - t for every n (P contains the ball, whose
// signed distance from E is sd(c, E) - t; sd bounded above by sd_upper, weak duality).  c: the witness
// x = s(n) + value n moved along n (into P) to the centre of the largest ball tangent to x's supporting plane
// there, t: c's depth below every face plane, deflated by its rounding (a few ulps of |c| + the hull's size);
// when c is not inside (t < 0), the lowest vertex (t = 0).  Tight for deep face contacts (the ball rolls E's
// witness), and for deep vertex and edge contacts no deeper than E's curvature radius there.  Not tried where it
// cannot close, within tol of value (INFINITY, no bound): the ball where c lies on E's inward normal at s deeper
// than E's smallest radius of curvature there (s is then not c's nearest boundary point, so sd(c, E) - t
// > value + r - t >= value; bench meshes, deep: 2 in 3 pairs, none of them closed by it, the ones it closes below
// 0.99 of that depth); the lowest vertex where value + tol < 0 and the vertex lies outside E (sd > 0).
template <class V, class M>
ELLIPSIM_HD_CALL double upper_bound2(const Vec3& a2, const V& p, const Hull& H, const M& m, const Vec3& n,
                                     double value, double tol) {
  const point_ellipsoid::Support sp = point_ellipsoid::support(a2, n);
  const Vec3 s = sp.s;
  const Vec3 x = {s.x + value * n.x, s.y + value * n.y, s.z + value * n.z};
  double reach = INFINITY;
  for (int f = 0; f < H.nf; ++f) {
    const Vec3 mf = normal_of(m, f);
    const double den = 1.0 + dot(mf, n);  // the plane's approach along n per unit of radius
    if (den > 1e-9) reach = min2(reach, (dot(mf, vertex(p, H.face[3 * f])) - dot(mf, x)) / den);
  }
  const double r = reach < INFINITY ? max2(reach, 0.0) : 0.0;
  if (!(-value - r > min_radius(a2, n, s, sp.h))) {
    const Vec3 c = {x.x + r * n.x, x.y + r * n.y, x.z + r * n.z};
    double t = INFINITY, size = 0.0;
    for (int f = 0; f < H.nf; ++f) {
      const Vec3 mf = normal_of(m, f);
      const Vec3 a = vertex(p, H.face[3 * f]);
      t = min2(t, dot(mf, a) - dot(mf, c));
      size = max2(size, math::fabs(a.x) + math::fabs(a.y) + math::fabs(a.z));
    }
    t -= tol::PAIR_SIGMA_SLACK_ULPS * tol::U * (math::fabs(c.x) + math::fabs(c.y) + math::fabs(c.z) + size);
    if (t >= 0.0) return sd_upper(a2, c, foot3(a2, c).t) - t;
  }
  int k = 0;
  double lo = INFINITY;
  for (int i = 0; i < H.nv; ++i) {
    const double v = dot(n, vertex(p, i));
    if (v < lo) {
      lo = v;
      k = i;
    }
  }
  const Vec3 q = vertex(p, k);
  if (value + tol < 0.0 && q.x * q.x / a2.x + q.y * q.y / a2.y + q.z * q.z / a2.z > 1.0 + 1e-6) return INFINITY;
  return sd_upper(a2, q, foot3(a2, q).t);
}

// --- the fast start (a hull with its adjacency): the contact feature found by walking the edges -------------

// A vertex's key along n: n.p_i less n.e, the same for every vertex (p_i = e + T v_i, so n.p_i = n.e + m.v_i,
// m = T^T n), read from the hull in its own frame: the walk compares vertices along n by their keys, one product
// a vertex whether the hull is stored in E's frame or posed (where a vertex in E's frame costs a rotation).
struct Keys {
  Vec3 m;
  const double* v;
  ELLIPSIM_HD double operator()(int i) const { return m.x * v[3 * i] + m.y * v[3 * i + 1] + m.z * v[3 * i + 2]; }
};

ELLIPSIM_HD Keys keys(const Hull& H, const Mat3& T, const Vec3& n) { return {rotate_t(T, n), H.v}; }

// The vertex lowest in n.p, by descent along the edges from `start` (by their keys): a vertex no edge descends from
// minimises the linear function over the polytope (the simplex method's optimality test; Ziegler, Lectures on
// Polytopes 3.2).
ELLIPSIM_HD int descend(const Hull& H, const Mat3& T, const Vec3& n, int start) {
  const Keys key = keys(H, T, n);
  int i = start;
  double v = key(i);
  for (;;) {
    int next = i;
    for (int k = H.adj_start[i]; k < H.adj_start[i + 1]; ++k) {
      const double w = key(H.adj[k]);
      if (w < v) {
        v = w;
        next = H.adj[k];
      }
    }
    if (next == i) return i;
    i = next;
  }
}

// consider with sigma by descent from *low (the incumbent's lowest vertex, moved to the candidate's when it wins).
// Returns whether the incumbent reached stop (the walk's callers then stop: the pair is proven apart).
template <class V>
ELLIPSIM_HD bool consider_walk(const Vec3& a2, const V& p, const Hull& H, const Mat3& T, const Vec3& q, const Vec3& n,
                               Best& b, int& low, double stop = INFINITY) {
  const double h = math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
  if (!(n.x * q.x + n.y * q.y + n.z * q.z - h > b.value)) return false;
  const int k = descend(H, T, n, low);
  const double v = dot(n, vertex(p, k)) - h;
  if (v > b.value) {
    b = {v, n};
    low = k;
  }
  return b.value >= stop;
}

// The vertices within band of the lowest (low) in n.p (by their keys), at most 16, by a walk along the edges from
// low (every one is reached: from each, a descending path to low stays in the band), marked in mark (1 added: a
// mark's odd part is membership, walk_refine keeps the round it tried a vertex in the rest); returns their count.
ELLIPSIM_HD int feature(const Hull& H, const Mat3& T, const Vec3& n, int low, double band, int* active,
                        unsigned char* mark) {
  const Keys key = keys(H, T, n);
  const double top = key(low) + band;
  int na = 1;
  active[0] = low;
  mark[low] += 1;
  for (int a = 0; a < na; ++a) {
    const int i = active[a];
    for (int k = H.adj_start[i]; k < H.adj_start[i + 1] && na < 16; ++k) {
      const int j = H.adj[k];
      if ((mark[j] & 1) == 0 && key(j) <= top) {
        mark[j] += 1;
        active[na++] = j;
      }
    }
  }
  return na;
}

// The incumbent b (its lowest vertex low) refined as refine does but locally: per round the vertices of the
// contact feature (feature, within band_rel of max(scale, |p_low|_1), at most 16), their global maximisers, the
// normals of the triangles through them and the edges between them (all_edges: every edge through them; with the
// triangles, the pieces bounding their strata), sigma by descent (consider_walk).  O(feature) a round, no pass
// over the hull.  mark: nv numbers of scratch, all 0 on entry and on return.  Ends early once the incumbent
// reaches stop (a separated pair needs only a sigma beyond its cutoff, not the maximum: GJK's early exit).
// A piece tried in an earlier round is not tried again (the incumbent only rises, so it cannot win now): a
// vertex's maximiser and triangles once (mark holds 2 (round + 1) for the first 64 vertices tried), an edge
// once its ends were tried in the same round, both in that round's feature (or, all_edges, its end tried).
template <class V>
ELLIPSIM_HD Best walk_refine(const Vec3& a2, const V& p, const Hull& H, const Mat3& T, Best b, int& low,
                             double band_rel, double scale, int rounds, bool all_edges, unsigned char* mark,
                             double stop = INFINITY) {
  int active[16], seen[64], ns = 0;
  const auto round_of = [&](int i) { return (mark[i] >> 1) - 1; };  // the round i's pieces were tried, or -1
  bool done = b.value >= stop;
  for (int round = 0; round < rounds && !done; ++round) {
    const Best before = b;
    const Vec3 pl = vertex(p, low);
    const double band = band_rel * max2(scale, math::fabs(pl.x) + math::fabs(pl.y) + math::fabs(pl.z));
    const int na = feature(H, T, b.n, low, band, active, mark);
    for (int a = 0; a < na && !done; ++a) {
      const int i = active[a];
      const int ri = round_of(i);
      if (ri < 0) {
        done = consider_walk(a2, p, H, T, vertex(p, i), foot3(a2, vertex(p, i)).n, b, low, stop);
        for (int k = H.vface_start[i]; k < H.vface_start[i + 1] && !done; ++k) {
          const Vec3 mf = face_normal(T, H, p, H.vface[k]);
          done =
              consider_walk(a2, p, H, T, vertex(p, H.face[3 * H.vface[k]]), {-mf.x, -mf.y, -mf.z}, b, low, stop);
        }
        if (ns < 64) {
          seen[ns++] = i;
          mark[i] += (unsigned char)(2 * (round + 1));
        }
      }
      for (int k = H.adj_start[i]; k < H.adj_start[i + 1] && !done; ++k) {
        const int j = H.adj[k];
        const bool in = (mark[j] & 1) != 0;
        if (in ? j <= i : !all_edges) continue;  // an edge between two of the feature's vertices once
        const int rj = round_of(j);
        if (ri >= 0 && (all_edges || (in && rj == ri))) continue;  // tried in round ri
        const EdgeProblem ep = edge_problem(a2, p, i, j);
        const point_ellipsoid::Foot2 ft = foot2(ep.el.lam, ep.el.mu, ep.p.x, ep.p.y);
        done = consider_walk(a2, p, H, T, ep.q, from_plane(ft.n0, ft.n1, ep.el.c, ep.el.s, ep.pl.b1, ep.pl.b2), b,
                             low, stop);
      }
    }
    for (int a = 0; a < na; ++a) mark[active[a]] -= 1;
    if (b.value == before.value) break;
  }
  for (int k = 0; k < ns; ++k) mark[seen[k]] = 0;
  return b;
}

// A local maximum from n0 (nonzero): its lowest vertex by descent from vertex 0, then walk_refine on the contact
// feature (band 1e-6), ending early at stop; or n0 alone where skip(sigma at n0) says so.
template <class V, class F>
ELLIPSIM_HD Best walk_max(const Vec3& a2, const V& p, const Hull& H, const Mat3& T, const Vec3& n0, int& low,
                          unsigned char* mark, double stop, F&& skip) {
  const Vec3 n = unit(n0);
  low = descend(H, T, n, 0);
  const Best b = {dot(n, vertex(p, low)) - math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z), n};
  if (skip(b.value)) return b;
  return walk_refine(a2, p, H, T, b, low, 1e-6, 0.0, 16, false, mark, stop);
}

// ub1 (upper_bound1) with the distance bounded by the triangles through the contact feature at n only: each
// point y of a triangle is a point of P, so sd(x', P) <= |x' - y| whatever x' (inside P, sd < 0); tight when the
// witness lies on one of them.  mark: as walk_max's.
template <class V>
ELLIPSIM_HD double upper_bound1_walk(const Vec3& a2, const V& p, const Hull& H, const Mat3& T, double rho,
                                     const Vec3& n, int low, unsigned char* mark) {
  const Vec3 s = point_ellipsoid::support(a2, n).s;
  const Vec3 w = {s.x - rho * n.x, s.y - rho * n.y, s.z - rho * n.z};
  int active[16];
  const Vec3 pl = vertex(p, low);
  const int na = feature(H, T, n, low, 1e-6 * (math::fabs(pl.x) + math::fabs(pl.y) + math::fabs(pl.z)), active, mark);
  double best = INFINITY;
  for (int a = 0; a < na; ++a) {
    const int i = active[a];
    for (int k = H.vface_start[i]; k < H.vface_start[i + 1]; ++k) {
      const int f = H.vface[k];
      const Vec3 x = nearest_on_triangle(w, vertex(p, H.face[3 * f]), vertex(p, H.face[3 * f + 1]),
                                         vertex(p, H.face[3 * f + 2]));
      const Vec3 z = sub(w, x);
      best = min2(best, dot(z, z));
    }
  }
  for (int a = 0; a < na; ++a) mark[active[a]] = 0;
  return math::sqrt(best) - rho;
}

// (status, dist, normal, pos, ub).
struct Result {
  int status;
  double dist;
  Vec3 normal, pos;
  double ub;
};

// m: every face normal in E's frame, stored (the walk computes the few it reads); posed: nothing to store.
ELLIPSIM_HD void fill_normals(const Mat3& T, const Hull& H, const double* p, double* m) {
  for (int f = 0; f < H.nf; ++f) {
    const Vec3 w = face_normal(T, H, p, f);
    m[3 * f] = w.x;
    m[3 * f + 1] = w.y;
    m[3 * f + 2] = w.z;
  }
}

ELLIPSIM_HD void fill_normals(const Mat3&, const Hull&, const Posed&, const Posed&) {}

// polytope_ellipsoid's body on the hull p and normals m in E's frame (stored, or Posed), far the rounding scale
// max_i |p_i|_1, T P's axes in E's frame; ctr: the no-adjacency path's 3 nv numbers, flags 2 nv bytes.
template <class V, class M>
ELLIPSIM_HD Result solve(const Ellipsoid& E, const Vec3& cP, const Mat3& T, const Hull& H, const V& p, M m,
                         double far, double* ctr, unsigned char* flags, double cutoff, Vec3 start) {
  const auto normals = [&]() { fill_normals(T, H, p, m); };
  const Vec3 a2 = {E.r.x * E.r.x, E.r.y * E.r.y, E.r.z * E.r.z};
  const double tol = tol::PAIR_CERT_REL * min2(min2(E.r.x, E.r.y), E.r.z);
  const double rho = distance::rolling_radius(E.r);
  unsigned char* mark = flags + H.nv;  // zeroed: the result never hangs on what scratch held
  for (int i = 0; i < H.nv; ++i) mark[i] = 0;
  Best b;
  double ub = INFINITY;
  int low = 0;
  bool faces = true;  // b is at least sigma (by descent) at every face normal: enumerate_max's start
  const auto face_pass = [&](Best& w) {  // every face normal, sigma by descent
    for (int f = 0; f < H.nf; ++f)
      consider_walk(a2, p, H, T, vertex(p, H.face[3 * f]), flip(normal_of(m, f)), w, low);
  };
  // the enumeration's start: b at least sigma at every face normal (to rounding), its sigma exact.  Along -m_f
  // the face's own vertex is the lowest (a supporting plane), so sigma there is that vertex's f: one product a
  // face, no descent; the best face's sigma is then computed in full, and where it falls short of its vertex's f
  // by more than rounding (a degenerate triangle's normal: a height field's flat prism) every face by descent
  // (bench meshes, deep: 1.5-4% fewer instructions a pair)
  const double slack = tol::PAIR_SIGMA_SLACK_ULPS * tol::U * (far + max3(E.r));
  const auto seed = [&]() {
    Best w = b;
    for (int f = 0; f < H.nf; ++f) {
      const Vec3 n = flip(normal_of(m, f)), q = vertex(p, H.face[3 * f]);
      const double v = dot(n, q) - math::sqrt(a2.x * n.x * n.x + a2.y * n.y * n.y + a2.z * n.z * n.z);
      if (v > w.value) w = {v, n};
    }
    const double full = sigma_hull(a2, p, H.nv, w.n);
    if (full >= w.value - slack) {
      b = {full, w.n};
      return;
    }
    face_pass(b);
    b.value = sigma_hull(a2, p, H.nv, b.n);
  };
  if (H.adj_start != nullptr && H.vface_start != nullptr) {
    // the fast start, from E's normal nearest P's origin (foot3); then the best face normal (sigma by descent),
    // the contact feature's pieces, a wider band's (1e-2 of the hull's size): ub1 over the feature's triangles
    // after each
    const Vec3 o = rotate_t(E.R, sub(cP, E.c));
    const auto apart = [&](double value) {  // value, a sigma, less its rounding allowance, proves it beyond cutoff
      if (!(value >= cutoff)) return false;
      b.value = value - slack;
      return b.value >= cutoff;
    };
    const bool given = dot(start, start) > 0.0;
    if (!given && cutoff < INFINITY && dot(o, o) > 0.0) {  // the centre line first: a pair well apart, one pass
      b.n = unit(o);
      if (apart(sigma_hull(a2, p, H.nv, b.n))) return {APART, b.value, matvec(E.R, b.n), {}, INFINITY};
    }
    const Vec3 n0 = given ? rotate_t(E.R, start) : dot(o, o) > 0.0 ? foot3(a2, o).n : Vec3{0.0, 0.0, 1.0};
    // the walk stops at a sigma (by descent) beyond cutoff + 2 slack: its full pass then proves the pair apart.
    // It does not walk a crossing deeper than E's largest semi-axis a: such a one goes to the enumeration (nothing
    // but ub2 closes there), whose face-normal pass seeds it about as well as the walk's maximum would (bench
    // meshes, deep: 11-14% fewer instructions a pair, the other categories within 0.1%).  Deep, by a guess that
    // only picks the path: sigma at the start below -a and E's centre inside P (below every face plane, P's own
    // normals in its frame; the start alone misleads where P's origin is far from the contact, a resting slab's);
    // or, from a caller's start (the height field's, near the maximum), sigma there below -a / 2 (bench height
    // field, deep: 3% fewer instructions a call, apart and shallow within 0.1%; below -rho it saves 9% on deep
    // calls but costs apart calls 16%: a prism's start at a side face can be that low where the pair is apart,
    // and the walk's early exit then is what proves it)
    const double a = max3(E.r);
    bool skipped = false;
    const auto deep = [&](double value) {
      if (given && value < -0.5 * a) return skipped = true;
      if (!(value < -a)) return false;
      const Vec3 c = rotate_t(T, o);  // E's centre in P's frame, negated
      for (int f = 0; f < H.nf; ++f) {
        const double* v = H.v + 3 * H.face[3 * f];
        const double* w = H.normal + 3 * f;
        if (w[0] * (v[0] + c.x) + w[1] * (v[1] + c.y) + w[2] * (v[2] + c.z) < 0.0) return false;
      }
      return skipped = true;
    };
    b = walk_max(a2, p, H, T, n0, low, mark, cutoff + 2.0 * slack, deep);
    const double walked = sigma_hull(a2, p, H.nv, b.n);
    if (apart(walked)) return {APART, b.value, matvec(E.R, b.n), {}, INFINITY};
    b.value = walked;
    // (over triangles, ub1 >= -rho: below -rho - tol it cannot close, and is not computed)
    if (!(b.value < -rho - tol)) ub = upper_bound1_walk(a2, p, H, T, rho, b.n, low, mark);
    if (!(ub - b.value <= tol)) normals();
    if (skipped) seed();  // the best face normal, where ub2 is then tried

    const double scale = far;  // the hull's size from E's centre, as refine's
    // The two stages only while the incumbent is above -rho.  Deeper, ub1 over triangles (>= -rho) cannot close,
    // nor can any tangent plane of E near a maximum below -rho (along the sphere the plane's bound rises as
    // value cos(angle)); ub2 closes deep face contacts from the walk's own maximum, and the enumeration starts
    // from it (after the face normals' pass it needs): the feature's pieces cost more than they save there
    // (bench meshes, deep: 15-20% a pair).
    const bool stages = !skipped && !(b.value < -rho);
    faces = skipped || stages;
    for (int stage = 0; stage < (stages ? 2 : 0) && !(ub - b.value <= tol); ++stage) {
      Best w = b;
      if (stage == 0) {
        face_pass(w);
        // every edge through the feature (ub1 may close: above -rho)
        w = walk_refine(a2, p, H, T, w, low, 1e-6, scale, 16, true, mark);
      } else {
        w = walk_refine(a2, p, H, T, w, low, 1e-2, scale, 8, false, mark);
      }
      w.value = sigma_hull(a2, p, H.nv, w.n);
      if (w.value > b.value) {
        b = w;
        ub = upper_bound1_walk(a2, p, H, T, rho, b.n, low, mark);
      } else {
        low = descend(H, T, b.n, low);  // back to the incumbent's lowest vertex
      }
    }
    // the full ub1: x' inside P (a crossing deeper than rho) is bounded by every face plane; not where the walk
    // was skipped (deeper than E's largest semi-axis ub2 closes what ub1 would: bench meshes, deep, 2-3% fewer
    // instructions)
    if (!skipped && !(ub - b.value <= tol)) ub = min2(ub, upper_bound1(a2, p, H, m, rho, b.n));
  } else {
    normals();
    b = local_max(a2, p, H, m, mark);
    ub = upper_bound1(a2, p, H, m, rho, b.n);
    if (!(ub - b.value <= tol)) {  // the pieces of a wider band (1e-2 of the hull's size), then ub1 again
      const Best wide = refine(a2, p, H, b, 1e-2, 8, mark);
      if (wide.value > b.value) {
        b = wide;
        ub = upper_bound1(a2, p, H, m, rho, b.n);
      }
    }
  }
  if (!(ub - b.value <= tol)) ub = min2(ub, upper_bound2(a2, p, H, m, b.n, b.value, tol));
  int status = CERTIFIED;
  if (!(ub - b.value <= tol)) {
    if (!faces) seed();
    b = enumerate_max(a2, p, H, m, tol, rho, b, ctr, flags);
    status = ENUMERATED;
  }
  const point_ellipsoid::Contact c = contact_in_world(E, a2, b.n, b.value);
  return {status, b.value, c.normal, c.pos, status == CERTIFIED ? ub : INFINITY};
}

// For the ellipsoid E and the hull H posed at (cP, RP) (centre metres, rotation row-major): dist the signed
// distance (sigma at the returned normal), normal unit from E to P, pos the midpoint of the witness points (as
// box.hpp), status CERTIFIED or ENUMERATED.  scratch: scratch_size(H.nv, H.nf) numbers.  cutoff (the narrow
// phase's margin): where sigma along the centre line, or at the walking start, less its rounding allowance
// (PAIR_SIGMA_SLACK_ULPS of the pair's scale, box.hpp's centre_line_bound's), reaches it, APART at once: the pair
// is proven beyond it, dist that bound.  start (world frame, from E towards P; 0: none): the walk's first
// direction instead of E's normal nearest P's origin, for a caller that knows a better one (the height field's
// prisms, whose origin is the field's); the centre line is then not tried.
ELLIPSIM_HD Result polytope_ellipsoid(const Ellipsoid& E, const Vec3& cP, const Mat3& RP, const Hull& H,
                                      double* scratch, double cutoff = INFINITY, Vec3 start = {0.0, 0.0, 0.0}) {
  double* p = scratch;
  const Mat3 T = distance::tmatmul(E.R, RP);  // P's axes in E's frame
  const double far = to_frame(E, cP, T, H, p);
  return solve(E, cP, T, H, static_cast<const double*>(p), scratch + 3 * H.nv, far, scratch + 3 * H.nv + 3 * H.nf,
               reinterpret_cast<unsigned char*>(scratch + 6 * H.nv + 3 * H.nf), cutoff, start);
}

// polytope_ellipsoid with the hull never stored (Posed: each vertex and face normal computed where read, the same
// bits): scratch only flags, posed_flags_size(H.nv) bytes, so a large hull fits a GPU thread (MuJoCo Warp's
// meshes).  H must have its adjacency (without, a non-finite result: the callers' fallback).  More arithmetic than
// the stored path (a vertex a product, a normal three).
ELLIPSIM_HD Result polytope_ellipsoid_posed(const Ellipsoid& E, const Vec3& cP, const Mat3& RP, const Hull& H,
                                            unsigned char* flags, double cutoff = INFINITY,
                                            Vec3 start = {0.0, 0.0, 0.0}) {
  if (H.adj_start == nullptr || H.vface_start == nullptr)
    return {ENUMERATED, NAN, {NAN, NAN, NAN}, {NAN, NAN, NAN}, NAN};
  const Mat3 T = distance::tmatmul(E.R, RP);
  const Posed P = {rotate_t(E.R, sub(cP, E.c)), T, &H};
  double far = 0.0;
  for (int i = 0; i < H.nv; ++i) {
    const Vec3 q = vertex(P, i);
    far = max2(far, math::fabs(q.x) + math::fabs(q.y) + math::fabs(q.z));
  }
  return solve(E, cP, T, H, P, P, far, nullptr, flags, cutoff, start);
}

}  // namespace ellipsim::pairs::polytope
