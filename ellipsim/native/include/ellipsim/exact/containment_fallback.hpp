// Containment decided exactly on the float64 inputs, for the pairs the float filter leaves undecided
// (internal tangency and near it): ellipsim/core/exact/containment.py's rational fallback, in integers.
//
// B subset A iff N(nu) = B_y - nu A_y is positive semidefinite for some nu > 0 (containment.hpp).  The set of
// such nu is a closed interval with det N singular at its left end, so B subset A iff some positive root r
// of T(nu) = det N(nu) has N(r) PSD, i.e. the sums of principal minors E_1, E_2, E_3 of N(r) are all >= 0.
// The pair is scaled to integers as in rational_fallback.hpp, and N is replaced by the congruent
// S N S alpha P_b, S = diag(r_a1 r_a2, r_a0 r_a2, r_a0 r_a1, 1): positive semidefiniteness and the roots of
// det are unchanged, and every entry is an integer polynomial of degree <= 1 in nu:
//
//     N'(nu) = [[ (r_a0 r_a1 r_a2)^2 N_jl - [j = l] alpha P_b S_j^2 nu ,  -(r_a0 r_a1 r_a2) (N z)_j ],
//               [ -(r_a0 r_a1 r_a2) (N z)_l                           ,  p1 - alpha P_b + alpha P_b nu ]]
//
// (N = M^T G M, z, p1, P_b as in rational_fallback.hpp).  Roots are isolated by Sturm sequences on dyadic
// intervals and the signs of E_k at them decided exactly (polynomial.hpp).  Host only.
#pragma once

#include <cstdint>
#include <vector>

#include "../vec3.hpp"
#include "containment.hpp"
#include "polynomial.hpp"
#include "rational_fallback.hpp"

namespace ellipsim::exact {

using PolyMatrix = std::vector<std::vector<Polynomial>>;

// The determinant of a square matrix of polynomials (Laplace along the first row; at most 4x4 here).
inline Polynomial poly_det(const PolyMatrix& M) {
  const std::size_t n = M.size();
  if (n == 1) return M[0][0];
  Polynomial out;
  for (std::size_t c = 0; c < n; ++c) {
    if (M[0][c].empty()) continue;
    PolyMatrix minor;
    for (std::size_t r = 1; r < n; ++r) {
      std::vector<Polynomial> row;
      for (std::size_t k = 0; k < n; ++k)
        if (k != c) row.push_back(M[r][k]);
      minor.push_back(row);
    }
    const Polynomial term = multiply(M[0][c], poly_det(minor));
    out = c % 2 == 0 ? add(out, term) : subtract(out, term);
  }
  return out;
}

// Sum of the principal minors of order k of the 4x4 M.
inline Polynomial principal_minor_sum(const PolyMatrix& M, int k) {
  Polynomial out;
  for (int mask = 0; mask < 16; ++mask) {
    if (__builtin_popcount(static_cast<unsigned>(mask)) != k) continue;
    std::vector<int> J;
    for (int i = 0; i < 4; ++i)
      if (mask & (1 << i)) J.push_back(i);
    PolyMatrix sub;
    for (int i : J) {
      std::vector<Polynomial> row;
      for (int j : J) row.push_back(M[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)]);
      sub.push_back(row);
    }
    out = add(out, poly_det(sub));
  }
  return out;
}

// N'(nu) above, entries highest degree first.
inline PolyMatrix containment_pencil(const Ellipsoid& A, const Ellipsoid& B) {
  const PencilTerms t = pencil_terms(A, B);
  const IntegerPair& x = t.x;
  const Integer *N = t.N, *Nz = t.Nz;
  const Integer aP = t.det * t.det * (x.rb[0] * x.rb[0] * t.G[0]);
  const Integer& p1 = t.p1;
  const Integer pr = x.ra[0] * x.ra[1] * x.ra[2];
  const Integer pr2 = pr * pr;
  const Integer S[3] = {x.ra[1] * x.ra[2], x.ra[0] * x.ra[2], x.ra[0] * x.ra[1]};
  PolyMatrix out(4, std::vector<Polynomial>(4));
  for (int j = 0; j < 3; ++j) {
    for (int l = 0; l < 3; ++l) {
      const Integer c = pr2 * N[3 * j + l];
      out[j][l] = j == l ? strip({-(aP * S[j] * S[j]), c}) : strip({c});
    }
    out[j][3] = out[3][j] = strip({-(pr * Nz[j])});
  }
  out[3][3] = strip({aP, p1 - aP});
  return out;
}

// INSIDE or NOT_INSIDE for one pair, exactly.
inline std::int8_t contains_exact(const Ellipsoid& A, const Ellipsoid& B) {
  const PolyMatrix N = containment_pencil(A, B);
  const Polynomial T = primitive(poly_det(N));  // positive factors change no sign
  const Polynomial E[3] = {primitive(principal_minor_sum(N, 1)), primitive(principal_minor_sum(N, 2)),
                           primitive(principal_minor_sum(N, 3))};
  Polynomial sf = squarefree(strip(T));
  while (degree(sf) >= 1 && sf.back().is_zero()) sf.pop_back();  // a factor nu: the positive roots stay
  const Sturm sturm(sf);
  for (const Root& root : positive_roots(sf, sturm)) {
    bool psd = true;
    for (const Polynomial& q : E) psd = psd && sign_at_root(q, root, sturm, sf) >= 0;
    if (psd) return INSIDE;
  }
  return NOT_INSIDE;
}

}  // namespace ellipsim::exact
