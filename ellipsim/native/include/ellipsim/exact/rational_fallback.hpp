// The exact relation of two ellipsoids on their float64 inputs, always right: the fallback for the
// pairs the certified float path leaves UNDECIDED (ellipsim/core/exact/rational_fallback.py is the
// Fraction version it replaces and the tests' reference).
//
// Every float64 is an integer times a power of two.  Scaling a rotation by 2^-k together with its
// radii leaves the ellipsoid {x : |D^-1 R^T (x - c)| <= 1} unchanged, and scaling every length by 2^-L
// is a similarity, so the pair becomes one with integer entries and the same relation.  In A's frame
// (pair_frame.hpp: C = cof(R_a), alpha = det(R_a)^2, M = R_b^T C, z = R_a^T (c_b - c_a)) the pencil is
// f(mu) = mu N(mu) - (mu + alpha) P(mu); with P_b = (r_b0 r_b1 r_b2)^2 and G = P_b D_b^-2 (integers),
//
//     h(nu) = P_b^4 f(nu / P_b) = -nu^4 + (p1 - alpha P_b - T1) nu^3 + (T1 p1 - |u|^2 - alpha P_b T1 - T2) nu^2
//             + (T3 E / S - alpha P_b T2 - T3) nu - alpha P_b T3
//
// where K = D_a M^T G M D_a (T1, T2, T3 its trace, principal 2x2 minors, determinant), p1 = |G^1/2 M z|^2,
// u = D_a M^T G M z, S = (r_a0 r_a1 r_a2)^2 and E = sum_i z_i^2 S / r_ai^2: every coefficient an integer.
// nu = P_b mu > 0 maps the positive roots of f onto those of h, so the theorem of Wang, Wang & Kim
// (thesis ch. 4, Theorem 1) reads the relation off h's distinct positive roots: two separated, one (a
// double root) touching, none overlapping.  They are counted by a Sturm sequence (thesis 4.2.1) of
// primitive pseudo-remainders (polynomial.hpp), the sign of each term's scale tracked.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "../relation.hpp"
#include "../vec3.hpp"
#include "integer.hpp"
#include "polynomial.hpp"

namespace ellipsim::exact {

// The pair with integer entries: R_a, R_b scaled by powers of two with their radii, every length by one
// more (see the top of this file).
struct IntegerPair {
  Integer Ra[9], Rb[9], ra[3], rb[3], d[3];
};

inline int lowest_bit_of(const double* x, int n, int fallback) {
  int k = fallback;
  bool any = false;
  for (int i = 0; i < n; ++i) {
    if (x[i] == 0.0) continue;
    const int b = Integer::lowest_bit(x[i]);
    k = any ? std::min(k, b) : b;
    any = true;
  }
  return k;
}

inline IntegerPair integer_pair(const Ellipsoid& A, const Ellipsoid& B) {
  const int ka = lowest_bit_of(A.R.m, 9, 0), kb = lowest_bit_of(B.R.m, 9, 0);
  const double lengths[6] = {A.c.x, A.c.y, A.c.z, B.c.x, B.c.y, B.c.z};
  const double ra[3] = {A.r.x, A.r.y, A.r.z}, rb[3] = {B.r.x, B.r.y, B.r.z};
  int L = std::min(lowest_bit_of(ra, 3, 0) - ka, lowest_bit_of(rb, 3, 0) - kb);  // radii are > 0
  L = std::min(L, lowest_bit_of(lengths, 6, L));
  IntegerPair out;
  for (int k = 0; k < 9; ++k) {
    out.Ra[k] = Integer::from_double(A.R.m[k], -ka);
    out.Rb[k] = Integer::from_double(B.R.m[k], -kb);
  }
  for (int i = 0; i < 3; ++i) {
    out.ra[i] = Integer::from_double(ra[i], -ka - L);
    out.rb[i] = Integer::from_double(rb[i], -kb - L);
    out.d[i] = Integer::from_double(lengths[3 + i], -L) - Integer::from_double(lengths[i], -L);
  }
  return out;
}

// The terms both exact pencils are built from (this file's h, containment_fallback.hpp's N'): the pair in
// integers, det(R_a), G, N = M^T G M (symmetric), z = R_a^T d, N z and p1 = z^T N z.
struct PencilTerms {
  IntegerPair x;
  Integer det, G[3], N[9], z[3], Nz[3], p1;
};

inline PencilTerms pencil_terms(const Ellipsoid& A, const Ellipsoid& B) {
  PencilTerms t;
  t.x = integer_pair(A, B);
  const IntegerPair& x = t.x;
  const Integer* R = x.Ra;
  const Integer C[9] = {R[4] * R[8] - R[5] * R[7], R[5] * R[6] - R[3] * R[8], R[3] * R[7] - R[4] * R[6],
                        R[2] * R[7] - R[1] * R[8], R[0] * R[8] - R[2] * R[6], R[1] * R[6] - R[0] * R[7],
                        R[1] * R[5] - R[2] * R[4], R[2] * R[3] - R[0] * R[5], R[0] * R[4] - R[1] * R[3]};
  t.det = R[0] * C[0] + R[1] * C[1] + R[2] * C[2];
  Integer M[9];  // M = R_b^T C
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M[3 * i + j] = x.Rb[i] * C[j] + x.Rb[3 + i] * C[3 + j] + x.Rb[6 + i] * C[6 + j];
  const Integer b2[3] = {x.rb[0] * x.rb[0], x.rb[1] * x.rb[1], x.rb[2] * x.rb[2]};
  t.G[0] = b2[1] * b2[2], t.G[1] = b2[0] * b2[2], t.G[2] = b2[0] * b2[1];
  for (int j = 0; j < 3; ++j)
    for (int l = j; l < 3; ++l)
      t.N[3 * l + j] = t.N[3 * j + l] =
          M[j] * M[l] * t.G[0] + M[3 + j] * M[3 + l] * t.G[1] + M[6 + j] * M[6 + l] * t.G[2];
  for (int i = 0; i < 3; ++i) t.z[i] = R[i] * x.d[0] + R[3 + i] * x.d[1] + R[6 + i] * x.d[2];
  for (int j = 0; j < 3; ++j) t.Nz[j] = t.N[3 * j] * t.z[0] + t.N[3 * j + 1] * t.z[1] + t.N[3 * j + 2] * t.z[2];
  t.p1 = t.z[0] * t.Nz[0] + t.z[1] * t.Nz[1] + t.z[2] * t.Nz[2];
  return t;
}

// h(nu), the integer pencil above, highest degree first.
inline Polynomial pencil_polynomial(const Ellipsoid& A, const Ellipsoid& B) {
  const PencilTerms t = pencil_terms(A, B);
  const IntegerPair& x = t.x;
  const Integer *N = t.N, *z = t.z, *Nz = t.Nz;
  const Integer& p1 = t.p1;
  const Integer alpha = t.det * t.det;
  const Integer Pb = x.rb[0] * x.rb[0] * t.G[0];
  const Integer a2[3] = {x.ra[0] * x.ra[0], x.ra[1] * x.ra[1], x.ra[2] * x.ra[2]};
  const Integer S = a2[0] * a2[1] * a2[2];
  Integer K[9];  // D_a N D_a
  for (int j = 0; j < 3; ++j)
    for (int l = 0; l < 3; ++l) K[3 * j + l] = x.ra[j] * x.ra[l] * N[3 * j + l];
  const Integer u[3] = {x.ra[0] * Nz[0], x.ra[1] * Nz[1], x.ra[2] * Nz[2]};
  const Integer T1 = K[0] + K[4] + K[8];
  const Integer T2 = (K[0] * K[4] - K[1] * K[3]) + (K[0] * K[8] - K[2] * K[6]) + (K[4] * K[8] - K[5] * K[7]);
  const Integer T3 = K[0] * (K[4] * K[8] - K[5] * K[7]) - K[1] * (K[3] * K[8] - K[5] * K[6]) +
                     K[2] * (K[3] * K[7] - K[4] * K[6]);
  // T3 E / S = det(M)^2 prod(G) sum_i z_i^2 S / r_ai^2, exactly: T3 = S det(M)^2 prod(G)
  const Integer E = z[0] * z[0] * a2[1] * a2[2] + z[1] * z[1] * a2[0] * a2[2] + z[2] * z[2] * a2[0] * a2[1];
  const Integer T3E = S.is_zero() ? Integer() : divexact(T3, S) * E;
  const Integer aP = alpha * Pb;
  return {Integer(-1), p1 - aP - T1, T1 * p1 - (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) - aP * T1 - T2,
          T3E - aP * T2 - T3, -(aP * T3)};
}

// SEPARATED, TOUCHING or OVERLAPPING, exactly; -1 when the pencil's constant term is zero (a singular
// rotation: never for a validated batch).
inline int exact_relation(const Ellipsoid& A, const Ellipsoid& B) {
  const int count = distinct_positive_roots(primitive(pencil_polynomial(A, B)));
  if (count == 2) return SEPARATED;
  if (count == 1) return TOUCHING;
  if (count == 0) return OVERLAPPING;
  return -1;
}

}  // namespace ellipsim::exact
