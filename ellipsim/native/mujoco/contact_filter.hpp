// mjcb_contactfilter: the certified contact pre-filter (mode "filter") and the recorder of candidate pairs
// (mode "record"); ellipsim/mujoco/callbacks.py documents both.
//
// MuJoCo calls the filter for every candidate geom pair after its broad phase, in place of the
// contype/conaffinity test (engine_collision_driver.c, filterCollisionPair), so the callback first repeats
// that test exactly.  Ellipsoid-ellipsoid and sphere-ellipsoid pairs are then tested on ellipsoids that
// enclose the bodies MuJoCo collides (each grown by half of margin + gap + 2 ccd_tolerance) and discarded
// only when a separating axis is certified: no contact MuJoCo would make is lost.  With speculative
// contacts on, no pair is discarded (MuJoCo's conservative advancement runs only for pairs that reach its
// narrow phase).
#pragma once

#include <cstdint>

#include <ellipsim/exact/certified_filter.hpp>
#include <ellipsim/tolerances.hpp>
#include <ellipsim/vec3.hpp>

#include "context.hpp"

namespace ellipsim::glue {

// Geom g as an ellipsoid (centre, rotation row-major, semi-axes), grown to enclose its `grow`-offset body
// (a sphere by grow, an ellipsoid scaled about its centre by 1 + grow / its shortest semi-axis).
inline Ellipsoid geom_ellipsoid(const mjModel* m, const mjData* d, int type, int g, double grow) {
  const mjtNum* c = d->geom_xpos + 3 * g;
  const mjtNum* R = d->geom_xmat + 9 * g;
  const mjtNum* s = m->geom_size + 3 * g;
  Ellipsoid E = {{c[0], c[1], c[2]}, {{R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8]}}, {s[0], s[1], s[2]}};
  if (type == mjGEOM_SPHERE) {
    const double r = s[0] + grow;
    E.r = {r, r, r};
  } else if (grow != 0.0) {
    const double k = 1.0 + grow / min3(E.r);  // E + ball(grow) lies inside E scaled by k about its centre
    E.r = {E.r.x * k, E.r.y * k, E.r.z * k};
  }
  return E;
}

// Geom g as (centre, rotation, geom_size), whatever its type.
inline Ellipsoid geom_pose(const mjModel* m, const mjData* d, int g) {
  const mjtNum* c = d->geom_xpos + 3 * g;
  const mjtNum* R = d->geom_xmat + 9 * g;
  const mjtNum* s = m->geom_size + 3 * g;
  return {{c[0], c[1], c[2]}, {{R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8]}}, {s[0], s[1], s[2]}};
}

inline bool handled_type(int other) {
  return other == mjGEOM_ELLIPSOID || other == mjGEOM_SPHERE || other == mjGEOM_CAPSULE || other == mjGEOM_BOX ||
         other == mjGEOM_CYLINDER || other == mjGEOM_MESH || other == mjGEOM_HFIELD;
}

// 1: discard the pair; 0: keep it (MuJoCo's narrow phase decides).
extern "C" inline int ellipsim_contact_filter(const mjModel* m, mjData* d, int g1, int g2) {
  const int* contype = m->geom_contype;
  const int* conaff = m->geom_conaffinity;
  if ((contype[g1] & conaff[g2]) == 0 && (contype[g2] & conaff[g1]) == 0)
    return 1;  // MuJoCo's own bitmask test, which this callback replaces
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  const int other = t1 == mjGEOM_ELLIPSOID ? t2 : (t2 == mjGEOM_ELLIPSOID ? t1 : -1);
  if (!handled_type(other)) return 0;
  const std::int64_t* ctx = context();
  const std::int64_t slot = slot_of(ctx, d);
  const std::int64_t* row = slot ? registry_row(ctx, slot) : nullptr;
  const std::int64_t mode = row ? row[2] : 0;
  if (mode != FILTER && mode != RECORD) return 0;  // not attached in these modes: MuJoCo's own test, as above
  if (mode == FILTER && other != mjGEOM_ELLIPSOID && other != mjGEOM_SPHERE) return 0;
  const std::int64_t counters = row[1];
  if (mode == RECORD) {  // every row of PAIR_TYPES, after the bitmask test
    const std::int64_t i = count(counters, RECORDED);
    if (i < row[4]) {
      int* pairs = reinterpret_cast<int*>(row[3]);
      pairs[2 * i] = g1;
      pairs[2 * i + 1] = g2;
    }
    return 0;
  }
  if (m->opt.enableflags & mjENBL_SPECULATIVE) {  // a pair apart now may still meet within the step
    count(counters, SEEN);
    count(counters, PASSED);
    return 0;
  }
  double total = (m->opt.enableflags & mjENBL_OVERRIDE) ? m->opt.o_margin : m->geom_margin[g1] + m->geom_margin[g2];
  total = max2(total + m->geom_gap[g1] + m->geom_gap[g2], 0.0);
  total += tol::FILTER_CCD_FACTOR * m->opt.ccd_tolerance;
  const mjtNum* s1 = m->geom_size + 3 * g1;
  const mjtNum* s2 = m->geom_size + 3 * g2;
  const double scale = max2(max2(max2(max2(max2(s1[0], s1[1]), s1[2]), s2[0]), s2[1]), s2[2]);
  const double grow = 0.5 * total + tol::FILTER_RELATIVE_SLACK * scale;
  const bool discard =
      exact::separated_by_axes(geom_ellipsoid(m, d, t1, g1, grow), geom_ellipsoid(m, d, t2, g2, grow));
  count(counters, SEEN);
  count(counters, discard ? DISCARDED : PASSED);
  return discard ? 1 : 0;
}

}  // namespace ellipsim::glue
