// Exact integers of any size, for the exact fallbacks (rational_fallback.hpp): every float64 is an
// integer times a power of two, so the pencil of two ellipsoids scaled by powers of two has integer
// coefficients, and its roots can be counted with no rounding at all.
//
// Sign and magnitude, 64-bit limbs (least significant first), schoolbook multiplication and exact
// division (Jebelean, "An algorithm for exact division", J. Symbolic Computation 15, 1993).  Host only:
// the magnitude lives in a std::vector.  Only pairs the certified float path cannot decide come here
// (touching, or within ~1e-13 of it), so the allocation is off the hot path.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ellipsim::exact {

class Integer {
 public:
  using Limb = std::uint64_t;
  using Wide = unsigned __int128;

  Integer() = default;
  Integer(std::int64_t v) : negative_(v < 0) {  // NOLINT: implicit from small integers, like Python's int
    if (v != 0) limbs_.push_back(v < 0 ? Limb(0) - Limb(v) : Limb(v));
  }

  // x * 2^shift for a finite double x; x * 2^shift must be an integer (ScaledInputs chooses shift).
  static Integer from_double(double x, int shift) {
    if (x == 0.0) return {};
    int e = 0;
    const double f = std::frexp(std::fabs(x), &e);  // |x| = f 2^e, f in [0.5, 1)
    const Limb m = static_cast<Limb>(std::ldexp(f, 53));  // exact: 53 bits
    const int k = e - 53 + shift;
    Integer out;
    out.limbs_.push_back(m);
    if (k >= 0) {
      out = out.shifted_left(k);
    } else {
      if ((m & ((Limb(1) << -k) - 1)) != 0) throw std::logic_error("from_double: x * 2^shift is not an integer");
      out.limbs_[0] = m >> -k;
    }
    out.negative_ = x < 0.0;
    out.trim();
    return out;
  }

  // The integer with these limbs (least significant first) and sign.
  static Integer from_limbs(std::vector<Limb> limbs, bool negative) {
    Integer out;
    out.limbs_ = std::move(limbs);
    out.negative_ = negative;
    out.trim();
    return out;
  }

  // The exponent of the lowest set bit of a nonzero finite double (x = odd * 2^lowest_bit(x)).
  static int lowest_bit(double x) {
    int e = 0;
    Limb m = static_cast<Limb>(std::ldexp(std::frexp(std::fabs(x), &e), 53));
    int k = e - 53;
    while ((m & 1) == 0) {
      m >>= 1;
      ++k;
    }
    return k;
  }

  int sign() const { return limbs_.empty() ? 0 : (negative_ ? -1 : 1); }
  bool is_zero() const { return limbs_.empty(); }

  Integer operator-() const {
    Integer out = *this;
    if (!out.is_zero()) out.negative_ = !out.negative_;
    return out;
  }

  friend Integer operator+(const Integer& a, const Integer& b) { return add(a, b, b.negative_); }
  friend Integer operator-(const Integer& a, const Integer& b) { return add(a, b, !b.negative_); }

  friend Integer operator*(const Integer& a, const Integer& b) {
    Integer out;
    if (a.is_zero() || b.is_zero()) return out;
    const std::size_t n = a.limbs_.size(), m = b.limbs_.size();
    out.limbs_.assign(n + m, 0);
    for (std::size_t i = 0; i < n; ++i) {
      Limb carry = 0;
      const Wide ai = a.limbs_[i];
      for (std::size_t j = 0; j < m; ++j) {
        const Wide t = ai * b.limbs_[j] + out.limbs_[i + j] + carry;
        out.limbs_[i + j] = static_cast<Limb>(t);
        carry = static_cast<Limb>(t >> 64);
      }
      out.limbs_[i + m] = carry;
    }
    out.negative_ = a.negative_ != b.negative_;
    out.trim();
    return out;
  }

  Integer& operator+=(const Integer& b) { return *this = *this + b; }
  Integer& operator-=(const Integer& b) { return *this = *this - b; }
  Integer& operator*=(const Integer& b) { return *this = *this * b; }

  friend bool operator==(const Integer& a, const Integer& b) {
    return a.negative_ == b.negative_ && a.limbs_ == b.limbs_;
  }
  friend bool operator!=(const Integer& a, const Integer& b) { return !(a == b); }

  // a / b for b != 0 dividing a exactly (the subresultant sequence's divisions): Jebelean's method,
  // the quotient's limbs from the lowest up, each by one multiplication with 1 / b mod 2^64.
  friend Integer divexact(const Integer& a, const Integer& b) {
    if (b.is_zero()) throw std::domain_error("divexact: division by zero");
    if (a.is_zero()) return {};
    // Strip b's factor 2^t (a has it too), so that b's lowest limb is odd and invertible mod 2^64.
    int t = 0;
    while (b.bit(t) == 0) ++t;
    std::vector<Limb> r = a.shifted_right(t).limbs_;
    const std::vector<Limb> d = b.shifted_right(t).limbs_;
    if (r.size() < d.size()) throw std::logic_error("divexact: not an exact division");
    Limb inv = d[0];  // Newton's iteration for d0^-1 mod 2^64: each step doubles the correct bits
    for (int k = 0; k < 6; ++k) inv *= Limb(2) - d[0] * inv;
    const std::size_t nq = r.size() - d.size() + 1;
    Integer q;
    q.limbs_.assign(nq, 0);
    for (std::size_t i = 0; i < nq; ++i) {
      const Limb qi = r[i] * inv;  // makes limb i of r zero
      q.limbs_[i] = qi;
      if (qi == 0) continue;
      Limb carry = 0, borrow = 0;  // r -= qi * d * 2^(64 i)
      for (std::size_t j = 0; j < d.size(); ++j) {
        const Wide p = Wide(qi) * d[j] + carry;
        carry = static_cast<Limb>(p >> 64);
        const Limb lo = static_cast<Limb>(p);
        const Limb x = r[i + j];
        const Limb y = x - lo - borrow;
        borrow = (x < lo) || (x - lo < borrow);
        r[i + j] = y;
      }
      for (std::size_t j = i + d.size(); j < r.size() && (carry | borrow); ++j) {
        const Limb x = r[j];
        const Limb y = x - carry - borrow;
        borrow = (x < carry) || (x - carry < borrow);
        carry = 0;
        r[j] = y;
      }
    }
    for (Limb x : r)
      if (x != 0) throw std::logic_error("divexact: not an exact division");
    q.negative_ = a.negative_ != b.negative_;
    q.trim();
    return q;
  }

  // This integer times 2^k (k >= 0).
  Integer shifted_left(int k) const {
    Integer out;
    if (is_zero()) return out;
    const std::size_t whole = static_cast<std::size_t>(k / 64);
    const int part = k % 64;
    out.limbs_.assign(whole, 0);
    Limb carry = 0;
    for (Limb x : limbs_) {
      out.limbs_.push_back(part ? (x << part) | carry : x);
      carry = part ? x >> (64 - part) : 0;
    }
    if (carry) out.limbs_.push_back(carry);
    out.negative_ = negative_;
    out.trim();
    return out;
  }

  // This integer divided by 2^k, truncated (k >= 0).
  Integer shifted_right(int k) const {
    Integer out;
    const std::size_t whole = static_cast<std::size_t>(k / 64);
    if (whole >= limbs_.size()) return out;
    const int part = k % 64;
    for (std::size_t i = whole; i < limbs_.size(); ++i) {
      const Limb hi = i + 1 < limbs_.size() ? limbs_[i + 1] : 0;
      out.limbs_.push_back(part ? (limbs_[i] >> part) | (hi << (64 - part)) : limbs_[i]);
    }
    out.negative_ = negative_;
    out.trim();
    return out;
  }

  // Bit k of the magnitude.
  int bit(int k) const {
    const std::size_t i = static_cast<std::size_t>(k / 64);
    return i < limbs_.size() ? static_cast<int>((limbs_[i] >> (k % 64)) & 1) : 0;
  }

  std::size_t limbs() const { return limbs_.size(); }

  // The magnitude's limbs, least significant first (for tests: Python rebuilds the int from them).
  const std::vector<Limb>& magnitude() const { return limbs_; }

 private:
  bool negative_ = false;
  std::vector<Limb> limbs_;

  void trim() {
    while (!limbs_.empty() && limbs_.back() == 0) limbs_.pop_back();
    if (limbs_.empty()) negative_ = false;
  }

  // -1, 0, 1 as |a| <, ==, > |b|.
  static int compare_magnitude(const std::vector<Limb>& a, const std::vector<Limb>& b) {
    if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
    for (std::size_t i = a.size(); i-- > 0;)
      if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
    return 0;
  }

  // a + (b's magnitude with sign negative_b).
  static Integer add(const Integer& a, const Integer& b, bool negative_b) {
    if (b.is_zero()) return a;
    if (a.is_zero()) {
      Integer out = b;
      out.negative_ = negative_b;
      return out;
    }
    Integer out;
    if (a.negative_ == negative_b) {  // same signs: add the magnitudes
      const std::vector<Limb>& x = a.limbs_.size() >= b.limbs_.size() ? a.limbs_ : b.limbs_;
      const std::vector<Limb>& y = a.limbs_.size() >= b.limbs_.size() ? b.limbs_ : a.limbs_;
      out.limbs_.resize(x.size() + 1);
      Limb carry = 0;
      for (std::size_t i = 0; i < x.size(); ++i) {
        const Wide t = Wide(x[i]) + (i < y.size() ? y[i] : 0) + carry;
        out.limbs_[i] = static_cast<Limb>(t);
        carry = static_cast<Limb>(t >> 64);
      }
      out.limbs_[x.size()] = carry;
      out.negative_ = negative_b;
    } else {  // opposite signs: subtract the smaller magnitude from the larger
      const int c = compare_magnitude(a.limbs_, b.limbs_);
      if (c == 0) return {};
      const std::vector<Limb>& x = c > 0 ? a.limbs_ : b.limbs_;
      const std::vector<Limb>& y = c > 0 ? b.limbs_ : a.limbs_;
      out.limbs_.resize(x.size());
      Limb borrow = 0;
      for (std::size_t i = 0; i < x.size(); ++i) {
        const Limb yi = i < y.size() ? y[i] : 0;
        const Limb d = x[i] - yi - borrow;
        borrow = (x[i] < yi) || (x[i] - yi < borrow);
        out.limbs_[i] = d;
      }
      out.negative_ = c > 0 ? a.negative_ : negative_b;
    }
    out.trim();
    return out;
  }
};

}  // namespace ellipsim::exact
