// A pair of ellipsoids seen from A's frame: the thesis's "rearranged" set-up (thesis 4.1.3;
// ellipsim/core/exact/pair_frame.py has the derivation).
//
// x = c_a + R_a^{-T} D_a y maps A onto |y| <= 1 and B onto (y - e)^T K (y - e) <= 1 with
// W = D_b^{-1} R_b^T R_a^{-T} D_a, K = W^T W, e = D_a^{-1} R_a^T (c_b - c_a).  R_a^{-T} = C / det(R_a)
// with C = cof(R_a); carrying alpha = det(R_a)^2 and W_c = D_b^{-1} R_b^T C D_a keeps every quantity a
// polynomial in the inputs.  The pencil is
//
//     f(mu) = mu N(mu) - (mu + alpha) P(mu),  P(mu) = mu^3 + t1 mu^2 + t2 mu + t3,  N(mu) = p1 mu^2 + q mu + s3
//
// with t1 = sum |w_j|^2, t2 = sum_{j<l} |w_j x w_l|^2, t3 = det(W_c)^2, p1 = |v|^2,
// q = sum |w_j x v|^2, s3 = t3 |e|^2 (w_j the columns of W_c, v = W_c e).
//
// Every quantity comes with its "mag": the same expression on |leaves|, each subtraction an
// addition; n roundings on any path from a leaf err by at most gamma_n * mag (Higham, Accuracy and
// Stability of Numerical Algorithms, ch. 3).  Depths are noted as [n].
#pragma once

#include "../math.hpp"

#include "../vec3.hpp"

namespace ellipsim::exact {

template <typename T>
struct InvariantsT {
  T t1, t2, t3, p1, q, s3;
};
using Invariants = InvariantsT<double>;

// Cofactor matrix C of R (R^-1 = C^T / det), its mag, det R and its mag.  Depths: C [2], det [5].
template <typename T>
struct Cofactors {
  Mat3T<T> C, mC;
  T det, mdet;
};

template <typename T>
ELLIPSIM_HD Cofactors<T> cofactors(const Mat3T<T>& R) {
  using math::fabs;
  const T r00 = R.m[0], r01 = R.m[1], r02 = R.m[2], r10 = R.m[3], r11 = R.m[4], r12 = R.m[5], r20 = R.m[6],
          r21 = R.m[7], r22 = R.m[8];
  Cofactors<T> out{{{r11 * r22 - r12 * r21, r12 * r20 - r10 * r22, r10 * r21 - r11 * r20,  //
                     r02 * r21 - r01 * r22, r00 * r22 - r02 * r20, r01 * r20 - r00 * r21,  //
                     r01 * r12 - r02 * r11, r02 * r10 - r00 * r12, r00 * r11 - r01 * r10}},
                   {{fabs(r11 * r22) + fabs(r12 * r21), fabs(r12 * r20) + fabs(r10 * r22), fabs(r10 * r21) + fabs(r11 * r20),
                     fabs(r02 * r21) + fabs(r01 * r22), fabs(r00 * r22) + fabs(r02 * r20), fabs(r01 * r20) + fabs(r00 * r21),
                     fabs(r01 * r12) + fabs(r02 * r11), fabs(r02 * r10) + fabs(r00 * r12), fabs(r00 * r11) + fabs(r01 * r10)}},
                   T(0),
                   T(0)};
  out.det = r00 * out.C.m[0] + r01 * out.C.m[1] + r02 * out.C.m[2];
  out.mdet = fabs(r00) * out.mC.m[0] + fabs(r01) * out.mC.m[1] + fabs(r02) * out.mC.m[2];
  return out;
}

// e = D_a^{-1} R_a^T (c_b - c_a) [5] and its mag, so that q_A(c_b) = |e|^2.
template <typename T>
struct Offset {
  Vec3T<T> e, me;
};

template <typename T>
ELLIPSIM_HD Offset<T> offset(const Vec3T<T>& ca, const Mat3T<T>& Ra, const Vec3T<T>& ra, const Vec3T<T>& cb) {
  const Vec3T<T> d = sub(cb, ca);                                     // [1]
  const Vec3T<T> z = rotate_t(Ra, d), mz = rotate_t_mag(Ra, abs3(d));  // [4]
  const Vec3T<T> i = reciprocal(ra);                                  // [1]
  return {{z.x * i.x, z.y * i.y, z.z * i.z}, {mz.x * i.x, mz.y * i.y, mz.z * i.z}};
}

// W_c = D_b^{-1} R_b^T C D_a [6] (row-major), its mag, alpha [6] and its mag.  ib = 1 / r_b, rounded
// once [1].  exact_inverse = false takes C = R_a and alpha = 1 (the thesis's orthonormal assumption,
// used by the uncertified set-ups).
template <typename T>
struct Shape {
  Mat3T<T> W, mW;
  T alpha, malpha;
};

template <typename T>
ELLIPSIM_HD Shape<T> shape(const Mat3T<T>& Ra, const Vec3T<T>& ra, const Mat3T<T>& Rb, const Vec3T<T>& ib,
                           bool exact_inverse) {
  using math::fabs;
  Mat3T<T> C, mC;
  T alpha = T(1), malpha = T(1);
  if (exact_inverse) {
    const Cofactors<T> cof = cofactors(Ra);
    C = cof.C;
    mC = cof.mC;
    alpha = cof.det * cof.det;
    malpha = cof.mdet * cof.mdet;
  } else {
    C = Ra;
    for (int k = 0; k < 9; ++k) mC.m[k] = fabs(Ra.m[k]);
  }
  const T* b = Rb.m;
  const T* c = C.m;
  const T* mc = mC.m;
  const T s[3] = {ra.x, ra.y, ra.z};
  const T t[3] = {ib.x, ib.y, ib.z};
  Shape<T> out{};
  for (int i = 0; i < 3; ++i) {  // row i of W: column i of R_b against the columns of C
    for (int j = 0; j < 3; ++j) {
      out.W.m[3 * i + j] = dot3(b[i], b[3 + i], b[6 + i], c[j], c[3 + j], c[6 + j]) * (s[j] * t[i]);
      out.mW.m[3 * i + j] =
          dot3(fabs(b[i]), fabs(b[3 + i]), fabs(b[6 + i]), mc[j], mc[3 + j], mc[6 + j]) * (s[j] * t[i]);
    }
  }
  out.alpha = alpha;
  out.malpha = malpha;
  return out;
}

// (t1, t2, t3, p1, q, s3) and their mags from W_c, e and v = W_c e [9].  Depths [11, 13, 12, 12, 16, 13].
template <typename T>
struct InvariantsWithMag {
  InvariantsT<T> inv, minv;
};

template <typename T>
ELLIPSIM_HD InvariantsWithMag<T> invariants(const Mat3T<T>& W, const Mat3T<T>& mW, const Vec3T<T>& e,
                                            const Vec3T<T>& me, const Vec3T<T>& v, const Vec3T<T>& mv) {
  const Vec3T<T> w0 = column(W, 0), w1 = column(W, 1), w2 = column(W, 2);
  const Vec3T<T> m0 = column(mW, 0), m1 = column(mW, 1), m2 = column(mW, 2);
  InvariantsWithMag<T> out{};
  out.inv.t1 = norm2(w0) + norm2(w1) + norm2(w2);
  out.minv.t1 = norm2(m0) + norm2(m1) + norm2(m2);
  const Vec3T<T> x12 = cross3(w1, w2);  // [8]
  const Vec3T<T> mx12 = cross3_mag(m1, m2);
  out.inv.t2 = norm2(cross3(w0, w1)) + norm2(cross3(w0, w2)) + norm2(x12);
  out.minv.t2 = norm2(cross3_mag(m0, m1)) + norm2(cross3_mag(m0, m2)) + norm2(mx12);
  const T det = w0.x * x12.x + w0.y * x12.y + w0.z * x12.z;  // [11]
  const T mdet = m0.x * mx12.x + m0.y * mx12.y + m0.z * mx12.z;
  out.inv.t3 = det * det;
  out.minv.t3 = mdet * mdet;
  out.inv.p1 = norm2(v);
  out.minv.p1 = norm2(mv);
  out.inv.q = norm2(cross3(w0, v)) + norm2(cross3(w1, v)) + norm2(cross3(w2, v));
  out.minv.q = norm2(cross3_mag(m0, mv)) + norm2(cross3_mag(m1, mv)) + norm2(cross3_mag(m2, mv));
  const T ee = norm2(e);  // [8]
  out.inv.s3 = out.inv.t3 * ee;
  out.minv.s3 = out.minv.t3 * norm2(me);
  return out;
}

// f(mu) = mu N(mu) - (mu + alpha) P(mu) [21].
ELLIPSIM_HD double pencil(double mu, const Invariants& k, double alpha) {
  const double n = (k.p1 * mu + k.q) * mu + k.s3;
  const double p = ((mu + k.t1) * mu + k.t2) * mu + k.t3;
  return mu * n - (mu + alpha) * p;
}

// mag of pencil: mu N_mag(mu) + (mu + alpha_mag) P_mag(mu).
ELLIPSIM_HD double pencil_mag(double mu, const Invariants& m, double malpha) {
  const double n = (m.p1 * mu + m.q) * mu + m.s3;
  const double p = ((mu + m.t1) * mu + m.t2) * mu + m.t3;
  return mu * n + (mu + malpha) * p;
}

// Coefficients (mu^4 ... mu^0) of f(mu) = mu N(mu) - (mu + alpha) P(mu).
template <typename T>
struct Quartic {
  T c4, c3, c2, c1, c0;
};

template <typename T>
ELLIPSIM_HD Quartic<T> coefficients(const InvariantsT<T>& k, T alpha) {
  return {-T(1), k.p1 - alpha - k.t1, k.q - alpha * k.t1 - k.t2, k.s3 - alpha * k.t2 - k.t3, -alpha * k.t3};
}

}  // namespace ellipsim::exact
