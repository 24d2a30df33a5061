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
    out.limbs_ = multiply_magnitudes(a.limbs_.data(), a.limbs_.size(), b.limbs_.data(), b.limbs_.size());
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

  // a / b for b != 0 dividing a exactly (by a content, in a pseudo-quotient): Jebelean's method,
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

  // The nonnegative greatest common divisor (gcd(0, 0) = 0): Lehmer's algorithm on 62-bit leading digits
  // (Knuth, TAOCP vol. 2, 4.5.2, algorithm L), a long division where the leading digits cannot decide.
  friend Integer gcd(const Integer& x, const Integer& y) {
    std::vector<Limb> a = x.limbs_, b = y.limbs_;
    while (true) {
      if (compare_magnitude(a, b) < 0) std::swap(a, b);
      if (b.empty()) break;
      if (a.size() <= 2) {  // both fit in 128 bits: Euclid on machine words
        Wide u = a[0] | (a.size() > 1 ? Wide(a[1]) << 64 : 0), v = b[0] | (b.size() > 1 ? Wide(b[1]) << 64 : 0);
        while (v != 0) {
          const Wide r = u % v;
          u = v;
          v = r;
        }
        a = {static_cast<Limb>(u), static_cast<Limb>(u >> 64)};
        b.clear();
        break;
      }
      const int k = bits(a) - 62;
      const std::int64_t x0 = static_cast<std::int64_t>(leading(a, k)), y0 = static_cast<std::int64_t>(leading(b, k));
      __int128 xx = x0, yy = y0, A = 1, B = 0, C = 0, D = 1;
      while (yy + C != 0 && yy + D != 0) {
        const __int128 q = (xx + A) / (yy + C);
        if (q != (xx + B) / (yy + D)) break;
        __int128 t = A - q * C;
        A = C, C = t;
        t = B - q * D;
        B = D, D = t;
        t = xx - q * yy;
        xx = yy, yy = t;
      }
      if (B == 0) {  // the leading digits decided nothing: one division step
        std::vector<Limb> r = divmod_magnitudes(a, b).second;
        a = std::move(b);
        b = std::move(r);
        trim_magnitude(b);
        continue;
      }
      const Integer ia = from_limbs(a, false), ib = from_limbs(b, false);
      const Integer na = Integer(static_cast<std::int64_t>(A)) * ia + Integer(static_cast<std::int64_t>(B)) * ib;
      const Integer nb = Integer(static_cast<std::int64_t>(C)) * ia + Integer(static_cast<std::int64_t>(D)) * ib;
      a = na.limbs_;
      b = nb.limbs_;
    }
    return from_limbs(std::move(a), false);
  }

  // Quotient and remainder of |x| / |y| (y != 0), both nonnegative (Knuth, TAOCP vol. 2, 4.3.1, algorithm D).
  friend std::pair<Integer, Integer> divmod_magnitude(const Integer& x, const Integer& y) {
    if (y.is_zero()) throw std::domain_error("divmod: division by zero");
    auto [q, r] = divmod_magnitudes(x.limbs_, y.limbs_);
    return {from_limbs(std::move(q), false), from_limbs(std::move(r), false)};
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

  // Schoolbook below KARATSUBA_LIMBS limbs, Karatsuba above (the fallbacks' coefficients reach thousands of
  // bits, their Sturm sequences tens of thousands).
  static constexpr std::size_t KARATSUBA_LIMBS = 24;

  static std::vector<Limb> schoolbook(const Limb* a, std::size_t n, const Limb* b, std::size_t m) {
    std::vector<Limb> out(n + m, 0);
    for (std::size_t i = 0; i < n; ++i) {
      Limb carry = 0;
      const Wide ai = a[i];
      for (std::size_t j = 0; j < m; ++j) {
        const Wide t = ai * b[j] + out[i + j] + carry;
        out[i + j] = static_cast<Limb>(t);
        carry = static_cast<Limb>(t >> 64);
      }
      out[i + m] = carry;
    }
    return out;
  }

  // out += x * 2^(64 shift), out long enough.
  static void add_into(std::vector<Limb>& out, const std::vector<Limb>& x, std::size_t shift) {
    Limb carry = 0;
    std::size_t i = 0;
    for (; i < x.size(); ++i) {
      const Wide t = Wide(out[shift + i]) + x[i] + carry;
      out[shift + i] = static_cast<Limb>(t);
      carry = static_cast<Limb>(t >> 64);
    }
    for (std::size_t j = shift + i; carry && j < out.size(); ++j) {
      const Wide t = Wide(out[j]) + carry;
      out[j] = static_cast<Limb>(t);
      carry = static_cast<Limb>(t >> 64);
    }
  }

  // x -= y (x >= y as magnitudes, trailing zero limbs allowed).
  static void sub_into(std::vector<Limb>& x, const std::vector<Limb>& y) {
    Limb borrow = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const Limb yi = i < y.size() ? y[i] : 0;
      const Limb d = x[i] - yi - borrow;
      borrow = (x[i] < yi) || (x[i] - yi < borrow);
      x[i] = d;
    }
  }

  static std::vector<Limb> sum_of(const Limb* a, std::size_t n, const Limb* b, std::size_t m) {
    std::vector<Limb> out(std::max(n, m) + 1, 0);
    Limb carry = 0;
    for (std::size_t i = 0; i + 1 < out.size(); ++i) {
      const Wide t = Wide(i < n ? a[i] : 0) + (i < m ? b[i] : 0) + carry;
      out[i] = static_cast<Limb>(t);
      carry = static_cast<Limb>(t >> 64);
    }
    out.back() = carry;
    return out;
  }

  static std::vector<Limb> multiply_magnitudes(const Limb* a, std::size_t n, const Limb* b, std::size_t m) {
    if (n < m) return multiply_magnitudes(b, m, a, n);  // n >= m
    if (m < KARATSUBA_LIMBS) return schoolbook(a, n, b, m);
    const std::size_t h = n / 2;
    std::vector<Limb> out(n + m, 0);
    if (m <= h) {  // unbalanced: a = a1 B^h + a0, b whole
      add_into(out, multiply_magnitudes(a, h, b, m), 0);
      add_into(out, multiply_magnitudes(a + h, n - h, b, m), h);
      return out;
    }
    // a = a1 B^h + a0, b = b1 B^h + b0: z1 = (a0 + a1)(b0 + b1) - z0 - z2
    std::vector<Limb> z0 = multiply_magnitudes(a, h, b, h);
    std::vector<Limb> z2 = multiply_magnitudes(a + h, n - h, b + h, m - h);
    const std::vector<Limb> sa = sum_of(a, h, a + h, n - h), sb = sum_of(b, h, b + h, m - h);
    std::vector<Limb> z1 = multiply_magnitudes(sa.data(), sa.size(), sb.data(), sb.size());
    sub_into(z1, z0);
    sub_into(z1, z2);
    add_into(out, z0, 0);
    add_into(out, z2, 2 * h);
    while (!z1.empty() && z1.back() == 0) z1.pop_back();
    add_into(out, z1, h);
    return out;
  }

  static void trim_magnitude(std::vector<Limb>& x) {
    while (!x.empty() && x.back() == 0) x.pop_back();
  }

  static int bits(const std::vector<Limb>& x) {
    if (x.empty()) return 0;
    return static_cast<int>(64 * (x.size() - 1)) + 64 - __builtin_clzll(x.back());
  }

  // The 62 bits of x at bit k upward (x >> k, x < 2^(k + 62)); k >= 0.
  static Limb leading(const std::vector<Limb>& x, int k) {
    const std::size_t i = static_cast<std::size_t>(k / 64);
    const int s = k % 64;
    const Limb lo = i < x.size() ? x[i] : 0, hi = i + 1 < x.size() ? x[i + 1] : 0;
    return s ? (lo >> s) | (hi << (64 - s)) : lo;
  }

  // (u / v, u mod v) for magnitudes, v nonzero (Knuth's algorithm D, 64-bit limbs).
  static std::pair<std::vector<Limb>, std::vector<Limb>> divmod_magnitudes(std::vector<Limb> u, std::vector<Limb> v) {
    trim_magnitude(u);
    trim_magnitude(v);
    if (compare_magnitude(u, v) < 0) return {{}, u};
    const std::size_t n = v.size(), m = u.size() - n;
    std::vector<Limb> q(m + 1, 0);
    if (n == 1) {
      Wide r = 0;
      for (std::size_t j = u.size(); j-- > 0;) {
        const Wide cur = (r << 64) | u[j];
        q[j] = static_cast<Limb>(cur / v[0]);
        r = cur % v[0];
      }
      trim_magnitude(q);
      std::vector<Limb> rem = {static_cast<Limb>(r)};
      trim_magnitude(rem);
      return {q, rem};
    }
    const int s = __builtin_clzll(v.back());  // normalise: the divisor's top bit set
    std::vector<Limb> vn(n), un(u.size() + 1);
    for (std::size_t i = n; i-- > 0;) vn[i] = (v[i] << s) | (s && i ? v[i - 1] >> (64 - s) : 0);
    un[u.size()] = s ? u.back() >> (64 - s) : 0;
    for (std::size_t i = u.size(); i-- > 0;) un[i] = (u[i] << s) | (s && i ? u[i - 1] >> (64 - s) : 0);
    const Wide base = Wide(1) << 64;
    for (std::size_t j = m + 1; j-- > 0;) {
      const Wide num = (Wide(un[j + n]) << 64) | un[j + n - 1];
      Wide qhat = num / vn[n - 1], rhat = num % vn[n - 1];
      while (qhat >= base || qhat * vn[n - 2] > ((rhat << 64) | un[j + n - 2])) {
        --qhat;
        rhat += vn[n - 1];
        if (rhat >= base) break;
      }
      // un[j .. j+n] -= qhat * vn
      Limb borrow = 0, carry = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const Wide p = qhat * vn[i] + carry;
        carry = static_cast<Limb>(p >> 64);
        const Limb lo = static_cast<Limb>(p);
        const Limb x = un[i + j];
        un[i + j] = x - lo - borrow;
        borrow = (x < lo) || (x - lo < borrow);
      }
      const Limb x = un[j + n];
      un[j + n] = x - carry - borrow;
      const bool negative = (x < carry) || (x - carry < borrow);
      if (negative) {  // qhat was one too large: add v back
        --qhat;
        Limb c = 0;
        for (std::size_t i = 0; i < n; ++i) {
          const Wide t = Wide(un[i + j]) + vn[i] + c;
          un[i + j] = static_cast<Limb>(t);
          c = static_cast<Limb>(t >> 64);
        }
        un[j + n] += c;
      }
      q[j] = static_cast<Limb>(qhat);
    }
    std::vector<Limb> r(n);
    for (std::size_t i = 0; i < n; ++i) r[i] = (un[i] >> s) | (s ? un[i + 1] << (64 - s) : 0);
    trim_magnitude(q);
    trim_magnitude(r);
    return {q, r};
  }

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
