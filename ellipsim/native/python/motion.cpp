// The bindings of the core's motion/ folder: interpolation's rotation vectors and poses, and the broad phase's
// sweeps and per-step tests, each a drop-in for its numba kernel (same arguments, same outputs), plus the stages
// tests/test_native_motion.py checks on their own.
//
// The numba broad phase allocates its scratch and grows sweep_and_prune's output; the kernels of
// motion/broad_phase.hpp take both from here: scratch per call, and a buffer that a crowded frame doubles (the
// frame is swept again with room for all of its pairs).
#include <nanobind/stl/tuple.h>

#include <ellipsim/motion/broad_phase.hpp>
#include <ellipsim/motion/interpolation.hpp>
#include <tuple>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;
using ellipsim::Mat3;
using ellipsim::Vec3;
namespace motion = ellipsim::motion;

template <typename T, nb::ssize_t... N>
using Fixed = nb::ndarray<T, nb::shape<N...>, nb::c_contig, nb::device::cpu>;
template <typename T, std::size_t D>
using Array = nb::ndarray<T, nb::ndim<D>, nb::c_contig, nb::device::cpu>;

template <typename A>
std::int64_t len(const A& a, std::size_t axis = 0) {
  return static_cast<std::int64_t>(a.shape(axis));
}

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

Mat3 mat3(const double* a) { return {{a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]}}; }

// --- interpolation ----------------------------------------------------------------------------------------

std::tuple<double, double, double, double> rotation_vector(const Fixed<const double, 3, 3>& R0,
                                                           const Fixed<const double, 3, 3>& R1) {
  const motion::RotationVector r = motion::rotation_vector(mat3(R0.data()), mat3(R1.data()));
  return {r.w.x, r.w.y, r.w.z, r.theta};
}

void rotation_vectors(const Rotations<>& R0, const Rotations<>& R1, Fixed<double, -1, 3> out, Out<double> angle) {
  const std::int64_t n = len(R0);
  require(len(R1) == n && len(out) == n && len(angle) == n, "R0, R1, out and angle must have the same length");
  const double *a = R0.data(), *b = R1.data();
  double *w = out.data(), *th = angle.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = 0; i < n; ++i) {
    const motion::RotationVector r = motion::flushed_rotation_vector(mat3(a + 9 * i), mat3(b + 9 * i));
    w[3 * i] = r.w.x, w[3 * i + 1] = r.w.y, w[3 * i + 2] = r.w.z;
    th[i] = r.theta;
  }
}

void poses_at(const Centers<>& C0, const Rotations<>& R0, const Centers<>& C1, const Rotations<>& R1,
              const Centers<>& W, const In<double, nb::ndim<1>>& t, Fixed<double, -1, 3> C, Fixed<double, -1, 3, 3> R) {
  const std::int64_t n = len(C);
  require(len(C0) == n && len(R0) == n && len(C1) == n && len(R1) == n && len(W) == n && len(R) == n,
          "C0, R0, C1, R1, W, C and R must have the same length");
  require(n == 0 || len(t) == 1 || len(t) >= n, "t must have one time, or one per body");
  const std::int64_t st = len(t) > 1;  // stride 0 broadcasts one time
  const double *c0 = C0.data(), *r0 = R0.data(), *c1 = C1.data(), *r1 = R1.data(), *w = W.data(), *ts = t.data();
  double *c = C.data(), *r = R.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = 0; i < n; ++i) motion::pose_at(c0, r0, c1, r1, w, i, ts[i * st], c, r);
}

// --- broad phase ----------------------------------------------------------------------------------------

using Frames = In<double, nb::shape<-1, -1, 3>>;

nb::ndarray<nb::numpy, std::int64_t, nb::shape<-1, 3>> sweep_and_prune(const Frames& centers,
                                                                       const In<double, nb::ndim<1>>& rho) {
  const std::int64_t F = len(centers), g = len(centers, 1);
  require(len(rho) == g, "rho must have one radius per body");
  auto* pairs = new std::vector<std::int64_t>();
  std::int64_t n = 0;
  {
    nb::gil_scoped_release release;
    std::int64_t cap = 1024;
    pairs->resize(3 * cap);
    std::vector<double> lo(g);
    std::vector<std::int64_t> order(g);
    for (std::int64_t f = 0; f < F; ++f) {
      const double* frame = centers.data() + 3 * g * f;
      std::int64_t m =
          motion::sweep_frame(frame, rho.data(), g, f, lo.data(), order.data(), pairs->data() + 3 * n, cap - n);
      if (m > cap - n) {  // a crowded frame: more room, and the frame again
        while (cap < n + m) cap *= 2;
        pairs->resize(3 * cap);
        m = motion::sweep_frame(frame, rho.data(), g, f, lo.data(), order.data(), pairs->data() + 3 * n, cap - n);
      }
      n += m;
    }
  }
  nb::capsule owner(pairs, [](void* p) noexcept { delete static_cast<std::vector<std::int64_t>*>(p); });
  return {pairs->data(), {static_cast<std::size_t>(n), 3}, owner};
}

void block_pairs(const Frames& centers, const In<double, nb::ndim<1>>& rho, std::int64_t block, std::int64_t g_unit,
                 const In<bool, nb::ndim<2>>& allowed, Array<std::int32_t, 3> out, Out<std::int64_t> count,
                 std::int64_t lo, std::int64_t hi) {
  const std::int64_t F = len(centers), g = len(centers, 1);
  require(len(rho) == g, "rho must have one radius per body");
  require(block >= 1 && g_unit >= 1, "block and g_unit must be positive");
  require(len(allowed) == 0 || (len(allowed) == g && len(allowed, 1) == g), "allowed must be (0, 0) or (g, g)");
  require(len(out, 2) == 2, "out must have shape (blocks, room, 2)");
  if (lo < 0 || hi < lo) throw std::out_of_range("range outside the blocks");
  const std::int64_t first = motion::floor_div(lo + g_unit - 1, g_unit),
                     end = motion::floor_div(hi + g_unit - 1, g_unit);
  if (end > first) {
    if (end > len(out) || end > len(count) || (end - 1) * block > F - 1)
      throw std::out_of_range("range outside the blocks");
    if (g == 0) throw std::invalid_argument("zero-size array to reduction operation maximum which has no identity");
  }
  const bool* allow = len(allowed) ? allowed.data() : nullptr;
  nb::gil_scoped_release release;
  std::vector<double> lo3(3 * g), hi3(3 * g);
  std::vector<std::int64_t> order(g);
  motion::block_pairs(centers.data(), F, g, rho.data(), block, g_unit, allow, out.data(), len(out, 1), count.data(), lo,
                      hi, lo3.data(), hi3.data(), order.data());
}

void compact(const In<std::int32_t, nb::ndim<3>>& out, const In<std::int64_t, nb::ndim<1>>& count,
             Fixed<std::int64_t, -1, 3> blocks) {
  const std::int64_t nb = len(count), cap = len(out, 1);
  require(len(out) >= nb && len(out, 2) == 2, "out must have shape (blocks, room, 2)");
  std::int64_t total = 0;
  for (std::int64_t bk = 0; bk < nb; ++bk) {
    if (count.data()[bk] < 0 || count.data()[bk] > cap) throw std::out_of_range("a count outside [0, room]");
    total += count.data()[bk];
  }
  if (total > len(blocks)) throw std::out_of_range("blocks has fewer rows than the counts' sum");
  nb::gil_scoped_release release;
  motion::compact(out.data(), cap, count.data(), nb, blocks.data());
}

void capsule_motion(const Frames& centers, const In<double, nb::shape<-1, -1, 3, 3>>& rotations,
                    const In<std::int64_t, nb::ndim<1>>& axis, const In<double, nb::ndim<1>>& half,
                    nb::ndarray<double, nb::shape<-1, -1, 2, 3>, nb::c_contig, nb::device::cpu> ends,
                    Array<double, 2> bend) {
  const std::int64_t F = len(centers), g = len(centers, 1);
  require(len(rotations) == F && len(rotations, 1) == g && len(ends) == F && len(ends, 1) == g,
          "centers, rotations and ends must have the same (F, g)");
  require(len(axis) == g && len(half) == g, "axis and half must have one entry per body");
  require(len(bend) == (F > 0 ? F - 1 : 0) && len(bend, 1) == g, "bend must have shape (F - 1, g)");
  for (std::int64_t i = 0; i < g; ++i)
    if (axis.data()[i] < 0 || axis.data()[i] > 2) throw std::out_of_range("an axis outside 0, 1, 2");
  nb::gil_scoped_release release;
  motion::capsule_motion(centers.data(), rotations.data(), F, g, axis.data(), half.data(), ends.data(), bend.data());
}

void step_pairs(const In<std::int64_t, nb::shape<-1, 3>>& blocks, std::int64_t block, const Frames& centers,
                const In<double, nb::ndim<1>>& rho, const In<double, nb::shape<-1, -1, 2, 3>>& ends,
                const In<double, nb::ndim<2>>& bend, const In<double, nb::ndim<1>>& cap,
                const In<double, nb::ndim<1>>& big, Array<bool, 2> keep, std::int64_t lo, std::int64_t hi) {
  const std::int64_t F = len(centers), g = len(centers, 1), P = len(blocks);
  require(len(rho) == g && len(cap) == g && len(big) == g, "rho, cap and big must have one entry per body");
  require(len(ends) == F && len(ends, 1) == g, "ends must have shape (F, g, 2, 3)");
  require(len(bend) == (F > 0 ? F - 1 : 0) && len(bend, 1) == g, "bend must have shape (F - 1, g)");
  require(block >= 1 && len(keep) == P && len(keep, 1) >= block, "keep must have shape (len(blocks), block)");
  if (lo < 0 || hi < lo || hi > P) throw std::out_of_range("pair range outside the blocks");
  const std::int64_t* b = blocks.data();
  for (std::int64_t p = lo; p < hi; ++p)
    if (b[3 * p] < 0 || b[3 * p + 1] < 0 || b[3 * p + 1] >= g || b[3 * p + 2] < 0 || b[3 * p + 2] >= g)
      throw std::out_of_range("a block or body index outside the scene");
  const motion::StepScene S{centers.data(), F, g, rho.data(), ends.data(), bend.data(), cap.data(), big.data()};
  const std::int64_t stride = len(keep, 1);
  bool* k = keep.data();
  nb::gil_scoped_release release;
  for (std::int64_t p = lo; p < hi; ++p)
    motion::step_pair(S, b[3 * p], b[3 * p + 1], b[3 * p + 2], block, k + stride * p);
}

// --- test stages --------------------------------------------------------------------------------------------

void sincos(const In<double, nb::ndim<1>>& x, Fixed<double, -1, 2> out) {
  require(len(out) == len(x), "x and out must have the same length");
  for (std::int64_t i = 0; i < len(x); ++i) {
    const motion::SinCos sc = motion::sincos(x.data()[i]);
    out.data()[2 * i] = sc.s, out.data()[2 * i + 1] = sc.c;
  }
}

// Per row: rodrigues(w, phi) (c, s, 1 - c, k, |alpha|: 7), rodrigues_apply(., p) (3), rodrigues_matrix (9) and
// matmul(Rp, rodrigues_matrix) (9): 28 columns.
void rodrigues_stages(const Centers<>& w, const In<double, nb::ndim<1>>& phi, const Centers<>& p, const Rotations<>& Rp,
                      Fixed<double, -1, 28> out) {
  const std::int64_t n = len(out);
  require(len(w) == n && len(phi) == n && len(p) == n && len(Rp) == n,
          "w, phi, p, Rp and out must have the same length");
  for (std::int64_t i = 0; i < n; ++i) {
    const double* wi = w.data() + 3 * i;
    const double* pi = p.data() + 3 * i;
    const motion::Rodrigues rod = motion::rodrigues({wi[0], wi[1], wi[2]}, phi.data()[i]);
    const Vec3 a = motion::rodrigues_apply(rod, {pi[0], pi[1], pi[2]});
    const Mat3 E = motion::rodrigues_matrix(rod);
    const Mat3 M = motion::matmul(mat3(Rp.data() + 9 * i), E);
    double* o = out.data() + 28 * i;
    const double head[10] = {rod.c, rod.s, rod.om, rod.k.x, rod.k.y, rod.k.z, rod.al, a.x, a.y, a.z};
    for (int k = 0; k < 10; ++k) o[k] = head[k];
    for (int k = 0; k < 9; ++k) o[10 + k] = E.m[k], o[19 + k] = M.m[k];
  }
}

// rotation_at(R0[i], R1[i], w[i], t[i]) (the literal stage; poses_at reads the matrices in place).
void rotation_at(const Rotations<>& R0, const Rotations<>& R1, const Centers<>& w, const In<double, nb::ndim<1>>& t,
                 Fixed<double, -1, 3, 3> out) {
  const std::int64_t n = len(out);
  require(len(R0) == n && len(R1) == n && len(w) == n && len(t) == n, "R0, R1, w, t and out must have the same length");
  for (std::int64_t i = 0; i < n; ++i) {
    const double* wi = w.data() + 3 * i;
    const Mat3 M =
        motion::rotation_at(mat3(R0.data() + 9 * i), mat3(R1.data() + 9 * i), {wi[0], wi[1], wi[2]}, t.data()[i]);
    for (int k = 0; k < 9; ++k) out.data()[9 * i + k] = M.m[k];
  }
}

void segment_distance(const In<double, nb::shape<-1, 12>>& args, Out<double> out) {
  require(len(out) == len(args), "args and out must have the same length");
  for (std::int64_t i = 0; i < len(args); ++i) {
    const double* a = args.data() + 12 * i;
    out.data()[i] = motion::segment_distance(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11]);
  }
}

using Ends = In<double, nb::shape<-1, 2, 3>>;

template <typename O, typename F>
void per_motion(const Ends& a0, const Ends& a1, const Ends& b0, const Ends& b1, const In<double, nb::ndim<1>>& x,
                const In<double, nb::ndim<1>>& reach, Out<O> out, F f) {
  const std::int64_t n = len(out);
  require(len(a0) == n && len(a1) == n && len(b0) == n && len(b1) == n && len(x) == n && len(reach) == n,
          "every argument must have the same length");
  for (std::int64_t i = 0; i < n; ++i)
    out.data()[i] =
        f(a0.data() + 6 * i, a1.data() + 6 * i, b0.data() + 6 * i, b1.data() + 6 * i, x.data()[i], reach.data()[i]);
}

void capsule_gap(const Ends& a0, const Ends& a1, const Ends& b0, const Ends& b1, const In<double, nb::ndim<1>>& t,
                 const In<double, nb::ndim<1>>& reach, Out<double> out) {
  per_motion(a0, a1, b0, b1, t, reach, out, motion::capsule_gap);
}

void capsules_apart(const Ends& a0, const Ends& a1, const Ends& b0, const Ends& b1,
                    const In<double, nb::ndim<1>>& speed, const In<double, nb::ndim<1>>& reach, Out<bool> out) {
  per_motion(a0, a1, b0, b1, speed, reach, out, motion::capsules_apart);
}

void argsort(const In<double, nb::ndim<1>>& values, Out<std::int64_t> out) {
  require(len(out) == len(values), "values and out must have the same length");
  motion::argsort(values.data(), 1, len(values), out.data());
}

}  // namespace

void bind_motion(nb::module_& m, nb::module_& t) {
  m.def("rotation_vector", &rotation_vector, in("R0"), in("R1"),
        "(w0, w1, w2, theta): the axis-angle vector of R0^T R1 and its angle (interpolation.rotation_vector).");
  m.def("rotation_vectors", &rotation_vectors, in("R0"), in("R1"), in("out"), in("angle"),
        "out, angle: the rotation vectors of R0[i]^T R1[i] (0 below OMEGA_ZERO) and their angles.");
  m.def("poses_at", &poses_at, in("C0"), in("R0"), in("C1"), in("R1"), in("W"), in("t"), in("C"), in("R"),
        "C, R: the bodies of the motion from (C0, R0) to (C1, R1) (rotation vectors W) at t (one or one per body).");

  m.def("sweep_and_prune", &sweep_and_prune, in("centers"), in("rho"),
        "(P, 3) int64: the pairs (frame, i, j), i < j, whose bounding spheres overlap, numba's order.");
  m.def("block_pairs", &block_pairs, in("centers"), in("rho"), "block"_a, "g_unit"_a, in("allowed"), in("out"),
        in("count"), "lo"_a, "hi"_a, "out[bk], count[bk]: each block's pairs of overlapping boxes of centres.");
  m.def("compact", &compact, in("out"), in("count"), in("blocks"), "blocks: (block, i, j) of out[bk, :count[bk]].");
  m.def("capsule_motion", &capsule_motion, in("centers"), in("rotations"), in("axis"), in("half"), in("ends"),
        in("bend"), "ends (F, g, 2, 3), bend (F - 1, g): the capsules' segments and their bend over each step.");
  m.def("step_pairs", &step_pairs, in("blocks"), "block"_a, in("centers"), in("rho"), in("ends"), in("bend"), in("cap"),
        in("big"), in("keep"), "lo"_a, "hi"_a, "keep[p, k]: block pair p passes the tests of step k.");

  t.def("sincos", &sincos, in("x"), in("out"));
  t.def("rodrigues_stages", &rodrigues_stages, in("w"), in("phi"), in("p"), in("Rp"), in("out"));
  t.def("rotation_at", &rotation_at, in("R0"), in("R1"), in("w"), in("t"), in("out"));
  t.def("segment_distance", &segment_distance, in("args"), in("out"));
  t.def("capsule_gap", &capsule_gap, in("a0"), in("a1"), in("b0"), in("b1"), in("t"), in("reach"), in("out"));
  t.def("capsules_apart", &capsules_apart, in("a0"), in("a1"), in("b0"), in("b1"), in("speed"), in("reach"), in("out"));
  t.def("argsort", &argsort, in("values"), in("out"));
  nb::dict constants;  // the module-level constants of motion/ (tests: the same as the Python modules')
  constants["SWEEP_BLOCK"] = motion::SWEEP_BLOCK;
  constants["BLOCK_ROOM"] = motion::BLOCK_ROOM;
  constants["CAPSULE_SLACK"] = motion::CAPSULE_SLACK;
  constants["CAPSULE_STEPS"] = motion::CAPSULE_STEPS;
  constants["PLAIN_COS"] = motion::PLAIN_COS;
  t.attr("MOTION") = constants;
}

}  // namespace ellipsim::binding
