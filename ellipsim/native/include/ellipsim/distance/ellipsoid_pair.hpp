// Signed distance, contact normal and contact point of two ellipsoids: the narrow phase
// (ellipsim/core/distance/ellipsoid_pair.py).
//
// The signed distance of two convex bodies is the maximum over unit directions n of
//     sigma(n) = n . (c_B - c_A) - h_A(n) - h_B(-n),    h(n) = |D R^T n|  (ellipsoid support function),
// positive when separated (the distance), negative when penetrating (minus the depth); at the maximiser n* the
// normal is n* (from A to B, MuJoCo's convention) and the contact point is the midpoint of the support points
// c_A + grad h_A(n*) and c_B - grad h_B(n*), as mjc_Convex reports it (engine_collision_convex.c).
//
// One Newton run (sphere_newton.hpp) from the bisector seed finds a local maximum; it is the global one
// * when sigma > 0: a concave function maximised over the unit ball has its maximum on the sphere;
// * when the depth is below rho = rolling_radius(A) + rolling_radius(B): A + (-B) is a convex body plus a ball of
//   radius rho, so depth - rho is minus the distance from the centre offset to a convex set, which has one local
//   extremum;
// * for two spheres (sigma = n.d - r_a - r_b);
// * for concentric ellipsoids with the same axes, or spheroids about a common axis (a concave function's
//   minimum over a simplex lies at a vertex);
// * for a deeper converged maximum that the ellipsoid inside A + (-B) touching it there proves (inner_sum.hpp).
// Deeper penetrations it leaves, and a first run that does not converge, go to spheroids.hpp when the two are
// spheroids with parallel axes of revolution (parallel_max) or nearly parallel ones (tilted_max), or to
// ring_max.hpp when they are spheroids only nearly (a cross-section off a circle, a float32 rotation: the maxima
// a nearly flat ring), and the rest to branch_and_bound.hpp: a branch and bound over the sphere that proves its
// answer within TOL = max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of the global maximum, or reports
// UNPROVEN when its budget runs out (two spheroids at any angle then get tilted_max and ring_max as second
// chances).
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"
#include "branch_and_bound.hpp"
#include "inner_sum.hpp"
#include "ring_max.hpp"
#include "sphere_newton.hpp"
#include "spheroids.hpp"

namespace ellipsim::distance {

namespace ellipsoid_pair {

// What signed_distance reports per pair: GLOBAL (the returned maximum is proven global, to the header's TOL),
// UNPROVEN (the branch and bound's budget ran out: the best maximum found, no proof); status.hpp's
// DistanceStatus.
constexpr int GLOBAL = 0, UNPROVEN = 1;
// pair_signed_distance_until's third status: proven at least `apart` apart (dist: sigma at the returned normal,
// a lower bound on the distance, not the distance).
constexpr int APART = 2;

// The column of R_b equal to column k of R_a or to its negative, exactly; -1 if none.
ELLIPSIM_HD int column_match(const Mat3& Ra, int k, const Mat3& Rb) {
  const double* a = Ra.m;
  const double* b = Rb.m;
  int j = -1;
  for (int i = 0; i < 3; ++i) {
    const bool same = a[k] == b[i] && a[3 + k] == b[3 + i] && a[6 + k] == b[6 + i];
    const bool opposite = a[k] == -b[i] && a[3 + k] == -b[3 + i] && a[6 + k] == -b[6 + i];
    if (same || opposite) j = i;
  }
  return j;
}

// For concentric ellipsoids (c_b - c_a = 0) the axis k of A along which sigma is largest, when that is the global
// maximum (see pair_signed_distance), else -1.  Two cases:
// * the axes coincide (every column of R_b is a column of R_a or its negative, exactly): sigma depends on n
//   through (n_1^2, n_2^2, n_3^2) on the simplex;
// * both are spheroids about a common axis (a column of R_b is column k of R_a or its negative, exactly, and
//   each has equal semi-axes across it; B's other columns may be any rotation about it): sigma depends on n
//   through (n_k^2, 1 - n_k^2), and across the axis A's axis k+1 is as good as any direction (up to B's
//   rotation defect, which the header's TOL counts).
ELLIPSIM_HD int concentric_coaxial_axis(const Vec3& d, const Mat3& Ra, const Mat3& Rb, const Vec3& ra, const Vec3& rb) {
  using spheroids::at;
  if (d.x != 0.0 || d.y != 0.0 || d.z != 0.0) return -1;
  double best = -INFINITY;
  int kbest = -1;
  for (int k = 0; k < 3; ++k) {
    const int j = column_match(Ra, k, Rb);
    if (j < 0) {
      kbest = -1;
      break;
    }
    const double v = -(at(ra, k) + at(rb, j));
    if (v > best) {
      best = v;
      kbest = k;
    }
  }
  if (kbest >= 0) return kbest;
  for (int k = 0; k < 3; ++k) {
    const int j = column_match(Ra, k, Rb);
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
    if (j >= 0 && at(ra, k1) == at(ra, k2) && at(rb, j1) == at(rb, j2))
      return -(at(ra, k) + at(rb, j)) >= -(at(ra, k1) + at(rb, j1)) ? k : k1;
  }
  return -1;
}

// spheroids' parallel_max for the pair in A's frame, or, when A is a sphere (MuJoCo passes a sphere geom as g1,
// its frame the body's, unrelated to the limb's axis), in B's frame (a sphere is one in any frame): (proven,
// unit n in A's frame, nodes).  In B's frame the tolerance is B's (its rotation's defect in place of A's), less
// 16 u S for taking n back to A's frame (sigma is S-Lipschitz, n moves by ~4 u); n is (0, 0, 0) when
// parallel_max gives no direction.
ELLIPSIM_HD SpheroidMax parallel_spheroids(const Vec3& d, const Mat3& Ra, const Vec3& ra, const Mat3& Rb,
                                           const Vec3& rb, const Vec3& e, const Mat3& Ub, double tol_bb, double S,
                                           double rmin) {
  constexpr double U = tol::U;
  if (!(ra.x == ra.y && ra.y == ra.z)) return parallel_max(e, ra, Ub, rb, tol_bb, S);
  if (rb.x == rb.y && rb.y == rb.z) return {false, {0.0, 0.0, 0.0}, 0};
  const AFrame fb = a_frame({{0.0, 0.0, 0.0}, Rb, rb}, {{-d.x, -d.y, -d.z}, Ra, ra});
  const double delta = rotation_defect(Rb) + 4.0 * U;
  const double tol = max2(tol::BB_TOL_REL * rmin, (tol::BB_TOL_ULPS * U + 6.0 * delta) * S);
  const SpheroidMax r =
      parallel_max(fb.e, rb, fb.U, ra, tol - (tol::BB_FRAME_ULPS * U + 6.0 * delta + 16.0 * U) * S, S);
  if (norm2(r.n) < 0.5) return {false, r.n, r.nodes};
  // from B to A in B's frame -> from A to B in A's frame
  const Vec3 w = matvec(Rb, r.n);
  return {r.proven, unit(rotate_t(Ra, {-w.x, -w.y, -w.z})), r.nodes};
}

// (r_min, S, delta, tol_bb) of deep_tolerance.
struct DeepTolerance {
  double rmin, S, delta, tol_bb;
};

// The deep branch's scale, R_A's orthonormality defect and the tolerance left to its proof once the frame change
// is paid: the returned maximum is within TOL = max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of the global
// one (the header's comment).
ELLIPSIM_HD DeepTolerance deep_tolerance(const Vec3& e, const Mat3& Ra, const Vec3& ra, const Vec3& rb) {
  constexpr double U = tol::U;
  const double rmin = min2(min2(min2(min2(min2(ra.x, ra.y), ra.z), rb.x), rb.y), rb.z);
  const double S = math::sqrt(norm2(e)) + max3(ra) + max3(rb);
  const double delta = rotation_defect(Ra) + 4.0 * U;
  const double tol = max2(tol::BB_TOL_REL * rmin, (tol::BB_TOL_ULPS * U + 6.0 * delta) * S);
  return {rmin, S, delta, tol - (tol::BB_FRAME_ULPS * U + 6.0 * delta) * S};
}

// Whether inner_sum.hpp's bound proves sigma(n) within the deep branch's tolerance of max sigma (sigma(n) as
// evaluated, its rounding BB_ERR_SIGMA_ULPS u S counted against it).
ELLIPSIM_HD bool inner_sum_proves(const Vec3& n, const Vec3& e, const Mat3& Ra, const Vec3& ra, const Mat3& Ub,
                                  const Vec3& rb) {
  const DeepTolerance dt = deep_tolerance(e, Ra, ra, rb);
  const double v = sigma_only(n, e, ra, Ub, rb);
  return inner_sum_bound(n, e, ra, Ub, rb, v) <= v - tol::BB_ERR_SIGMA_ULPS * tol::U * dt.S + dt.tol_bb;
}

}  // namespace ellipsoid_pair

// (status, dist, normal, pos, work) of two ellipsoids.
struct PairDistance {
  int status;
  double dist;
  Vec3 normal, pos;
  int64_t work;
};

namespace ellipsoid_pair {

// (status, dist, normal, pos, steps) at the unit n of A's frame: dist the given value, or, with recompute,
// sigma(n); the contact point the midpoint of the support points (pair_signed_distance).
ELLIPSIM_HD PairDistance contact_at(const Vec3& ca, const Mat3& Ra, const Vec3& ra, const Vec3& rb, const Vec3& e,
                                    const Mat3& Ub, const Vec3& n, double u, double value, bool recompute, int status,
                                    int64_t steps) {
  // h_A, h_B at n through U (as branch_and_bound's sigma_only: errs by <= 11 u S, where through
  // M = U diag(b^2) U^T it errs by ~u max b^2 / h_B, beyond 1e-12 r_min for 100:1 ellipsoids) ...
  const Vec3 x = {ra.x * n.x, ra.y * n.y, ra.z * n.z};
  const Vec3 w = rotate_t(Ub, n);
  const Vec3 y = {rb.x * w.x, rb.y * w.y, rb.z * w.z};
  const double ha = math::sqrt(x.x * x.x + x.y * x.y + x.z * x.z);
  const double hb = math::sqrt(y.x * y.x + y.y * y.y + y.z * y.z);
  if (recompute) value = n.x * e.x + n.y * e.y + n.z * e.z - ha - hb;  // sigma at Newton's maximiser
  // ... and the support points grad h_A(n) = diag(a) x / h_A, grad h_B(n) = U diag(b) y / h_B, in A's frame,
  // their midpoint with B's taken from its centre e, then world
  const double inv = 0.5 / (ha * hb);
  const double ia = hb * inv, ib = ha * inv;
  const Vec3 b = matvec(Ub, {rb.x * y.x, rb.y * y.y, rb.z * y.z});
  const Vec3 mid = {ra.x * x.x * ia + 0.5 * e.x - b.x * ib, ra.y * x.y * ia + 0.5 * e.y - b.y * ib,
                    ra.z * x.z * ia + 0.5 * e.z - b.z * ib};
  const Vec3 normal = matvec(Ra, n);
  const Vec3 p = matvec(Ra, mid);
  const double iu = 1.0 / u;  // exact: u is a power of two
  return {status, value * iu, normal, {ca.x + p.x * iu, ca.y + p.y * iu, ca.z + p.z * iu}, steps};
}

// The narrow phase of one pair, its first Newton run started at `seed` (pair_signed_distance_from).
ELLIPSIM_HD PairDistance pair(const Ellipsoid& A, const Ellipsoid& B, int64_t max_iter, const Vec3& seed,
                              double apart = INFINITY) {
  const Vec3 &ca = A.c, &cb = B.c;
  const Mat3 &Ra = A.R, &Rb = B.R;
  // the pair in units of unit_scale (1.0 unless a semi-axis is beyond 2^+-50): A at the origin
  const double u = unit_scale(A.r, B.r);
  const Vec3 ra = scaled(A.r, u), rb = scaled(B.r, u);
  const Vec3 d = {(cb.x - ca.x) * u, (cb.y - ca.y) * u, (cb.z - ca.z) * u};
  const AFrame f = a_frame({{0.0, 0.0, 0.0}, Ra, ra}, {d, Rb, rb});
  const Vec3 &e = f.e, &a2 = f.a2;
  const Mat3 &M = f.M, &Ub = f.U;
  const Vec3 rb2 = {rb.x * rb.x, rb.y * rb.y, rb.z * rb.z};
  const double scale = max2(max2(max2(max2(max2(ra.x, ra.y), ra.z), rb.x), rb.y), rb.z);
  const double rho = rolling_radius(ra) + rolling_radius(rb);
  const double ss = norm2(seed);
  Vec3 start;
  if (1e-6 < ss && ss < 1e6) {  // (a torn or garbage seed is only a worse start: see pair_signed_distance_from)
    start = unit(rotate_t(Ra, seed));
  } else {
    start = bisector_seed(e, a2, Ub, rb2);
  }
  const int iters = int(min2(max_iter, int64_t(tol::FIRST_RUN_ITER)));
  const NewtonResult first = apart < INFINITY ? newton<true>(start, e, a2, M, scale, -INFINITY, iters, apart * u)
                                              : newton(start, e, a2, M, scale, -INFINITY, iters);
  if (first.status == REACHED) return contact_at(ca, Ra, ra, rb, e, Ub, first.n, u, first.value, false, APART, first.steps);
  Vec3 n = first.n;
  double value = first.value;
  const int run = first.status;
  int64_t steps = first.steps;
  int status = GLOBAL;
  const bool spheres = ra.x == ra.y && ra.y == ra.z && rb.x == rb.y && rb.y == rb.z;
  const bool shallow = run == CONVERGED && (value >= -rho || spheres);
  const int k = concentric_coaxial_axis(d, Ra, Rb, ra, rb);
  if (k >= 0) {
    // sigma = -(sqrt(sum a_i^2 x_i) + sqrt(sum b_j(i)^2 x_i)) with x_i = n_i^2 on the simplex: the sum of square
    // roots of linear functions is concave in x, so its minimum lies at a vertex, an axis (Rockafellar, Convex
    // Analysis, Cor. 32.3.2).  Its maxima form circles when semi-axes repeat, which the branch and bound cannot
    // isolate.
    n = {k == 0 ? 1.0 : 0.0, k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0};
    value = sigma_only(n, e, ra, Ub, rb);
  } else if (!shallow && run == CONVERGED && inner_sum_proves(n, e, Ra, ra, Ub, rb)) {
    // deep: the first run's maximum, proven global by the ellipsoid inside A + (-B) touching there
    value = sigma_only(n, e, ra, Ub, rb);
  } else if (!shallow) {
    // deep, or the first run stalled: spheroids with parallel axes (maxima on circles, or nearly flat along
    // them) by the 1-D branch and bound of spheroids.hpp, else the branch and bound over the sphere, seeded
    // with the first run's maximum
    const DeepTolerance dt = deep_tolerance(e, Ra, ra, rb);
    const double S = dt.S, tol_bb = dt.tol_bb;
    const SpheroidMax ps = parallel_spheroids(d, Ra, ra, Rb, rb, e, Ub, tol_bb, S, dt.rmin);
    const Vec3& nc = ps.n;
    int64_t count = ps.nodes;
    if (ps.proven) {
      n = nc;
      value = sigma_only(n, e, ra, Ub, rb);
    } else {
      bool have = run == CONVERGED;
      const bool near = norm2(nc) > 0.5;
      if (near) {  // nearly parallel spheroids: a climb from the parallel model's maximiser
        const Climb cl = climb(nc, e, ra, M, scale);  // converged or not (along the circle sigma is
        Vec3 m = cl.m;
        const double vc = sigma_only(nc, e, ra, Ub, rb);  // flat), the better
        double v = sigma_only(m, e, ra, Ub, rb);
        if (vc > v) {
          m = nc;
          v = vc;
        }
        if (!have || v > value) {
          n = m;
          value = v;
          have = true;
        }
      }
      int bb = branch_and_bound::UNPROVEN;
      if (near) {  // nearly parallel: the 2-D branch and bound first (spheroids' tilted_max), from the climb
        const SpheroidMax tm = tilted_max(e, ra, Ub, rb, tol_bb, S, n);
        n = tm.n;
        count += tm.nodes;
        value = sigma_only(n, e, ra, Ub, rb);
        if (tm.proven) bb = branch_and_bound::GLOBAL;
      }
      if (near && bb != branch_and_bound::GLOBAL) {  // not spheroids to the tolerance: nearly, the maxima a ring
        const SpheroidMax rm = ring_max(e, ra, Ub, rb, tol_bb, S, n);
        count += rm.nodes;
        if (rm.proven) {
          bb = branch_and_bound::GLOBAL;
          n = rm.n;
          value = sigma_only(n, e, ra, Ub, rb);
        }
      }
      if (bb != branch_and_bound::GLOBAL) {
        const GlobalMax gm = global_max(n, value, have, e, ra, Ub, rb, M, scale, tol_bb, tol::BB_MAX_PATCHES);
        bb = gm.status;
        n = gm.n;
        value = gm.value;
        count += gm.count;
      }
      if (bb == branch_and_bound::UNPROVEN && !near) {  // two spheroids at any angle: the 2-D one as a second chance
        const SpheroidMax tm = tilted_max(e, ra, Ub, rb, tol_bb, S, n);
        count += tm.nodes;
        if (tm.proven) {
          bb = branch_and_bound::GLOBAL;
          n = tm.n;
          value = sigma_only(tm.n, e, ra, Ub, rb);
        }
      }
      if (bb == branch_and_bound::UNPROVEN && !near) {  // nearly spheroidal, not found near parallel: a last chance
        const SpheroidMax rm = ring_max(e, ra, Ub, rb, tol_bb, S, n);
        count += rm.nodes;
        if (rm.proven) {
          bb = branch_and_bound::GLOBAL;
          n = rm.n;
          value = sigma_only(n, e, ra, Ub, rb);
        }
      }
      status = bb == branch_and_bound::GLOBAL || bb == branch_and_bound::SEPARATED_MAX ? GLOBAL : UNPROVEN;
    }
    steps += count;
  }
  return contact_at(ca, Ra, ra, rb, e, Ub, n, u, value, k < 0 && shallow, status, steps);
}

}  // namespace ellipsoid_pair

// (status, dist, normal (unit, from A to B), pos, work) of two ellipsoids in world coordinates.  dist > 0:
// distance; < 0: minus the penetration depth.  pos: midpoint of the two support points (MuJoCo's contact
// position).  status: GLOBAL or UNPROVEN (the header's comment).  work: Newton steps of the first run plus
// branch-and-bound nodes.
ELLIPSIM_HD PairDistance pair_signed_distance(const Ellipsoid& A, const Ellipsoid& B,
                                              int64_t max_iter = tol::NEWTON_MAX_ITER) {
  return ellipsoid_pair::pair(A, B, max_iter, {0.0, 0.0, 0.0});
}

// pair_signed_distance with the first Newton run started at `seed` (world frame, any length; (0, 0, 0), or a
// vector too short to normalise, for the bisector seed): the warm start of the MuJoCo glue, seeded with the pair's
// normal of the previous step.  The seed only chooses where the first run starts: which local maximum is proven
// global, and how, is decided as in pair_signed_distance, so the result satisfies the same contract from any
// seed, a wrong one included; from a good one Newton converges in 1-2 steps instead of 3-5.
ELLIPSIM_HD PairDistance pair_signed_distance_from(const Ellipsoid& A, const Ellipsoid& B, const Vec3& seed) {
  return ellipsoid_pair::pair(A, B, tol::NEWTON_MAX_ITER, seed);
}

// pair_signed_distance, stopped where an iterate of the first Newton run proves the pair at least `apart` apart
// (status APART, dist that lower bound, >= apart): the narrow phase of a pair with a contact margin, which needs
// the distance only below it (ellipsim/native/warp/narrowphase.hpp).  Below `apart` it is pair_signed_distance.
ELLIPSIM_HD PairDistance pair_signed_distance_until(const Ellipsoid& A, const Ellipsoid& B, double apart) {
  return ellipsoid_pair::pair(A, B, tol::NEWTON_MAX_ITER, {0.0, 0.0, 0.0}, apart);
}

// (sigma, normal, pos) of contact_at.
struct ContactAt {
  double value;
  Vec3 normal, pos;
};

// (sigma, normal, pos) of two ellipsoids at the direction n (world frame, nonzero, any length): the lower bound
// sigma(n / |n|) on their signed distance (no proof it is the maximum), the unit normal and the contact point as
// pair_signed_distance gives them at its maximiser.  The MuJoCo glue's answer for a pair whose maximum is not
// proven, at the better of ellipsim's and MuJoCo's normals.
ELLIPSIM_HD ContactAt contact_at(const Ellipsoid& A, const Ellipsoid& B, const Vec3& n) {
  const Vec3 &ca = A.c, &cb = B.c;
  const double u = unit_scale(A.r, B.r);
  const Vec3 ra = scaled(A.r, u), rb = scaled(B.r, u);
  const Vec3 d = {(cb.x - ca.x) * u, (cb.y - ca.y) * u, (cb.z - ca.z) * u};
  const AFrame f = a_frame({{0.0, 0.0, 0.0}, A.R, ra}, {d, B.R, rb});
  const PairDistance r = ellipsoid_pair::contact_at(ca, A.R, ra, rb, f.e, f.U, unit(rotate_t(A.R, n)), u, 0.0, true,
                                                    ellipsoid_pair::UNPROVEN, 0);
  return {r.dist, r.normal, r.pos};
}

// A lower bound on the signed distance of A and B from one direction n (world frame, any nonzero length):
// sigma(n / |n|) minus its rounding allowance; -inf where no bound is given.
//
// The signed distance is the maximum of sigma over unit directions, so sigma at any direction bounds it from
// below; with the body taken as c + R diag(r) ball for the float R as given (MuJoCo's support mapping),
// h = |diag(r) R^T n| exactly, orthonormal R or not.  Rounding, S = |d|_1 + max r_A + max r_B: <= 34 u S
// (ellipsoid_pair.py counts it); WARM_SIGMA_SLACK_ULPS of it is taken.  Only for semi-axes and |d| within
// [WARM_SCALE_MIN, WARM_SCALE_MAX] (no underflow in the squares, no overflow).
ELLIPSIM_HD double sigma_lower_bound(const Ellipsoid& A, const Ellipsoid& B, const Vec3& n) {
  const Vec3 &ca = A.c, &cb = B.c, &ra = A.r, &rb = B.r;
  const double nn = norm2(n);
  if (!(1e-6 < nn && nn < 1e6)) return -INFINITY;
  const double s = 1.0 / math::sqrt(nn);
  const Vec3 m = {n.x * s, n.y * s, n.z * s};
  const Vec3 d = {cb.x - ca.x, cb.y - ca.y, cb.z - ca.z};
  const double amax = max3(ra), bmax = max3(rb);
  const double S = math::fabs(d.x) + math::fabs(d.y) + math::fabs(d.z) + amax + bmax;
  const double lo = min2(min2(min2(min2(min2(ra.x, ra.y), ra.z), rb.x), rb.y), rb.z);
  if (!(lo >= tol::WARM_SCALE_MIN && S <= tol::WARM_SCALE_MAX)) return -INFINITY;
  const Vec3 za = rotate_t(A.R, m), zb = rotate_t(B.R, m);
  const double x0 = ra.x * za.x, x1 = ra.y * za.y, x2 = ra.z * za.z;
  const double y0 = rb.x * zb.x, y1 = rb.y * zb.y, y2 = rb.z * zb.z;
  const double v = m.x * d.x + m.y * d.y + m.z * d.z - math::sqrt(x0 * x0 + x1 * x1 + x2 * x2) -
                   math::sqrt(y0 * y0 + y1 * y1 + y2 * y2);
  return v - tol::WARM_SIGMA_SLACK_ULPS * tol::U * S;
}

}  // namespace ellipsim::distance
