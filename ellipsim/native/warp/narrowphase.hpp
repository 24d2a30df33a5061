// ellipsim's narrow phase inside MuJoCo Warp's kernels: one pair's contact from the core's own functions, the
// ones the CPU API and the MuJoCo C callback run (mujoco/narrowphase.hpp's rows, less what needs MuJoCo C: the
// warm-start table and MuJoCo's function for an unproven maximum).  ellipsim/warp/kernels.py compiles it into
// its kernels through wp.func_native (this folder and include/ on Warp's include path, this header in the
// module's preamble), on Warp's CPU JIT and on NVRTC: only math.hpp's functions, no allocation, no exception.
//
// Poses are Warp's: vectors with operator[], 3x3 matrices with data[row][col] (wp::vec_t, wp::mat_t), float64,
// widened from the float32 MuJoCo Warp holds.  A pair's rows as Warp's NXN orders its geoms (lower type first):
// a capsule is g1 (pairs::capsule's normal flipped), a box or cylinder g2, a sphere g1, a height field g1, a mesh g2.
#pragma once

#include <ellipsim/distance/ellipsoid_pair.hpp>
#include <ellipsim/exact/certified_filter.hpp>
#include <ellipsim/pairs/box.hpp>
#include <ellipsim/pairs/capsule.hpp>
#include <ellipsim/pairs/cylinder.hpp>
#include <ellipsim/pairs/height_field.hpp>
#include <ellipsim/pairs/polytope.hpp>
#include <ellipsim/vec3.hpp>

namespace ellipsim::warp_glue {

// Which core function a pair runs (ellipsim/pair_table.py's rows name them).
constexpr int ROW_ELLIPSOID = 0, ROW_CAPSULE = 1, ROW_BOX = 2, ROW_CYLINDER = 3, ROW_MESH = 4, ROW_HFIELD = 5;

// The largest mesh hull the mesh row stores in E's frame (vertices; a closed triangulated hull has at most
// 2 nv - 4 triangles): its scratch is a fixed local array of that size.  A larger hull runs posed
// (polytope_ellipsoid_posed: vertices and normals computed where read, the same bits), its two flags a vertex in
// the same array, up to MAX_POSED_HULL_VERTICES (ellipsim/warp/attachment.py leaves larger hulls to Warp).
constexpr int MAX_HULL_VERTICES = 64;
constexpr int MAX_HULL_FACES = 2 * MAX_HULL_VERTICES - 4;
constexpr int HULL_SCRATCH = pairs::polytope::scratch_size(MAX_HULL_VERTICES, MAX_HULL_FACES);
constexpr int MAX_POSED_HULL_VERTICES = 3000;
static_assert(pairs::polytope::posed_flags_size(MAX_POSED_HULL_VERTICES) <= 8 * HULL_SCRATCH,
              "a posed hull's flags fit the stored hull's scratch");

// The columns of the attachment's hull table (one row per mesh): the counts, then each array's offset into the
// concatenated hull arrays (vertices and normals into the float64 one, the rest into the int32 one).
constexpr int HULL_NV = 0, HULL_NE = 1, HULL_NF = 2, HULL_V = 3, HULL_NORMAL = 4, HULL_EDGE = 5, HULL_FACE = 6,
              HULL_ADJ_START = 7, HULL_ADJ = 8, HULL_VFACE_START = 9, HULL_VFACE = 10, HULL_COLUMNS = 11;

// A height-field pair's most contacts: MuJoCo's mjMAXCONPAIR, as mujoco/narrowphase.hpp's hfield_row.
constexpr int HFIELD_MAXCON = 50;

// A pair's status: its maximum proven global, or not (the best found), or proven apart beyond the cutoff by a
// certified filter (no distance computed).
constexpr int GLOBAL = 0, UNPROVEN = 1, APART = 2;

struct Contact {
  int status;
  double dist;
  Vec3 normal, pos;  // normal unit, from g1 to g2
  bool deep;         // past the shallow proof: the ellipsoid pair's depth beyond rho, another row's enumeration
};

template <typename V, typename M>
ELLIPSIM_HD Ellipsoid pose(const V& c, const M& R, const V& r) {
  return {{c[0], c[1], c[2]},
          {{R.data[0][0], R.data[0][1], R.data[0][2], R.data[1][0], R.data[1][1], R.data[1][2], R.data[2][0],
            R.data[2][1], R.data[2][2]}},
          {r[0], r[1], r[2]}};
}

template <typename V>
ELLIPSIM_HD void put(V& out, const Vec3& v) {
  out[0] = v.x;
  out[1] = v.y;
  out[2] = v.z;
}

// E grown to hold E + ball(grow) (mujoco/contact_filter.hpp's geom_ellipsoid): a sphere's radius plus grow,
// an ellipsoid scaled about its centre by 1 + grow / its smallest semi-axis.
ELLIPSIM_HD Ellipsoid grown(Ellipsoid E, bool sphere, double grow) {
  if (sphere) {
    const double r = E.r.x + grow;
    E.r = {r, r, r};
  } else if (grow != 0.0) {
    const double k = 1.0 + grow / min3(E.r);
    E.r = {E.r.x * k, E.r.y * k, E.r.z * k};
  }
  return E;
}

template <typename R>
ELLIPSIM_HD Contact from_pair(const R& r, bool flip, bool deep, int status) {
  const Vec3 n = flip ? Vec3{-r.normal.x, -r.normal.y, -r.normal.z} : r.normal;
  return {status, r.dist, n, r.pos, deep};
}

// One pair's contact.  G1, G2: the geoms' poses, G.r an ellipsoid's semi-axes ((r, r, r) for a sphere: sphere1)
// or MuJoCo's geom_size of the capsule, box or cylinder.  cutoff: where a certified filter, or for two ellipsoids
// sigma at a Newton iterate, proves the pair at least that far apart, APART (dist 0, or that lower bound) and the
// search stops; -inf computes every pair (the tests' and the bench's distances).
ELLIPSIM_HD Contact pair_contact(int row, const Ellipsoid& G1, const Ellipsoid& G2, bool sphere1, double cutoff) {
  const bool filter = cutoff > -INFINITY;
  if (row == ROW_CAPSULE) {  // g1 the capsule
    if (filter && pairs::capsule::centre_line_bound(G2, G1) >= cutoff) return {APART, 0.0, {}, {}, false};
    const pairs::capsule::Result r = pairs::capsule::capsule_ellipsoid(G2, G1);  // CERTIFIED or ENUMERATED
    return from_pair(r, true, r.status != pairs::capsule::CERTIFIED, GLOBAL);
  }
  if (row == ROW_BOX) {
    if (filter && pairs::box::centre_line_bound(G1, G2) >= cutoff) return {APART, 0.0, {}, {}, false};
    const pairs::box::Result r = pairs::box::box_ellipsoid(G1, G2);  // CERTIFIED or ENUMERATED
    return from_pair(r, false, r.status != pairs::box::CERTIFIED, GLOBAL);
  }
  if (row == ROW_CYLINDER) {
    if (filter && pairs::cylinder::centre_line_bound(G1, G2) >= cutoff) return {APART, 0.0, {}, {}, false};
    const pairs::cylinder::Result r = pairs::cylinder::cylinder_ellipsoid(G1, G2);  // a deep rim maximum: UNPROVEN
    return from_pair(r, false, r.status != pairs::cylinder::CERTIFIED,
                     r.status == pairs::cylinder::UNPROVEN ? UNPROVEN : GLOBAL);
  }
  // two ellipsoids, or a sphere (g1) and an ellipsoid: the centre line on the pair grown by half the cutoff each
  // (mujoco/narrowphase.hpp's ellipsim_narrowphase), then the distance, its first Newton run stopped where sigma
  // proves the pair beyond the cutoff (the bisector filter MuJoCo C runs next costs more on Warp than that run
  // where it fails: ellipsim bench --only warp)
  if (filter) {
    const double grow = 0.5 * max2(cutoff, 0.0);
    if (exact::centre_line_separates(grown(G1, sphere1, grow), grown(G2, false, grow)))
      return {APART, 0.0, {}, {}, false};
  }
  const distance::PairDistance r = distance::pair_signed_distance_until(G1, G2, filter ? cutoff : INFINITY);
  if (r.status == distance::ellipsoid_pair::APART) return {APART, r.dist, r.normal, r.pos, false};
  const double rho = distance::rolling_radius(G1.r) + distance::rolling_radius(G2.r);
  return from_pair(r, false, !(r.dist >= -rho), r.status == distance::ellipsoid_pair::GLOBAL ? GLOBAL : UNPROVEN);
}

// pair_contact on Warp's types, its outputs written through references (wp.func_native returns no struct).
template <typename V, typename M>
ELLIPSIM_HD void warp_pair_contact(int row, const V& c1, const M& R1, const V& r1, const V& c2, const M& R2,
                                   const V& r2, int sphere1, double cutoff, int& status, double& dist, V& normal,
                                   V& pos, int& deep) {
  const Contact k = pair_contact(row, pose(c1, R1, r1), pose(c2, R2, r2), sphere1 != 0, cutoff);
  status = k.status;
  dist = k.dist;
  put(normal, k.normal);
  put(pos, k.pos);
  deep = k.deep ? 1 : 0;
}

// The height-field row (not pair_contact's: several contacts): the ellipsoid (c2, R2, r2) with the field g1 posed
// at (c1, R1), its MuJoCo Warp model data (nrow, ncol, size (x, y, z, base) float32, elevations data[adr ...]), as
// hfield_row calls pairs::height_field::contacts: every prism within `margin`, in MuJoCo's order, up to
// HFIELD_MAXCON.  Contact k into row k of out (Warp's matrix HFIELD_MAXCON x 7: dist, normal from the field to the
// ellipsoid, pos); count their number, or -1 (a degenerate prism or a non-finite distance: no contacts).
template <typename V, typename M, typename V4, typename A, typename B>
ELLIPSIM_HD void warp_hfield_contacts(const V& c1, const M& R1, const V& c2, const M& R2, const V& r2, int nrow,
                                      int ncol, const V4& size, const A& data, int adr, double margin, int& count,
                                      B& out) {
  const pairs::height_field::Field F = {nrow, ncol, double(size[0]), double(size[1]), double(size[2]),
                                        double(size[3]), data.data + adr};
  const Ellipsoid field = pose(c1, R1, r2);  // its centre and rotation (r2 unused)
  int k = 0;
  count = pairs::height_field::contacts(pose(c2, R2, r2), field.c, field.R, F, margin, HFIELD_MAXCON,
                                        [&](const pairs::height_field::Contact& x) {
                                          const double row[7] = {x.dist,  x.normal.x, x.normal.y, x.normal.z,
                                                                 x.pos.x, x.pos.y,    x.pos.z};
                                          for (int j = 0; j < 7; ++j) out.data[k][j] = row[j];
                                          ++k;
                                        });
}

// The mesh row (mujoco/narrowphase.hpp's mesh_row's function): the ellipsoid g1 (c1, R1, r1) and the mesh g2
// posed at (c2, R2), its hull row `mesh` of the attachment's table (HULL_*) into the concatenated arrays real
// (float64) and ints (int32).  pairs::polytope::polytope_ellipsoid with the cutoff (posed above MAX_HULL_VERTICES
// or MAX_HULL_FACES); status GLOBAL (deep 1 where
// ENUMERATED: its certificate did not close), APART (proven beyond the cutoff), or -1 (a non-finite distance,
// where MuJoCo C's narrow phase calls MuJoCo's own function).  A call of its own (ELLIPSIM_HD_CALL): its scratch,
// a local array for the largest hull, is made only for a mesh pair.
template <typename V, typename M, typename T, typename R, typename I>
ELLIPSIM_HD_CALL void warp_mesh_contact(const V& c1, const M& R1, const V& r1, const V& c2, const M& R2,
                                        const T& table, int mesh, const R& real, const I& ints, double cutoff,
                                        int& status, double& dist, V& normal, V& pos, int& deep) {
  const int* h = table.data + HULL_COLUMNS * mesh;
  const double* x = real.data;
  const int* k = ints.data;
  const pairs::polytope::Hull H = {h[HULL_NV],          h[HULL_NE],          h[HULL_NF],
                                   x + h[HULL_V],       k + h[HULL_EDGE],    x + h[HULL_NORMAL],
                                   k + h[HULL_FACE],    k + h[HULL_ADJ_START], k + h[HULL_ADJ],
                                   k + h[HULL_VFACE_START], k + h[HULL_VFACE]};
  double scratch[HULL_SCRATCH];  // (not zeroed: not read)
  const Ellipsoid P = pose(c2, R2, r1);  // the mesh's centre and rotation (r1 unused)
  const Ellipsoid E = pose(c1, R1, r1);
  const bool stored = H.nv <= MAX_HULL_VERTICES && H.nf <= MAX_HULL_FACES;
  if (!stored && H.nv > MAX_POSED_HULL_VERTICES) {  // (hull_arrays refuses such a hull: never read past scratch)
    status = -1, deep = 0, dist = NAN;
    return;
  }
  const pairs::polytope::Result r =
      stored ? pairs::polytope::polytope_ellipsoid(E, P.c, P.R, H, scratch, cutoff)
             : pairs::polytope::polytope_ellipsoid_posed(E, P.c, P.R, H, reinterpret_cast<unsigned char*>(scratch),
                                                         cutoff);
  deep = r.status == pairs::polytope::ENUMERATED ? 1 : 0;
  status = r.status == pairs::polytope::APART ? APART : math::isfinite(r.dist) ? GLOBAL : -1;
  dist = r.dist;
  put(normal, r.normal);
  put(pos, r.pos);
}

}  // namespace ellipsim::warp_glue
