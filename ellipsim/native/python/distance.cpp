// The bindings of the core's distance/ folder.
#include <ellipsim/distance/sphere_newton.hpp>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;

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
    const double row[19] = {n0.x,  n0.y,  n0.z,  sigma(n0, f.e, f.a2, f.M), r.n.x, r.n.y, r.n.z,
                            r.value, double(r.status), double(r.steps), rolling_radius(A.r), t.t1.x, t.t1.y,
                            t.t1.z, t.t2.x, t.t2.y, t.t2.z, u.x, u.y};
    for (int k = 0; k < 19; ++k) o[19 * i + k] = row[k];
  }
}

}  // namespace

void bind_distance(nb::module_& m, nb::module_& t) {
  (void)m;
  t.def("sphere_newton_stages", &sphere_newton_stages, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        in("out"), "lo"_a, "hi"_a);
}

}  // namespace ellipsim::binding
