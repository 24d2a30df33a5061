// Positive-root tests on the characteristic quartic, as in the thesis (section 4.2), uncertified
// (ellipsim/core/exact/root_tests.py).  Both take the coefficients of a x^4 + b x^3 + c x^2 + d x + e
// and return a relation code, using that the quartic of two ellipsoids has at least two negative roots
// and a, e < 0 (thesis 4.1.1.1).  They run in the precision T of their inputs and are kept to be
// measured: neither is reliable near repeated roots.
#pragma once

#include "../math.hpp"

#include "../config.hpp"
#include "../relation.hpp"

namespace ellipsim::exact {

// Sign changes in a sequence, zeros skipped; counted with flags, not branches (the signs are data).
template <typename T>
ELLIPSIM_HD int variations(T s0, T s1, T s2, T s3, T s4) {
  const T s[5] = {s0, s1, s2, s3, s4};
  int count = 0;
  bool seen = false, last_positive = false;  // a nonzero term seen yet; the sign of the latest
  for (int k = 0; k < 5; ++k) {
    const bool nonzero = s[k] != T(0), positive = s[k] > T(0);
    count += static_cast<int>(nonzero & seen & (positive != last_positive));
    last_positive = nonzero ? positive : last_positive;
    seen = seen | nonzero;
  }
  return count;
}

// Sturm sequence of the quartic (thesis 4.2.1): distinct positive roots = V(0) - V(+inf).
//   f = a x^4 + b x^3 + c x^2 + d x + e, f1 = f', f2 = -rem(f, f1) = p x^2 + q x + r,
//   f3 = -rem(f1, f2) = s x + t, f4 = -rem(f2, f3) = u, with the thesis's special cases p = 0 and s = 0.
// Two distinct positive roots: separated; one (a double root): touching; none: overlapping.
template <typename T>
ELLIPSIM_HD int8_t sturm_relation(T a, T b, T c, T d, T e) {
  const T zero = T(0);
  const T p = T(3) * b * b / (T(16) * a) - c / T(2);
  const T q = b * c / (T(8) * a) - T(3) * d / T(4);
  const T r = b * d / (T(16) * a) - e;
  int at_inf, at_zero;  // values at +inf are leading coefficients, at 0 constant terms
  if (p != zero) {
    const T al = T(4) * a / p;
    const T be = (T(3) * b - al * q) / p;
    const T s = al * r + be * q - T(2) * c;
    const T t = be * r - d;
    if (s != zero) {
      const T ga = p / s;
      const T de = (q - ga * t) / s;
      const T u = de * t - r;
      at_inf = variations(a, a, p, s, u);
      at_zero = variations(e, d, r, t, u);
    } else {  // f3 = t is constant (or zero: the sequence ends at f2)
      at_inf = variations(a, a, p, t, zero);
      at_zero = variations(e, d, r, t, zero);
    }
  } else if (q != zero) {  // f2 = q x + r; f3 = -f1(-r / q)
    const T x = -r / q;
    const T f3 = -(((T(4) * a * x + T(3) * b) * x + T(2) * c) * x + d);
    at_inf = variations(a, a, q, f3, zero);
    at_zero = variations(e, d, r, f3, zero);
  } else {  // f2 = r constant, or zero (f1 divides f)
    at_inf = variations(a, a, r, zero, zero);
    at_zero = variations(e, d, r, zero, zero);
  }
  const int count = at_zero - at_inf;  // selects, not branches: the relation is data
  const int8_t two = count == 2 ? SEPARATED : OVERLAPPING;
  return count == 1 ? TOUCHING : two;
}

// Discriminant of the quartic times 27: 4 D0^3 - D1^2 (the resolvent cubic's invariants).
template <typename T>
ELLIPSIM_HD T discriminant(T a, T b, T c, T d, T e) {
  const T d0 = c * c - T(3) * b * d + T(12) * a * e;
  const T d1 = T(2) * c * c * c - T(9) * b * c * d + T(27) * b * b * e + T(27) * a * d * d - T(72) * a * c * e;
  return T(4) * d0 * d0 * d0 - d1 * d1;
}

// Discriminant + Descartes' rule of signs (thesis 4.2.2).  < 0: two complex roots, the real ones
// negative: overlapping.  > 0: four distinct real roots, V+ counts the positive ones.  == 0 with
// V+ = 2 is read as touching (where the test breaks for spheres and coaxial spheroids).
template <typename T>
ELLIPSIM_HD int8_t descartes_relation(T a, T b, T c, T d, T e) {
  const T disc = discriminant(a, b, c, d, e);
  if (disc < T(0)) return OVERLAPPING;
  if (variations(a, b, c, d, e) == 2) return disc > T(0) ? SEPARATED : TOUCHING;
  return OVERLAPPING;
}

}  // namespace ellipsim::exact
