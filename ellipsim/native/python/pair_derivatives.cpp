// The bindings of pairs/derivatives.hpp: shape_derivatives, a drop-in for the numba kernel of
// ellipsim/core/pairs/derivatives.py (same arguments, same outputs: threads.run can cut it into chunks), and, for
// tests/test_native_pair_derivatives.py, its stages on rows of numbers.
#include <ellipsim/pairs/derivatives.hpp>

#include <utility>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;
namespace pd = ellipsim::pairs::derivatives;

using Jacobians = nb::ndarray<double, nb::shape<-1, 3, 18>, nb::c_contig, nb::device::cpu>;

void same_length(std::int64_t n, std::int64_t m) {
  if (m != n) throw std::invalid_argument("the output arrays must have the same length");
}

// d dist, d normal, d pos, the DerivativeStatus and the ContactFeature of the pairs [lo, hi) at their normals
// (derivatives.shape_derivatives): E a batch of ellipsoids, K one of capsules, boxes or cylinders (kind 0, 1, 2).
void shape_derivatives(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                       const Rotations<>& Rk, const Centers<>& sk, int kind, const Centers<>& normal,
                       const In<bool, nb::ndim<1>>& proven, Rows<18> grad, Jacobians jn, Jacobians jp,
                       Out<std::int8_t> status, Out<std::int8_t> feature, std::int64_t lo, std::int64_t hi) {
  if (kind != pd::CAPSULE && kind != pd::BOX && kind != pd::CYLINDER)
    throw std::invalid_argument("kind must be 0 (capsule), 1 (box) or 2 (cylinder)");
  const auto a = batch(Ce, Re, re), b = batch(Ck, Rk, sk);
  const auto n = static_cast<std::int64_t>(status.shape(0));
  same_length(n, static_cast<std::int64_t>(normal.shape(0)));
  same_length(n, static_cast<std::int64_t>(proven.shape(0)));
  same_length(n, static_cast<std::int64_t>(grad.shape(0)));
  same_length(n, static_cast<std::int64_t>(jn.shape(0)));
  same_length(n, static_cast<std::int64_t>(jp.shape(0)));
  same_length(n, static_cast<std::int64_t>(feature.shape(0)));
  check_range(lo, hi, n, a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;  // stride 0 broadcasts a batch of one
  const double* nr = normal.data();
  const bool* pr = proven.data();
  double* g = grad.data();
  double* jnd = jn.data();
  double* jpd = jp.data();
  std::int8_t* s = status.data();
  std::int8_t* f = feature.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const Vec3 nn = {nr[3 * i], nr[3 * i + 1], nr[3 * i + 2]};
    const pd::Result r = pd::pair(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), kind, nn, pr[i],
                                  g + 18 * i, jnd + 54 * i, jpd + 54 * i);
    s[i] = static_cast<std::int8_t>(r.status);
    f[i] = static_cast<std::int8_t>(r.feature);
  }
}

void put(double*& o, double x) { *o++ = x; }
void put(double*& o, const Vec3& v) { put(o, v.x), put(o, v.y), put(o, v.z); }
Vec3 vec(const double*& p) {
  const Vec3 v = {p[0], p[1], p[2]};
  p += 3;
  return v;
}

// The stages on a row x = (kind, n (3), V (9: v0, v1, v2), sk (3), dw (3), Re (9), re (3), r1, r2): 33 columns;
// out = stratum(kind, n, V, sk) (f, k, g0, g1, w, rho, pt, u, bound0, bound1: 18), local(n, dw, Re, re, and the
// stratum's rho, pt, u, g0, k) (s, grad, h, g, z, J (9), H (9), t1, t2, R (3): 38), top(R, k), reduced_solve(R, k,
// r1, r2) (2), pnorm(n, pt, u) (4), unit(dw) (3), axpy(r1, n, dw) (3): 69 columns.
void pair_derivative_stages(const InRows<33>& x, Rows<69> out, std::int64_t lo, std::int64_t hi) {
  const auto n = static_cast<std::int64_t>(out.shape(0));
  if (lo < 0 || hi < lo || hi > n || hi > static_cast<std::int64_t>(x.shape(0)))
    throw std::out_of_range("row range outside the arrays");
  const double* in = x.data();
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const double* p = in + 33 * i;
    double* w = o + 69 * i;
    const int kind = static_cast<int>(*p++);
    const Vec3 nv = vec(p);
    pd::Axes V;
    for (Vec3& v : V.v) v = vec(p);
    const Vec3 sk = vec(p), dw = vec(p);
    Mat3 Re;
    for (double& m : Re.m) m = *p++;
    const Vec3 re = vec(p);
    const double r1 = p[0], r2 = p[1];
    const pd::Stratum st = pd::stratum(kind, nv, V, sk);
    put(w, double(st.f)), put(w, double(st.k)), put(w, st.g0), put(w, st.g1), put(w, st.w), put(w, st.rho);
    put(w, double(st.pt)), put(w, st.u), put(w, st.bound0), put(w, st.bound1);
    const pd::Local L = pd::local(nv, dw, Re, re, st.rho, st.pt, st.u, st.g0, st.k);
    put(w, L.s), put(w, L.grad), put(w, L.h), put(w, L.g), put(w, L.z);
    for (double m : L.J.m) put(w, m);
    for (double m : L.H.m) put(w, m);
    put(w, L.t1), put(w, L.t2), put(w, L.R.h11), put(w, L.R.h12), put(w, L.R.h22);
    put(w, pd::top(L.R, st.k));
    const pd::Step a = pd::reduced_solve(L.R, st.k, r1, r2);
    put(w, a.a1), put(w, a.a2);
    const pd::PNorm q = pd::pnorm(nv, st.pt, st.u);
    put(w, q.npn), put(w, q.Pn), put(w, pd::unit(dw)), put(w, pd::axpy(r1, nv, dw));
  }
}

}  // namespace

void bind_pair_derivatives(nb::module_& m, nb::module_& t) {
  m.def("shape_derivatives", &shape_derivatives, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), "kind"_a,
        in("normal"), in("proven"), in("grad"), in("jn"), in("jp"), in("status"), in("feature"), "lo"_a, "hi"_a);
  t.def("pair_derivative_stages", &pair_derivative_stages, in("x"), in("out"), "lo"_a, "hi"_a);
  nb::dict codes;  // the kernel's codes (tests: the same as pairs/derivatives.py's)
  const std::pair<const char*, int> named[] = {
      {"ONE_SIDED", pd::ONE_SIDED}, {"FACE", pd::FACE}, {"EDGE", pd::EDGE},       {"VERTEX", pd::VERTEX},
      {"SIDE", pd::SIDE},           {"END", pd::END},   {"CAP", pd::CAP},         {"RIM", pd::RIM},
      {"CAPSULE", pd::CAPSULE},     {"BOX", pd::BOX},   {"CYLINDER", pd::CYLINDER}};
  for (const auto& [name, code] : named) codes[name] = code;
  t.attr("PAIR_DERIVATIVE_CODES") = codes;
}

}  // namespace ellipsim::binding
