// Ellipsoid x height field, as MuJoCo collides them (engine_collision_convex.c, mjc_ConvexHField; issue 48): the
// field is a grid of elevations, each cell split into two triangles along its (r, c) - (r + 1, c + 1) diagonal and
// each triangle extruded down to the field's base: a prism, a convex polytope of 6 vertices.  The cells under the
// ellipsoid's bounding box are visited in MuJoCo's order (rows, then columns, then the cell's two triangles) and
// every prism the ellipsoid comes within the margin of gives one contact, its exact signed distance, normal and
// point (polytope.hpp, proven), up to `maxcon` contacts (MuJoCo's mjMAXCONPAIR).
//
// MuJoCo's own function raises each prism's top by the margin and grows the ellipsoid by half of it, so with a
// positive margin its contacts' dist is not the signed distance; here a prism gives a contact exactly when its
// signed distance from the ellipsoid is below the margin, MuJoCo's rule for every other pair (a contact's dist is
// the signed distance).  At margin 0 the two make the same contacts (those of the prisms the ellipsoid overlaps).
// The cell range is the bounding box's grown by the margin, so no prism within the margin is left out.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "polytope.hpp"

namespace ellipsim::pairs::height_field {

// A height field in its own frame (MuJoCo's hfield_size, hfield_nrow, hfield_ncol, hfield_data): x in
// [-sx, sx] over ncol columns, y in [-sy, sy] over nrow rows, elevation data[r ncol + c] in [0, 1] scaled by sz,
// the solid reaching down to z = -base.
struct Field {
  int nrow, ncol;
  double sx, sy, sz, base;
  const float* data;
};

// A prism's hull: vertices 0-2 the triangle at the base, 3-5 the same points at their elevations.  Edges: the two
// triangles', the three vertical ones and a diagonal of each side (the diagonal of its triangulation: only more
// candidates for the kernel); faces: base, top and each side as two triangles.
constexpr int NV = 6, NE = 12, NF = 8;
constexpr int EDGES[2 * NE] = {0, 1, 1, 2, 0, 2, 3, 4, 4, 5, 3, 5, 0, 3, 1, 4, 2, 5, 0, 4, 1, 5, 0, 5};
constexpr int FACES[3 * NF] = {0, 1, 2, 3, 4, 5, 0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 0, 2, 5, 0, 5, 3};
// Their adjacency, as polytope::build_adjacency makes it from EDGES and FACES (tests/test_meshes.py checks it).
constexpr int ADJ_START[NV + 1] = {0, 5, 9, 12, 15, 19, 24};
constexpr int ADJ[2 * NE] = {1, 2, 3, 4, 5, 0, 2, 4, 5, 1, 0, 5, 4, 5, 0, 3, 5, 1, 0, 4, 3, 2, 1, 0};
constexpr int VFACE_START[NV + 1] = {0, 5, 9, 12, 15, 19, 24};
constexpr int VFACE[3 * NF] = {0, 2, 3, 6, 7, 0, 2, 4, 5, 0, 4, 6, 1, 3, 7, 1, 2, 3, 5, 1, 4, 5, 6, 7};
// The scratch polytope_ellipsoid needs for a prism.
constexpr int SCRATCH = polytope::scratch_size(NV, NF);

// One prism: its vertices and outward unit face normals (field frame).
struct Prism {
  double v[3 * NV];
  double normal[3 * NF];
  bool valid;  // every face has a normal (false: a degenerate prism, e.g. an elevation at the base)
};

// The grid point (r, c) at its elevation (MuJoCo's addPrismVert: x = dx c - sx, y = dy r - sy).
ELLIPSIM_HD Vec3 grid_point(const Field& F, int r, int c) {
  const double dx = (2.0 * F.sx) / (F.ncol - 1), dy = (2.0 * F.sy) / (F.nrow - 1);
  return {dx * c - F.sx, dy * r - F.sy, double(F.data[r * F.ncol + c]) * F.sz};
}

// The prism of the triangle (a, b, c) (points at their elevations).  Normals: the base's -z; each side's (both its
// triangles) horizontal, normal to its edge in the plane, away from the third point; the top's the cross product,
// turned up (elevations are above the base, so the top faces up).  A triangle degenerate in the plane, or a side
// of zero length: not valid.
ELLIPSIM_HD Prism make_prism(const Field& F, const Vec3& a, const Vec3& b, const Vec3& c) {
  Prism P;
  const Vec3 top[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    P.v[3 * k] = P.v[3 * (k + 3)] = top[k].x;
    P.v[3 * k + 1] = P.v[3 * (k + 3) + 1] = top[k].y;
    P.v[3 * k + 2] = -F.base;
    P.v[3 * (k + 3) + 2] = top[k].z;
  }
  auto put = [&](int f, const Vec3& n) {
    P.normal[3 * f] = n.x;
    P.normal[3 * f + 1] = n.y;
    P.normal[3 * f + 2] = n.z;
  };
  put(0, {0.0, 0.0, -1.0});
  Vec3 n = cross3(sub(b, a), sub(c, a));
  double len = math::sqrt(polytope::dot(n, n));
  P.valid = len > 0.0 && n.z != 0.0;
  if (n.z < 0.0) len = -len;
  put(1, {n.x / len, n.y / len, n.z / len});
  const int side[3][3] = {{0, 1, 2}, {1, 2, 0}, {0, 2, 1}};  // FACES' sides: edge (j, k), the third point
  for (int s = 0; s < 3; ++s) {
    const Vec3 &p = top[side[s][0]], &q = top[side[s][1]], &o = top[side[s][2]];
    Vec3 m = {q.y - p.y, p.x - q.x, 0.0};  // the edge turned by 90 degrees in the plane
    const double l = math::sqrt(m.x * m.x + m.y * m.y);
    P.valid = P.valid && l > 0.0;
    if (m.x * (o.x - p.x) + m.y * (o.y - p.y) > 0.0) m = {-m.x, -m.y, 0.0};
    put(2 + 2 * s, {m.x / l, m.y / l, 0.0});
    put(3 + 2 * s, {m.x / l, m.y / l, 0.0});
  }
  return P;
}

// The cells an ellipsoid's bounding box grown by `grow` covers (field frame): rows [rmin, rmax), columns
// (cmin, cmax] of triangles as mjc_ConvexHField walks them; `empty` when the box misses the field's solid.
struct Range {
  int rmin, rmax, cmin, cmax;
  double zmin;  // the ellipsoid's lowest point less grow: a prism whose top is below it is beyond the margin
  bool empty;
};

// E in the field's frame: centre lc, rotation L (MuJoCo's local_pos, mat); its extent along axis k is
// sqrt(sum_j (L_kj r_j)^2), the support function at the axis (Schneider & Eberly 10.5.2).
ELLIPSIM_HD Range cell_range(const Field& F, const Vec3& lc, const Mat3& L, const Vec3& r, double grow) {
  double ext[3];
  for (int k = 0; k < 3; ++k) {
    const double a = L.m[3 * k] * r.x, b = L.m[3 * k + 1] * r.y, c = L.m[3 * k + 2] * r.z;
    ext[k] = math::sqrt(a * a + b * b + c * c);
  }
  const double xmin = lc.x - ext[0] - grow, xmax = lc.x + ext[0] + grow;
  const double ymin = lc.y - ext[1] - grow, ymax = lc.y + ext[1] + grow;
  const double zmin = lc.z - ext[2] - grow, zmax = lc.z + ext[2] + grow;
  Range R = {0, 0, 0, 0, zmin, false};
  if (xmin > F.sx || xmax < -F.sx || ymin > F.sy || ymax < -F.sy || zmin > F.sz || zmax < -F.base) {
    R.empty = true;
    return R;
  }
  R.cmin = max2(0, int(math::floor((xmin + F.sx) / (2.0 * F.sx) * (F.ncol - 1))));
  R.cmax = min2(F.ncol - 1, int(math::ceil((xmax + F.sx) / (2.0 * F.sx) * (F.ncol - 1))));
  R.rmin = max2(0, int(math::floor((ymin + F.sy) / (2.0 * F.sy) * (F.nrow - 1))));
  R.rmax = min2(F.nrow - 1, int(math::ceil((ymax + F.sy) / (2.0 * F.sy) * (F.nrow - 1))));
  return R;
}

// sigma(n) = min_i n.(v_i - lc) - h_E(n) at the unit n (field frame): a lower bound on the signed distance of E
// and the prism for any unit direction (polytope.hpp's sigma; Schneider & Eberly 10.5.2: h_E(n) = |diag(r) L^T n|).
ELLIPSIM_HD double prism_sigma(const Prism& P, const Vec3& lc, const Mat3& L, const Vec3& r, const Vec3& n) {
  double lo = INFINITY;
  for (int i = 0; i < NV; ++i)
    lo = min2(lo, n.x * (P.v[3 * i] - lc.x) + n.y * (P.v[3 * i + 1] - lc.y) + n.z * (P.v[3 * i + 2] - lc.z));
  const Vec3 w = rotate_t(L, n);  // n in E's frame
  return lo - math::sqrt(r.x * r.x * w.x * w.x + r.y * r.y * w.y * w.y + r.z * r.z * w.z * w.z);
}

// The pre-test: apart when a direction proves the prism beyond the margin, sigma less its rounding allowance
// (PAIR_SIGMA_SLACK_ULPS of the pair's scale) at a face normal, or normal to the plane separating E and the
// prism's top at their nearest points in E's metric (below).  Most prisms under the bounding box are apart, and
// this costs a few dot products, against a solve.  Otherwise n: the direction of the largest sigma tried (field
// frame), the solve's start.
struct PreTest {
  bool apart;
  Vec3 n;
};

ELLIPSIM_HD PreTest apart_by_faces(const Prism& P, const Vec3& lc, const Mat3& L, const Vec3& r, double margin) {
  double far = 0.0;
  for (int i = 0; i < NV; ++i)
    far = max2(far, math::fabs(P.v[3 * i] - lc.x) + math::fabs(P.v[3 * i + 1] - lc.y) + math::fabs(P.v[3 * i + 2] - lc.z));
  const double bar = margin + tol::PAIR_SIGMA_SLACK_ULPS * tol::U * (far + max3(r));
  PreTest t = {false, {0.0, 0.0, 1.0}};
  double best = -INFINITY;
  auto beyond = [&](const Vec3& n) {
    const double v = prism_sigma(P, lc, L, r, n);
    if (v > best) best = v, t.n = n;
    return t.apart = v >= bar;
  };
  auto face = [&](int f) { return Vec3{-P.normal[3 * f], -P.normal[3 * f + 1], -P.normal[3 * f + 2]}; };
  if (beyond(face(1))) return t;  // the top, most often
  // E's metric: the top's vertices in E's frame scaled to the unit ball, y their triangle's nearest point to the
  // origin; n = L diag(1/r) y is normal to the plane that separates the ball and the triangle there (for a sphere,
  // the direction from its centre to the top's nearest point).  Exact where the prism's nearest point to E is on
  // its top and E is above it (n down: the base's vertices are then no lower along n), as for the prisms beside a
  // resting ellipsoid's contact (the terrain scene: 43% fewer instructions a call than E's centre towards the
  // top's nearest point in the field's metric; bench height field: 4-5%)
  const auto scaled = [&](int i) {
    const Vec3 w = rotate_t(L, {P.v[3 * i] - lc.x, P.v[3 * i + 1] - lc.y, P.v[3 * i + 2] - lc.z});
    return Vec3{w.x / r.x, w.y / r.y, w.z / r.z};
  };
  const Vec3 y = polytope::nearest_on_triangle({0.0, 0.0, 0.0}, scaled(3), scaled(4), scaled(5));
  const Vec3 d = matvec(L, {y.x / r.x, y.y / r.y, y.z / r.z});
  const double dd = polytope::dot(d, d);
  if (dd > 0.0) {
    const double s = 1.0 / math::sqrt(dd);
    if (beyond({d.x * s, d.y * s, d.z * s})) return t;
  }
  (void)(beyond(face(2)) || beyond(face(4)) || beyond(face(6)) || beyond(face(0)));  // the sides (two triangles each), base
  return t;
}

// One contact: signed distance, unit normal from the field to the ellipsoid, point (world frame).
struct Contact {
  double dist;
  Vec3 normal, pos;
};

// The contacts of the ellipsoid E with the field F posed at (cF, RF) (centre, row-major rotation), in MuJoCo's
// order: emit(Contact) for each prism within `margin`, at most maxcon; returns how many, or -1 when a prism's
// distance is not finite (non-finite input: the caller's fallback).
template <class Emit>
ELLIPSIM_HD int contacts(const Ellipsoid& E, const Vec3& cF, const Mat3& RF, const Field& F, double margin, int maxcon,
                         Emit&& emit) {
  const Vec3 lc = rotate_t(RF, sub(E.c, cF));
  const Mat3 L = distance::tmatmul(RF, E.R);
  if (!math::isfinite(lc.x + lc.y + lc.z + E.r.x + E.r.y + E.r.z + margin)) return -1;  // (no cell of a NaN)
  const Range R = cell_range(F, lc, L, E.r, max2(margin, 0.0));
  if (R.empty) return 0;
  double scratch[SCRATCH];
  int n = 0;
  for (int r = R.rmin; r < R.rmax; ++r) {
    for (int c = R.cmin + 1; c <= R.cmax; ++c) {
      const Vec3 p00 = grid_point(F, r, c - 1), p10 = grid_point(F, r + 1, c - 1);
      const Vec3 p01 = grid_point(F, r, c), p11 = grid_point(F, r + 1, c);
      for (int i = 0; i < 2; ++i) {  // addPrismVert's window: (p10, p00, p11), then (p00, p11, p01)
        const Vec3 a = i == 0 ? p10 : p00, b = i == 0 ? p00 : p11, t = i == 0 ? p11 : p01;
        if (a.z < R.zmin && b.z < R.zmin && t.z < R.zmin) continue;  // its top below E by more than the margin
        const Prism P = make_prism(F, a, b, t);
        if (!P.valid) return -1;
        const PreTest pre = apart_by_faces(P, lc, L, E.r, margin);
        if (pre.apart) continue;
        const polytope::Hull H = {NV, NE, NF, P.v, EDGES, P.normal, FACES, ADJ_START, ADJ, VFACE_START, VFACE};
        const polytope::Result q =  // APART: beyond; the walk from the pre-test's best direction
            polytope::polytope_ellipsoid(E, cF, RF, H, scratch, margin, matvec(RF, pre.n));
        if (!math::isfinite(q.dist)) return -1;
        if (!(q.dist < margin)) continue;
        emit(Contact{q.dist, {-q.normal.x, -q.normal.y, -q.normal.z}, q.pos});
        if (++n >= maxcon) return n;
      }
    }
  }
  return n;
}

}  // namespace ellipsim::pairs::height_field
