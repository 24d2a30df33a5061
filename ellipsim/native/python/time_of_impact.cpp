// The bindings of the core's motion/time_of_impact.hpp: the batch kernel `toi` (a drop-in for
// time_of_impact._toi: the same arguments, the bodies as _check's tuples, writing pairs idx[lo:hi] of the
// caller's outputs and oracle), `float_poses` (for _float_poses), `toi_small` (for _toi_small and _rigid_turns),
// `resolve_exact` (time_of_impact._resolve_exact with the C++ exact fallback in place of rational.relation),
// `first_hits` (the bench's sampling checker, app/bench/motion.py), and for tests/test_native_time_of_impact.py
// toi_pair and the search's stages on rows of numbers.
//
// The oracle of exact relations (OT, OR, OC) stays caller-owned as in the Python: the kernel only reads it, and
// resolve_exact appends to it; nothing allocates per pair except the exact fallback's integers.
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <ellipsim/exact/rational_fallback.hpp>
#include <ellipsim/motion/time_of_impact.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;
namespace motion = ellipsim::motion;
namespace toi = ellipsim::motion::time_of_impact;
using toi::load3;
using toi::load9;

template <typename T, nb::ssize_t... N>
using Fixed = nb::ndarray<T, nb::shape<N...>, nb::c_contig, nb::device::cpu>;
template <typename T, std::size_t D>
using Array = nb::ndarray<T, nb::ndim<D>, nb::c_contig, nb::device::cpu>;

// One body's batches at t = 0, (centres, rotations, radii), and at t = 1, (centres, rotations, rotation vectors).
using Ends = std::tuple<Centers<>, Rotations<>, Centers<>>;

template <typename A>
std::int64_t len(const A& a, std::size_t axis = 0) {
  return static_cast<std::int64_t>(a.shape(axis));
}

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

// A body's two batches, all of one length (what _check guarantees the numba kernel).
toi::Motion motion_of(const Ends& x0, const Ends& x1, const char* what) {
  const auto& [C0, R0, r] = x0;
  const auto& [C1, R1, W] = x1;
  const std::int64_t n = len(C0);
  if (len(R0) != n || len(r) != n || len(C1) != n || len(R1) != n || len(W) != n)
    throw std::invalid_argument(std::string(what) + ": every array of both poses must have the same length");
  return {C0.data(), R0.data(), r.data(), C1.data(), R1.data(), W.data(), n};
}

// Pair i is readable from both bodies (a batch of one broadcasts).
void check_pair(std::int64_t i, std::int64_t n, const toi::Motion& A, const toi::Motion& B) {
  if (i < 0 || i >= n) throw std::out_of_range("a pair index outside the outputs");
  if ((A.n != 1 && i >= A.n) || (B.n != 1 && i >= B.n)) throw std::out_of_range("a pair index outside the batches");
}

struct Kernel {
  toi::Motion A, B;
  toi::Oracle O;
  toi::Outputs out;
  std::int64_t n;
};

// The kernel's view of _toi's arguments, every shape checked against what the numba kernel would read.
Kernel kernel_of(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, const Array<double, 2>& OT,
                 const Array<std::int8_t, 2>& OR, const Out<std::int64_t>& OC, const Out<double>& out,
                 const Out<std::int8_t>& status, const Out<double>& t_exact, const Out<std::int64_t>& steps) {
  Kernel k{motion_of(A0, A1, "a"), motion_of(B0, B1, "b"), {}, {}, len(out)};
  require(len(status) == k.n && len(t_exact) == k.n && len(steps) == k.n && len(OC) == k.n && len(OT) == k.n &&
              len(OR) == k.n,
          "out, status, t_exact, steps, OT, OR and OC must have one row per pair");
  require(len(OT, 1) == len(OR, 1), "OT and OR must have the same width");
  k.O = {OT.data(), OR.data(), OC.data(), len(OT, 1)};
  k.out = {out.data(), status.data(), t_exact.data(), steps.data()};
  return k;
}

void check_oracle(const Kernel& k, std::int64_t i) {
  if (k.O.count[i] < 0 || k.O.count[i] > k.O.width) throw std::out_of_range("an oracle count outside [0, width]");
}

// _toi: pairs idx[lo:hi] into out, status, t_exact and steps (rows idx[k]).
void toi_kernel(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, const In<std::int64_t, nb::ndim<1>>& idx,
                const Array<double, 2>& OT, const Array<std::int8_t, 2>& OR, const Out<std::int64_t>& OC, Out<double> out,
                Out<std::int8_t> status, Out<double> t_exact, Out<std::int64_t> steps, std::int64_t lo, std::int64_t hi) {
  const Kernel k = kernel_of(A0, A1, B0, B1, OT, OR, OC, out, status, t_exact, steps);
  if (lo < 0 || hi < lo || hi > len(idx)) throw std::out_of_range("pair range outside idx");
  const std::int64_t* ix = idx.data();
  for (std::int64_t j = lo; j < hi; ++j) {
    check_pair(ix[j], k.n, k.A, k.B);
    check_oracle(k, ix[j]);
  }
  nb::gil_scoped_release release;
  toi::toi(k.A, k.B, ix, k.O, k.out, lo, hi);
}

// _resolve_exact on pairs [lo, hi): each pair asking for the exact relation gets it from the exact fallback at
// its float pose, added to its oracle, and its search reruns until it asks no more (UNRESOLVED once the oracle
// is full).  Pairs are independent, so this is the Python's batched loop pair by pair.
void resolve_exact(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, Array<double, 2> OT,
                   Array<std::int8_t, 2> OR, Out<std::int64_t> OC, Out<double> out, Out<std::int8_t> status,
                   Out<double> t_exact, Out<std::int64_t> steps, std::int64_t lo, std::int64_t hi) {
  const Kernel k = kernel_of(A0, A1, B0, B1, OT, OR, OC, out, status, t_exact, steps);
  require(k.O.width == tol::TOI_MAX_ORACLE, "OT and OR must have TOI_MAX_ORACLE columns");
  if (lo < 0 || hi < lo || hi > k.n) throw std::out_of_range("pair range outside the outputs");
  for (std::int64_t i = lo; i < hi; ++i) {
    if (k.out.status[i] != toi::NEED_EXACT) continue;
    check_pair(i, k.n, k.A, k.B);
    check_oracle(k, i);
  }
  double* ot = OT.data();
  std::int8_t* orel = OR.data();
  std::int64_t* oc = OC.data();
  const std::int64_t sa = k.A.n > 1, sb = k.B.n > 1, w = k.O.width;
  std::int64_t singular = -1;
  {
    nb::gil_scoped_release release;
    for (std::int64_t i = lo; i < hi; ++i) {
      while (k.out.status[i] == toi::NEED_EXACT) {
        if (oc[i] >= tol::TOI_MAX_ORACLE) {
          k.out.status[i] = toi::UNRESOLVED;  // out holds the proven end
          break;
        }
        const double t = k.out.t_exact[i];
        const toi::PosePair P = toi::pose_at(t, toi::load_pair(k.A, k.B, i * sa, i * sb).pair);
        const int rel = exact::exact_relation(P.A, P.B);
        if (rel < 0) {  // a singular rotation: rational.relation fails there too
          if (singular < 0) singular = i;
          break;
        }
        ot[w * i + oc[i]] = t;
        orel[w * i + oc[i]] = static_cast<std::int8_t>(rel);
        oc[i] += 1;
        toi::run_pair(i, k.A, k.B, sa, sb, k.O, k.out);
      }
    }
  }
  if (singular >= 0)
    throw std::domain_error("pair " + std::to_string(singular) +
                            ": the pencil has a zero constant term (a singular rotation)");
}

// _float_poses: the float poses the kernel classifies at t[k] for pair idx[k].
void float_poses(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, const In<std::int64_t, nb::ndim<1>>& idx,
                 const In<double, nb::ndim<1>>& t, Fixed<double, -1, 3> CA, Fixed<double, -1, 3, 3> RA,
                 Fixed<double, -1, 3> ra, Fixed<double, -1, 3> CB, Fixed<double, -1, 3, 3> RB, Fixed<double, -1, 3> rb) {
  const toi::Motion A = motion_of(A0, A1, "a"), B = motion_of(B0, B1, "b");
  const std::int64_t m = len(idx);
  require(len(t) >= m && len(CA) >= m && len(RA) >= m && len(ra) >= m && len(CB) >= m && len(RB) >= m && len(rb) >= m,
          "t and the outputs must have a row per index");
  const std::int64_t* ix = idx.data();
  const std::int64_t bound = std::max(A.n, B.n);
  for (std::int64_t k = 0; k < m; ++k) check_pair(ix[k], bound, A, B);
  nb::gil_scoped_release release;
  for (std::int64_t k = 0; k < m; ++k)
    toi::float_pose(A, B, ix[k], t.data()[k], k, CA.data(), RA.data(), ra.data(), CB.data(), RB.data(), rb.data());
}

// _rigid_turns: body i's semi-axes equal at both poses and no turn within HALF_TURN_TOL of a half turn; w[i]
// its rotation vector (0 below OMEGA_ZERO).
bool rigid_turns(const double* r0, const double* r1, const double* R0, const double* R1, std::int64_t n, double* w) {
  for (std::int64_t i = 0; i < n; ++i)
    for (int j = 0; j < 3; ++j)
      if (r0[3 * i + j] != r1[3 * i + j]) return false;
  constexpr double PI = 3.141592653589793;  // math.pi
  bool ok = true;
  for (std::int64_t i = 0; i < n; ++i) {  // every vector first, as _rotation_vectors, then the angles
    const motion::RotationVector r = motion::flushed_rotation_vector(load9(R0, i), load9(R1, i));
    w[3 * i] = r.w.x, w[3 * i + 1] = r.w.y, w[3 * i + 2] = r.w.z;
    if (PI - r.theta < tol::HALF_TURN_TOL) ok = false;
  }
  return ok;
}

template <typename T>
nb::ndarray<nb::numpy, T, nb::ndim<1>> owned(std::vector<T>* v) {
  nb::capsule owner(v, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return {v->data(), {v->size()}, owner};
}

// _toi_small: time_of_impact of 1 to SMALL_BATCH_PAIRS pairs in one call, (done, toi, status); done is False (and
// nothing computed) unless the lengths make such a batch, and False when a check fails or a pair needs the exact
// relation (time_of_impact's general path then reports or resolves it).
nb::tuple toi_small(const Centers<>& Ca0, const Rotations<>& Ra0, const Centers<>& ra0, const Centers<>& Ca1,
                    const Rotations<>& Ra1, const Centers<>& ra1, const Centers<>& Cb0, const Rotations<>& Rb0,
                    const Centers<>& rb0, const Centers<>& Cb1, const Rotations<>& Rb1, const Centers<>& rb1) {
  const std::int64_t na = len(Ca0), nb = len(Cb0), n = std::max(na, nb);
  require(len(Ra0) == na && len(ra0) == na && len(Ra1) == len(Ca1) && len(ra1) == len(Ca1) && len(Rb0) == nb &&
              len(rb0) == nb && len(Rb1) == len(Cb1) && len(rb1) == len(Cb1),
          "each pose's centres, rotations and radii must have the same length");
  if (na != len(Ca1) || nb != len(Cb1) || std::min(na, nb) == 0 || n > tol::SMALL_BATCH_PAIRS ||
      (na != nb && std::min(na, nb) != 1))
    return nb::make_tuple(false, owned(new std::vector<double>()), owned(new std::vector<std::int8_t>()));
  auto* out = new std::vector<double>(n);
  auto* status = new std::vector<std::int8_t>(n);
  bool done = false;
  {
    nb::gil_scoped_release release;
    double wa[3 * tol::SMALL_BATCH_PAIRS], wb[3 * tol::SMALL_BATCH_PAIRS];
    if (rigid_turns(ra0.data(), ra1.data(), Ra0.data(), Ra1.data(), na, wa) &&
        rigid_turns(rb0.data(), rb1.data(), Rb0.data(), Rb1.data(), nb, wb)) {
      double OT[tol::SMALL_BATCH_PAIRS * tol::TOI_MAX_ORACLE] = {}, t_exact[tol::SMALL_BATCH_PAIRS];
      std::int8_t OR[tol::SMALL_BATCH_PAIRS * tol::TOI_MAX_ORACLE] = {};
      std::int64_t OC[tol::SMALL_BATCH_PAIRS] = {}, steps[tol::SMALL_BATCH_PAIRS], idx[tol::SMALL_BATCH_PAIRS];
      for (std::int64_t i = 0; i < n; ++i) idx[i] = i;
      const toi::Motion A{Ca0.data(), Ra0.data(), ra0.data(), Ca1.data(), Ra1.data(), wa, na};
      const toi::Motion B{Cb0.data(), Rb0.data(), rb0.data(), Cb1.data(), Rb1.data(), wb, nb};
      toi::toi(A, B, idx, {OT, OR, OC, tol::TOI_MAX_ORACLE}, {out->data(), status->data(), t_exact, steps}, 0, n);
      done = true;
      for (std::int64_t i = 0; i < n; ++i)
        if ((*status)[i] == toi::NEED_EXACT) done = false;
    }
  }
  return nb::make_tuple(done, owned(out), owned(status));
}

// The bench's sampling checker (app/bench/motion.py's first_hits, in place of its numba loop): per pair i the first
// of N uniform instants k / (N - 1) whose float pose (pose_at, the pose the search classifies) the certified filter
// does not prove separated, N when none.  An instant the filter cannot decide ends the pair's scan there and is
// recorded as (i, k) in `undecided` while it has rows; the count of such pairs is returned (the caller finishes
// them exactly).  One thread, the bench's timing.
std::int64_t first_hits(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, std::int64_t N,
                        Out<std::int64_t> out, Fixed<std::int64_t, -1, 2> undecided) {
  const toi::Motion A = motion_of(A0, A1, "a"), B = motion_of(B0, B1, "b");
  const std::int64_t n = len(out), room = len(undecided);
  require(N >= 2, "N must be at least 2");
  require(n == 0 || ((A.n == 1 || A.n >= n) && (B.n == 1 || B.n >= n)), "out has more rows than the batches' pairs");
  const std::int64_t sa = A.n > 1, sb = B.n > 1;
  std::int64_t* o = out.data();
  std::int64_t* u = undecided.data();
  std::int64_t count = 0;
  nb::gil_scoped_release release;
  for (std::int64_t i = 0; i < n; ++i) {
    const toi::Pair pair = toi::load_pair(A, B, i * sa, i * sb).pair;
    o[i] = N;
    for (std::int64_t k = 0; k < N; ++k) {
      const toi::PosePair P = toi::pose_at(static_cast<double>(k) / static_cast<double>(N - 1), pair);
      const std::int8_t rel = exact::certify_pair(P.A, P.B);
      if (rel == UNDECIDED) {
        if (count < room) u[2 * count] = i, u[2 * count + 1] = k;
        ++count;
        o[i] = k;
        break;
      }
      if (rel != SEPARATED) {
        o[i] = k;
        break;
      }
    }
  }
  return count;
}

// --- test stages --------------------------------------------------------------------------------------------

using Vec = Fixed<const double, 3>;
using Mat = Fixed<const double, 3, 3>;

// toi_pair on one pair's twelve arrays and its oracle row.
std::tuple<double, int, double, std::int64_t> toi_pair(const Vec& ca0, const Mat& Ra0, const Vec& ca1, const Mat& Ra1,
                                                       const Vec& ra, const Vec& wa, const Vec& cb0, const Mat& Rb0,
                                                       const Vec& cb1, const Mat& Rb1, const Vec& rb, const Vec& wb,
                                                       const In<double, nb::ndim<1>>& ot,
                                                       const In<std::int8_t, nb::ndim<1>>& orel, std::int64_t ocount) {
  if (ocount < 0 || ocount > len(ot) || ocount > len(orel)) throw std::out_of_range("ocount outside the oracle");
  const toi::Impact r =
      toi::toi_pair(load3(ca0.data(), 0), load9(Ra0.data(), 0), load3(ca1.data(), 0), load9(Ra1.data(), 0), load3(ra.data(), 0),
                    load3(wa.data(), 0), load3(cb0.data(), 0), load9(Rb0.data(), 0), load3(cb1.data(), 0), load9(Rb1.data(), 0),
                    load3(rb.data(), 0), load3(wb.data(), 0), ot.data(), orel.data(), ocount);
  return {r.toi, r.status, r.t_exact, r.steps};
}

constexpr int STAGE_COLUMNS = 32;

// Per pair i (loaded as load_pair(i, i)) and its row args = (a, m, end, n (3), t, mu0): the stages of the search
// below _step, STAGE_COLUMNS numbers (tests/test_native_time_of_impact.py's _stages writes the same; _step itself
// is left to the kernel's tests: numba takes minutes to compile a wrapper that inlines it).
void stages(const Ends& A0, const Ends& A1, const Ends& B0, const Ends& B1, const In<double, nb::shape<-1, 8>>& args,
            Fixed<double, -1, STAGE_COLUMNS> out) {
  const toi::Motion A = motion_of(A0, A1, "a"), B = motion_of(B0, B1, "b");
  const std::int64_t n = len(out);
  require(len(args) == n && A.n >= n && B.n >= n, "args, out and the batches must have the same length");
  for (std::int64_t i = 0; i < n; ++i) {
    const double* x = args.data() + 8 * i;
    const double a = x[0], m = x[1], end = x[2], t = x[6], mu0 = x[7];
    const Vec3 nv = {x[3], x[4], x[5]};
    const toi::PairData pd = toi::load_pair(A, B, i, i);
    const toi::Pair& pair = pd.pair;
    double* o = out.data() + STAGE_COLUMNS * i;
    int c = 0;
    const toi::SweptSpheres sw = toi::swept_spheres(pd.swept);
    o[c++] = sw.whole, o[c++] = sw.t_in, o[c++] = sw.t_out;
    o[c++] = pair.ka, o[c++] = pair.kb, o[c++] = pair.p, o[c++] = pair.half[0].ball, o[c++] = pair.half[1].ball;
    o[c++] = pd.swept.rho, o[c++] = pd.swept.ball;
    const int piece = a < 0.5 ? 0 : 1;
    const toi::Ctx ctx = toi::ctx_at(m, piece, pair.half[piece]);
    const toi::Setup S = toi::setup(nv, m, ctx);
    const double head[10] = {S.nd, S.nv, S.E0, S.E1, S.A.eps_q, S.A.c1, S.A.c2, S.B.eps_q, S.B.c1, S.B.c2};
    for (double v : head) o[c++] = v;
    const double M0 = toi::margin_lower(0.0, S);
    o[c++] = M0;
    o[c++] = toi::certified(M0, 0.01, S);
    o[c++] = toi::model_root(S, M0, end - m);
    const toi::End e = toi::largest_end(a, m, end, S, i % 2 == 1);  // quick on odd rows
    o[c++] = e.b, o[c++] = e.fail;
    const toi::PosePair P = toi::pose_at(t, pair);
    o[c++] = toi::witness_relation(P.A.c, P.A.R, P.A.r, P.B.c, P.B.R, P.B.r, mu0, pair.ka, pair.kb);
    o[c++] = toi::probe(t, pair, mu0, nullptr, nullptr, 0);
    const toi::ContactNormal cn = toi::contact_normal(P.A.c, P.A.R, P.A.r, P.B.c, P.B.R, P.B.r, mu0);
    o[c++] = cn.n.x, o[c++] = cn.n.y, o[c++] = cn.n.z, o[c++] = cn.mu;
    o[c++] = toi::spheres_apart_on(nv, a, end, pd.swept.d0, pd.swept.d1, pd.swept.v, pd.swept.rho, pd.swept.ball);
  }
}

}  // namespace

void bind_time_of_impact(nb::module_& m, nb::module_& t) {
  m.def("toi", &toi_kernel, in("A0"), in("A1"), in("B0"), in("B1"), in("idx"), in("OT"), in("OR"), in("OC"), in("out"),
        in("status"), in("t_exact"), in("steps"), "lo"_a, "hi"_a,
        "time_of_impact._toi: (toi, status, t_exact, steps) of pairs idx[lo:hi] into rows idx[k] of the outputs.");
  m.def("resolve_exact", &resolve_exact, in("A0"), in("A1"), in("B0"), in("B1"), in("OT"), in("OR"), in("OC"),
        in("out"), in("status"), in("t_exact"), in("steps"), "lo"_a, "hi"_a,
        "time_of_impact._resolve_exact on pairs [lo, hi), with the exact fallback: every NEED_EXACT pair resolved.");
  m.def("toi_small", &toi_small, in("Ca0"), in("Ra0"), in("ra0"), in("Ca1"), in("Ra1"), in("ra1"), in("Cb0"),
        in("Rb0"), in("rb0"), in("Cb1"), in("Rb1"), in("rb1"),
        "time_of_impact._toi_small: (done, toi, status) of a batch of 1 to SMALL_BATCH_PAIRS pairs in one call.");
  m.def("float_poses", &float_poses, in("A0"), in("A1"), in("B0"), in("B1"), in("idx"), in("t"), in("CA"), in("RA"),
        in("ra"), in("CB"), in("RB"), in("rb"), "time_of_impact._float_poses: the float poses classified at t[k].");
  m.def("first_hits", &first_hits, in("A0"), in("A1"), in("B0"), in("B1"), "N"_a, in("out"), in("undecided"),
        "The bench's sampling checker: per pair the first of N uniform instants not proven separated (N if none); "
        "returns how many stopped undecided, those (pair, k) in undecided.");
  t.def("toi_pair", &toi_pair, in("ca0"), in("Ra0"), in("ca1"), in("Ra1"), in("ra"), in("wa"), in("cb0"), in("Rb0"),
        in("cb1"), in("Rb1"), in("rb"), in("wb"), in("ot"), in("orel"), "ocount"_a);
  t.def("toi_stages", &stages, in("A0"), in("A1"), in("B0"), in("B1"), in("args"), in("out"));
  t.attr("TOI_STAGE_COLUMNS") = STAGE_COLUMNS;
}

}  // namespace ellipsim::binding
