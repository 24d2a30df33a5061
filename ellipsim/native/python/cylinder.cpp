// The bindings of the core's pairs/cylinder.hpp and of shape_distance's batch kernel: shape_distances, a drop-in for
// ellipsim/core/pairs/shape_distance.py's _distances (capsule, box or cylinder by kind), and, for the tests
// (test_cylinder.py, test_native_cylinder.py), the cylinder's kernel and stages in the testing submodule.
#include <ellipsim/pairs/box.hpp>
#include <ellipsim/pairs/capsule.hpp>
#include <ellipsim/pairs/cylinder.hpp>

#include "common.hpp"

namespace ellipsim::binding {
namespace {

using namespace nb::literals;

// shape_distance.py's kind codes (derivatives.py CAPSULE, BOX, CYLINDER).
constexpr std::int64_t CAPSULE = 0, BOX = 1, CYLINDER = 2;

// dist, normal, pos and status of the pairs [lo, hi) by one kernel (its kind chosen once per call, so that each
// kind's loop is its own function): status 0 when proven and finite, 1 otherwise.
template <typename F>
void distances_by(const Batch<>& a, const Batch<>& b, double* d, double* nr, double* p, std::int8_t* s, std::int64_t lo,
                  std::int64_t hi, F kernel) {
  const std::int64_t sa = a.n > 1, sb = b.n > 1;  // stride 0 broadcasts a batch of one
  for (std::int64_t i = lo; i < hi; ++i) {
    bool ok = true;
    const auto r = kernel(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), ok);
    d[i] = r.dist;
    s[i] = ok && std::isfinite(r.dist) ? 0 : 1;
    nr[3 * i] = r.normal.x, nr[3 * i + 1] = r.normal.y, nr[3 * i + 2] = r.normal.z;
    p[3 * i] = r.pos.x, p[3 * i + 1] = r.pos.y, p[3 * i + 2] = r.pos.z;
  }
}

// Signed distance, normal, contact point and status of the ellipsoid x capsule, box or cylinder pairs [lo, hi)
// (shape_distance._distances): status 0 when proven and finite, 1 otherwise (a cylinder's UNPROVEN rim, a
// non-finite distance).
void shape_distances(const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck,
                     const Rotations<>& Rk, const Centers<>& sk, std::int64_t kind, Out<double> dist, Rows<3> normal,
                     Rows<3> pos, Out<std::int8_t> status, std::int64_t lo, std::int64_t hi) {
  if (kind != CAPSULE && kind != BOX && kind != CYLINDER)
    throw std::invalid_argument("kind must be 0 (capsule), 1 (box) or 2 (cylinder)");
  const auto a = batch(Ce, Re, re), b = batch(Ck, Rk, sk);
  const auto n = static_cast<std::int64_t>(dist.shape(0));
  if (static_cast<std::int64_t>(normal.shape(0)) != n || static_cast<std::int64_t>(pos.shape(0)) != n ||
      static_cast<std::int64_t>(status.shape(0)) != n)
    throw std::invalid_argument("the output arrays must have the same length");
  check_range(lo, hi, n, a, b);
  double* d = dist.data();
  double* nr = normal.data();
  double* p = pos.data();
  std::int8_t* s = status.data();
  nb::gil_scoped_release release;
  if (kind == CAPSULE) {
    distances_by(a, b, d, nr, p, s, lo, hi,
                 [](const Ellipsoid& E, const Ellipsoid& K, bool&) { return pairs::capsule::capsule_ellipsoid(E, K); });
  } else if (kind == BOX) {
    distances_by(a, b, d, nr, p, s, lo, hi,
                 [](const Ellipsoid& E, const Ellipsoid& K, bool&) { return pairs::box::box_ellipsoid(E, K); });
  } else {
    distances_by(a, b, d, nr, p, s, lo, hi, [](const Ellipsoid& E, const Ellipsoid& K, bool& ok) {
      const pairs::cylinder::Result r = pairs::cylinder::cylinder_ellipsoid(E, K);
      ok = r.status != pairs::cylinder::UNPROVEN;
      return r;
    });
  }
}

// out[i, :K] = f(E_i, K_i) for the ellipsoids E and the cylinders K of pairs [lo, hi), with the GIL released.
template <int KO, typename F>
void def_poses(nb::module_& t, const char* name, F f) {
  t.def(
      name,
      [f](const Centers<>& Ce, const Rotations<>& Re, const Centers<>& re, const Centers<>& Ck, const Rotations<>& Rk,
          const Centers<>& sk, Rows<KO> out, std::int64_t lo, std::int64_t hi) {
        const auto a = batch(Ce, Re, re), b = batch(Ck, Rk, sk);
        check_range(lo, hi, static_cast<std::int64_t>(out.shape(0)), a, b);
        const std::int64_t sa = a.n > 1, sb = b.n > 1;
        double* o = out.data();
        nb::gil_scoped_release release;
        for (std::int64_t i = lo; i < hi; ++i)
          f(load(a.C, a.R, a.r, i * sa), load(b.C, b.R, b.r, i * sb), Writer{o + KO * i});
      },
      in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), in("out"), "lo"_a, "hi"_a);
}

void write_model(Writer& w, const pairs::cylinder::CertModel& cm) {
  w.f(cm.ok), w.v(cm.t1), w.v(cm.t2), w.f(cm.g.x), w.f(cm.g.y), w.f(cm.H11), w.f(cm.H12), w.f(cm.H22);
  w.f(cm.value), w.f(cm.h), w.f(cm.ss), w.f(cm.bt), w.f(cm.eg), w.f(cm.eh), w.f(cm.reach);
}

}  // namespace

void bind_cylinder(nb::module_& m, nb::module_& t) {
  using namespace pairs::cylinder;
  m.def("shape_distances", &shape_distances, in("Ce"), in("Re"), in("re"), in("Ck"), in("Rk"), in("sk"), "kind"_a,
        in("dist"), in("normal"), in("pos"), in("status"), "lo"_a, "hi"_a);

  // cylinder_ellipsoid: status, dist, normal (3), pos (3), ub
  def_poses<9>(t, "cylinder_ellipsoid", [](const Ellipsoid& E, const Ellipsoid& K, Writer w) {
    const Result r = cylinder_ellipsoid(E, K);
    w.f(r.status), w.f(r.dist), w.v(r.normal), w.v(r.pos), w.f(r.ub);
  });
  // The stages on a pose: e, a2, u (9); local_max (n, stratum, converged: 5); at the centre line's direction
  // unit(e) and at local_max's n, each: sigma, upper_bound1, upper_bound2, sweep_bound, capsule_bound, upper_bound
  // (12); the witness at local_max's n (3); deep_search from (sigma, unit(e)) and from (-inf, e_x) (value, n,
  // proven: 10); mirrored; axis_max at unit(e) (ok, n, value: 5); sd_point_cylinder(e); centre_line_bound: 47.
  def_poses<47>(t, "cylinder_stages", [](const Ellipsoid& E, const Ellipsoid& K, Writer w) {
    const Frame f = to_frame(E, K);
    const Vec3 &e = f.e, &a2 = f.a2, &u = f.u;
    const double r = K.r.x, L = K.r.y;
    const Vec3& ra = E.r;
    const double rho = rolling_radius(ra);
    const Scales sc = scales(e, ra, r, L);
    const double scale = sc.scale, tol = sc.tol, slack = sc.slack;
    w.v(e), w.v(a2), w.v(u);
    const LocalMax lm = local_max(a2, e, u, L, r);
    w.v(lm.n), w.f(lm.stratum), w.f(lm.converged);
    const Vec3 nc = unit(e);
    for (const Vec3& n : {nc, lm.n}) {
      const double value = sigma_cylinder(a2, e, u, L, r, n);
      w.f(value), w.f(upper_bound1(a2, e, u, L, r, rho, n)), w.f(upper_bound2(a2, e, u, L, r, n, value));
      w.f(sweep_bound(a2, e, u, L, r, n)), w.f(capsule_bound(a2, e, u, L, r, rho, n, value, tol, slack));
      w.f(upper_bound(a2, e, u, L, r, rho, n, value, tol, slack));
    }
    w.v(witness(a2, e, lm.n, sigma_cylinder(a2, e, u, L, r, lm.n)));
    const DeepSearch d1 = deep_search(a2, e, u, L, r, sigma_cylinder(a2, e, u, L, r, nc), nc, tol, slack);
    const DeepSearch d2 = deep_search(a2, e, u, L, r, -INFINITY, {1.0, 0.0, 0.0}, tol, slack);
    w.f(d1.value), w.v(d1.n), w.f(d1.proven), w.f(d2.value), w.v(d2.n), w.f(d2.proven);
    w.f(mirrored(a2, e, u));
    const AxisMax am = axis_max(a2, e, u, L, r, tol, scale, nc);
    w.f(am.ok), w.v(am.n), w.f(am.value);
    w.f(sd_point_cylinder(e, u, L, r)), w.f(centre_line_bound(E, K));
  });
  // rim_newton: a2, e, u, L, r, sg, n -> n (3), value, code
  def_rows<15, 5>(t, "rim_newton", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), e = x.v(), u = x.v();
    const double L = x.f(), r = x.f(), sg = x.f();
    const RimNewton rn = rim_newton(a2, e, u, L, r, sg, x.v());
    w.v(rn.n), w.f(rn.value), w.f(rn.code);
  });
  // rim_bb: a2, e, u, L, r, sg, best, bn, tol, slack, side_ub -> best, bn (3), proven
  def_rows<19, 5>(t, "rim_bb", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), e = x.v(), u = x.v();
    const double L = x.f(), r = x.f(), sg = x.f(), best = x.f();
    const Vec3 bn = x.v();
    const double tol = x.f(), slack = x.f(), side_ub = x.f();
    const RimBB b = rim_bb(a2, e, u, L, r, sg, best, bn, tol, slack, side_ub);
    w.f(b.best), w.v(b.bn), w.f(b.proven);
  });
  // cert_model(a2, q, su, r, n) (19: ok, t1, t2, g (2), H (3), value, h, ss, bt, eg, eh, reach) and
  // cert_region(that model, n, r, v0, v1, v2, v3, room): a2, q, su, r, n, v0..v3, room -> 20
  def_rows<26, 20>(t, "cert_stages", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), q = x.v(), su = x.v();
    const double r = x.f();
    const Vec3 n = x.v(), v0 = x.v(), v1 = x.v(), v2 = x.v(), v3 = x.v();
    const double room = x.f();
    const CertModel cm = cert_model(a2, q, su, r, n);
    write_model(w, cm);
    w.f(cert_region(cm, n, r, v0, v1, v2, v3, room));
  });
  // split_settles(a2, p, su, ca, cb, b, cert_model(a2, q, su, r, n), n, theta, r, room, floor, slack, equator):
  // a2, q, p, su, ca, cb, n, b, theta, r, room, floor, slack, equator -> 1
  def_rows<28, 1>(t, "split_settles", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), q = x.v(), p = x.v(), su = x.v(), ca = x.v(), cb = x.v(), n = x.v();
    const double b = x.f(), theta = x.f(), r = x.f(), room = x.f(), floor = x.f(), slack = x.f(), equator = x.f();
    w.f(split_settles(a2, p, su, ca, cb, b, cert_model(a2, q, su, r, n), n, theta, r, room, floor, slack, equator));
  });
  // poly_bound(a2, p, v0..v3, slack, floor, stop, edge12) (bound, m), edge_max(a2, p, v0, v1, slack, floor, stop)
  // and edge_max(v1, v2) (bound, m each): a2, p, v0..v3, slack, floor, stop, edge12 -> 12
  def_rows<22, 12>(t, "polygon_stages", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), p = x.v(), v0 = x.v(), v1 = x.v(), v2 = x.v(), v3 = x.v();
    const double slack = x.f(), floor = x.f(), stop = x.f(), edge12 = x.f();
    const Top pb = poly_bound(a2, p, v0, v1, v2, v3, slack, floor, stop, edge12);
    const Top e1 = edge_max(a2, p, v0, v1, slack, floor, stop), e2 = edge_max(a2, p, v1, v2, slack, floor, stop);
    w.f(pb.v), w.v(pb.m), w.f(e1.v), w.v(e1.m), w.f(e2.v), w.v(e2.m);
  });
  // envelope(g0, gm, g2, cs, sn), sub_max(g0, 1, 0, cs, sn), split_max(g0, gm, 1, 0, cs, sn), plane_pole(g0.x,
  // g0.y, gm.x) (ok, na, nb), py_mod(g2.x, g2.y), equator_bound(cs, sn, (g0, gm.x), (gm.y, g2), (cs, sn, g0.x),
  // g0.y): g0, gm, g2 (2 each), cs, sn -> 8
  def_rows<8, 8>(t, "small_stages", [](Reader x, Writer w) {
    const V2 g0 = {x.f(), x.f()}, gm = {x.f(), x.f()}, g2 = {x.f(), x.f()};
    const double cs = x.f(), sn = x.f();
    w.f(envelope(g0, gm, g2, cs, sn)), w.f(sub_max(g0, 1.0, 0.0, cs, sn)), w.f(split_max(g0, gm, 1.0, 0.0, cs, sn));
    const PlanePole pp = plane_pole(g0.x, g0.y, gm.x);
    w.f(pp.ok), w.f(pp.na), w.f(pp.nb), w.f(py_mod(g2.x, g2.y));
    w.f(equator_bound(cs, sn, {g0.x, g0.y, gm.x}, {gm.y, g2.x, g2.y}, {cs, sn, g0.x}, g0.y));
  });
  // sigma_cylinder: a2, e, u, L, r, n -> 1
  def_rows<14, 1>(t, "sigma_cylinder", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), e = x.v(), u = x.v();
    const double L = x.f(), r = x.f();
    w.f(sigma_cylinder(a2, e, u, L, r, x.v()));
  });
  // local_max: a2, e, u, L, r -> n (3), stratum, converged
  def_rows<11, 5>(t, "cylinder_local_max", [](Reader x, Writer w) {
    const Vec3 a2 = x.v(), e = x.v(), u = x.v();
    const double L = x.f(), r = x.f();
    const LocalMax lm = local_max(a2, e, u, L, r);
    w.v(lm.n), w.f(lm.stratum), w.f(lm.converged);
  });
  // equator_bound: side_ub, r, ca, cb, c, slack -> 1
  def_rows<12, 1>(t, "equator_bound", [](Reader x, Writer w) {
    const double side_ub = x.f(), r = x.f();
    const Vec3 ca = x.v(), cb = x.v(), c = x.v();
    w.f(equator_bound(side_ub, r, ca, cb, c, x.f()));
  });
  // The constants of cylinder.hpp by name (the same as cylinder.py's).
  nb::dict c;
  c["CERTIFIED"] = CERTIFIED, c["ENUMERATED"] = ENUMERATED, c["UNPROVEN"] = UNPROVEN;
  c["NEWTON_MAX_ITER"] = NEWTON_MAX_ITER, c["NEWTON_STEP_TOL"] = NEWTON_STEP_TOL, c["CAP_TOL"] = CAP_TOL;
  c["SIDE"] = SIDE, c["CAP_P"] = CAP_P, c["CAP_M"] = CAP_M, c["RIM_P"] = RIM_P, c["RIM_M"] = RIM_M;
  c["CONVERGED"] = CONVERGED, c["AT_CAP"] = AT_CAP, c["STALLED"] = STALLED;
  c["CAPSULE_MIN_FIT"] = CAPSULE_MIN_FIT, c["SPLIT_REACH"] = SPLIT_REACH, c["SPLIT_TRIES"] = SPLIT_TRIES;
  c["SKIP_EXCESS"] = SKIP_EXCESS, c["RIM_LUNES"] = RIM_LUNES, c["D3_NORM"] = D3_NORM, c["REACH_STEPS"] = REACH_STEPS;
  t.attr("CYLINDER_CONSTANTS") = c;
}

}  // namespace ellipsim::binding
