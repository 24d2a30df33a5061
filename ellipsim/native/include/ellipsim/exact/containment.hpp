// Containment: does ellipsoid B lie inside ellipsoid A?  The certified float filter
// (ellipsim/core/exact/containment.py has the derivation; containment_fallback.hpp decides what it leaves).
//
// In A's frame (pair_frame.hpp) A is the unit ball and B = {y : (y - e)^T K (y - e) <= 1}.  Geometric Tools
// (Eberly, "Intersection of Ellipsoids", 11.9.2) maximises q_A over B by Lagrange multipliers; we use the
// dual: B subset A iff N(nu) = B_y - nu A_y is positive semidefinite for some nu > 0 (the S-lemma).
// * inside: the same frame with no longer axes (exact comparisons); or, strictly, mu < 0 with K_c + mu I
//   positive definite (Sylvester) and f(mu) > 0, mu from the secular equation of max_B |y|^2.
// * not inside: a sorted semi-axis of B longer than A's, B's centre outside A, the bounding spheres apart,
//   or a point strictly inside B with |y| > 1.
// * UNDECIDED otherwise (internal tangency, near it): exact arithmetic.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "certified_filter.hpp"
#include "pair_frame.hpp"

namespace ellipsim::exact {

constexpr int8_t INSIDE = 1, NOT_INSIDE = 0, CONTAIN_UNDECIDED = -1;

// r sorted ascending, as min / max of the pairs: selects (minsd / maxsd), not branches, the inputs being random
// (written as compare-exchanges, GCC turns the swaps into branches).
ELLIPSIM_HD Vec3 sort3(const Vec3& r) {
  const double lo = min2(r.x, r.y), hi = max2(r.x, r.y);
  return {min2(lo, r.z), max2(lo, min2(hi, r.z)), max2(hi, r.z)};
}

// --- K_c's eigenbasis (float guidance only) -------------------------------------------------------------

// (t, c, s) of the Jacobi rotation annihilating a_pq (Numerical Recipes, 11.1).
struct Givens {
  double t, c, s;
};

ELLIPSIM_HD Givens givens(double app, double aqq, double apq) {
  const double theta = (aqq - app) / (2.0 * apq);
  const double t = (theta >= 0.0 ? 1.0 : -1.0) / (math::fabs(theta) + math::sqrt(theta * theta + 1.0));
  const double c = 1.0 / math::sqrt(t * t + 1.0);
  return {t, c, t * c};
}

ELLIPSIM_HD void rotate_columns(Vec3& vp, Vec3& vq, double c, double s) {
  const Vec3 p = {c * vp.x - s * vq.x, c * vp.y - s * vq.y, c * vp.z - s * vq.z};
  const Vec3 q = {s * vp.x + c * vq.x, s * vp.y + c * vq.y, s * vp.z + c * vq.z};
  vp = p;
  vq = q;
}

// One Jacobi rotation in the plane (p, q) of a symmetric 3x3, r its third index: a_pq annihilated, a_pp, a_qq,
// a_rp, a_rq updated, the eigenvector columns v_p, v_q rotated; nothing when a_pq is already 0.
ELLIPSIM_HD void jacobi_rotate(double& app, double& aqq, double& apq, double& arp, double& arq, Vec3& vp, Vec3& vq) {
  if (apq == 0.0) return;
  const Givens g = givens(app, aqq, apq);
  const double npp = app - g.t * apq, nqq = aqq + g.t * apq;
  app = npp, aqq = nqq, apq = 0.0;
  const double nrp = g.c * arp - g.s * arq, nrq = g.s * arp + g.c * arq;
  arp = nrp, arq = nrq;
  rotate_columns(vp, vq, g.c, g.s);
}

// Eigenvalues (ascending) and eigenvectors (columns V[0..2]) of the symmetric K by cyclic Jacobi.
struct Eigen3 {
  Vec3 kap;
  Vec3 V[3];
};

ELLIPSIM_HD Eigen3 jacobi3(const Sym3T<double>& K) {
  double a00 = K.s00, a01 = K.s01, a02 = K.s02, a11 = K.s11, a12 = K.s12, a22 = K.s22;
  Vec3 v0 = {1.0, 0.0, 0.0}, v1 = {0.0, 1.0, 0.0}, v2 = {0.0, 0.0, 1.0};
  for (int sweep = 0; sweep < tol::JACOBI_SWEEPS; ++sweep) {
    if (a01 * a01 + a02 * a02 + a12 * a12 <= 1e-36 * (a00 * a00 + a11 * a11 + a22 * a22)) break;
    jacobi_rotate(a00, a11, a01, a02, a12, v0, v1);  // (p, q) = (0, 1), r = 2
    jacobi_rotate(a00, a22, a02, a01, a12, v0, v2);  // (0, 2), r = 1
    jacobi_rotate(a11, a22, a12, a01, a02, v1, v2);  // (1, 2), r = 0
  }
  double t;
  Vec3 w;
  if (a00 > a11) t = a00, a00 = a11, a11 = t, w = v0, v0 = v1, v1 = w;
  if (a11 > a22) t = a11, a11 = a22, a22 = t, w = v1, v1 = v2, v2 = w;
  if (a00 > a11) t = a00, a00 = a11, a11 = t, w = v0, v0 = v1, v1 = w;
  return {{a00, a11, a22}, {v0, v1, v2}};
}

// H(nu') = 1 - alpha / nu' - sum kappa_i eh_i^2 / (kappa_i - nu').
ELLIPSIM_HD double secular(double nu, const Vec3& kap, const Vec3& eh2, double alpha) {
  double h = 1.0 - alpha / nu;
  const double k[3] = {kap.x, kap.y, kap.z}, q[3] = {eh2.x, eh2.y, eh2.z};
  for (int i = 0; i < 3; ++i) {
    const double g = 1.0 / (k[i] - nu);
    h -= k[i] * q[i] * g;
  }
  return h;
}

// nu' in (0, kappa_1) maximising the concave H: bisection on the sign of H', with Newton steps on the nearly
// linear zeta = 1 / sqrt(sum kappa eh^2 / (kappa - nu)^2) - nu' / sqrt(alpha).
ELLIPSIM_HD double maximise_secular(const Vec3& kap, const Vec3& eh2, double alpha, double rtol) {
  double lo = 0.0, hi = kap.x;
  double nu = 0.5 * kap.x;
  const double ia = 1.0 / math::sqrt(alpha);
  const double k[3] = {kap.x, kap.y, kap.z}, q[3] = {eh2.x, eh2.y, eh2.z};
  for (int step = 0; step < tol::CONTAIN_NEWTON_STEPS; ++step) {
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double g = 1.0 / (k[i] - nu);
      s1 += k[i] * q[i] * g * g;
      s2 += k[i] * q[i] * g * g * g;
    }
    if (alpha / (nu * nu) - s1 > 0.0) {  // H'(nu') > 0: the maximiser lies right of nu'
      lo = nu;
    } else {
      hi = nu;
    }
    double next = 0.5 * (lo + hi);
    if (s1 > 0.0) {
      const double z = 1.0 / math::sqrt(s1) - nu * ia;
      const double dz = -s2 / (s1 * math::sqrt(s1)) - ia;
      next = nu - z / dz;
      if (!(lo < next && next < hi)) next = 0.5 * (lo + hi);
    }
    const bool done = math::fabs(next - nu) <= rtol * nu || hi - lo <= rtol * kap.x;
    nu = next;
    if (done) break;
  }
  return nu;
}

// --- certificates -------------------------------------------------------------------------------------

// K_c + mu I positive definite (leading minors) and f(mu) > 0, all certified (mu < 0): B strictly inside A.
ELLIPSIM_HD bool inside_certificate(double mu, const Mat3& W, const Mat3& mW, const Invariants& k,
                                    const Invariants& m, double alpha, double malpha) {
  const double am = math::fabs(mu);
  const Vec3 w0 = column(W, 0), w1 = column(W, 1);
  const Vec3 m0 = column(mW, 0), m1 = column(mW, 1);
  if (!positive(norm2(w0) + mu, norm2(m0) + am, tol::ERR_POLY)) return false;
  const double d2 = norm2(cross3(w0, w1)) + mu * (norm2(w0) + norm2(w1)) + mu * mu;
  if (!positive(d2, norm2(cross3_mag(m0, m1)) + am * (norm2(m0) + norm2(m1)) + mu * mu, tol::ERR_POLY)) return false;
  const double p = ((mu + k.t1) * mu + k.t2) * mu + k.t3;
  const double mp = ((am + m.t1) * am + m.t2) * am + m.t3;
  if (!positive(p, mp, tol::ERR_POLY)) return false;
  const double n = (k.p1 * mu + k.q) * mu + k.s3;
  const double mn = (m.p1 * am + m.q) * am + m.s3;
  return positive(mu * n - (mu + alpha) * p, am * mn + (am + malpha) * mp, tol::ERR_POLY);
}

// y strictly outside A (|y|^2 > 1 [4]) and strictly inside B (alpha - |W_c (y - e)|^2 > 0 [13]).
ELLIPSIM_HD bool outside_certificate(const Vec3& y, const Mat3& W, const Mat3& mW, const Vec3& e, const Vec3& me,
                                     double alpha, double malpha) {
  const double yy = norm2(y);
  if (!positive(yy - 1.0, yy + 1.0, tol::ERR_WITNESS)) return false;
  const Vec3 u = sub(y, e);
  const Vec3 mu = {math::fabs(y.x) + me.x, math::fabs(y.y) + me.y, math::fabs(y.z) + me.z};
  return positive(alpha - norm2(matvec(W, u)), malpha + norm2(matvec(mW, mu)), tol::ERR_WITNESS);
}

// e + f (y - e): y pulled towards B's centre.
ELLIPSIM_HD Vec3 towards(const Vec3& y, const Vec3& e, double f) {
  return {e.x + f * (y.x - e.x), e.y + f * (y.y - e.y), e.z + f * (y.z - e.z)};
}

// V z for V given as three columns.
ELLIPSIM_HD Vec3 in_basis(const Vec3* V, const Vec3& z) {
  return {V[0].x * z.x + V[1].x * z.y + V[2].x * z.z, V[0].y * z.x + V[1].y * z.y + V[2].y * z.z,
          V[0].z * z.x + V[1].z * z.y + V[2].z * z.z};
}

// INSIDE / NOT_INSIDE proven from the candidates the multiplier nu gives, else CONTAIN_UNDECIDED.
// The invariants are computed on first use (only the inside certificate reads them): `have` says whether
// `inv` holds them yet.
ELLIPSIM_HD int8_t containment_certificates(double nu, const Eigen3& eig, const Vec3& eh, const Vec3& eh2,
                                                 const Vec3& e, const Vec3& me, const Shape<double>& sh,
                                                 InvariantsWithMag<double>& inv, bool& have) {
  const Vec3& kap = eig.kap;
  const Vec3* V = eig.V;
  const Mat3 &W = sh.W, &mW = sh.mW;
  const double alpha = sh.alpha, malpha = sh.malpha;
  if (secular(nu, kap, eh2, alpha) > 0.0) {
    if (!have) {
      inv = invariants(W, mW, e, me, matvec(W, e), matvec(mW, me));
      have = true;
    }
    // inside: the maximiser, then points towards kappa_1 and towards 0 where H is still positive
    if (inside_certificate(-nu, W, mW, inv.inv, inv.minv, alpha, malpha)) return INSIDE;
    const double up[4] = {0.5, 0.9, 0.99, 0.999999};
    for (double f : up) {
      const double cand = nu + f * (kap.x - nu);
      if (secular(cand, kap, eh2, alpha) > 0.0 && inside_certificate(-cand, W, mW, inv.inv, inv.minv, alpha, malpha))
        return INSIDE;
    }
    const double down[2] = {0.75, 0.95};
    for (double f : down) {
      const double cand = nu * f;
      if (secular(cand, kap, eh2, alpha) > 0.0 && inside_certificate(-cand, W, mW, inv.inv, inv.minv, alpha, malpha))
        return INSIDE;
    }
    return CONTAIN_UNDECIDED;
  }
  // not inside: the maximiser of |y|^2 on B, y = (K_c - nu' I)^{-1} K_c e, pulled towards e
  Vec3 y = in_basis(V, {kap.x * eh.x / (kap.x - nu), kap.y * eh.y / (kap.y - nu), kap.z * eh.z / (kap.z - nu)});
  // the hard case (e nearly orthogonal to the first eigenvector): move along it to B's boundary
  const Vec3 u = sub(y, e);
  const double qb = norm2(matvec(W, u)) / alpha;
  if (qb < 1.0) {
    double tt = math::sqrt((1.0 - qb) * alpha / kap.x);
    if (V[0].x * y.x + V[0].y * y.y + V[0].z * y.z < 0.0) tt = -tt;
    y = {y.x + tt * V[0].x, y.y + tt * V[0].y, y.z + tt * V[0].z};
  }
  const double yy = norm2(y);
  const double pulls[4] = {1.0 - 0.25 * min2(1.0, max2(yy - 1.0, 0.0)), 1.0 - 1e-9, 1.0 - 1e-4, 0.999};
  for (double f : pulls)
    if (outside_certificate(towards(y, e, f), W, mW, e, me, alpha, malpha)) return NOT_INSIDE;
  const double k[3] = {kap.x, kap.y, kap.z};
  for (int i = 0; i < 3; ++i) {  // the ends of B's principal axes
    const double s = math::sqrt(alpha / k[i]) * 0.999999;
    const double signs[2] = {-1.0, 1.0};
    for (double sg : signs) {
      const Vec3 yi = {e.x + sg * s * V[i].x, e.y + sg * s * V[i].y, e.z + sg * s * V[i].z};
      if (outside_certificate(yi, W, mW, e, me, alpha, malpha)) return NOT_INSIDE;
    }
  }
  return CONTAIN_UNDECIDED;
}

// INSIDE when B is certainly inside A, NOT_INSIDE when certainly not, else CONTAIN_UNDECIDED.
ELLIPSIM_HD int8_t contains_pair(const Ellipsoid& A, const Ellipsoid& B) {
  const Vec3 &ca = A.c, &cb = B.c, &ra = A.r, &rb = B.r;
  // First, from the radii alone (most pairs end here): a semi-axis of B longer than A's.  The same-frame case
  // below never ends here: rb <= ra componentwise keeps each sorted semi-axis of B within A's.
  const Vec3 sa = sort3(ra), sb = sort3(rb);
  if ((sb.x > sa.x * tol::AXIS_SLACK) | (sb.y > sa.y * tol::AXIS_SLACK) | (sb.z > sa.z * tol::AXIS_SLACK))
    return NOT_INSIDE;  // one branch, not three
  bool same = ca.x == cb.x && ca.y == cb.y && ca.z == cb.z;
  for (int k = 0; k < 9 && same; ++k) same = A.R.m[k] == B.R.m[k];
  if (same && rb.x <= ra.x && rb.y <= ra.y && rb.z <= ra.z)
    return INSIDE;  // the same frame and no longer axes: q_A <= q_B everywhere, exactly
  const Vec3 d = sub(cb, ca);
  if (bounding_spheres_apart(ra, rb, norm2(d))) return NOT_INSIDE;
  if (!in_float_range(ra, rb)) return CONTAIN_UNDECIDED;
  const Offset<double> off = offset(ca, A.R, ra, cb);
  const Vec3 &e = off.e, &me = off.me;
  const double ee = norm2(e);
  if (positive(ee - 1.0, norm2(me) + 1.0, tol::ERR_SHORT)) return NOT_INSIDE;  // B's centre is outside A
  const Shape<double> sh = shape(A.R, ra, B.R, reciprocal(rb), true);
  InvariantsWithMag<double> inv{};
  bool have = false;
  const Vec3 w0 = column(sh.W, 0), w1 = column(sh.W, 1), w2 = column(sh.W, 2);
  const Sym3T<double> K = {norm2(w0), w0.x * w1.x + w0.y * w1.y + w0.z * w1.z, w0.x * w2.x + w0.y * w2.y + w0.z * w2.z,
                           norm2(w1), w1.x * w2.x + w1.y * w2.y + w1.z * w2.z, norm2(w2)};
  const Eigen3 eig = jacobi3(K);
  if (!(eig.kap.x > 0.0)) return CONTAIN_UNDECIDED;
  const Vec3* V = eig.V;
  const Vec3 eh = {V[0].x * e.x + V[0].y * e.y + V[0].z * e.z, V[1].x * e.x + V[1].y * e.y + V[1].z * e.z,
                   V[2].x * e.x + V[2].y * e.y + V[2].z * e.z};
  const Vec3 eh2 = {eh.x * eh.x, eh.y * eh.y, eh.z * eh.z};
  double nu = maximise_secular(eig.kap, eh2, sh.alpha, tol::CONTAIN_RTOL);
  for (int attempt = 0; attempt < 2; ++attempt) {  // a multiplier to 1e-9 settles all but ~1 pair in 50 000
    const int8_t rel = containment_certificates(nu, eig, eh, eh2, e, me, sh, inv, have);
    if (rel != CONTAIN_UNDECIDED || attempt == 1) return rel;
    nu = maximise_secular(eig.kap, eh2, sh.alpha, tol::CONTAIN_RTOL_FINE);
  }
  return CONTAIN_UNDECIDED;
}

}  // namespace ellipsim::exact
