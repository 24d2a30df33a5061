// What every binding file of _ellipsim shares: the array types it takes, a batch of ellipsoids as the
// kernels read it, the range check and the pairwise loop.  The binding is thin by design: the Python layer
// (ellipsim/core) checks every input and owns every error message; a kernel here takes C-contiguous
// arrays already validated, writes pairs [lo, hi) of its output and releases the GIL while it runs, so
// that ellipsim.core.threads.run can cut a batch into chunks on its own threads.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <ellipsim/vec3.hpp>

namespace ellipsim::binding {

namespace nb = nanobind;

template <typename T, typename Shape>
using In = nb::ndarray<const T, Shape, nb::c_contig, nb::device::cpu>;
template <typename T>
using Out = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <typename T = double>
using Centers = In<T, nb::shape<-1, 3>>;
template <typename T = double>
using Rotations = In<T, nb::shape<-1, 3, 3>>;
using Indices = In<std::int64_t, nb::ndim<1>>;

// A batch of ellipsoids as the kernels read it: raw pointers, its length.
template <typename T = double>
struct Batch {
  const T* C;
  const T* R;
  const T* r;
  std::int64_t n;
};

template <typename T>
Batch<T> batch(const Centers<T>& C, const Rotations<T>& R, const Centers<T>& r) {
  const auto n = static_cast<std::int64_t>(C.shape(0));
  if (static_cast<std::int64_t>(R.shape(0)) != n || static_cast<std::int64_t>(r.shape(0)) != n)
    throw std::invalid_argument("centres, rotations and radii must have the same length");
  return {C.data(), R.data(), r.data(), n};
}

// [lo, hi) must lie in the output; a batch of one broadcasts (stride 0), any other covers hi.
template <typename T>
void check_range(std::int64_t lo, std::int64_t hi, std::int64_t size, const Batch<T>& a, const Batch<T>& b) {
  if (lo < 0 || hi < lo || hi > size) throw std::out_of_range("pair range outside the output");
  if (hi > lo && ((a.n != 1 && a.n < hi) || (b.n != 1 && b.n < hi)))
    throw std::out_of_range("pair range outside the batches");
}

// out[i] = f(a[i * sa], b[i * sb]) for i in [lo, hi), with the GIL released.
template <typename T, typename O, typename F>
void pairwise(const Batch<T>& a, const Batch<T>& b, O* out, std::int64_t lo, std::int64_t hi, F f) {
  const std::int64_t sa = a.n > 1, sb = b.n > 1;  // stride 0 broadcasts a batch of one
  // the pointers in locals: a store to an int8 output may alias anything, the batches' fields included
  const T *Ca = a.C, *Ra = a.R, *ra = a.r, *Cb = b.C, *Rb = b.R, *rb = b.r;
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) out[i] = f(ellipsim::load(Ca, Ra, ra, i * sa), ellipsim::load(Cb, Rb, rb, i * sb));
}

// An array argument bound without conversion: a strided or wrongly typed array is refused, never copied
// (an output copied would be lost).
inline auto in(const char* name) { return nb::arg(name).noconvert(); }

// Rows of numbers, one per call: how the testing bindings take a stage's inputs and give its outputs (the
// tests pack them).
template <int K>
using Rows = nb::ndarray<double, nb::shape<-1, K>, nb::c_contig, nb::device::cpu>;
template <int K>
using InRows = In<double, nb::shape<-1, K>>;

// What a row holds, read in order.
struct Reader {
  const double* p;
  double f() { return *p++; }
  int i() { return static_cast<int>(*p++); }
  bool b() { return *p++ != 0.0; }
  Vec3 v() {
    const Vec3 x = {p[0], p[1], p[2]};
    p += 3;
    return x;
  }
  Mat3 m() {
    Mat3 x;
    for (int k = 0; k < 9; ++k) x.m[k] = p[k];
    p += 9;
    return x;
  }
};

// What a row receives, written in order.
struct Writer {
  double* p;
  void f(double x) { *p++ = x; }
  void v(const Vec3& x) { f(x.x), f(x.y), f(x.z); }
};

// Binds `name`: out[i] = f(inp[i]) for the rows [lo, hi), with the GIL released.
template <int KI, int KO, typename F>
void def_rows(nb::module_& t, const char* name, F f) {
  t.def(
      name,
      [f](const InRows<KI>& inp, Rows<KO> out, std::int64_t lo, std::int64_t hi) {
        const auto n = static_cast<std::int64_t>(out.shape(0));
        if (static_cast<std::int64_t>(inp.shape(0)) != n)
          throw std::invalid_argument("inp and out must have the same length");
        if (lo < 0 || hi < lo || hi > n) throw std::out_of_range("row range outside the output");
        const double* in = inp.data();
        double* o = out.data();
        nb::gil_scoped_release release;
        for (std::int64_t i = lo; i < hi; ++i) f(Reader{in + KI * i}, Writer{o + KO * i});
      },
      in("inp"), in("out"), nb::arg("lo"), nb::arg("hi"));
}

// Each folder of the core binds its kernels (m) and the internals its tests need (testing).
void bind_exact(nb::module_& m, nb::module_& testing);
void bind_distance(nb::module_& m, nb::module_& testing);
void bind_pairs(nb::module_& m, nb::module_& testing);
void bind_pair_derivatives(nb::module_& m, nb::module_& testing);
void bind_motion(nb::module_& m, nb::module_& testing);
void bind_time_of_impact(nb::module_& m, nb::module_& testing);
void bind_mujoco(nb::module_& m, nb::module_& testing);
void bind_bench(nb::module_& m, nb::module_& testing);
void bind_cylinder(nb::module_& m, nb::module_& testing);
void bind_meshes(nb::module_& m, nb::module_& testing);

}  // namespace ellipsim::binding
