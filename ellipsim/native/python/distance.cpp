// The bindings of the core's distance/ folder: the narrow phase's batch kernels (signed_distances, derivatives:
// drop-ins for ellipsoid_pair._distances and derivatives._derivatives) and, for the tests (tests/distance_stages.py
// calls them with the stages' own arguments), its stages on rows of numbers; the bench's timing loops
// (distances_serial, newton_runs: bench/common.py).
#include <ellipsim/distance/branch_and_bound.hpp>
#include <ellipsim/distance/derivatives.hpp>
#include <ellipsim/distance/ellipsoid_pair.hpp>
#include <ellipsim/distance/inner_sum.hpp>
#include <ellipsim/distance/sphere_newton.hpp>
#include <ellipsim/distance/spheroids.hpp>
#include <ellipsim/distance/status.hpp>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;

using Jacobians = nb::ndarray<double, nb::shape<-1, 3, 18>, nb::c_contig, nb::device::cpu>;
using Codes = In<std::int8_t, nb::ndim<1>>;

void same_length(std::int64_t n, std::int64_t m) {
  if (m != n) throw std::invalid_argument("the output arrays must have the same length");
}

// Signed distance, normal, contact point and status of the pairs [lo, hi) (ellipsoid_pair._distances).
void signed_distances(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                      const Rotations<>& Rb, const Centers<>& rb, std::int64_t max_iter, Out<double> dist,
                      Rows<3> normal, Rows<3> pos, Out<std::int8_t> status, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  const auto n = static_cast<std::int64_t>(dist.shape(0));
  same_length(n, static_cast<std::int64_t>(normal.shape(0)));
  same_length(n, static_cast<std::int64_t>(pos.shape(0)));
  same_length(n, static_cast<std::int64_t>(status.shape(0)));
  check_range(lo, hi, n, a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;  // stride 0 broadcasts a batch of one
  double* d = dist.data();
  double* nr = normal.data();
  double* p = pos.data();
  std::int8_t* s = status.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const distance::PairDistance r =
        distance::pair_signed_distance(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), max_iter);
    d[i] = r.dist;
    s[i] = static_cast<std::int8_t>(r.status);
    nr[3 * i] = r.normal.x, nr[3 * i + 1] = r.normal.y, nr[3 * i + 2] = r.normal.z;
    p[3 * i] = r.pos.x, p[3 * i + 1] = r.pos.y, p[3 * i + 2] = r.pos.z;
  }
}

// d dist, d normal, d pos and the DerivativeStatus of the pairs [lo, hi) at their normals (derivatives._derivatives).
void derivatives(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                 const Rotations<>& Rb, const Centers<>& rb, const Centers<>& normal, const Codes& dist_status,
                 Rows<18> grad, Jacobians jn, Jacobians jp, Out<std::int8_t> status, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  const auto n = static_cast<std::int64_t>(status.shape(0));
  same_length(n, static_cast<std::int64_t>(normal.shape(0)));
  same_length(n, static_cast<std::int64_t>(dist_status.shape(0)));
  same_length(n, static_cast<std::int64_t>(grad.shape(0)));
  same_length(n, static_cast<std::int64_t>(jn.shape(0)));
  same_length(n, static_cast<std::int64_t>(jp.shape(0)));
  check_range(lo, hi, n, a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  const double* nr = normal.data();
  const std::int8_t* ds = dist_status.data();
  double* g = grad.data();
  double* jnd = jn.data();
  double* jpd = jp.data();
  std::int8_t* s = status.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Vec3 nn = {nr[3 * i], nr[3 * i + 1], nr[3 * i + 2]};
    s[i] = static_cast<std::int8_t>(distance::pair_derivatives(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb),
                                                               nn, ds[i], g + 18 * i, jnd + 54 * i, jpd + 54 * i));
  }
}

// The stages of sphere_newton.hpp on a batch, for tests/test_native_distance.py: each row is n0 (the
// bisector seed, 3), sigma(n0), the Newton run from n0 (n 3, value, status, steps), rolling_radius(r_a),
// tangent_basis(n0) (6) and unit(e) (3): 19 columns.
void sphere_newton_stages(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                          const Rotations<>& Rb, const Centers<>& rb,
                          nb::ndarray<double, nb::shape<-1, 19>, nb::c_contig, nb::device::cpu> out, std::int64_t lo,
                          std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    using namespace ellipsim::distance;
    const Ellipsoid A = load(a.C, a.R, a.r, i * sa), B = load(b.C, b.R, b.r, i * sb);
    const AFrame f = a_frame(A, B);
    const Vec3 rb2 = {B.r.x * B.r.x, B.r.y * B.r.y, B.r.z * B.r.z};
    const Vec3 n0 = bisector_seed(f.e, f.a2, f.U, rb2);
    const double scale = std::sqrt(norm2(f.e)) + max3(A.r) + max3(B.r);
    const NewtonResult r = newton(n0, f.e, f.a2, f.M, scale, -INFINITY, tol::NEWTON_MAX_ITER);
    const TangentBasis t = tangent_basis(n0);
    const Vec3 u = unit(f.e);
    const double row[19] = {n0.x,
                            n0.y,
                            n0.z,
                            sigma(n0, f.e, f.a2, f.M),
                            r.n.x,
                            r.n.y,
                            r.n.z,
                            r.value,
                            double(r.status),
                            double(r.steps),
                            rolling_radius(A.r),
                            t.t1.x,
                            t.t1.y,
                            t.t1.z,
                            t.t2.x,
                            t.t2.y,
                            t.t2.z,
                            u.x,
                            u.y};
    for (int k = 0; k < 19; ++k) o[19 * i + k] = row[k];
  }
}

// --- the bench's timing loops (ellipsim/app/bench/common.py): one thread, no input checks beyond the lengths ---

// out[i] = the narrow phase's signed distance of pair i (pair_signed_distance's dist), for every i of out.
void distances_serial(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                      const Rotations<>& Rb, const Centers<>& rb, std::int64_t max_iter, Out<double> out) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  const auto n = static_cast<std::int64_t>(out.shape(0));
  check_range(0, n, n, a, b);
  pairwise(a, b, out.data(), 0, n, [max_iter](const Ellipsoid& A, const Ellipsoid& B) {
    return distance::pair_signed_distance(A, B, max_iter).dist;
  });
}

// out[i] = sigma after one Newton run of at most max_iter steps from the bisector seed (scale: the largest
// semi-axis): the narrow phase's first run alone, without its restart, multistart or proof.
void newton_runs(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                 const Rotations<>& Rb, const Centers<>& rb, std::int64_t max_iter, Out<double> out) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  const auto n = static_cast<std::int64_t>(out.shape(0));
  check_range(0, n, n, a, b);
  const int steps = static_cast<int>(max_iter);
  pairwise(a, b, out.data(), 0, n, [steps](const Ellipsoid& A, const Ellipsoid& B) {
    using namespace ellipsim::distance;
    const AFrame f = a_frame(A, B);
    const Vec3 rb2 = {B.r.x * B.r.x, B.r.y * B.r.y, B.r.z * B.r.z};
    const double scale = max2(max3(A.r), max3(B.r));
    const Vec3 nn = newton(bisector_seed(f.e, f.a2, f.U, rb2), f.e, f.a2, f.M, scale, -INFINITY, steps).n;
    return sigma(nn, f.e, f.a2, f.M);
  });
}

// --- the stages on rows: out[i] = f(inp[i]) for i in [lo, hi), each a row of numbers (the test packs them) ------

// A pair-level stage: out[i] = f(a[i], b[i], x[i]) for a per-pair 3-vector x (none: zeros), with the batches'
// broadcasting.
template <int KO, typename F>
void pairs_with(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                const Rotations<>& Rb, const Centers<>& rb, const Centers<>* x, Rows<KO>& out, std::int64_t lo,
                std::int64_t hi, F f) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  const auto n = static_cast<std::int64_t>(out.shape(0));
  if (x && static_cast<std::int64_t>(x->shape(0)) != n)
    throw std::invalid_argument("x and out must have the same length");
  check_range(lo, hi, n, a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  const double* xs = x ? x->data() : nullptr;
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Vec3 v = xs ? Vec3{xs[3 * i], xs[3 * i + 1], xs[3 * i + 2]} : Vec3{0.0, 0.0, 0.0};
    f(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), v, Writer{o + KO * i});
  }
}

template <int KO, typename F>
void def_pairs(nb::module_& t, const char* name, F f) {
  t.def(
      name,
      [f](const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb, const Rotations<>& Rb,
          const Centers<>& rb, const Centers<>& x, Rows<KO> out, std::int64_t lo,
          std::int64_t hi) { pairs_with<KO>(Ca, Ra, ra, Cb, Rb, rb, &x, out, lo, hi, f); },
      in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("x"), in("out"), "lo"_a, "hi"_a);
}

void write_pair(Writer& w, const distance::PairDistance& r) {
  w.f(r.status), w.f(r.dist), w.v(r.normal), w.v(r.pos), w.f(double(r.work));
}

void bind_stages(nb::module_& t) {
  using namespace ellipsim::distance;
  // sphere_newton.hpp's stages, each on its own arguments (tests/test_sphere_newton.py)
  // sphere_newton_a_frame: A (c, R (9), r), B (c, R (9), r) -> e, a2, M (9), U (9)
  def_rows<30, 24>(t, "sphere_newton_a_frame", [](Reader r, Writer w) {
    const Vec3 ca = r.v();
    const Mat3 Ra = r.m();
    const Vec3 ra = r.v(), cb = r.v();
    const Mat3 Rb = r.m();
    const AFrame f = a_frame({ca, Ra, ra}, {cb, Rb, r.v()});
    w.v(f.e), w.v(f.a2);
    for (int k = 0; k < 9; ++k) w.f(f.M.m[k]);
    for (int k = 0; k < 9; ++k) w.f(f.U.m[k]);
  });
  // sphere_newton_sigma: n, e, a2, M (9) -> sigma
  def_rows<18, 1>(t, "sphere_newton_sigma", [](Reader r, Writer w) {
    const Vec3 n = r.v(), e = r.v(), a2 = r.v();
    w.f(sigma(n, e, a2, r.m()));
  });
  // sphere_newton_unit: v -> unit(v)
  def_rows<3, 3>(t, "sphere_newton_unit", [](Reader r, Writer w) { w.v(unit(r.v())); });
  // sphere_newton_tangent_basis: n -> t1, t2
  def_rows<3, 6>(t, "sphere_newton_tangent_basis", [](Reader r, Writer w) {
    const TangentBasis b = tangent_basis(r.v());
    w.v(b.t1), w.v(b.t2);
  });
  // sphere_newton_newton: n, e, a2, M (9), scale, target, max_iter -> n (3), value, status, steps
  def_rows<21, 6>(t, "sphere_newton_newton", [](Reader r, Writer w) {
    const Vec3 n = r.v(), e = r.v(), a2 = r.v();
    const Mat3 M = r.m();
    const double scale = r.f(), target = r.f();
    const NewtonResult x = newton(n, e, a2, M, scale, target, r.i());
    w.v(x.n), w.f(x.value), w.f(x.status), w.f(x.steps);
  });
  // sphere_newton_bisector_seed: e, a2, U (9), rb2 -> seed
  def_rows<18, 3>(t, "sphere_newton_bisector_seed", [](Reader r, Writer w) {
    const Vec3 e = r.v(), a2 = r.v();
    const Mat3 U = r.m();
    w.v(bisector_seed(e, a2, U, r.v()));
  });
  // sphere_newton_rolling_radius: r -> rolling_radius(r)
  def_rows<3, 1>(t, "sphere_newton_rolling_radius", [](Reader r, Writer w) { w.f(rolling_radius(r.v())); });
  // inner_sum_bound: n, e, a, Ub (9), b, value -> bound
  def_rows<22, 1>(t, "inner_sum_bound", [](Reader r, Writer w) {
    const Vec3 n = r.v(), e = r.v(), a = r.v();
    const Mat3 Ub = r.m();
    const Vec3 b = r.v();
    w.f(inner_sum_bound(n, e, a, Ub, b, r.f()));
  });
  // sigma_grad and sigma_only: c, e, a, U (9), b -> s, G (3), ha, hb, sigma_only
  def_rows<21, 7>(t, "sigma_grad", [](Reader r, Writer w) {
    const Vec3 c = r.v(), e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const SigmaGrad g = sigma_grad(c, e, a, U, b);
    w.f(g.s), w.v(g.G), w.f(g.ha), w.f(g.hb), w.f(sigma_only(c, e, a, U, b));
  });
  // patch_point and patch_cap: face, level, i, j, Q (9) -> p (3), inv, pc, rho, cap centre (3), cap rho
  def_rows<13, 10>(t, "patch_point", [](Reader r, Writer w) {
    const int face = r.i(), level = r.i();
    const auto i = static_cast<std::int64_t>(r.f()), j = static_cast<std::int64_t>(r.f());
    const Mat3 Q = r.m();
    const PatchPoint p = patch_point(face, level, i, j, Q);
    const PatchCap c = patch_cap(face, level, i, j, Q);
    w.v(p.p), w.f(p.inv), w.f(p.pc), w.f(p.rho), w.v(c.c), w.f(c.rho);
  });
  // certify_region: m, e, a, U (9), b, amax, bmax, S, err_sigma, tol -> ok, m (3), value, region (22)
  def_rows<26, 27>(t, "certify_region", [](Reader r, Writer w) {
    const Vec3 m = r.v(), e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const double amax = r.f(), bmax = r.f(), S = r.f(), err_sigma = r.f(), tol = r.f();
    const Certified c = certify_region_call(m, e, a, U, b, amax, bmax, S, err_sigma, tol);
    w.f(c.ok), w.v(c.m), w.f(c.value);
    for (int k = 0; k < branch_and_bound::REGION_SIZE; ++k) w.f(c.region.d[k]);
  });
  // in_region: c, rho, region (22) -> inside
  def_rows<26, 1>(t, "in_region", [](Reader r, Writer w) {
    const Vec3 c = r.v();
    const double rho = r.f();
    Region d;
    for (int k = 0; k < branch_and_bound::REGION_SIZE; ++k) d.d[k] = r.f();
    w.f(in_region(c, rho, d));
  });
  // climb: c, e, a, M (9), scale -> converged, m (3), value
  def_rows<19, 5>(t, "climb", [](Reader r, Writer w) {
    const Vec3 c = r.v(), e = r.v(), a = r.v();
    const Mat3 M = r.m();
    const Climb cl = climb(c, e, a, M, r.f());
    w.f(cl.converged), w.v(cl.m), w.f(cl.value);
  });
  // global_max: n0, v0, have0, e, a, U (9), b, M (9), scale, tol, max_patches -> status, n (3), value, count, runs
  def_rows<35, 7>(t, "global_max", [](Reader r, Writer w) {
    const Vec3 n0 = r.v();
    const double v0 = r.f();
    const bool have0 = r.b();
    const Vec3 e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const Mat3 M = r.m();
    const double scale = r.f(), tol = r.f();
    const auto max_patches = static_cast<std::int64_t>(r.f());
    const GlobalMax g = global_max(n0, v0, have0, e, a, U, b, M, scale, tol, max_patches);
    w.f(g.status), w.v(g.n), w.f(g.value), w.f(double(g.count)), w.f(g.runs);
  });
  // parallel_max: e, a, U (9), b, tol, S -> proven, n (3), nodes
  def_rows<20, 5>(t, "parallel_max", [](Reader r, Writer w) {
    const Vec3 e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const double tol = r.f(), S = r.f();
    const SpheroidMax p = parallel_max(e, a, U, b, tol, S);
    w.f(p.proven), w.v(p.n), w.f(double(p.nodes));
  });
  // tilted_max: e, a, U (9), b, tol, S, n0 -> proven, n (3), nodes
  def_rows<23, 5>(t, "tilted_max", [](Reader r, Writer w) {
    const Vec3 e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const double tol = r.f(), S = r.f();
    const SpheroidMax p = tilted_max(e, a, U, b, tol, S, r.v());
    w.f(p.proven), w.v(p.n), w.f(double(p.nodes));
  });
  // ring_max: e, a, U (9), b, tol, S, n0 -> proven, n (3), nodes
  def_rows<23, 5>(t, "ring_max", [](Reader r, Writer w) {
    const Vec3 e = r.v(), a = r.v();
    const Mat3 U = r.m();
    const Vec3 b = r.v();
    const double tol = r.f(), S = r.f();
    const SpheroidMax p = ring_max(e, a, U, b, tol, S, r.v());
    w.f(p.proven), w.v(p.n), w.f(double(p.nodes));
  });
  // axis_bb: ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, tol1, S, curv, t0, p0 -> proven, t, p, moved, nodes
  def_rows<16, 5>(t, "axis_bb", [](Reader r, Writer w) {
    const double ek = r.f(), ex = r.f(), ey = r.f();
    const int hk = r.i();
    double x[12];
    for (double& v : x) v = r.f();
    const AxisBB p = axis_bb(ek, ex, ey, hk, x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10], x[11]);
    w.f(p.proven), w.f(p.t), w.f(p.p), w.f(p.moved), w.f(double(p.nodes));
  });
  // pair_signed_distance_from: the pairs and a seed each -> status, dist, normal (3), pos (3), work
  def_pairs<9>(t, "pair_signed_distance_from", [](const Ellipsoid& A, const Ellipsoid& B, const Vec3& seed, Writer w) {
    write_pair(w, pair_signed_distance_from(A, B, seed));
  });
  // pair_signed_distance: the pairs, max_iter -> status, dist, normal (3), pos (3), work
  t.def(
      "pair_signed_distance",
      [](const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb, const Rotations<>& Rb,
         const Centers<>& rb, std::int64_t max_iter, Rows<9> out, std::int64_t lo, std::int64_t hi) {
        pairs_with<9>(Ca, Ra, ra, Cb, Rb, rb, nullptr, out, lo, hi,
                      [max_iter](const Ellipsoid& A, const Ellipsoid& B, const Vec3&, Writer w) {
                        write_pair(w, pair_signed_distance(A, B, max_iter));
                      });
      },
      in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), "max_iter"_a, in("out"), "lo"_a, "hi"_a);
  // contact_at: the pairs and a direction each -> sigma, normal (3), pos (3)
  def_pairs<7>(t, "contact_at", [](const Ellipsoid& A, const Ellipsoid& B, const Vec3& n, Writer w) {
    const ContactAt c = contact_at(A, B, n);
    w.f(c.value), w.v(c.normal), w.v(c.pos);
  });
  // sigma_lower_bound: the pairs and a direction each -> bound
  def_pairs<1>(t, "sigma_lower_bound", [](const Ellipsoid& A, const Ellipsoid& B, const Vec3& n, Writer w) {
    w.f(sigma_lower_bound(A, B, n));
  });
  // branch_and_bound's RHO_TABLE (rho_table.hpp), and the status codes (status.hpp) by name
  t.def("rho_table", []() {
    std::vector<double> v(branch_and_bound::RHO_TABLE, branch_and_bound::RHO_TABLE + branch_and_bound::RHO_TABLE_SIZE);
    return v;
  });
  nb::dict codes;
  codes["DistanceStatus.GLOBAL"] = int(DistanceStatus::GLOBAL);
  codes["DistanceStatus.UNPROVEN"] = int(DistanceStatus::UNPROVEN);
  codes["DerivativeStatus.SMOOTH"] = int(DerivativeStatus::SMOOTH);
  codes["DerivativeStatus.BRANCH"] = int(DerivativeStatus::BRANCH);
  codes["DerivativeStatus.FLAT"] = int(DerivativeStatus::FLAT);
  codes["DerivativeStatus.UNPROVEN"] = int(DerivativeStatus::UNPROVEN);
  codes["DerivativeStatus.ONE_SIDED"] = int(DerivativeStatus::ONE_SIDED);
  codes["ContactFeature.FACE"] = int(ContactFeature::FACE);
  codes["ContactFeature.EDGE"] = int(ContactFeature::EDGE);
  codes["ContactFeature.VERTEX"] = int(ContactFeature::VERTEX);
  codes["ContactFeature.SIDE"] = int(ContactFeature::SIDE);
  codes["ContactFeature.END"] = int(ContactFeature::END);
  codes["ContactFeature.CAP"] = int(ContactFeature::CAP);
  codes["ContactFeature.RIM"] = int(ContactFeature::RIM);
  codes["ellipsoid_pair.GLOBAL"] = ellipsoid_pair::GLOBAL;
  codes["ellipsoid_pair.UNPROVEN"] = ellipsoid_pair::UNPROVEN;
  codes["branch_and_bound.GLOBAL"] = branch_and_bound::GLOBAL;
  codes["branch_and_bound.UNPROVEN"] = branch_and_bound::UNPROVEN;
  codes["branch_and_bound.SEPARATED_MAX"] = branch_and_bound::SEPARATED_MAX;
  codes["derivatives.SMOOTH"] = derivatives::SMOOTH;
  codes["derivatives.BRANCH"] = derivatives::BRANCH;
  codes["derivatives.FLAT"] = derivatives::FLAT;
  codes["derivatives.UNPROVEN"] = derivatives::UNPROVEN;
  t.attr("DISTANCE_CODES") = codes;
  nb::dict constants;  // the folder's own constants that the tests read (not in tolerances.hpp)
  constants["sphere_newton.CONVERGED"] = CONVERGED;
  constants["sphere_newton.NOT_CONVERGED"] = NOT_CONVERGED;
  constants["sphere_newton.ABANDONED"] = ABANDONED;
  constants["branch_and_bound.RHO_LEVELS"] = branch_and_bound::RHO_LEVELS;
  constants["spheroids.ERR_C_ULPS"] = spheroids::ERR_C_ULPS;
  t.attr("DISTANCE_CONSTANTS") = constants;
}

}  // namespace

void bind_distance(nb::module_& m, nb::module_& t) {
  m.def("signed_distances", &signed_distances, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), "max_iter"_a,
        in("dist"), in("normal"), in("pos"), in("status"), "lo"_a, "hi"_a);
  m.def("derivatives", &derivatives, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("normal"),
        in("dist_status"), in("grad"), in("jn"), in("jp"), in("status"), "lo"_a, "hi"_a);
  t.def("distances_serial", &distances_serial, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        "max_iter"_a, in("out"));
  t.def("newton_runs", &newton_runs, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), "max_iter"_a,
        in("out"));
  t.def("sphere_newton_stages", &sphere_newton_stages, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        in("out"), "lo"_a, "hi"_a);
  bind_stages(t);
}

}  // namespace ellipsim::binding
