// The bindings of pairs/polytope.hpp and pairs/height_field.hpp for the public API (ellipsim/core/pairs/
// shape_distance.py's "mesh" kind and height_field.py): a batch of ellipsoids against one convex hull posed per
// pair, and against one height field posed per pair (every prism within the margin, in MuJoCo's order).
#include <algorithm>

#include <ellipsim/pairs/derivatives.hpp>
#include <ellipsim/pairs/height_field.hpp>
#include <ellipsim/pairs/polytope.hpp>

#include "common.hpp"
#include "hull.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;

// A pose of a batch (centres (n, 3), rotations (n, 3, 3); a batch of one broadcasts).
struct Poses {
  const double* C;
  const double* R;
  std::int64_t n;
  Vec3 c(std::int64_t i) const {
    const double* p = C + 3 * (n > 1 ? i : 0);
    return {p[0], p[1], p[2]};
  }
  Mat3 rot(std::int64_t i) const {
    const double* q = R + 9 * (n > 1 ? i : 0);
    return {{q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]}};
  }
};

Poses poses(const Centers<>& C, const Rotations<>& R, std::int64_t lo, std::int64_t hi) {
  const auto n = static_cast<std::int64_t>(C.shape(0));
  if (static_cast<std::int64_t>(R.shape(0)) != n) throw std::invalid_argument("centres and rotations differ in length");
  if (hi > lo && n != 1 && n < hi) throw std::out_of_range("pair range outside the poses");
  return {C.data(), R.data(), n};
}

// Signed distance, normal (from the ellipsoid), contact point and status (0 proven and finite, 1 otherwise) of the
// ellipsoids and the hull (vertices, edges, outward normals, triangles: its own frame; the indices checked by
// the caller, core/pairs/hull.py) posed at (CP, RP), pairs [lo, hi).
void mesh_distances(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& CP,
                    const Rotations<>& RP, const Centers<>& vertices, const EdgeArray& edges, const Centers<>& normals,
                    const FaceArray& faces, Out<double> dist, Rows<3> normal, Rows<3> pos, Out<std::int8_t> status,
                    std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ce, Re, re);
  const auto n = static_cast<std::int64_t>(dist.shape(0));
  if (lo < 0 || hi < lo || hi > n || static_cast<std::int64_t>(normal.shape(0)) != n ||
      static_cast<std::int64_t>(pos.shape(0)) != n || static_cast<std::int64_t>(status.shape(0)) != n)
    throw std::out_of_range("pair range outside the outputs");
  if (hi > lo && a.n != 1 && a.n < hi) throw std::out_of_range("pair range outside the ellipsoids");
  const Poses P = poses(CP, RP, lo, hi);
  const BoundHull hull(vertices, edges, normals, faces);  // checked, its adjacency built: once per call
  const pairs::polytope::Hull& H = hull.H;
  std::vector<double> scratch = hull.scratch();
  double *d = dist.data(), *nr = normal.data(), *p = pos.data();
  std::int8_t* s = status.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Ellipsoid E = load(a.C, a.R, a.r, a.n > 1 ? i : 0);
    const pairs::polytope::Result r = pairs::polytope::polytope_ellipsoid(E, P.c(i), P.rot(i), H, scratch.data());
    d[i] = r.dist;
    s[i] = std::isfinite(r.dist) ? 0 : 1;
    nr[3 * i] = r.normal.x, nr[3 * i + 1] = r.normal.y, nr[3 * i + 2] = r.normal.z;
    p[3 * i] = r.pos.x, p[3 * i + 1] = r.pos.y, p[3 * i + 2] = r.pos.z;
  }
}

// Every contact of the ellipsoids with the height field (elevation (nrow, ncol) float32 in [0, 1], size (x, y,
// z, base), posed at (CF, RF)) within margin[i], at most maxcon per pair, in MuJoCo's order: count[i] of them
// (-1: a degenerate prism or a non-finite distance), dist (n, maxcon), normal (n, maxcon, 3) from the field to
// the ellipsoid, pos (n, maxcon, 3); pairs [lo, hi).
void hfield_contacts(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& CF,
                     const Rotations<>& RF, const In<float, nb::ndim<2>>& elevation, const In<double, nb::shape<4>>& size,
                     const In<double, nb::ndim<1>>& margin, std::int64_t maxcon, Out<std::int32_t> count,
                     nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu> dist,
                     nb::ndarray<double, nb::ndim<3>, nb::c_contig, nb::device::cpu> normal,
                     nb::ndarray<double, nb::ndim<3>, nb::c_contig, nb::device::cpu> pos, std::int64_t lo,
                     std::int64_t hi) {
  const auto a = batch(Ce, Re, re);
  const auto n = static_cast<std::int64_t>(count.shape(0));
  if (maxcon < 1) throw std::invalid_argument("maxcon must be at least 1");
  if (lo < 0 || hi < lo || hi > n || static_cast<std::int64_t>(dist.shape(0)) != n ||
      static_cast<std::int64_t>(dist.shape(1)) != maxcon || static_cast<std::int64_t>(normal.shape(0)) != n ||
      static_cast<std::int64_t>(normal.shape(1)) != maxcon || normal.shape(2) != 3 ||
      static_cast<std::int64_t>(pos.shape(0)) != n || static_cast<std::int64_t>(pos.shape(1)) != maxcon ||
      pos.shape(2) != 3 || static_cast<std::int64_t>(margin.shape(0)) != n)
    throw std::out_of_range("pair range outside the outputs");
  if (hi > lo && a.n != 1 && a.n < hi) throw std::out_of_range("pair range outside the ellipsoids");
  if (elevation.shape(0) < 2 || elevation.shape(1) < 2) throw std::invalid_argument("the field needs 2 x 2 points");
  const Poses P = poses(CF, RF, lo, hi);
  const double* sz = size.data();
  const pairs::height_field::Field F = {int(elevation.shape(0)), int(elevation.shape(1)), sz[0], sz[1], sz[2], sz[3],
                                        elevation.data()};
  const double* mg = margin.data();
  std::int32_t* c = count.data();
  double *d = dist.data(), *nr = normal.data(), *p = pos.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Ellipsoid E = load(a.C, a.R, a.r, a.n > 1 ? i : 0);
    std::int64_t k = 0;
    c[i] = pairs::height_field::contacts(E, P.c(i), P.rot(i), F, mg[i], int(maxcon),
                                         [&](const pairs::height_field::Contact& x) {
                                           const std::int64_t j = i * maxcon + k++;
                                           d[j] = x.dist;
                                           nr[3 * j] = x.normal.x, nr[3 * j + 1] = x.normal.y, nr[3 * j + 2] = x.normal.z;
                                           p[3 * j] = x.pos.x, p[3 * j + 1] = x.pos.y, p[3 * j + 2] = x.pos.z;
                                         });
  }
}

// d dist, d normal, d pos (18 columns: pairs/derivatives.hpp's, the mesh's size columns zero), the
// DerivativeStatus and the ContactFeature (FACE, EDGE, VERTEX) of the ellipsoids and the hull posed at (CP, RP), at
// their normals (from the ellipsoid), pairs [lo, hi).
void mesh_derivatives(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& CP,
                      const Rotations<>& RP, const Centers<>& vertices, const EdgeArray& edges,
                      const Centers<>& normals, const FaceArray& faces, const Centers<>& normal,
                      const In<bool, nb::ndim<1>>& proven,
                      nb::ndarray<double, nb::shape<-1, 18>, nb::c_contig, nb::device::cpu> grad,
                      nb::ndarray<double, nb::shape<-1, 3, 18>, nb::c_contig, nb::device::cpu> jn,
                      nb::ndarray<double, nb::shape<-1, 3, 18>, nb::c_contig, nb::device::cpu> jp,
                      Out<std::int8_t> status, Out<std::int8_t> feature, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ce, Re, re);
  const auto n = static_cast<std::int64_t>(status.shape(0));
  if (lo < 0 || hi < lo || hi > n || static_cast<std::int64_t>(normal.shape(0)) != n ||
      static_cast<std::int64_t>(proven.shape(0)) != n || static_cast<std::int64_t>(grad.shape(0)) != n ||
      static_cast<std::int64_t>(jn.shape(0)) != n || static_cast<std::int64_t>(jp.shape(0)) != n ||
      static_cast<std::int64_t>(feature.shape(0)) != n)
    throw std::out_of_range("pair range outside the outputs");
  if (hi > lo && a.n != 1 && a.n < hi) throw std::out_of_range("pair range outside the ellipsoids");
  const Poses P = poses(CP, RP, lo, hi);
  const BoundHull hull(vertices, edges, normals, faces);
  const pairs::polytope::Hull& H = hull.H;
  const double* nr = normal.data();
  const bool* pr = proven.data();
  double *g = grad.data(), *jnd = jn.data(), *jpd = jp.data();
  std::int8_t *s = status.data(), *f = feature.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Ellipsoid E = load(a.C, a.R, a.r, a.n > 1 ? i : 0);
    const pairs::derivatives::Result r = pairs::derivatives::mesh_pair(
        E, P.c(i), P.rot(i), H, {nr[3 * i], nr[3 * i + 1], nr[3 * i + 2]}, pr[i], g + 18 * i, jnd + 54 * i,
        jpd + 54 * i);
    s[i] = static_cast<std::int8_t>(r.status);
    f[i] = static_cast<std::int8_t>(r.feature);
  }
}

// The hull's adjacency (polytope.hpp's build_adjacency) into adj_start (nv + 1), adj (2 ne), vface_start (nv + 1),
// vface (3 nf): the MuJoCo glue's hull table holds it (ellipsim/mujoco/attachment.py).
void hull_adjacency(const Centers<>& vertices, const EdgeArray& edges, const Centers<>& normals, const FaceArray& faces,
                    Out<std::int32_t> adj_start, Out<std::int32_t> adj, Out<std::int32_t> vface_start,
                    Out<std::int32_t> vface) {
  const BoundHull hull(vertices, edges, normals, faces);
  const pairs::polytope::Hull& H = hull.H;
  if (adj_start.shape(0) != std::size_t(H.nv + 1) || adj.shape(0) != std::size_t(2 * H.ne) ||
      vface_start.shape(0) != std::size_t(H.nv + 1) || vface.shape(0) != std::size_t(3 * H.nf))
    throw std::invalid_argument("adjacency arrays of the wrong sizes");
  std::copy(hull.adj_start.begin(), hull.adj_start.end(), adj_start.data());
  std::copy(hull.adj.begin(), hull.adj.end(), adj.data());
  std::copy(hull.vface_start.begin(), hull.vface_start.end(), vface_start.data());
  std::copy(hull.vface.begin(), hull.vface.end(), vface.data());
}

}  // namespace

void bind_meshes(nb::module_& m, nb::module_& t) {
  (void)t;
  m.def("mesh_distances", &mesh_distances, in("Ce"), in("Re"), in("re"), in("CP"), in("RP"), in("vertices"),
        in("edges"), in("normals"), in("faces"), in("dist"), in("normal"), in("pos"), in("status"), "lo"_a, "hi"_a);
  m.def("mesh_derivatives", &mesh_derivatives, in("Ce"), in("Re"), in("re"), in("CP"), in("RP"), in("vertices"),
        in("edges"), in("normals"), in("faces"), in("normal"), in("proven"), in("grad"), in("jn"), in("jp"),
        in("status"), in("feature"), "lo"_a, "hi"_a);
  m.def("hull_adjacency", &hull_adjacency, in("vertices"), in("edges"), in("normals"), in("faces"), in("adj_start"),
        in("adj"), in("vface_start"), in("vface"));
  m.def("hfield_contacts", &hfield_contacts, in("Ce"), in("Re"), in("re"), in("CF"), in("RF"), in("elevation"),
        in("size"), in("margin"), "maxcon"_a, in("count"), in("dist"), in("normal"), in("pos"), "lo"_a, "hi"_a);
}

}  // namespace ellipsim::binding
