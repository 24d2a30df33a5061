// The bindings of the core's exact/ folder: the certified filter, the contact scale, the thesis's
// set-ups and root tests, and the exact fallback.
#include <ellipsim/exact/certified_filter.hpp>
#include <ellipsim/exact/characteristic.hpp>
#include <ellipsim/exact/contact_scale.hpp>
#include <ellipsim/exact/containment.hpp>
#include <ellipsim/exact/containment_fallback.hpp>
#include <ellipsim/exact/rational_fallback.hpp>
#include <ellipsim/exact/root_tests.hpp>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;

void certify(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb, const Rotations<>& Rb,
             const Centers<>& rb, Out<std::int8_t> out, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  pairwise(a, b, out.data(), lo, hi,
           [](const ellipsim::Ellipsoid& A, const ellipsim::Ellipsoid& B) { return ellipsim::exact::certify_pair(A, B); });
}

void certify_indexed(const Centers<>& C, const Rotations<>& R, const Centers<>& r, const Indices& first,
                     const Indices& second, Out<std::int8_t> out, std::int64_t lo, std::int64_t hi) {
  const auto s = batch(C, R, r);
  const auto k = static_cast<std::int64_t>(out.shape(0));
  if (static_cast<std::int64_t>(first.shape(0)) != k || static_cast<std::int64_t>(second.shape(0)) != k)
    throw std::invalid_argument("first, second and out must have the same length");
  if (lo < 0 || hi < lo || hi > k) throw std::out_of_range("pair range outside the output");
  const std::int64_t* f = first.data();
  const std::int64_t* g = second.data();
  for (std::int64_t i = lo; i < hi; ++i)  // indices are checked by the Python layer; a stray one is fatal
    if (f[i] < 0 || f[i] >= s.n || g[i] < 0 || g[i] >= s.n) throw std::out_of_range("index outside the batch");
  std::int8_t* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i)
    o[i] = ellipsim::exact::certify_pair(ellipsim::load(s.C, s.R, s.r, f[i]), ellipsim::load(s.C, s.R, s.r, g[i]));
}

void contact_scales(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                    const Rotations<>& Rb, const Centers<>& rb, Out<double> out, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  pairwise(a, b, out.data(), lo, hi,
           [](const ellipsim::Ellipsoid& A, const ellipsim::Ellipsoid& B) { return ellipsim::exact::contact_scale_pair(A, B); });
}

void separated_by_axes(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                       const Rotations<>& Rb, const Centers<>& rb, Out<bool> out, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  pairwise(a, b, out.data(), lo, hi,
           [](const ellipsim::Ellipsoid& A, const ellipsim::Ellipsoid& B) { return ellipsim::exact::separated_by_axes(A, B); });
}

// The thesis's uncertified relation (sturm or descartes on either set-up) in the arrays' precision, in blocks of
// BLOCK pairs: the set-ups of a block, then its root tests.  Each test ends in a chain of dependent divisions;
// run after the next pair's set-up, the chains of successive pairs overlap (12% faster for the cofactor set-up,
// measured).  Each pair's result is the same either way.
template <bool Cofactor, bool Sturm, typename T>
void classify_float_blocks(const Batch<T>& a, const Batch<T>& b, std::int8_t* out, std::int64_t lo, std::int64_t hi) {
  using namespace ellipsim::exact;
  constexpr std::int64_t BLOCK = 32;
  const std::int64_t sa = a.n > 1, sb = b.n > 1;  // stride 0 broadcasts a batch of one
  nb::gil_scoped_release release;
  for (std::int64_t i0 = lo; i0 < hi; i0 += BLOCK) {
    const std::int64_t m = hi - i0 < BLOCK ? hi - i0 : BLOCK;
    Quartic<T> q[BLOCK];
    for (std::int64_t j = 0; j < m; ++j) {
      const auto A = ellipsim::load(a.C, a.R, a.r, (i0 + j) * sa), B = ellipsim::load(b.C, b.R, b.r, (i0 + j) * sb);
      if constexpr (Cofactor) {
        q[j] = cofactor_coefficients(A, B);
      } else {
        q[j] = rearranged_frame_coefficients(A, B);
      }
    }
    for (std::int64_t j = 0; j < m; ++j) {
      const Quartic<T>& c = q[j];
      if constexpr (Sturm) {
        out[i0 + j] = sturm_relation(c.c4, c.c3, c.c2, c.c1, c.c0);
      } else {
        out[i0 + j] = descartes_relation(c.c4, c.c3, c.c2, c.c1, c.c0);
      }
    }
  }
}

template <typename T>
void classify_float(const Centers<T>& Ca, const Rotations<T>& Ra, const Centers<T>& ra, const Centers<T>& Cb,
                    const Rotations<T>& Rb, const Centers<T>& rb, bool cofactor, bool sturm, Out<std::int8_t> out,
                    std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  std::int8_t* o = out.data();
  if (cofactor) {
    sturm ? classify_float_blocks<true, true>(a, b, o, lo, hi) : classify_float_blocks<true, false>(a, b, o, lo, hi);
  } else {
    sturm ? classify_float_blocks<false, true>(a, b, o, lo, hi) : classify_float_blocks<false, false>(a, b, o, lo, hi);
  }
}

// Coefficients of det(lambda A + B), (n, 5) rows lambda^4 ... 1.
void polynomials(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                 const Rotations<>& Rb, const Centers<>& rb, bool cofactor,
                 nb::ndarray<double, nb::shape<-1, 5>, nb::c_contig, nb::device::cpu> out, std::int64_t lo,
                 std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  double* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i) {
    const ellipsim::Ellipsoid A = ellipsim::load(a.C, a.R, a.r, i * sa), B = ellipsim::load(b.C, b.R, b.r, i * sb);
    const auto c = cofactor ? ellipsim::exact::cofactor_coefficients(A, B) : ellipsim::exact::rearranged_coefficients(A, B);
    double* row = o + 5 * i;
    row[0] = c.c4, row[1] = c.c3, row[2] = c.c2, row[3] = c.c1, row[4] = c.c0;
  }
}

// out[i] = the exact relation for every i in [lo, hi) where out[i] is UNDECIDED (classify's fallback).
void resolve(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
             const Rotations<>& Rb, const Centers<>& rb, Out<std::int8_t> out, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  std::int8_t* o = out.data();
  std::int64_t singular = -1;
  {
    nb::gil_scoped_release release;
    for (std::int64_t i = lo; i < hi; ++i) {
      if (o[i] != ellipsim::UNDECIDED) continue;
      const int rel = ellipsim::exact::exact_relation(ellipsim::load(a.C, a.R, a.r, i * sa),
                                                      ellipsim::load(b.C, b.R, b.r, i * sb));
      if (rel < 0 && singular < 0) singular = i;
      o[i] = static_cast<std::int8_t>(rel);
    }
  }
  if (singular >= 0)
    throw std::domain_error("pair " + std::to_string(singular) + ": the pencil has a zero constant term (a singular rotation)");
}

// out[lo:hi]: INSIDE / NOT_INSIDE where the float filter is sure, UNDECIDED elsewhere (containment.py _contains).
void contains(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
              const Rotations<>& Rb, const Centers<>& rb, Out<std::int8_t> out, std::int64_t lo, std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  pairwise(a, b, out.data(), lo, hi,
           [](const ellipsim::Ellipsoid& A, const ellipsim::Ellipsoid& B) { return ellipsim::exact::contains_pair(A, B); });
}

// out[i] for the UNDECIDED entries of out[lo:hi]: containment decided exactly (containment_fallback.hpp).
void resolve_containment(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra, const Centers<>& Cb,
                         const Rotations<>& Rb, const Centers<>& rb, Out<std::int8_t> out, std::int64_t lo,
                         std::int64_t hi) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
  const std::int64_t sa = a.n > 1, sb = b.n > 1;
  std::int8_t* o = out.data();
  nb::gil_scoped_release release;
  for (std::int64_t i = lo; i < hi; ++i)
    if (o[i] == ellipsim::exact::CONTAIN_UNDECIDED)
      o[i] = ellipsim::exact::contains_exact(ellipsim::load(a.C, a.R, a.r, i * sa), ellipsim::load(b.C, b.R, b.r, i * sb));
}

// Python ints <-> Integer, for the tests of the exact arithmetic.
ellipsim::exact::Integer to_integer(nb::handle x) {
  const bool negative = nb::cast<bool>(x.attr("__lt__")(0));
  nb::object magnitude = x.attr("__abs__")();
  const auto bits = nb::cast<std::size_t>(magnitude.attr("bit_length")());
  const std::size_t words = (bits + 63) / 64;
  nb::bytes raw = nb::cast<nb::bytes>(magnitude.attr("to_bytes")(words * 8, "little"));
  std::vector<std::uint64_t> limbs(words);
  const auto* bytes = static_cast<const unsigned char*>(raw.data());
  for (std::size_t i = 0; i < words * 8; ++i) limbs[i / 8] |= std::uint64_t(bytes[i]) << (8 * (i % 8));
  return ellipsim::exact::Integer::from_limbs(std::move(limbs), negative);
}

nb::object from_integer(const ellipsim::exact::Integer& v) {
  std::string bytes;
  for (std::uint64_t limb : v.magnitude())
    for (int k = 0; k < 8; ++k) bytes.push_back(static_cast<char>((limb >> (8 * k)) & 0xff));
  nb::object magnitude = nb::module_::import_("builtins").attr("int").attr("from_bytes")(
      nb::bytes(bytes.data(), bytes.size()), "little");
  return v.sign() < 0 ? magnitude.attr("__neg__")() : magnitude;
}

nb::object integer_op(const std::string& op, nb::handle a, nb::handle b) {
  const ellipsim::exact::Integer x = to_integer(a), y = to_integer(b);
  if (op == "+") return from_integer(x + y);
  if (op == "-") return from_integer(x - y);
  if (op == "*") return from_integer(x * y);
  if (op == "divexact") return from_integer(divexact(x, y));
  if (op == "<<") return from_integer(x.shifted_left(nb::cast<int>(b)));
  if (op == "gcd") return from_integer(gcd(x, y));
  if (op == "//") return from_integer(divmod_magnitude(x, y).first);
  if (op == "%") return from_integer(divmod_magnitude(x, y).second);
  throw std::invalid_argument("op must be +, -, *, divexact, <<, gcd, // or %");
}

int distinct_positive_roots(const std::vector<nb::object>& coefficients) {
  ellipsim::exact::Polynomial p;
  for (const nb::object& c : coefficients) p.push_back(to_integer(c));
  return ellipsim::exact::distinct_positive_roots(std::move(p));
}

std::vector<nb::object> pencil_polynomial(const Centers<>& Ca, const Rotations<>& Ra, const Centers<>& ra,
                                          const Centers<>& Cb, const Rotations<>& Rb, const Centers<>& rb) {
  const auto a = batch(Ca, Ra, ra), b = batch(Cb, Rb, rb);
  if (a.n != 1 || b.n != 1) throw std::invalid_argument("one pair");
  std::vector<nb::object> out;
  for (const auto& c : ellipsim::exact::pencil_polynomial(ellipsim::load(a.C, a.R, a.r, 0), ellipsim::load(b.C, b.R, b.r, 0)))
    out.push_back(from_integer(c));
  return out;
}

}  // namespace

void bind_exact(nb::module_& m, nb::module_& t) {
  m.def("contains", &contains, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("out"), "lo"_a, "hi"_a,
        "out[lo:hi]: INSIDE (1) / NOT_INSIDE (0) where the float filter is sure that b lies in a, UNDECIDED elsewhere.");
  m.def("resolve_containment", &resolve_containment, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        in("out"), "lo"_a, "hi"_a, "out[i] for the UNDECIDED entries of out[lo:hi]: containment decided exactly.");
  m.def("certify", &certify, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("out"), "lo"_a, "hi"_a,
        "out[lo:hi]: SEPARATED / OVERLAPPING where the certified float path is sure, UNDECIDED elsewhere.");
  m.def("certify_indexed", &certify_indexed, in("C"), in("R"), in("r"), in("first"), in("second"), in("out"),
        "lo"_a, "hi"_a, "certify on the pairs (first[k], second[k]) of one batch.");
  m.def("contact_scales", &contact_scales, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("out"),
        "lo"_a, "hi"_a, "out[lo:hi]: the Perram-Wertheim contact scale of each pair.");

  m.def("classify_float", &classify_float<double>, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        "cofactor"_a, "sturm"_a, in("out"), "lo"_a, "hi"_a,
        "out[lo:hi]: the thesis's uncertified relation (Sturm or Descartes, cofactor or rearranged set-up).");
  m.def("classify_float", &classify_float<float>, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        "cofactor"_a, "sturm"_a, in("out"), "lo"_a, "hi"_a);
  m.def("polynomials", &polynomials, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), "cofactor"_a,
        in("out"), "lo"_a, "hi"_a, "out[lo:hi]: coefficients (lambda^4 ... 1) of det(lambda A + B).");

  m.def("resolve", &resolve, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"), in("out"), "lo"_a, "hi"_a,
        "out[i] for the UNDECIDED entries of out[lo:hi]: the exact relation (integer arithmetic).");

  t.def("integer_op", &integer_op, "op"_a, "a"_a, "b"_a);
  t.def("distinct_positive_roots", &distinct_positive_roots, "coefficients"_a);
  t.def("pencil_polynomial", &pencil_polynomial, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"));
  t.def("separated_by_axes", &separated_by_axes, in("Ca"), in("Ra"), in("ra"), in("Cb"), in("Rb"), in("rb"),
        in("out"), "lo"_a, "hi"_a);
}

}  // namespace ellipsim::binding
