// The narrow phase (mode "narrowphase"): an mjfCollision for MuJoCo's table mjCOLLISIONFUNC at every row of
// context.PAIR_TYPES; ellipsim/mujoco/callbacks.py (narrowphase, _narrow_pair) documents it, this is its C++.
//
// MuJoCo indexes the table type1 <= type2 (engine_collision_driver.c swaps a pair by type), so a capsule or a
// height field is g1 (the capsule's normal is pairs::capsule's flipped) and a box, cylinder or mesh is g2.  A mesh
// collides through its convex hull (the data's hull table, attachment.py), a height field through the prisms of
// its cells (pairs/height_field.hpp: up to mjMAXCONPAIR contacts, MuJoCo's mjc_ConvexHField's).  A pair certified apart beyond the margin
// gets no contact; otherwise the signed distance, normal (from g1 to g2) and contact point of the C++ core fill
// the mjPreContact as mjc_Convex does (tangent zero: mj_setContact completes the frame).  A maximum that is not
// proven goes to MuJoCo's original function (the context's fallback words), counted; for two ellipsoids its
// contact then carries the better of MuJoCo's normal and ellipsim's, sigma evaluated by ellipsim at both.
//
// Ellipsoid and sphere pairs of a data with a warm-start table (its registry row) start Newton from the pair's
// last normal extrapolated by the one before; the table has epochs (context.py), advanced when the data's time
// goes back or jumps ahead, so a rerun from the same state is bit-identical to a fresh data's.  One data's table
// is read and written only by calls on that data.  Everything per data is reached through the registry: the
// function keeps no state of its own, allocates nothing and throws nothing; -ffp-contract=off (CMakeLists.txt)
// makes its arithmetic the numba callback's, bit for bit.
#pragma once

#include <cmath>
#include <cstdint>

#include <ellipsim/distance/ellipsoid_pair.hpp>
#include <ellipsim/exact/certified_filter.hpp>
#include <ellipsim/pairs/box.hpp>
#include <ellipsim/pairs/capsule.hpp>
#include <ellipsim/pairs/cylinder.hpp>
#include <ellipsim/pairs/height_field.hpp>
#include <ellipsim/pairs/polytope.hpp>
#include <ellipsim/vec3.hpp>

#include "contact_filter.hpp"
#include "context.hpp"

namespace ellipsim::glue {

// --- the warm-start table (context.WARM_SLOT_WORDS words a slot: key << 1 | contact, normal, normal before,
// epoch).  Relaxed atomic loads and stores, plain moves on x86: under mju_threadpool two pairs of one data whose
// keys share a set may interleave their words, which only gives a worse seed (callbacks._warm_store).

// A table word as int64 (callbacks._warm_find's `table[...]` reads).
inline std::int64_t load_word(const std::int64_t* p) { return __atomic_load_n(p, __ATOMIC_RELAXED); }
// callbacks._warm_store's `table[...] = ...` writes.
inline void store_word(std::int64_t* p, std::int64_t v) { __atomic_store_n(p, v, __ATOMIC_RELAXED); }
// A table word as float64 (callbacks._warm_epoch's `clock`, _narrow_pair's `normals[...]` reads).
inline double load_real(const std::int64_t* p) {
  double v;
  __atomic_load(reinterpret_cast<const double*>(p), &v, __ATOMIC_RELAXED);
  return v;
}
// callbacks._warm_store's `normals[...] = ...` writes.
inline void store_real(std::int64_t* p, double v) { __atomic_store(reinterpret_cast<double*>(p), &v, __ATOMIC_RELAXED); }

// callbacks._warm_set: the first slot of pair (g1, g2)'s two-slot set, a multiplicative hash folded once.
inline std::int64_t warm_set(int g1, int g2, std::int64_t mask) {
  std::int64_t h = std::int64_t(g1) * 1540483477 + std::int64_t(g2) * 668265261;
  h ^= h >> 17;
  return (h << 1) & mask;
}

// callbacks._warm_epoch: the table's epoch at data time t, advanced when t goes back or jumps ahead.
inline std::int64_t warm_epoch(std::int64_t* counters, double t, double step) {
  const double last = load_real(counters + WARM_TIME);
  if (t < last || t > last + WARM_JUMP * step) store_word(counters + WARM_EPOCH, load_word(counters + WARM_EPOCH) + 1);
  if (t != last) store_real(counters + WARM_TIME, t);
  return load_word(counters + WARM_EPOCH);
}

// callbacks._warm_find: the slot holding `key` of this epoch in the set starting at `first`, or -1.
inline std::int64_t warm_find(const std::int64_t* table, std::int64_t first, std::int64_t key, std::int64_t epoch) {
  const std::int64_t* a = table + WARM_SLOT_WORDS * first;
  if (load_word(a) >> 1 == key && load_word(a + WARM_SLOT_WORDS - 1) == epoch) return first;
  const std::int64_t* b = a + WARM_SLOT_WORDS;
  if (load_word(b) >> 1 == key && load_word(b + WARM_SLOT_WORDS - 1) == epoch) return first + 1;
  return -1;
}

// callbacks._warm_store: (key, contact, normal) into slot k, or (k < 0) a free slot of the set, the first's entry
// moved to the second in a full set.
inline void warm_store(std::int64_t* table, std::int64_t first, std::int64_t k, std::int64_t key, const Vec3& normal,
                       bool contact, std::int64_t epoch) {
  if (k >= 0) {  // the last normal becomes the one before
    std::int64_t* s = table + WARM_SLOT_WORDS * k;
    for (int w = 1; w <= 3; ++w) store_real(s + 3 + w, load_real(s + w));
  } else {  // a slot of another epoch is free (as on a fresh table: reruns are bit-identical)
    std::int64_t* a = table + WARM_SLOT_WORDS * first;
    std::int64_t* b = a + WARM_SLOT_WORDS;
    if (load_word(a) == 0 || load_word(a + WARM_SLOT_WORDS - 1) != epoch) {
      k = first;
    } else if (load_word(b) == 0 || load_word(b + WARM_SLOT_WORDS - 1) != epoch) {
      k = first + 1;
    } else {  // words 1-7 of the first slot (normals and epoch) to the second, then its key
      for (int w = 1; w < WARM_SLOT_WORDS; ++w) store_word(b + w, load_word(a + w));
      store_word(b, load_word(a));
      k = first;
    }
    std::int64_t* s = table + WARM_SLOT_WORDS * k;  // a new entry: no motion yet
    store_real(s + 4, normal.x);
    store_real(s + 5, normal.y);
    store_real(s + 6, normal.z);
  }
  std::int64_t* s = table + WARM_SLOT_WORDS * k;
  store_real(s + 1, normal.x);
  store_real(s + 2, normal.y);
  store_real(s + 3, normal.z);
  store_word(s + WARM_SLOT_WORDS - 1, epoch);
  store_word(s, (key << 1) | (contact ? 1 : 0));
}

// --- the callback

// The mjPreContact of a contact (callbacks._narrow_pair's last lines): dist, pos, normal, tangent zero.
inline void write_contact(mjPreContact* con, double dist, const Vec3& pos, const Vec3& normal) {
  con->dist = dist;
  con->pos[0] = pos.x;
  con->pos[1] = pos.y;
  con->pos[2] = pos.z;
  con->normal[0] = normal.x;
  con->normal[1] = normal.y;
  con->normal[2] = normal.z;
  con->tangent[0] = con->tangent[1] = con->tangent[2] = 0.0;
}

// MuJoCo's original function for the pair (callbacks._narrow_pair's dispatch on the rows of PAIR_TYPES).
inline mjfCollision original_function(const std::int64_t* ctx, int t1, int t2) {
  int word;
  if (t1 == mjGEOM_HFIELD)
    word = FALLBACK_HFIELD;
  else if (t2 == mjGEOM_MESH)
    word = FALLBACK_MESH;
  else if (t1 == mjGEOM_CAPSULE)
    word = FALLBACK_CAPSULE;
  else if (t2 == mjGEOM_BOX)
    word = FALLBACK_BOX;
  else if (t2 == mjGEOM_CYLINDER)
    word = FALLBACK_CYLINDER;
  else
    word = t1 == mjGEOM_SPHERE ? FALLBACK_SPHERE : FALLBACK_ELLIPSOID;
  return reinterpret_cast<mjfCollision>(static_cast<std::uintptr_t>(ctx[word]));
}

// What a row of _narrow_pair leaves for its common end: the call's answer when it is decided (SEPARATED, or a
// fallback's), else the measured (dist, normal, pos) and whether its maximum is proven.
struct RowResult {
  int decided;  // -1: not yet (the end below decides); 0 or 1: the callback's return value
  bool proven;
  double dist;
  Vec3 normal, pos;
};

// callbacks._narrow_pair's capsule row: g1 the capsule, g2 the ellipsoid.  Each row is out of line: inlined
// together, the kernels make one function of a 4.6 kB frame, ~10 ns a call slower than numba's.
__attribute__((noinline)) inline RowResult capsule_row(const mjModel* m, const mjData* d, int g1, int g2,
                                                       mjtNum margin, std::int64_t counters) noexcept {
  const Ellipsoid E = geom_ellipsoid(m, d, mjGEOM_ELLIPSOID, g2, 0.0), K = geom_pose(m, d, g1);
  if (pairs::capsule::centre_line_bound(E, K) >= margin) {  // a direction proves them apart beyond the margin
    count(counters, SEPARATED);
    return {0, true, 0.0, {}, {}};
  }
  const pairs::capsule::Result r = pairs::capsule::capsule_ellipsoid(E, K);  // CERTIFIED or ENUMERATED: proven
  const Vec3 normal = {-r.normal.x, -r.normal.y, -r.normal.z};            // from the capsule (g1) to the ellipsoid
  return {-1, std::isfinite(r.dist), r.dist, normal, r.pos};
}

// callbacks._narrow_pair's box row: g1 the ellipsoid, g2 the box.
__attribute__((noinline)) inline RowResult box_row(const mjModel* m, const mjData* d, int g1, int g2, mjtNum margin,
                                                   std::int64_t counters) noexcept {
  const Ellipsoid E = geom_ellipsoid(m, d, mjGEOM_ELLIPSOID, g1, 0.0), K = geom_pose(m, d, g2);
  if (pairs::box::centre_line_bound(E, K) >= margin) {
    count(counters, SEPARATED);
    return {0, true, 0.0, {}, {}};
  }
  const pairs::box::Result r = pairs::box::box_ellipsoid(E, K);  // CERTIFIED or ENUMERATED: both proven
  return {-1, std::isfinite(r.dist), r.dist, r.normal, r.pos};
}

// callbacks._narrow_pair's cylinder row: g1 the ellipsoid, g2 the cylinder.
__attribute__((noinline)) inline RowResult cylinder_row(const mjModel* m, const mjData* d, int g1, int g2,
                                                        mjtNum margin, std::int64_t counters) noexcept {
  const Ellipsoid E = geom_ellipsoid(m, d, mjGEOM_ELLIPSOID, g1, 0.0), K = geom_pose(m, d, g2);
  if (pairs::cylinder::centre_line_bound(E, K) >= margin) {
    count(counters, SEPARATED);
    return {0, true, 0.0, {}, {}};
  }
  const pairs::cylinder::Result r = pairs::cylinder::cylinder_ellipsoid(E, K);  // a deep rim maximum: UNPROVEN
  return {-1, r.status != pairs::cylinder::UNPROVEN && std::isfinite(r.dist), r.dist, r.normal, r.pos};
}

// The mesh row: g1 the ellipsoid, g2 the mesh, through the mesh's convex hull as MuJoCo collides it (mjc_Convex
// reads mesh_graph), from this data's hull table (`hulls`, attachment.py); the scratch from MuJoCo's arena.
__attribute__((noinline)) inline RowResult mesh_row(const mjModel* m, mjData* d, int g1, int g2, mjtNum margin,
                                                    const std::int64_t* row, const std::int64_t* ctx) noexcept {
  const std::int64_t counters = row[1];
  const std::int64_t* hulls = reinterpret_cast<const std::int64_t*>(row[HULLS]);
  const int mesh = m->geom_dataid[g2];
  const std::int64_t* h = hulls && mesh >= 0 ? hulls + HULL_WORDS * mesh : nullptr;
  if (!h || h[0] == 0) return {-1, false, 0.0, {}, {}};  // no hull: MuJoCo's own function, counted
  const pairs::polytope::Hull H = {int(h[0]),
                                   int(h[1]),
                                   int(h[2]),
                                   reinterpret_cast<const double*>(h[3]),
                                   reinterpret_cast<const int*>(h[4]),
                                   reinterpret_cast<const double*>(h[5]),
                                   reinterpret_cast<const int*>(h[6]),
                                   reinterpret_cast<const int*>(h[7]),
                                   reinterpret_cast<const int*>(h[8]),
                                   reinterpret_cast<const int*>(h[9]),
                                   reinterpret_cast<const int*>(h[10])};
  const Ellipsoid E = geom_ellipsoid(m, d, mjGEOM_ELLIPSOID, g1, 0.0);
  const mjtNum* c = d->geom_xpos + 3 * g2;
  const mjtNum* R = d->geom_xmat + 9 * g2;
  const Vec3 cP = {c[0], c[1], c[2]};
  const Mat3 RP = {{R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8]}};
  using MarkStack = void (*)(mjData*);
  using StackAllocNum = mjtNum* (*)(mjData*, size_t);
  reinterpret_cast<MarkStack>(static_cast<std::uintptr_t>(ctx[MARK_STACK]))(d);
  double* scratch = reinterpret_cast<StackAllocNum>(static_cast<std::uintptr_t>(ctx[STACK_ALLOC_NUM]))(
      d, size_t(pairs::polytope::scratch_size(H.nv, H.nf)));
  // proven (CERTIFIED or ENUMERATED), or APART: its walking start's sigma proves it beyond the margin
  const pairs::polytope::Result r = pairs::polytope::polytope_ellipsoid(E, cP, RP, H, scratch, margin);
  reinterpret_cast<MarkStack>(static_cast<std::uintptr_t>(ctx[FREE_STACK]))(d);
  if (r.status == pairs::polytope::APART) {
    count(counters, SEPARATED);
    return {0, true, 0.0, {}, {}};
  }
  return {-1, std::isfinite(r.dist), r.dist, r.normal, r.pos};
}

// The height-field row: g1 the field, g2 the ellipsoid; up to mjMAXCONPAIR contacts, one per prism the ellipsoid
// comes within the margin of (pairs/height_field.hpp, in mjc_ConvexHField's order).  Returns the number of
// contacts, or -1 for MuJoCo's own function (a field with a degenerate prism, or non-finite poses).
__attribute__((noinline)) inline int hfield_row(const mjModel* m, mjData* d, mjPreContact* con, int g1, int g2,
                                                mjtNum margin, std::int64_t counters) noexcept {
  const int hid = m->geom_dataid[g1];
  const mjtNum* size = m->hfield_size + 4 * hid;
  const pairs::height_field::Field F = {m->hfield_nrow[hid], m->hfield_ncol[hid], size[0], size[1], size[2],
                                        size[3], m->hfield_data + m->hfield_adr[hid]};
  const mjtNum* c = d->geom_xpos + 3 * g1;
  const mjtNum* R = d->geom_xmat + 9 * g1;
  const Ellipsoid E = geom_ellipsoid(m, d, mjGEOM_ELLIPSOID, g2, 0.0);
  int n = 0;
  const int made = pairs::height_field::contacts(
      E, {c[0], c[1], c[2]}, {{R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8]}}, F, margin, mjMAXCONPAIR,
      [&](const pairs::height_field::Contact& k) { write_contact(con + n++, k.dist, k.pos, k.normal); });
  if (made < 0) return -1;
  count(counters, made ? CONTACTS : SEPARATED);
  if (made == mjMAXCONPAIR) count(counters, CAPPED);  // its further prisms within the margin made no contact
  return made;
}

// callbacks._narrow_pair's ellipsoid row: two ellipsoids, or a sphere (g1) and an ellipsoid, warm-started from
// this data's table (`row` its registry row); an unproven maximum gets the better of MuJoCo's and ellipsim's.
__attribute__((noinline)) inline RowResult ellipsoid_row(const mjModel* m, mjData* d, mjPreContact* con, int g1,
                                                         int g2, mjtNum margin, const std::int64_t* row, int t1,
                                                         int t2, mjfCollision original) noexcept {
  const std::int64_t counters = row[1];
  const Ellipsoid A = geom_ellipsoid(m, d, t1, g1, 0.0), B = geom_ellipsoid(m, d, t2, g2, 0.0);
  const double grow = 0.5 * max2(margin, 0.0);
  Ellipsoid Ag = A, Bg = B;
  if (grow > 0.0) {
    Ag = geom_ellipsoid(m, d, t1, g1, grow);
    Bg = geom_ellipsoid(m, d, t2, g2, grow);
  }
  // the pair's entry in this data's warm-start table: its last normal, and whether that call made a contact
  const std::int64_t mask = row[WARM_MASK];
  std::int64_t* table = reinterpret_cast<std::int64_t*>(row[WARM_ADDRESS]);
  const std::int64_t key = (std::int64_t(g1) << 32) | g2;
  std::int64_t first = 0, k = -1, epoch = 0;
  Vec3 seed = {0.0, 0.0, 0.0};
  bool touching = false;
  if (mask) {
    epoch = warm_epoch(reinterpret_cast<std::int64_t*>(counters), d->time, m->opt.timestep);
    first = warm_set(g1, g2, mask);
    k = warm_find(table, first, key, epoch);
    if (k >= 0) {  // the last normal extrapolated by the one before
      const std::int64_t* s = table + WARM_SLOT_WORDS * k;
      const Vec3 last = {load_real(s + 1), load_real(s + 2), load_real(s + 3)};
      const Vec3 before = {load_real(s + 4), load_real(s + 5), load_real(s + 6)};
      seed = {2.0 * last.x - before.x, 2.0 * last.y - before.y, 2.0 * last.z - before.z};
      touching = (load_word(s) & 1) == 1;
    }
  }
  if (!touching) {  // in contact at the last call: most likely still, straight to Newton
    if (exact::bisector_separates_pair(Ag, Bg) ||
        (k >= 0 && distance::sigma_lower_bound(A, B, seed) >= margin)) {  // (the last normal proves it apart)
      count(counters, SEPARATED);
      return {0, true, 0.0, {}, {}};
    }
  }
  const distance::PairDistance r = distance::pair_signed_distance_from(A, B, seed);
  const bool proven = r.status == distance::ellipsoid_pair::GLOBAL;
  if (mask && proven) warm_store(table, first, k, key, r.normal, r.dist < margin, epoch);
  if (proven || !std::isfinite(r.dist)) return {-1, proven, r.dist, r.normal, r.pos};
  // no proof (nearly parallel spheroids): the better of MuJoCo's normal and ellipsim's, sigma evaluated by
  // ellipsim at both (each a lower bound on the signed distance); counted
  count(counters, FALLBACKS);
  if (original(m, d, con, g1, g2, margin) == 0) return {0, false, 0.0, {}, {}};  // none dropped MuJoCo made
  double dist = r.dist;
  Vec3 normal = r.normal, pos = r.pos;
  const distance::ContactAt c = distance::contact_at(A, B, {con->normal[0], con->normal[1], con->normal[2]});
  if (c.value > dist) {
    dist = c.value;
    normal = c.normal;
    pos = c.pos;
  }
  if (dist >= margin) return {0, false, 0.0, {}, {}};  // ellipsim's lower bound puts them apart beyond the margin
  write_contact(con, dist, pos, normal);
  return {1, false, 0.0, {}, {}};
}

// callbacks._narrow_pair: the narrow phase of a pair not two ellipsoids (or a sphere and an ellipsoid), or whose
// centre line did not prove them apart.  Out of line: the entry stays small (issue 23).
__attribute__((noinline)) inline int narrow_pair(const mjModel* m, mjData* d, mjPreContact* con, int g1, int g2,
                                                 mjtNum margin) noexcept {
  const std::int64_t* ctx = context();
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  const mjfCollision original = original_function(ctx, t1, t2);
  const std::int64_t slot = slot_of(ctx, d);
  const std::int64_t* row = slot ? registry_row(ctx, slot) : nullptr;
  if (!row || row[2] != NARROW) return original(m, d, con, g1, g2, margin);  // not attached: MuJoCo's own
  const std::int64_t counters = row[1];
  if (t1 == mjGEOM_HFIELD) {  // several contacts
    const int made = hfield_row(m, d, con, g1, g2, margin, counters);
    if (made >= 0) return made;
    count(counters, FALLBACKS);
    return original(m, d, con, g1, g2, margin);
  }
  RowResult r;
  if (t2 == mjGEOM_MESH)
    r = mesh_row(m, d, g1, g2, margin, row, ctx);
  else if (t1 == mjGEOM_CAPSULE)
    r = capsule_row(m, d, g1, g2, margin, counters);
  else if (t2 == mjGEOM_BOX)
    r = box_row(m, d, g1, g2, margin, counters);
  else if (t2 == mjGEOM_CYLINDER)
    r = cylinder_row(m, d, g1, g2, margin, counters);
  else
    r = ellipsoid_row(m, d, con, g1, g2, margin, row, t1, t2, original);
  if (r.decided >= 0) return r.decided;
  if (!r.proven) {  // no proof that this is the global maximum: MuJoCo's own answer, counted
    count(counters, FALLBACKS);
    return original(m, d, con, g1, g2, margin);
  }
  if (r.dist >= margin) {
    count(counters, APART);
    return 0;
  }
  write_contact(con, r.dist, r.pos, r.normal);
  count(counters, CONTACTS);
  return 1;
}

// callbacks.narrowphase: two ellipsoids (or a sphere and an ellipsoid) first against their centre line, which
// ends most calls, before the warm-start table is read (its slot a likely cache miss); every other call in
// narrow_pair.
extern "C" inline int ellipsim_narrowphase(const mjModel* m, mjData* d, mjPreContact* con, int g1, int g2,
                                           mjtNum margin) noexcept {
  const std::int64_t* ctx = context();
  const std::int64_t slot = slot_of(ctx, d);
  if (slot == 0 || registry_row(ctx, slot)[2] != NARROW) return narrow_pair(m, d, con, g1, g2, margin);
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  if (t2 != mjGEOM_ELLIPSOID || (t1 != mjGEOM_ELLIPSOID && t1 != mjGEOM_SPHERE))
    return narrow_pair(m, d, con, g1, g2, margin);
  const double grow = 0.5 * max2(margin, 0.0);
  if (exact::centre_line_separates(geom_ellipsoid(m, d, t1, g1, grow), geom_ellipsoid(m, d, t2, g2, grow))) {
    count(registry_row(ctx, slot)[1], SEPARATED);
    return 0;
  }
  return narrow_pair(m, d, con, g1, g2, margin);
}

}  // namespace ellipsim::glue
