// The bench's timing loops (ellipsim/app/bench: inside_mujoco.py, pair_types.py, common.py): MuJoCo callbacks and
// functions called through their addresses in a compiled loop, so that a per-call time is the function's own and
// not Python's.  Private: `_ellipsim.bench`.
#include <mujoco/mujoco.h>

#include "../mujoco/narrowphase.hpp"
#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;
using Pairs = In<std::int32_t, nb::shape<-1, 2>>;
using Doubles = In<double, nb::ndim<1>>;

template <typename F>
F* function(std::uintptr_t address) {
  if (address == 0) throw std::invalid_argument("function address is 0");
  return reinterpret_cast<F*>(address);
}

// sum over reps x pairs of fn(m, d, g1, g2): MuJoCo's mjfConFilt, as mjcb_contactfilter is called.
std::int64_t filter_loop(std::uintptr_t fn, std::uintptr_t m, std::uintptr_t d, const Pairs& pairs, std::int64_t reps) {
  auto* f = function<int(const mjModel*, mjData*, int, int)>(fn);
  const auto* M = reinterpret_cast<const mjModel*>(m);
  auto* D = reinterpret_cast<mjData*>(d);
  const std::int32_t* p = pairs.data();
  const auto k = static_cast<std::int64_t>(pairs.shape(0));
  std::int64_t total = 0;
  nb::gil_scoped_release release;
  for (std::int64_t r = 0; r < reps; ++r)
    for (std::int64_t i = 0; i < k; ++i) total += f(M, D, p[2 * i], p[2 * i + 1]);
  return total;
}

// sum over reps x pairs of fn(m, d, con, g1, g2, margin[i]): an mjfCollision, as mjCOLLISIONFUNC's entries are.
std::int64_t collision_loop(std::uintptr_t fn, std::uintptr_t m, std::uintptr_t d, std::uintptr_t con,
                            const Pairs& pairs, const Doubles& margins, std::int64_t reps) {
  auto* f = function<int(const mjModel*, const mjData*, mjContact*, int, int, mjtNum)>(fn);
  const auto k = static_cast<std::int64_t>(pairs.shape(0));
  if (static_cast<std::int64_t>(margins.shape(0)) != k) throw std::invalid_argument("one margin per pair");
  const auto* M = reinterpret_cast<const mjModel*>(m);
  const auto* D = reinterpret_cast<const mjData*>(d);
  auto* C = reinterpret_cast<mjContact*>(con);
  const std::int32_t* p = pairs.data();
  const double* mg = margins.data();
  std::int64_t total = 0;
  nb::gil_scoped_release release;
  for (std::int64_t r = 0; r < reps; ++r)
    for (std::int64_t i = 0; i < k; ++i) total += f(M, D, C, p[2 * i], p[2 * i + 1], mg[i]);
  return total;
}

// out[i] = fn(m, d, g1, g2, distmax, nullptr): MuJoCo's mj_geomDistance over the pairs.
void geom_distance_loop(std::uintptr_t fn, std::uintptr_t m, std::uintptr_t d, const Pairs& pairs, double distmax,
                        nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> out) {
  auto* f = function<mjtNum(const mjModel*, const mjData*, int, int, mjtNum, mjtNum*)>(fn);
  const auto k = static_cast<std::int64_t>(pairs.shape(0));
  if (static_cast<std::int64_t>(out.shape(0)) != k) throw std::invalid_argument("one output per pair");
  const auto* M = reinterpret_cast<const mjModel*>(m);
  const auto* D = reinterpret_cast<const mjData*>(d);
  const std::int32_t* p = pairs.data();
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = 0; i < k; ++i) o[i] = f(M, D, p[2 * i], p[2 * i + 1], distmax, nullptr);
}

// An mjfCollision that makes no contact: the bench's measure of the table call's own cost.
extern "C" int ellipsim_noop_collision(const mjModel*, const mjData*, mjContact*, int, int, mjtNum) { return 0; }

// ellipsim's narrow phase with its contact dropped: in mj_step against the no-op, ellipsim's own cost of a call
// (the kernels, the glue, the caches as MuJoCo leaves them) without MuJoCo's work on the contacts it returns.
extern "C" int ellipsim_discard_collision(const mjModel* m, mjData* d, mjPreContact* con, int g1, int g2,
                                          mjtNum margin) {
  glue::ellipsim_narrowphase(m, d, con, g1, g2, margin);
  return 0;
}

}  // namespace

void bind_bench(nb::module_& m, nb::module_& testing) {
  (void)testing;
  nb::module_ b = m.def_submodule("bench", "The bench's compiled timing loops (private).");
  b.def("filter_loop", &filter_loop, "fn"_a, "m"_a, "d"_a, in("pairs"), "reps"_a);
  b.def("collision_loop", &collision_loop, "fn"_a, "m"_a, "d"_a, "con"_a, in("pairs"), in("margins"), "reps"_a);
  b.def("geom_distance_loop", &geom_distance_loop, "fn"_a, "m"_a, "d"_a, in("pairs"), "distmax"_a, in("out"));
  b.attr("NOOP") = reinterpret_cast<std::uintptr_t>(&ellipsim_noop_collision);
  b.attr("DISCARD") = reinterpret_cast<std::uintptr_t>(&ellipsim_discard_collision);
}

}  // namespace ellipsim::binding
