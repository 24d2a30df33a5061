// Polynomials with integer coefficients and the real-root tools the exact fallbacks need: Sturm sequences
// built as subresultant sequences from primitive polynomials (Cohen, A Course in Computational Algebraic
// Number Theory, 3.3), gcds and square-free parts, signs at dyadic points (n / 2^k), and the
// isolation of positive roots by bisection (the Fraction code of ellipsim/core/exact/containment.py and
// rational_fallback.py, in integers only).  Host only (std::vector), off the hot path.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "integer.hpp"

namespace ellipsim::exact {

// Highest degree first (as the Python lists); the zero polynomial is empty.
using Polynomial = std::vector<Integer>;

inline Polynomial strip(Polynomial p) {
  std::size_t i = 0;
  while (i < p.size() && p[i].is_zero()) ++i;
  p.erase(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(i));
  return p;
}

inline int degree(const Polynomial& p) { return static_cast<int>(p.size()) - 1; }

inline Polynomial add(const Polynomial& a, const Polynomial& b) {
  Polynomial out(std::max(a.size(), b.size()));
  const std::size_t n = out.size();
  for (std::size_t i = 0; i < a.size(); ++i) out[n - a.size() + i] += a[i];
  for (std::size_t i = 0; i < b.size(); ++i) out[n - b.size() + i] += b[i];
  return strip(std::move(out));
}

inline Polynomial negate(Polynomial p) {
  for (Integer& c : p) c = -c;
  return p;
}

inline Polynomial subtract(const Polynomial& a, const Polynomial& b) { return add(a, negate(b)); }

inline Polynomial multiply(const Polynomial& a, const Polynomial& b) {
  if (a.empty() || b.empty()) return {};
  Polynomial out(a.size() + b.size() - 1);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) out[i + j] += a[i] * b[j];
  return strip(std::move(out));
}

inline Polynomial derivative(const Polynomial& p) {
  Polynomial out;
  const int n = degree(p);
  for (int k = 0; k < n; ++k) out.push_back(p[static_cast<std::size_t>(k)] * Integer(n - k));
  return strip(std::move(out));
}

// The pseudo-remainder lc(b)^(deg a - deg b + 1) (a mod b); b nonzero and stripped, deg a >= deg b.
inline Polynomial pseudo_remainder(Polynomial a, const Polynomial& b) {
  int e = degree(a) - degree(b) + 1;
  const Integer& lead = b.front();
  while (!a.empty() && degree(a) >= degree(b)) {
    const Integer top = a.front();
    for (std::size_t k = 0; k < a.size(); ++k) a[k] = a[k] * lead;  // lc(b) a - top x^(deg a - deg b) b
    for (std::size_t k = 0; k < b.size(); ++k) a[k] = a[k] - top * b[k];
    a.erase(a.begin());  // its leading term cancelled
    a = strip(std::move(a));
    --e;
  }
  if (e > 0) {
    Integer scale = 1;
    for (int k = 0; k < e; ++k) scale = scale * lead;
    for (Integer& c : a) c = c * scale;
  }
  return a;
}

// The pseudo-quotient q with lc(b)^(deg a - deg b + 1) a = q b + r (deg r < deg b): when b divides a it is
// a nonzero integer multiple of a / b, with the same roots.
inline Polynomial pseudo_quotient(Polynomial a, const Polynomial& b) {
  const int da = degree(a), db = degree(b);
  if (da < db) return {};
  const Integer& lead = b.front();
  Polynomial q(static_cast<std::size_t>(da - db + 1));
  for (int step = 0; step <= da - db; ++step) {  // scale by lc(b) every step, so all divisions are exact
    for (Integer& c : q) c = c * lead;
    for (Integer& c : a) c = c * lead;
    const Integer top = divexact(a[static_cast<std::size_t>(step)], lead);
    q[static_cast<std::size_t>(step)] = top;
    for (std::size_t k = 0; k < b.size(); ++k) a[static_cast<std::size_t>(step) + k] -= top * b[k];
  }
  return strip(std::move(q));
}

// The gcd of the coefficients (positive; 0 for the zero polynomial).
inline Integer content(const Polynomial& p) {
  Integer g;
  for (const Integer& c : p) {
    g = gcd(g, c);
    if (g == Integer(1)) break;
  }
  return g;
}

// p divided by its content: the same signs everywhere, coefficients as small as they can be.
inline Polynomial primitive(Polynomial p) {
  const Integer g = content(p);
  if (g.is_zero() || g == Integer(1)) return p;
  for (Integer& c : p) c = divexact(c, g);
  return p;
}

// A point n / 2^k of the positive reals (k may be negative).
struct Dyadic {
  Integer n;
  int k = 0;
};

// -1, 0, 1 as x <, ==, > y.
inline int compare(const Dyadic& x, const Dyadic& y) {
  const int k = std::max(x.k, y.k);
  const Integer a = x.n.shifted_left(k - x.k), b = y.n.shifted_left(k - y.k);
  return (a - b).sign();
}

// sign of p(x), in integers: 2^(k deg p) p(n / 2^k) by homogeneous Horner (Python's containment._sign).
inline int sign_at(const Polynomial& p, const Dyadic& x) {
  if (p.empty()) return 0;
  Integer n = x.n;
  int k = x.k;
  if (k < 0) {
    n = n.shifted_left(-k);
    k = 0;
  }
  Integer v = p[0];
  for (std::size_t i = 1; i < p.size(); ++i) v = v * n + p[i].shifted_left(k * static_cast<int>(i));
  return v.sign();
}

// The Sturm sequence of p: f_0 = p, f_1 = p', f_{i+1} = -rem(f_{i-1}, f_i), ending at the last nonzero
// remainder (the gcd of p and p').  p and p' are made primitive, then the terms B_i are the subresultant
// sequence's (exact divisions, no gcd per step; Collins; Cohen, algorithm 3.3.1), f_i a positive multiple
// of eps_i B_i: rem(B_{i-1}, B_i) = B_{i+1} g h^delta / lc(B_i)^(delta + 1), so
// eps_{i+1} = -eps_{i-1} sign(g) sign(h)^delta sign(lc(B_i))^(delta + 1).
struct Sturm {
  std::vector<Polynomial> chain;
  std::vector<int> eps;

  explicit Sturm(Polynomial p) {
    p = primitive(strip(std::move(p)));
    chain.push_back(p);
    eps.push_back(1);
    if (degree(p) < 1) return;
    chain.push_back(primitive(derivative(p)));
    eps.push_back(1);
    Integer g = 1, h = 1;
    while (degree(chain.back()) > 0) {
      const Polynomial& a = chain[chain.size() - 2];
      const Polynomial& b = chain.back();
      const int delta = degree(a) - degree(b);
      Polynomial r = pseudo_remainder(a, b);
      if (r.empty()) break;
      Integer divisor = g;
      for (int k = 0; k < delta; ++k) divisor = divisor * h;
      for (Integer& c : r) c = divexact(c, divisor);
      int sign = -eps[eps.size() - 2] * g.sign();
      if (delta % 2 == 1) sign *= h.sign();
      if ((delta + 1) % 2 == 1) sign *= b.front().sign();
      const Integer lead = b.front();
      chain.push_back(std::move(r));
      eps.push_back(sign);
      g = lead;  // h = g^delta / h^(delta - 1)
      if (delta == 1) {
        h = g;
      } else if (delta > 1) {
        Integer num = 1, den = 1;
        for (int k = 0; k < delta; ++k) num = num * g;
        for (int k = 0; k < delta - 1; ++k) den = den * h;
        h = divexact(num, den);
      }
    }
  }

  // The last term: a multiple of gcd(p, p').
  const Polynomial& last() const { return chain.back(); }

  static int changes(const std::vector<int>& signs) {
    int count = 0, last = 0;
    for (int s : signs) {
      if (s == 0) continue;
      if (last != 0 && s != last) ++count;
      last = s;
    }
    return count;
  }

  int variations_at_zero() const {
    std::vector<int> s;
    for (std::size_t i = 0; i < chain.size(); ++i) s.push_back(chain[i].empty() ? 0 : eps[i] * chain[i].back().sign());
    return changes(s);
  }

  int variations_at_infinity() const {
    std::vector<int> s;
    for (std::size_t i = 0; i < chain.size(); ++i) s.push_back(chain[i].empty() ? 0 : eps[i] * chain[i].front().sign());
    return changes(s);
  }

  int variations(const Dyadic& x) const {
    std::vector<int> s;
    for (std::size_t i = 0; i < chain.size(); ++i) s.push_back(eps[i] * sign_at(chain[i], x));
    return changes(s);
  }

  int sign(const Dyadic& x) const { return sign_at(chain[0], x); }

  // Distinct roots of p in (lo, hi] (p square-free where lo or hi may be roots).
  int count(const Dyadic& lo, const Dyadic& hi) const { return variations(lo) - variations(hi); }
};

// Number of distinct roots in (0, inf) of a polynomial with a nonzero constant term; -1 for a zero one.
inline int distinct_positive_roots(Polynomial p) {
  p = strip(std::move(p));
  if (p.empty() || p.back().is_zero()) return -1;
  if (degree(p) == 0) return 0;
  const Sturm s(std::move(p));
  return s.variations_at_zero() - s.variations_at_infinity();
}

// gcd(a, b) up to a nonzero factor (the last nonzero subresultant, made primitive), or empty if both are 0.
inline Polynomial gcd(Polynomial a, Polynomial b) {
  a = primitive(strip(std::move(a)));
  b = primitive(strip(std::move(b)));
  if (degree(a) < degree(b)) std::swap(a, b);
  if (b.empty()) return a;
  Integer g = 1, h = 1;
  while (true) {
    const int delta = degree(a) - degree(b);
    Polynomial r = pseudo_remainder(a, b);
    if (r.empty()) return primitive(std::move(b));
    if (degree(r) == 0) return {Integer(1)};  // coprime
    Integer divisor = g;
    for (int k = 0; k < delta; ++k) divisor = divisor * h;
    for (Integer& c : r) c = divexact(c, divisor);
    a = std::move(b);
    b = std::move(r);
    g = a.front();
    if (delta == 1) {
      h = g;
    } else if (delta > 1) {
      Integer num = 1, den = 1;
      for (int k = 0; k < delta; ++k) num = num * g;
      for (int k = 0; k < delta - 1; ++k) den = den * h;
      h = divexact(num, den);
    }
  }
}

// A polynomial with the distinct roots of p, each simple: p / gcd(p, p') (up to a nonzero factor).
inline Polynomial squarefree(const Polynomial& p) {
  const Polynomial g = gcd(p, derivative(p));
  return degree(g) >= 1 ? primitive(pseudo_quotient(p, g)) : primitive(p);
}

inline int bit_length(const Integer& x) {
  const auto& limbs = x.magnitude();
  if (limbs.empty()) return 0;
  int top = 63;
  while (((limbs.back() >> top) & 1) == 0) --top;
  return static_cast<int>(64 * (limbs.size() - 1)) + top + 1;
}

inline Integer magnitude_of(const Integer& x) { return x.sign() < 0 ? -x : x; }

// A point strictly between 0 < lo < hi: a power of two halfway in exponent while hi / lo > 4 (roots of
// float-built polynomials span hundreds of binades), the midpoint otherwise (containment.py's _split).
inline Dyadic split(const Dyadic& lo, const Dyadic& hi) {
  Dyadic four_lo{lo.n, lo.k - 2};
  if (compare(hi, four_lo) > 0) {
    const int sum = (bit_length(lo.n) - lo.k) + (bit_length(hi.n) - hi.k);  // log2 lo + log2 hi, to within 2
    const int e = sum >= 0 ? sum / 2 : -((-sum + 1) / 2);                       // floor(sum / 2)
    Dyadic mid{Integer(1), -e};
    if (compare(lo, mid) < 0 && compare(mid, hi) < 0) return mid;
  }
  const int k = std::max(lo.k, hi.k);
  return {lo.n.shifted_left(k - lo.k) + hi.n.shifted_left(k - hi.k), k + 1};
}

// An isolated positive root: exactly `at` (exact), or the only root in the open interval (lo, hi).
struct Root {
  bool exact;
  Dyadic lo, hi;  // exact: lo == hi == the root
};

// The distinct positive roots of the square-free p with p(0) != 0 (Cauchy bounds, then bisection).
inline std::vector<Root> positive_roots(const Polynomial& p, const Sturm& sturm) {
  std::vector<Root> out;
  if (degree(p) < 1) return out;
  Integer top = 0, bottom = 0;  // max |c_i| over i >= 1, and over i < deg
  for (std::size_t i = 1; i < p.size(); ++i)
    if (bit_length(p[i]) > bit_length(top)) top = magnitude_of(p[i]);
  for (std::size_t i = 0; i + 1 < p.size(); ++i)
    if (bit_length(p[i]) > bit_length(bottom)) bottom = magnitude_of(p[i]);
  const int m_hi = std::max(bit_length(top) - bit_length(p.front()) + 1, 0) + 1;
  const int m_lo = std::max(bit_length(bottom) - bit_length(p.back()) + 1, 0) + 1;
  std::vector<std::pair<Dyadic, Dyadic>> stack = {{Dyadic{Integer(1), m_lo}, Dyadic{Integer(1), -m_hi}}};
  while (!stack.empty()) {
    auto [lo, hi] = stack.back();
    stack.pop_back();
    const int k = sturm.count(lo, hi);
    if (k == 0) continue;
    if (k == 1) {
      if (sturm.sign(hi) == 0)
        out.push_back({true, hi, hi});
      else
        out.push_back({false, lo, hi});
      continue;
    }
    const Dyadic mid = split(lo, hi);
    stack.push_back({lo, mid});
    stack.push_back({mid, hi});
  }
  return out;
}

// Sign of q at an isolated root of the square-free sf (its Sturm sequence `sturm`): containment.py's
// _sign_at_root.
inline int sign_at_root(const Polynomial& q, Root root, const Sturm& sturm, const Polynomial& sf) {
  if (q.empty()) return 0;
  if (root.exact) return sign_at(q, root.lo);
  const Polynomial g = gcd(sf, q);
  if (degree(g) >= 1 && Sturm(g).count(root.lo, root.hi) > 0) return 0;  // q shares the root
  const Polynomial qs = squarefree(q);
  if (degree(qs) < 1) return q.front().sign();
  const Sturm qsturm(qs);
  Dyadic lo = root.lo, hi = root.hi;
  while (true) {  // refine (lo, hi) around the root until q has no root in it
    const Dyadic mid = split(lo, hi);
    const int s = sign_at(q, mid);
    if (qsturm.count(lo, hi) == 0 && s != 0) return s;
    if (sturm.sign(mid) == 0) return s;
    if (sturm.count(lo, mid) == 1)
      hi = mid;
    else
      lo = mid;
  }
}

}  // namespace ellipsim::exact
