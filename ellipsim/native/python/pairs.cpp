// The bindings of the core's pairs/ folder: the capsule and box kernels and the stages of
// pairs/{point_ellipsoid,tangent_cones,capsule,box}.hpp the tests call (test_capsule.py, test_box.py,
// test_point_ellipsoid.py, test_tangent_cones.py, test_native_pairs.py), in the testing submodule.
#include <ellipsim/pairs/box.hpp>
#include <ellipsim/pairs/capsule.hpp>
#include <ellipsim/pairs/point_ellipsoid.hpp>
#include <ellipsim/pairs/polytope.hpp>
#include <ellipsim/pairs/tangent_cones.hpp>

#include "common.hpp"
#include "hull.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;


// out[i, :K] = f(E_i, K_i) for the ellipsoids E and the capsules or boxes K (centres, rotations, sizes as
// MuJoCo's geoms) of pairs [lo, hi), with the GIL released.
template <int K, typename F>
void pair_rows(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
               const Rotations<>& Rk, const Centers<>& sk, Rows<K>& out, std::int64_t lo, std::int64_t hi, F f) {
  const auto a = batch(Ce, Re, re), b = batch(Ck, Rk, sk);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) f(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), o + K * i);
}

// out[i, :K] = f(x[i, :N]) for the rows [lo, hi) of one input per row.
template <int N, int K, typename F>
void rows(const InRows<N>& x, Rows<K>& out, std::int64_t lo, std::int64_t hi, F f) {
  const auto n = static_cast<std::int64_t>(out.shape(0));
  if (lo < 0 || hi < lo || hi > n || hi > static_cast<std::int64_t>(x.shape(0)))
    throw std::out_of_range("row range outside the arrays");
  const double* in = x.data();
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) f(in + N * i, o + K * i);
}

ELLIPSIM_HD Vec3 vec(const double* x) { return {x[0], x[1], x[2]}; }

ELLIPSIM_HD void put(double* o, const Vec3& v) {
  o[0] = v.x;
  o[1] = v.y;
  o[2] = v.z;
}

// capsule_ellipsoid's result: status, dist, normal (3), pos (3), ub: 9 columns.
void capsule_ellipsoid(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                       const Rotations<>& Rk, const Centers<>& sk, Rows<9> out, std::int64_t lo, std::int64_t hi) {
  pair_rows<9>(Ce, Re, re, Ck, Rk, sk, out, lo, hi, [](const Ellipsoid& E, const Ellipsoid& K, double* o) {
    const pairs::capsule::Result r = pairs::capsule::capsule_ellipsoid(E, K);
    o[0] = double(r.status);
    o[1] = r.dist;
    put(o + 2, r.normal);
    put(o + 5, r.pos);
    o[8] = r.ub;
  });
}

// box_ellipsoid's result, as capsule_ellipsoid: 9 columns.
void box_ellipsoid(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                   const Rotations<>& Rk, const Centers<>& sk, Rows<9> out, std::int64_t lo, std::int64_t hi) {
  pair_rows<9>(Ce, Re, re, Ck, Rk, sk, out, lo, hi, [](const Ellipsoid& E, const Ellipsoid& K, double* o) {
    const pairs::box::Result r = pairs::box::box_ellipsoid(E, K);
    o[0] = double(r.status);
    o[1] = r.dist;
    put(o + 2, r.normal);
    put(o + 5, r.pos);
    o[8] = r.ub;
  });
}

// The stages of capsule.hpp on a pair, at the centre line's direction n = unit(e) (the local solve is
// checked through capsule_ellipsoid): e, a2, u (9), n (3), sigma there, upper_bound1, upper_bound2,
// enumerate_max from (sigma, n) and from (-inf, e_x) (value, n: 8), centre_line_bound: 24 columns.
void capsule_stages(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                    const Rotations<>& Rk, const Centers<>& sk, Rows<24> out, std::int64_t lo, std::int64_t hi) {
  pair_rows<24>(Ce, Re, re, Ck, Rk, sk, out, lo, hi, [](const Ellipsoid& E, const Ellipsoid& K, double* o) {
    using namespace pairs::capsule;
    const Frame f = to_frame(E, K);
    const double r = K.r.x, L = K.r.y;
    const double rho = rolling_radius(E.r);
    const double tol = ellipsim::tol::PAIR_CERT_REL * min2(min2(min2(E.r.x, E.r.y), E.r.z), r);
    const Vec3 n = unit(f.e);
    const double value = sigma_capsule(f.a2, f.e, f.u, L, r, n);
    const Best b1 = enumerate_max(f.a2, f.e, f.u, L, r, value, n, tol);
    const Best b2 = enumerate_max(f.a2, f.e, f.u, L, r, -INFINITY, {1.0, 0.0, 0.0}, tol);
    put(o, f.e);
    put(o + 3, f.a2);
    put(o + 6, f.u);
    put(o + 9, n);
    o[12] = value;
    o[13] = upper_bound1(f.a2, f.e, f.u, L, r, rho, n);
    o[14] = upper_bound2(f.a2, f.e, f.u, L, r, n, value);
    o[15] = b1.value;
    put(o + 16, b1.n);
    o[19] = b2.value;
    put(o + 20, b2.n);
    o[23] = centre_line_bound(E, K);
  });
}

// The stages of box.hpp on a pair, at the centre line's direction n = unit(e) (the local solve is checked
// through box_ellipsoid): e, a2, V (15), face_normal (9), edge_plane (18), face_cosines (3), n (3), sigma there,
// upper_bound1, upper_bound2, enumerate_max from (sigma, n) and from (-inf, e_x) (value, n: 8), sd_point_box(e),
// centre_line_bound: 61 columns.
void box_stages(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                const Rotations<>& Rk, const Centers<>& sk, Rows<61> out, std::int64_t lo, std::int64_t hi) {
  pair_rows<61>(Ce, Re, re, Ck, Rk, sk, out, lo, hi, [](const Ellipsoid& E, const Ellipsoid& K, double* o) {
    using namespace pairs::box;
    const Frame f = to_frame(E, K);
    const Vec3& r = K.r;
    const double rho = rolling_radius(E.r);
    const double tol = ellipsim::tol::PAIR_CERT_REL * min2(min2(min2(min2(min2(E.r.x, E.r.y), E.r.z), r.x), r.y), r.z);
    const Vec3 n = unit(f.e);
    const double value = sigma_box(f.a2, f.e, f.V, r, n);
    const Best b1 = enumerate_max(f.a2, f.e, f.V, r, value, n, tol);
    const Best b2 = enumerate_max(f.a2, f.e, f.V, r, -INFINITY, {1.0, 0.0, 0.0}, tol);
    put(o, f.e);
    put(o + 3, f.a2);
    for (int j = 0; j < 3; ++j) {
      put(o + 6 + 3 * j, f.V.v[j]);
      put(o + 15 + 3 * j, face_normal(f.V, j));
      const Plane p = edge_plane(f.V, j);
      put(o + 24 + 6 * j, p.b1);
      put(o + 27 + 6 * j, p.b2);
    }
    put(o + 42, face_cosines(f.V));
    put(o + 45, n);
    o[48] = value;
    o[49] = upper_bound1(f.a2, f.e, f.V, r, rho, n);
    o[50] = upper_bound2(f.a2, f.e, f.V, r, n, value);
    o[51] = b1.value;
    put(o + 52, b1.n);
    o[55] = b2.value;
    put(o + 56, b2.n);
    o[59] = sd_point_box(f.e, f.V, r);
    o[60] = centre_line_bound(E, K);
  });
}

// The stages of point_ellipsoid.hpp on x = (a2 (3), q (3), w1 (3), w2 (3), t): foot3 (t, n), sd_upper at foot3's
// t and at x's t, support(a2, w1) (h, s), secular_roots(a2, q) with and without the largest (6), pole_normal
// for i = 0, 1, 2 and sign +1, -1 (ok, n: 24), foot2 of (a2_0, a2_1) and (q_0, q_1) (t, n0, n1), sd_upper2 at
// foot2's t and at x's t, project_ellipse(a2, w1, w2) (lam, mu, c, s), from_plane(foot2's n, c, s, w1, w2),
// circle_max_bound(a2, q, w1, w2) (n, ub): 56 columns.
void point_ellipsoid_stages(const InRows<13>& x, Rows<56> out, std::int64_t lo, std::int64_t hi) {
  rows<13, 56>(x, out, lo, hi, [](const double* in, double* o) {
    using namespace pairs::point_ellipsoid;
    const Vec3 a2 = vec(in), q = vec(in + 3), w1 = vec(in + 6), w2 = vec(in + 9);
    const double t = in[12];
    const Foot3 f3 = foot3(a2, q);
    o[0] = f3.t;
    put(o + 1, f3.n);
    o[4] = sd_upper(a2, q, f3.t);
    o[5] = sd_upper(a2, q, t);
    const Support s = support(a2, w1);
    o[6] = s.h;
    put(o + 7, s.s);
    const Roots r1 = secular_roots(a2, q, true), r2 = secular_roots(a2, q, false);
    for (int k = 0; k < 3; ++k) {
      o[10 + k] = r1.t[k];
      o[13 + k] = r2.t[k];
    }
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 2; ++k) {
        const PoleNormal p = pole_normal(a2, q, i, k == 0 ? 1.0 : -1.0);
        double* row = o + 16 + 8 * i + 4 * k;
        row[0] = p.ok ? 1.0 : 0.0;
        put(row + 1, p.n);
      }
    }
    const Foot2 f2 = foot2(a2.x, a2.y, q.x, q.y);
    o[40] = f2.t;
    o[41] = f2.n0;
    o[42] = f2.n1;
    o[43] = sd_upper2(a2.x, a2.y, q.x, q.y, f2.t);
    o[44] = sd_upper2(a2.x, a2.y, q.x, q.y, t);
    const Ellipse el = project_ellipse(a2, w1, w2);
    o[45] = el.lam;
    o[46] = el.mu;
    o[47] = el.c;
    o[48] = el.s;
    put(o + 49, from_plane(f2.n0, f2.n1, el.c, el.s, w1, w2));
    const CircleMax cm = circle_max_bound(a2, q, w1, w2);
    put(o + 52, cm.n);
    o[55] = cm.ub;
  });
}

// The stages of tangent_cones.hpp on x = (a2, q, u (3 each), r, bn, a, b, c (3 each), floor, rho): xb =
// tangent_point(a2, u, r, bn) (3), cone_below(a2, q, u, r, bn, xb, a, b, c, floor, rho), arc_below on (a, b),
// (b, c) and (c, a): 7 columns (1.0 for true).
void tangent_cones_stages(const InRows<24>& x, Rows<7> out, std::int64_t lo, std::int64_t hi) {
  rows<24, 7>(x, out, lo, hi, [](const double* in, double* o) {
    using namespace pairs::tangent_cones;
    const Vec3 a2 = vec(in), q = vec(in + 3), u = vec(in + 6);
    const double r = in[9];
    const Vec3 bn = vec(in + 10), a = vec(in + 13), b = vec(in + 16), c = vec(in + 19);
    const double floor = in[22];
    const Vec3 xb = tangent_point(a2, u, r, bn);
    put(o, xb);
    o[3] = cone_below(a2, q, u, r, bn, xb, a, b, c, floor, in[23]) ? 1.0 : 0.0;
    o[4] = arc_below(a2, q, u, r, bn, xb, a, b, floor) ? 1.0 : 0.0;
    o[5] = arc_below(a2, q, u, r, bn, xb, b, c, floor) ? 1.0 : 0.0;
    o[6] = arc_below(a2, q, u, r, bn, xb, c, a, floor) ? 1.0 : 0.0;
  });
}

// box.hpp's local_max and vertex_q on x = (a2, e, V (9: v0, v1, v2), r, s (3 each)): local_max(a2, e, V, r) (3),
// vertex_q(e, V, r, s0, s1, s2) (3): 6 columns (tests/test_tangent_cones.py's octants).
void box_vertex_stages(const InRows<21>& x, Rows<6> out, std::int64_t lo, std::int64_t hi) {
  rows<21, 6>(x, out, lo, hi, [](const double* in, double* o) {
    using namespace pairs::box;
    const Vec3 a2 = vec(in), e = vec(in + 3);
    const Axes V = {{vec(in + 6), vec(in + 9), vec(in + 12)}};
    const Vec3 r = vec(in + 15);
    put(o, local_max(a2, e, V, r));
    put(o + 3, vertex_q(e, V, r, in[18], in[19], in[20]));
  });
}

// polytope_ellipsoid for the ellipsoids E and one hull (vertices (nv, 3), edges (ne, 2), face normals (nf, 3),
// triangles (nf, 3), its local frame) posed at (CP, RP) per pair, pairs [lo, hi): status, dist, normal (3), pos
// (3), ub per row; cutoff polytope_ellipsoid's (a pair proven beyond it: APART); posed: polytope_ellipsoid_posed
// instead (the hull never stored, as MuJoCo Warp's mesh row runs a large hull).
void polytope_ellipsoid(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& CP,
                        const Rotations<>& RP, const Centers<>& vertices, const EdgeArray& edges,
                        const Centers<>& normals, const FaceArray& faces, Rows<9> out,
                        std::int64_t lo, std::int64_t hi, double cutoff, bool posed) {
  const auto a = batch(Ce, Re, re);
  const auto n = static_cast<std::int64_t>(out.shape(0));
  if (lo < 0 || hi < lo || hi > n || hi > a.n || hi > static_cast<std::int64_t>(CP.shape(0)) ||
      static_cast<std::int64_t>(RP.shape(0)) != static_cast<std::int64_t>(CP.shape(0)))
    throw std::out_of_range("pair range outside the arrays");
  const BoundHull hull(vertices, edges, normals, faces);
  const pairs::polytope::Hull& H = hull.H;
  std::vector<double> scratch = hull.scratch();
  std::vector<unsigned char> flags(pairs::polytope::posed_flags_size(H.nv));
  double* o = out.data();
  const double *C = CP.data(), *R = RP.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Ellipsoid E = load(a.C, a.R, a.r, i);
    const Mat3 Rp = {{R[9 * i], R[9 * i + 1], R[9 * i + 2], R[9 * i + 3], R[9 * i + 4], R[9 * i + 5], R[9 * i + 6],
                      R[9 * i + 7], R[9 * i + 8]}};
    const Vec3 c = {C[3 * i], C[3 * i + 1], C[3 * i + 2]};
    const pairs::polytope::Result r =
        posed ? pairs::polytope::polytope_ellipsoid_posed(E, c, Rp, H, flags.data(), cutoff)
              : pairs::polytope::polytope_ellipsoid(E, c, Rp, H, scratch.data(), cutoff);
    double* row = o + 9 * i;
    row[0] = double(r.status);
    row[1] = r.dist;
    put(row + 2, r.normal);
    put(row + 5, r.pos);
    row[8] = r.ub;
  }
}

}  // namespace

void bind_pairs(nb::module_& m, nb::module_& t) {
  (void)m;
  t.def("capsule_ellipsoid", &capsule_ellipsoid, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), in("out"),
        "lo"_a, "hi"_a);
  t.def("box_ellipsoid", &box_ellipsoid, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), in("out"), "lo"_a,
        "hi"_a);
  t.def("polytope_ellipsoid", &polytope_ellipsoid, in("Ce"), in("Re"), in("re"), in("CP"), in("RP"), in("vertices"),
        in("edges"), in("normals"), in("faces"), in("out"), "lo"_a, "hi"_a, "cutoff"_a = INFINITY, "posed"_a = false);
  t.def("capsule_stages", &capsule_stages, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), in("out"),
        "lo"_a, "hi"_a);
  t.def("box_stages", &box_stages, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), in("out"), "lo"_a,
        "hi"_a);
  t.def("point_ellipsoid_stages", &point_ellipsoid_stages, in("x"), in("out"), "lo"_a, "hi"_a);
  t.def("tangent_cones_stages", &tangent_cones_stages, in("x"), in("out"), "lo"_a, "hi"_a);
  t.def("box_vertex_stages", &box_vertex_stages, in("x"), in("out"), "lo"_a, "hi"_a);
  // The statuses of capsule.hpp and box.hpp by name (the same as capsule.py's and box.py's), and box.hpp's NO_AXIS.
  nb::dict capsule, box;
  capsule["CERTIFIED"] = pairs::capsule::CERTIFIED, capsule["ENUMERATED"] = pairs::capsule::ENUMERATED;
  box["CERTIFIED"] = pairs::box::CERTIFIED, box["ENUMERATED"] = pairs::box::ENUMERATED;
  const Vec3 no_axis = pairs::box::no_axis();
  box["NO_AXIS"] = nb::make_tuple(no_axis.x, no_axis.y, no_axis.z);
  t.attr("CAPSULE_CONSTANTS") = capsule;
  t.attr("BOX_CONSTANTS") = box;
}

}  // namespace ellipsim::binding
