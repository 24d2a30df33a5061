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
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i)
    out[i] = f(ellipsim::load(a.C, a.R, a.r, i * sa), ellipsim::load(b.C, b.R, b.r, i * sb));
}

// An array argument bound without conversion: a strided or wrongly typed array is refused, never copied
// (an output copied would be lost).
inline auto in(const char* name) { return nb::arg(name).noconvert(); }

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

}  // namespace ellipsim::binding
