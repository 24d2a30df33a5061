// Proven maximum of sigma for two spheroids with parallel or nearly parallel axes of revolution (issue 18;
// ellipsim/core/distance/spheroids.py, whose docstring has the bounds).
//
// When A and B are spheroids (or a spheroid and a sphere) whose axes of revolution are parallel to a line w,
// sigma(n) = n.e - h_A(n) - h_B(n) depends on n only through its angle t to w and its azimuth phi about w, and
// only the offset e sees the azimuth: the maximum over the sphere is the maximum of two coaxial ellipses'
// sigma in the plane of w and e_perp (Schneider & Eberly, Geometric Tools 10.5.2: h(n) = |D R^T n|, which for a
// spheroid depends on (n.w)^2 only):
//   g(z, r) = e_k z + |e_perp| r - sqrt(qa^2 z^2 + pa^2 r^2) - sqrt(qb^2 z^2 + pb^2 r^2),  (z, r) = (cos t, sin t),
// maximised by a branch and bound over t in [0, pi] with the concave majorant of branch_and_bound.hpp in two
// dimensions (parallel_max).  The pair need not be exactly of revolution nor exactly parallel: sigma is within
// delta of the model (spheroids.py), and the 1-D branch and bound runs to tol - 2 delta - ERR_G - ERR_SIGMA.
// Axes tilted by more than about tol / max b go to tilted_max: a branch and bound over both angles about A's
// axis (axis_bb) that keeps B's tilt exactly and bounds sigma on a cell by its second-order Taylor expansion,
// the second partials bounded in midpoint-radius (ball) interval arithmetic.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"

namespace ellipsim::distance {

namespace spheroids {

constexpr double U64 = 0x1p-53;
constexpr int MAX_LEVEL = 52;  // arcs of pi 2^-52: far below any tolerance reached
// Rounding, S = |e| + max a + max b: g at a float point c = (cos t, sin t) errs by <= 3 u |e| (two products, a
// sum) + 2.5 u max a + 2.5 u max b (each root of a sum of two rounded products of rounded squares) + 2 u S (the
// subtractions) + u S (|c| = 1 +- u, g is 1-homogeneous): ERR_G = 8 u S covers it; an arc's bound adds ~4 u S
// of its own sum to that (the gradient's error is epsg, times rho):
constexpr double ERR_G_ULPS = 8.0;
constexpr double ARC_SLACK_ULPS = 12.0;
constexpr double CANDIDATE_TILT = tol::PARALLEL_CANDIDATE_TILT;

constexpr double PI = 3.141592653589793;  // math.pi

constexpr double ERR_C_ULPS = 16.0;    // sigma_m at a float centre: cos, sin rounded (n within ~3 u), the roots, sums
constexpr int TILT_LEVELS = 52;        // cells of pi 2^-52 in either direction: far below any tolerance's width
constexpr int TILT_DEPTH = 62;         // splits along one root-to-leaf path (their directions are bits of one int64)
constexpr int ROOT_T = 2, ROOT_P = 3;  // 4 x 8 root cells over [0, T] x [-T, T]
constexpr double T_DOMAIN = 3.1415926535897936;  // the float above pi: the cells cover [0, pi] x [-pi, pi]
constexpr double U4 = 4.0 * U64;

// v[k] of a 3-vector, a negative k counting from the end (a numba tuple's index).
ELLIPSIM_HD double at(const Vec3& v, int k) {
  if (k < 0) k += 3;
  return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

// M.m[k], a negative k counting from the end.
ELLIPSIM_HD double at(const Mat3& M, int k) { return M.m[k < 0 ? k + 9 : k]; }

// 2^-L for 0 <= L <= 62, exactly (numba's float ** int: 1 / 2^L by repeated squaring, exact for a power of two).
ELLIPSIM_HD double pow2_neg(int L) { return 1.0 / double(int64_t(1) << L); }

// (g(z, r), G = grad g, h_A, h_B).
struct GGrad {
  double g, G0, G1, ha, hb;
};

ELLIPSIM_HD GGrad g_grad(double z, double r, double ek, double ep, double qa2, double pa2, double qb2, double pb2) {
  const double ha = math::sqrt(qa2 * z * z + pa2 * r * r);
  const double hb = math::sqrt(qb2 * z * z + pb2 * r * r);
  const double ia = 1.0 / ha, ib = 1.0 / hb;
  return {ek * z + ep * r - ha - hb, ek - qa2 * z * ia - qb2 * z * ib, ep - pa2 * r * ia - pb2 * r * ib, ha, hb};
}

// g <= lv on the arc |n - c| <= rho around the unit c = (z, r): branch_and_bound's test in 2-D.
ELLIPSIM_HD bool arc_test(double z, double r, double rho, double g, double G0, double G1, double epsg, double lv) {
  const double gc = G0 * z + G1 * r;
  const double gt = math::fabs(G1 * z - G0 * r);  // |G - (G.c) c|
  return g + (gt + epsg) * rho + max2(-gc, 0.0) * rho * rho * 0.5000000000001 <= lv;
}

// The axis k whose two other semi-axes are closest to equal, and half their difference.
struct AxisOf {
  int k;
  double half;
};

ELLIPSIM_HD AxisOf axis_of(const Vec3& r) {
  double best = INFINITY;
  int kb = 0;
  for (int k = 0; k < 3; ++k) {
    const double d = math::fabs(at(r, (k + 1) % 3) - at(r, (k + 2) % 3));
    if (d < best) {
      best = d;
      kb = k;
    }
  }
  return {kb, 0.5 * best};
}

// (j, qb, pb, delta0, tilt, eps) of delta.
struct Delta {
  int j;
  double qb, pb, delta0, tilt, eps;
};

// B's axis nearest to A's axis k and the bound delta = delta0 + tilt of spheroids.py's docstring (upwards; tilt
// its term in eps), with A's and B's semi-axes across their axes taken as their means.
ELLIPSIM_HD Delta delta(const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b, int k, double S) {
  using math::fabs;
  (void)e;
  const double dbb = axis_of(b).half;
  int j = -1;
  double db = INFINITY;
  for (int jj = 0; jj < 3; ++jj) {  // B's axes of revolution (any, for a sphere): the one nearest to A's axis k
    const double d = 0.5 * fabs(at(b, (jj + 1) % 3) - at(b, (jj + 2) % 3));
    if (d <= dbb * (1.0 + 1e-9) && (j < 0 || fabs(at(U, 3 * k + jj)) > fabs(at(U, 3 * k + j)))) {
      j = jj;
      db = d;
    }
  }
  const int k1 = (k + 1) % 3, k2 = (k + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  const double qb = at(b, j), pb = 0.5 * (at(b, j1) + at(b, j2));
  const double ujk = at(U, 3 * k + j);
  const double s = ujk >= 0.0 ? 1.0 : -1.0;
  const double uk1 = at(U, 3 * k1 + j), uk2 = at(U, 3 * k2 + j);
  const double eps = math::sqrt(uk1 * uk1 + uk2 * uk2 + (ujk - s) * (ujk - s));
  double dfu = 0.0;
  for (int p = 0; p < 3; ++p) {
    for (int q = p; q < 3; ++q) {
      const double v = U.m[3 * p] * U.m[3 * q] + U.m[3 * p + 1] * U.m[3 * q + 1] + U.m[3 * p + 2] * U.m[3 * q + 2] -
                       (p == q ? 1.0 : 0.0);
      dfu = max2(dfu, fabs(v));
    }
  }
  dfu += 4.0 * U64;  // each entry: three products and their sums, <= 3 u, and the - 1
  // |U^T n|^2 = 1 +- 3 def moves h_B^2 by <= 3 pb^2 def, so h_B by that over h_B + its model >= 2 min(qb, pb)
  const double delta0 =
      0.5 * fabs(at(a, k1) - at(a, k2)) + db * (1.0 + 3.0 * dfu) + 1.5 * pb * pb * dfu / (min2(qb, pb) * (1.0 - 1e-9));
  const double tilt = fabs(qb * qb - pb * pb) * eps * (2.0 + eps) / min2(qb, pb);
  return {j, qb, pb, delta0 * (1.0 + 1e-12) + 6.0 * U64 * S, tilt * (1.0 + 1e-12), eps};
}

}  // namespace spheroids

// (proven, unit n, nodes) of parallel_max and tilted_max.
struct SpheroidMax {
  bool proven;
  Vec3 n;
  int64_t nodes;
};

// The proven maximum of sigma(n) = n.e - |diag(a) n| - |diag(b) U^T n| on the unit sphere for two spheroids with
// (near) parallel axes, in A's frame (the header's comment).
//
// tol: the tolerance to prove (global_max's tol_bb).  When proven, max sigma <= sigma(n) + tol for the exact
// sigma of (e, a, U, b); n lies in the plane of A's axis k and e_perp (of A's axes k and k + 1 when e_perp = 0:
// any azimuth is as good there).  Not proven when the axes are too far from parallel (2 delta + ERR_G +
// ERR_SIGMA leaves less than the arcs' rounding slack of tol) or the node budget runs out.  n is then the
// maximiser of the parallel model when the pair is within CANDIDATE_TILT of it (a start for
// branch_and_bound.hpp: there the true maxima are within 2 delta of that model's), else (0, 0, 0).
ELLIPSIM_HD SpheroidMax parallel_max(const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b, double tol, double S) {
  using namespace spheroids;
  const SpheroidMax none = {false, {0.0, 0.0, 0.0}, 0};
  const int k = axis_of(a).k;
  const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  const Delta dl = delta(e, a, U, b, k, S);
  const double qb = dl.qb, pb = dl.pb, eps = dl.eps;
  const double dlt = dl.delta0 + dl.tilt;
  const double qa = at(a, k), pa = 0.5 * (at(a, k1) + at(a, k2));
  const double amax = max3(a), bmax = max3(b);
  const double slack = ARC_SLACK_ULPS * U64 * S;
  const double tol1 = tol - 2.0 * dlt - (ERR_G_ULPS + tol::BB_ERR_SIGMA_ULPS) * U64 * S;
  const bool provable = tol1 >= (ARC_SLACK_ULPS + 4.0) * U64 * S;
  if (!provable && !(eps <= CANDIDATE_TILT && dlt <= CANDIDATE_TILT * S)) return none;
  const double ek = at(e, k), ep = math::sqrt(at(e, k1) * at(e, k1) + at(e, k2) * at(e, k2));
  const double qa2 = qa * qa, pa2 = pa * pa, qb2 = qb * qb, pb2 = pb * pb;
  // incumbent: the best of 33 angles, polished by Newton in t (only a start: the branch and bound proves
  // whatever it ends with)
  double best = -INFINITY, bt = 0.0;
  for (int i = 0; i < 33; ++i) {
    const double t = PI * double(i) / 32.0;
    const double g = g_grad(math::cos(t), math::sin(t), ek, ep, qa2, pa2, qb2, pb2).g;
    if (g > best) {
      best = g;
      bt = t;
    }
  }
  double t = bt;
  for (int it = 0; it < 30; ++it) {
    const double z = math::cos(t), r = math::sin(t);
    const GGrad gg = g_grad(z, r, ek, ep, qa2, pa2, qb2, pb2);
    const double ha = gg.ha, hb = gg.hb;
    // g(t) = ek cos t + ep sin t - sqrt(alpha) - sqrt(beta), alpha = pa2 + (qa2 - pa2) cos^2 t
    const double d1 = gg.G1 * z - gg.G0 * r;
    const double s2 = math::sin(2.0 * t), c2 = math::cos(2.0 * t);
    const double al1 = -(qa2 - pa2) * s2, be1 = -(qb2 - pb2) * s2;
    const double al2 = -2.0 * (qa2 - pa2) * c2, be2 = -2.0 * (qb2 - pb2) * c2;
    double d2 = -ek * z - ep * r - (al2 / (2.0 * ha) - al1 * al1 / (4.0 * ha * ha * ha));
    d2 -= be2 / (2.0 * hb) - be1 * be1 / (4.0 * hb * hb * hb);
    if (!(d2 < 0.0)) break;
    double step = max2(-0.2, min2(0.2, -d1 / d2));
    bool gained = false;
    double tn = 0.0, gn = 0.0;
    for (int back = 0; back < 40; ++back) {  // backtracking: a full Newton step may overshoot a sharp peak
      tn = min2(PI, max2(0.0, t + step));
      gn = g_grad(math::cos(tn), math::sin(tn), ek, ep, qa2, pa2, qb2, pb2).g;
      if (gn >= best) {
        gained = true;
        break;
      }
      step *= 0.5;
    }
    if (!gained) break;
    best = gn;
    bt = tn;
    t = tn;
    if (math::fabs(step) < 1e-15) break;
  }
  // the branch and bound over the arcs (level L, index i) of [0, pi], depth first, no allocation
  int64_t nodes = 0;
  int L = 1;
  int64_t i = 0;
  while (provable) {
    nodes += 1;
    if (nodes > tol::COAXIAL_MAX_NODES) return none;
    const double w = PI * pow2_neg(L);
    const double tc = w * (double(i) + 0.5);
    const double z = math::cos(tc), r = math::sin(tc);
    const GGrad gg = g_grad(z, r, ek, ep, qa2, pa2, qb2, pb2);
    if (gg.g > best) {
      best = gg.g;
      bt = tc;
    }
    const double rho = 0.5 * w * (1.0 + 1e-15) + 4.0 * U64;  // chord <= half the arc's length; c rounded by a few u
    const double epsg = U64 * (32.0 * (S + amax * amax / gg.ha + bmax * bmax / gg.hb) + 16.0 * S);
    if (arc_test(z, r, rho, gg.g, gg.G0, gg.G1, epsg, best + tol1 - slack)) {
      while ((i & 1) == 1 && L > 1) {  // the next arc after this one's subtree
        i >>= 1;
        L -= 1;
      }
      if ((i & 1) == 1) break;
      i += 1;
    } else if (L >= MAX_LEVEL) {
      return none;
    } else {
      L += 1;
      i *= 2;
    }
  }
  const double z = math::cos(bt), r = math::sin(bt);
  double u1 = 1.0, u2 = 0.0;
  if (ep > 0.0) {
    u1 = at(e, k1) / ep;
    u2 = at(e, k2) / ep;
  }
  const double x = r * u1, y = r * u2;  // (z, x, y) along A's axes (k, k1, k2)
  if (k == 0) return {provable, {z, x, y}, nodes};
  if (k == 1) return {provable, {y, z, x}, nodes};
  return {provable, {x, y, z}, nodes};
}

// --- Nearly parallel axes: a branch and bound over (t, phi) with second-order bounds -----------------------
//
// For spheroids whose axes are tilted by tau from parallel, the maxima of sigma are no longer a circle nor
// nearly flat isolated points of the parallel model: along the circle sigma varies by O(tau max b) and across it
// by O(max b).  Here n = (cos t, sin t cos phi, sin t sin phi) along A's axes (k, k + 1, k + 2), and the model
//   sigma_m(t, phi) = n.e - sqrt(qa^2 cos^2 t + pa^2 sin^2 t) - sqrt(pb^2 + (qb^2 - pb^2) (u.n)^2)
// (u = B's axis j in A's frame, as given: no tilt is modelled away; |sigma - sigma_m| <= delta0) is smooth in
// (t, phi), poles included.  On a cell [tc +- ht] x [pc +- hp], Taylor's theorem with the Lagrange remainder
// gives sigma_m <= sigma_m(c) + q(s_t, Mtt, ht) + q(s_p, Mpp, hp) + Ktp ht hp, q(g, M, h) = max_{|d| <= h}
// g d + M d^2 / 2, with Mtt, Mpp upper bounds of the second partials over the cell and Ktp of |s_tp|, evaluated
// in midpoint-radius (ball) interval arithmetic from cos, sin of the cell's centre (|cos(x + d) - cos x| <=
// |sin x| |d| + d^2 / 2).  Each cell is split in the direction whose term is larger.  Every ball operation
// widens its radius by its own rounding; the centre values carry ERR_C (sigma_m) and the gradient's epsg.

namespace spheroids {

// A ball (midpoint, radius).
struct Ball {
  double m, r;
};

// Ball product, the rounding of the midpoint added to the radius.
ELLIPSIM_HD Ball bm(const Ball& x, const Ball& y) {
  using math::fabs;
  const double m = x.m * y.m;
  return {m, fabs(x.m) * y.r + fabs(y.m) * x.r + x.r * y.r + U4 * fabs(m)};
}

// Ball sx x + sy y for exact scalars sx, sy.
ELLIPSIM_HD Ball ba(const Ball& x, const Ball& y, double sx, double sy) {
  using math::fabs;
  const double m = sx * x.m + sy * y.m;
  return {m, fabs(sx) * x.r + fabs(sy) * y.r + U4 * (fabs(sx * x.m) + fabs(sy * y.m))};
}

// Ball c x for an exact scalar c.
ELLIPSIM_HD Ball bc(double c, const Ball& x) {
  const double m = c * x.m;
  return {m, math::fabs(c) * x.r + U4 * math::fabs(m)};
}

// Balls of 1 / sqrt(Q) and 1 / sqrt(Q)^3.
struct InvRoots {
  Ball i1, i3;
};

// Balls of 1 / sqrt(Q) and 1 / sqrt(Q)^3 for Q in the ball q, known >= qlo > 0.
ELLIPSIM_HD InvRoots inv_roots(const Ball& q, double qlo) {
  const double lo = max2(q.m - q.r, qlo), hi = q.m + q.r;
  const double i_hi = (1.0 + U4) / math::sqrt(lo), i_lo = (1.0 - U4) / math::sqrt(hi);
  const double j_hi = i_hi * i_hi * i_hi * (1.0 + U4), j_lo = i_lo * i_lo * i_lo * (1.0 - U4);
  return {{0.5 * (i_hi + i_lo), 0.5 * (i_hi - i_lo) * (1.0 + U4)},
          {0.5 * (j_hi + j_lo), 0.5 * (j_hi - j_lo) * (1.0 + U4)}};
}

// Balls of cos and sin over [x - h, x + h].
struct TrigBall {
  Ball c, s;
};

ELLIPSIM_HD TrigBall trig_ball(double x, double h) {
  const double c = math::cos(x), s = math::sin(x);
  const double h2 = 0.5 * h * h;
  return {{c, (math::fabs(s) * h + h2) * (1.0 + U4) + U64}, {s, (math::fabs(c) * h + h2) * (1.0 + U4) + U64}};
}

// Balls of l and of its partials t, p, tt, pp, tp.
struct FormBalls {
  Ball l, lt, lp, ltt, lpp, ltp;
};

// Balls of l = lz cos t + sin t (lx cos phi + ly sin phi) and of its partials t, p, tt, pp, tp.
ELLIPSIM_HD FormBalls form_balls(double lz, double lx, double ly, const Ball& ct, const Ball& st, const Ball& cp,
                                 const Ball& sp) {
  const Ball m = ba(cp, sp, lx, ly);
  const Ball mq = ba(sp, cp, -lx, ly);  // d m / d phi
  const Ball l = ba(ct, bm(st, m), lz, 1.0);
  const Ball lt = ba(st, bm(ct, m), -lz, 1.0);
  const Ball lp = bm(st, mq);
  const Ball lpp = bc(-1.0, bm(st, m));
  const Ball ltp = bm(ct, mq);
  return {l, lt, lp, {-l.m, l.r}, lpp, ltp};
}

// Ball of d2 sqrt(Q) = Q_xy / (2 sqrt Q) - Q_x Q_y / (4 sqrt(Q)^3).
ELLIPSIM_HD Ball root_second(const Ball& qxy, const Ball& qx, const Ball& qy, const Ball& i1, const Ball& i3) {
  return ba(bm(qxy, i1), bm(bm(qx, qy), i3), 0.5, -0.25);
}

// (h_A, dh_A / dt).
struct HaAt {
  double ha, ha_t;
};

// (h_A, dh_A / dt) at a point: hk = 0 a spheroid, sqrt(h1 cos^2 t + h2 sin^2 t) (h1, h2 the squared semi-axes
// along and across the pole); hk = 1 a cylinder, h1 |cos t| + h2 sin t (h1 its half-length, h2 its radius), each
// of its two pieces h1 s cos t + h2 sin t (s = +-1) an extension that is <= the cylinder's sigma term
// -h1 |cos t| nowhere below it: -|x| = min(x, -x), so sigma <= the piece's model.
ELLIPSIM_HD HaAt ha_at(int hk, double h1, double h2, double ct, double st) {
  if (hk == 0) {
    const double ha = math::sqrt(h1 * ct * ct + h2 * st * st);
    return {ha, (h2 - h1) * st * ct / ha};
  }
  const double sg = ct >= 0.0 ? 1.0 : -1.0;
  return {h1 * sg * ct + h2 * st, -h1 * sg * st + h2 * ct};
}

// Balls of s_tt, s_pp, s_tp.
struct HessianBalls {
  Ball tt, pp, tp;
};

// Balls of s_tt, s_pp, s_tp of sigma_m over the cell (tc +- ht, pc +- hp); a cylinder's piece is the one of the
// cell's centre.
ELLIPSIM_HD HessianBalls hessian_balls(double tc, double ht, double pc, double hp, double ek, double ex, double ey,
                                       int hk, double h1, double h2, double kb, double pb2, double wz, double wx,
                                       double wy, double qlo_a, double qlo_b) {
  const TrigBall tt = trig_ball(tc, ht);
  const TrigBall pt = trig_ball(pc, hp);
  const Ball &ct = tt.c, &st = tt.s, &cp = pt.c, &sp = pt.s;
  const FormBalls ef = form_balls(ek, ex, ey, ct, st, cp, sp);
  Ball hatt;
  if (hk == 0) {
    // h_A = sqrt(P), P = h1 cos^2 t + h2 sin^2 t: P_t = 2 (h2 - h1) sin t cos t, P_tt = 2 (h2 - h1) (cos^2 - sin^2)
    const Ball c2 = bm(ct, ct), s2 = bm(st, st), cs = bm(ct, st);
    const Ball P = ba(c2, s2, h1, h2);
    const Ball Pt = bc(2.0 * (h2 - h1), cs);
    const Ball Ptt = bc(2.0 * (h2 - h1), ba(c2, s2, 1.0, -1.0));
    const InvRoots ia = inv_roots(P, qlo_a);
    hatt = root_second(Ptt, Pt, Pt, ia.i1, ia.i3);
  } else {  // h1 s cos t + h2 sin t: its second derivative is minus itself
    const double sg = ct.m >= 0.0 ? 1.0 : -1.0;
    hatt = ba(ct, st, -h1 * sg, -h2);
  }
  // h_B = sqrt(Q), Q = pb2 + kb w^2
  const FormBalls w = form_balls(wz, wx, wy, ct, st, cp, sp);
  const Ball Q = ba({pb2, 0.0}, bm(w.l, w.l), 1.0, kb);
  const Ball Qt = bc(2.0 * kb, bm(w.l, w.lt)), Qp = bc(2.0 * kb, bm(w.l, w.lp));
  const Ball Qtt = bc(2.0 * kb, ba(bm(w.lt, w.lt), bm(w.l, w.ltt), 1.0, 1.0));
  const Ball Qpp = bc(2.0 * kb, ba(bm(w.lp, w.lp), bm(w.l, w.lpp), 1.0, 1.0));
  const Ball Qtp = bc(2.0 * kb, ba(bm(w.lt, w.lp), bm(w.l, w.ltp), 1.0, 1.0));
  const InvRoots ib = inv_roots(Q, qlo_b);
  const Ball hbtt = root_second(Qtt, Qt, Qt, ib.i1, ib.i3);
  const Ball hbpp = root_second(Qpp, Qp, Qp, ib.i1, ib.i3);
  const Ball hbtp = root_second(Qtp, Qt, Qp, ib.i1, ib.i3);
  const Ball stt = ba(ba(ef.ltt, hatt, 1.0, -1.0), hbtt, 1.0, -1.0);
  return {stt, ba(ef.lpp, hbpp, 1.0, -1.0), ba(ef.ltp, hbtp, 1.0, -1.0)};
}

// (sigma_m, s_t, s_p, h_A, h_B).
struct ModelAt {
  double s, s_t, s_p, ha, hb;
};

// (sigma_m, s_t, s_p, h_A, h_B) at the float (t, p).
ELLIPSIM_HD ModelAt model_at(double t, double p, double ek, double ex, double ey, int hk, double h1, double h2,
                             double kb, double pb2, double wz, double wx, double wy) {
  const double ct = math::cos(t), st = math::sin(t), cp = math::cos(p), sp = math::sin(p);
  const double me = ex * cp + ey * sp, mqe = -ex * sp + ey * cp;
  const double mw = wx * cp + wy * sp, mqw = -wx * sp + wy * cp;
  const double w = wz * ct + st * mw;
  const HaAt h = ha_at(hk, h1, h2, ct, st);
  const double hb = math::sqrt(pb2 + kb * w * w);
  const double s = ek * ct + st * me - h.ha - hb;
  const double wt = -wz * st + ct * mw, wp = st * mqw;
  const double s_t = -ek * st + ct * me - h.ha_t - kb * w * wt / hb;
  const double s_p = st * mqe - kb * w * wp / hb;
  return {s, s_t, s_p, h.ha, hb};
}

// (t, p, sigma_m) of polish.
struct Polished {
  double t, p, s;
};

// axis_bb's model: A a spheroid or a cylinder (ha_at), B a spheroid about its axis w, e in pole coordinates.
struct RevolutionModel {
  double ek, ex, ey;
  int hk;
  double h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b;
  ELLIPSIM_HD ModelAt at(double t, double p) const { return model_at(t, p, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy); }
  ELLIPSIM_HD HessianBalls hessian(double tc, double ht, double pc, double hp) const {
    return hessian_balls(tc, ht, pc, hp, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b);
  }
};

// Newton on the model's sigma in (t, phi) from (t, p) of value s (its Hessian: the balls' midpoints at a point):
// (t, p, s) no worse, only a better incumbent (the proof does not rest on it).
template <typename Model>
ELLIPSIM_HD Polished polish(double t, double p, double s, const Model& model) {
  using math::fabs;
  for (int it = 0; it < 30; ++it) {
    const ModelAt md = model.at(t, p);
    const double g1 = md.s_t, g2 = md.s_p;
    const HessianBalls hs = model.hessian(t, 0.0, p, 0.0);
    double a11 = hs.tt.m, a22 = hs.pp.m;
    const double a12 = hs.tp.m;
    // shifted to negative definite where it is not (a saddle, or flat along the circle)
    const double top = 0.5 * (a11 + a22) + math::sqrt(0.25 * (a11 - a22) * (a11 - a22) + a12 * a12);
    const double mu = 1e-9 * (fabs(a11) + fabs(a22)) + 1e-300;
    if (top > -mu) {
      a11 = a11 - top - mu;
      a22 = a22 - top - mu;
    }
    const double det = a11 * a22 - a12 * a12;
    if (!(det > 0.0)) break;
    double dt = -(a22 * g1 - a12 * g2) / det, dp = -(a11 * g2 - a12 * g1) / det;
    const double size = math::sqrt(dt * dt + dp * dp);
    if (!(size > 0.0)) break;
    if (size > 0.25) {
      dt = dt * 0.25 / size;
      dp = dp * 0.25 / size;
    }
    bool better = false;
    double tn = 0.0, pn = 0.0, sn = 0.0;
    for (int back = 0; back < 40; ++back) {  // backtracking
      tn = t + dt;
      pn = p + dp;
      if (tn < 0.0 || tn > PI) {  // the same direction with t in [0, pi], where h_A's model holds
        tn = tn < 0.0 ? -tn : 2.0 * PI - tn;
        pn = pn < 0.0 ? pn + PI : pn - PI;
      }
      sn = model.at(tn, pn).s;
      if (sn > s) {
        better = true;
        break;
      }
      dt = 0.5 * dt;
      dp = 0.5 * dp;
    }
    if (!better) break;
    t = tn;
    p = pn;
    s = sn;
  }
  return {t, p, s};
}

// max over |d| <= h of g d + M d^2 / 2 (upwards).
ELLIPSIM_HD double q(double g, double M, double h) {
  g = math::fabs(g);
  if (M < 0.0 && g <= -M * h) return g * g / (-2.0 * M) * (1.0 + U4);
  return (g * h + 0.5 * M * h * h) * (1.0 + U4) + U4 * math::fabs(M) * h * h;
}

}  // namespace spheroids

// (proven, t, p, moved, nodes) of axis_bb.
struct AxisBB {
  bool proven;
  double t, p;
  bool moved;
  int64_t nodes;
};

// The branch and bound over cells of (t, phi) for a model of sigma in pole coordinates (model.at: value and gradient
// at a point; model.hessian: balls of the second partials over a cell), from the incumbent (t0, p0) polished by
// Newton first: axis_bb's loop, for axis_bb's model and quadric_max's.  curv, bmax2: the gradient's rounding
// scales (A's and B's squared largest semi-axes).
template <typename Model>
ELLIPSIM_HD AxisBB cells_bb(const Model& model, double tol1, double S, double curv, double bmax2, double t0,
                            double p0) {
  using namespace spheroids;
  const double s0 = model.at(t0, p0).s;
  const Polished pl = spheroids::polish(t0, p0, s0, model);
  double bt = pl.t, bp = pl.p, best = pl.s;
  bool moved = best != s0;
  int64_t nodes = 0;
  for (int root = 0; root < (1 << ROOT_T) * (1 << ROOT_P); ++root) {
    int Lt = ROOT_T, Lp = ROOT_P;
    int64_t it = root >> ROOT_P, ip = root & ((1 << ROOT_P) - 1);
    int depth = 0;
    int64_t dims = 0;
    while (true) {
      nodes += 1;
      if (nodes > tol::TILTED_MAX_NODES) return {false, bt, bp, moved, nodes};
      const double wt = T_DOMAIN * pow2_neg(Lt), wp = 2.0 * T_DOMAIN * pow2_neg(Lp);
      const double tc = wt * (double(it) + 0.5), pc = -T_DOMAIN + wp * (double(ip) + 0.5);
      const double ht = 0.5 * wt * (1.0 + 1e-15) + U4 * tc;
      const double hp = 0.5 * wp * (1.0 + 1e-15) + U4 * T_DOMAIN;
      const ModelAt md = model.at(tc, pc);
      const double s = md.s;
      if (s > best) {
        if (s > best + tol1) {  // a poor incumbent: climb from the better centre
          const Polished p1 = spheroids::polish(tc, pc, s, model);
          best = p1.s;
          bt = p1.t;
          bp = p1.p;
        } else {
          best = s;
          bt = tc;
          bp = pc;
        }
        moved = true;
      }
      const HessianBalls hs = model.hessian(tc, ht, pc, hp);
      const double Mtt = hs.tt.m + hs.tt.r, Mpp = hs.pp.m + hs.pp.r, Ktp = math::fabs(hs.tp.m) + hs.tp.r;
      const double epsg = U64 * (32.0 * (S + curv / md.ha + bmax2 / md.hb) + 16.0 * S);
      const double qt = q(md.s_t, Mtt, ht) + epsg * ht, qp = q(md.s_p, Mpp, hp) + epsg * hp;
      const double cross = Ktp * ht * hp * (1.0 + U4);
      if (s + qt + qp + cross <= best + tol1) {
        while (depth > 0) {  // the next cell after this one's subtree
          const int64_t d = (dims >> (depth - 1)) & 1;
          if (d == 0) {
            if ((it & 1) == 0) {
              it += 1;
              break;
            }
            it >>= 1;
            Lt -= 1;
          } else {
            if ((ip & 1) == 0) {
              ip += 1;
              break;
            }
            ip >>= 1;
            Lp -= 1;
          }
          depth -= 1;
        }
        if (depth == 0) break;
      } else {
        bool split_p = qp > qt;
        if (split_p && Lp >= TILT_LEVELS) split_p = false;
        if ((!split_p && Lt >= TILT_LEVELS) || depth >= TILT_DEPTH) return {false, bt, bp, moved, nodes};
        if (split_p) {
          dims |= int64_t(1) << depth;
          Lp += 1;
          ip *= 2;
        } else {
          dims &= ~(int64_t(1) << depth);
          Lt += 1;
          it *= 2;
        }
        depth += 1;
      }
    }
  }
  return {true, bt, bp, moved, nodes};
}

// The branch and bound over (t, phi) of the section's comment for the model sigma_m with pole coordinates:
// e = (ek, ex, ey), A's term by (hk, h1, h2) (ha_at), B a spheroid sqrt(pb2 + kb (w.n)^2) with its axis
// w = (wz, wx, wy); tol1 what is left of the tolerance once the model's and the centre values' errors are taken;
// curv bounds A's |h_A''| h_A (its squared largest semi-axis; 0 for a cylinder).  From the incumbent (t0, p0),
// polished by Newton first.  proven: max sigma_m <= sigma_m(t, p) as computed + tol1; moved: (t, p) is not
// (t0, p0).
ELLIPSIM_HD AxisBB axis_bb(double ek, double ex, double ey, int hk, double h1, double h2, double kb, double pb2,
                           double wz, double wx, double wy, double tol1, double S, double curv, double t0, double p0) {
  using namespace spheroids;
  const double qlo_a = hk == 0 ? min2(h1, h2) * (1.0 - 1e-12) : 1.0;
  const double ww = wz * wz + wx * wx + wy * wy;
  const double qlo_b = (pb2 + min2(kb, 0.0) * ww * (1.0 + 1e-12)) * (1.0 - 1e-12);
  if (!(tol1 > 0.0 && qlo_a > 0.0 && qlo_b > 0.0)) return {false, t0, p0, false, 0};
  const RevolutionModel model = {ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, qlo_a, qlo_b};
  return cells_bb(model, tol1, S, curv, max2(pb2, pb2 + kb), t0, p0);
}

// The proven maximum of sigma for spheroids with nearly parallel axes, in A's frame (axis_bb about A's axis), from
// the incumbent direction n0 (unit; any, e.g. a Newton climb's).
//
// When proven, max sigma <= sigma(n) + tol for the exact sigma of (e, a, U, b); n is n0 or a cell's centre.  Not
// proven when the pair is not two spheroids to within the tolerance (delta0 + ERR_C + ERR_SIGMA leaves no room),
// or the budget TILTED_MAX_NODES runs out, or a cell at TILT_LEVELS stays undecided; n is then the best found.
ELLIPSIM_HD SpheroidMax tilted_max(const Vec3& e, const Vec3& a, const Mat3& U, const Vec3& b, double tol, double S,
                                   const Vec3& n0) {
  using namespace spheroids;
  const int k = axis_of(a).k;
  const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  const Delta dl = delta(e, a, U, b, k, S);  // the model keeps the tilt: delta0 only
  const int j = dl.j;
  const double qb = dl.qb, pb = dl.pb;
  const double qa = at(a, k), pa = 0.5 * (at(a, k1) + at(a, k2));
  const double amax = max3(a);
  const double tol1 = tol - 2.0 * dl.delta0 - (ERR_C_ULPS + tol::BB_ERR_SIGMA_ULPS + 8.0) * U64 * S;
  const double nk = at(n0, k), nk1 = at(n0, k1), nk2 = at(n0, k2);
  const double t0 = math::atan2(math::sqrt(nk1 * nk1 + nk2 * nk2), nk);
  const double p0 = math::atan2(nk2, nk1);
  const AxisBB r = axis_bb(at(e, k), at(e, k1), at(e, k2), 0, qa * qa, pa * pa, qb * qb - pb * pb, pb * pb,
                           at(U, 3 * k + j), at(U, 3 * k1 + j), at(U, 3 * k2 + j), tol1, S, amax * amax, t0, p0);
  if (!r.moved) return {r.proven, n0, r.nodes};
  const double z = math::cos(r.t), rr = math::sin(r.t);
  const double x = rr * math::cos(r.p), y = rr * math::sin(r.p);
  if (k == 0) return {r.proven, {z, x, y}, r.nodes};
  if (k == 1) return {r.proven, {y, z, x}, r.nodes};
  return {r.proven, {x, y, z}, r.nodes};
}

}  // namespace ellipsim::distance
