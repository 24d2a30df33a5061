// Broad phase over many frames: which ellipsoid pairs of which frames may touch, in one batch
// (ellipsim/core/motion/broad_phase.py).
//
// A kinematic replay (or a recording) poses the same g ellipsoids in F frames.  Sweep and prune per frame over
// bounding spheres (Cohen, Lin, Manocha & Ponamgi, I-COLLIDE, 1995: sort the intervals along an axis, sweep)
// gives the candidate pairs; ellipsim.mujoco.geoms filters them by MuJoCo's rules, and one batched exact
// `classify` decides them all.
//
// Between two consecutive frames (swept_pairs, for ellipsim.mujoco.between): the same sweep once per block of
// steps over each geom's box of centres, then per step the centres' closest approach and enclosing capsules
// bounded over the step by conservative advancement.
//
// Arrays are C-contiguous and passed as pointers with their sizes.  The numba kernels allocate their scratch
// (the sort keys, the order, the boxes of centres) and sweep_and_prune grows its output; here every kernel
// takes its scratch and output from the caller and never allocates: sweep_frame and sweep_block write at most
// `cap` pairs and return how many there are, and the caller (python/motion.cpp) gives a crowded frame or block
// more room and runs it again.  The sort is numba's np.argsort (its quicksort, not stable), so that pairs come
// out in numba's order, ties included.
#pragma once

#include "../math.hpp"

#include "../tolerances.hpp"
#include "../vec3.hpp"

namespace ellipsim::motion {

// Steps per sweep in swept_pairs: one sweep over each geom's box of centres across the block, then the
// per-step tests on the pairs it finds.  Sweeps + per-step tests per 1024 frames of the 16-figure replays
// (gentle / violent hinge motions, one thread): 2 steps 48 / 110 ms, 4 26 / 89, 8 18 / 94.
constexpr int SWEEP_BLOCK = 4;

// Pairs per geom each block's sweep has room for at first (a crowded block reruns the sweep with room for all;
// 16 figures: 2-8 pairs per geom).
constexpr int BLOCK_ROOM = 16;

// Room the capsule test of swept_pairs leaves, relative to the pair's longest semi-axes: rotations are
// orthonormal only to ORTHONORMAL_TOL = 1e-6 (the ellipsoid of such an R lies within ~3e-6 r of its capsule),
// the interpolated rotation reaches R1 within that too, and the segment distance is rounded (~sqrt(u) relative
// when the segments are nearly parallel).  1e-4 is 30x the largest of these; a pair within it of touching just
// goes on to the exact time_of_impact.
constexpr double CAPSULE_SLACK = 1e-4;

// Distances the capsule test's conservative advancement evaluates before it gives up (the pair is kept).  16
// keeps 10% fewer pairs of the violent replay (71k of 79k per 1024 frames) for about the time time_of_impact
// saves on them; 3 keeps 50% more.
constexpr int CAPSULE_STEPS = 8;

// Geoms whose cos theta = (tr R0^T R1 - 1) / 2 in a step is below PLAIN_COS (turning by more than ~120
// degrees) get the sphere tests only: core.motion.interpolation has no motion near a half turn, and
// mujoco.between reports those pairs as they are, deciding the half turn from cos < -1/2 and then the angle;
// 1e-3 is room for rotations orthonormal to 1e-6 only.
constexpr double PLAIN_COS = -0.5 + 1e-3;

// --- numba's array reductions and np.argsort ------------------------------------------------------------

// Python's a // b for b > 0.
ELLIPSIM_HD int64_t floor_div(int64_t a, int64_t b) {
  const int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

// numba's array.max() and .min() of a[0], a[stride], ... (n >= 1 values): the first NaN, else the extreme.
ELLIPSIM_HD double array_max(const double* a, int64_t stride, int64_t n) {
  double m = a[0];
  if (math::isnan(m)) return m;
  for (int64_t i = 1; i < n; ++i) {
    const double v = a[i * stride];
    if (math::isnan(v)) return v;
    if (v > m) m = v;
  }
  return m;
}

ELLIPSIM_HD double array_min(const double* a, int64_t stride, int64_t n) {
  double m = a[0];
  if (math::isnan(m)) return m;
  for (int64_t i = 1; i < n; ++i) {
    const double v = a[i * stride];
    if (math::isnan(v)) return v;
    if (v < m) m = v;
  }
  return m;
}

// numba's order on floats for sorting: NaNs last (numba.np.numpy_support.lt_floats).
ELLIPSIM_HD bool lt_floats(double a, double b) { return a < b || (math::isnan(b) && !math::isnan(a)); }

// numba's quicksort (numba/misc/quicksort.py, the argsort variant): under this size an insertion sort ...
constexpr int64_t SMALL_QUICKSORT = 15;
// ... and the stack of pending partitions (the larger side is pushed: at most log2(n) deep).
constexpr int MAX_STACK = 100;

// Insertion sort of R[low..high] (inclusive) by A[R[.] * stride].
ELLIPSIM_HD void insertion_sort(const double* A, int64_t stride, int64_t* R, int64_t low,
                                int64_t high) {
  if (high <= low) return;
  for (int64_t i = low + 1; i < high + 1; ++i) {
    const int64_t k = R[i];
    const double v = A[k * stride];
    int64_t j = i;
    while (j > low && lt_floats(v, A[R[j - 1] * stride])) {
      R[j] = R[j - 1];
      j -= 1;
    }
    R[j] = k;
  }
}

ELLIPSIM_HD void swap_entries(int64_t* R, int64_t a, int64_t b) {
  const int64_t x = R[a];
  R[a] = R[b];
  R[b] = x;
}

// Partition R[low..high] around a median-of-three pivot; the pivot's index.
ELLIPSIM_HD int64_t partition(const double* A, int64_t stride, int64_t* R, int64_t low,
                                   int64_t high) {
  const int64_t mid = (low + high) >> 1;
  if (lt_floats(A[R[mid] * stride], A[R[low] * stride])) swap_entries(R, low, mid);
  if (lt_floats(A[R[high] * stride], A[R[mid] * stride])) swap_entries(R, high, mid);
  if (lt_floats(A[R[mid] * stride], A[R[low] * stride])) swap_entries(R, low, mid);
  const double pivot = A[R[mid] * stride];
  swap_entries(R, high, mid);  // stash the pivot at the end
  int64_t i = low, j = high - 1;
  while (true) {
    while (i < high && lt_floats(A[R[i] * stride], pivot)) i += 1;
    while (j >= low && lt_floats(pivot, A[R[j] * stride])) j -= 1;
    if (i >= j) break;
    swap_entries(R, i, j);
    i += 1;
    j -= 1;
  }
  swap_entries(R, i, high);  // the pivot in its final place
  return i;
}

// R = np.argsort(A[0], A[stride], ..., A[(n - 1) stride]) as numba computes it (kind="quicksort").
ELLIPSIM_HD void argsort(const double* A, int64_t stride, int64_t n, int64_t* R) {
  for (int64_t i = 0; i < n; ++i) R[i] = i;
  if (n < 2) return;
  int64_t stack_low[MAX_STACK], stack_high[MAX_STACK];
  stack_low[0] = 0, stack_high[0] = n - 1;
  int depth = 1;
  while (depth > 0) {
    depth -= 1;
    int64_t low = stack_low[depth], high = stack_high[depth];
    while (high - low >= SMALL_QUICKSORT) {  // partition until an insertion sort is cheaper
      const int64_t i = partition(A, stride, R, low, high);
      if (high - i > i - low) {  // push the larger side
        if (high > i) stack_low[depth] = i + 1, stack_high[depth] = high, depth += 1;
        high = i - 1;
      } else {
        if (i > low) stack_low[depth] = low, stack_high[depth] = i - 1, depth += 1;
        low = i + 1;
      }
    }
    insertion_sort(A, stride, R, low, high);
  }
}

// --- sweep_and_prune ------------------------------------------------------------------------------------

// Pairs (f, i, j), i < j, of frame f whose bounding spheres overlap: sort by c - rho along the frame's axis
// of widest spread (figures in a line along y must not be swept along x), sweep.  centers: the frame's (g, 3)
// centres, rho: (g,) bounding radii; lo (g) and order (g) scratch.  The first `cap` pairs go to out (rows of
// 3); returns how many there are.
ELLIPSIM_HD int64_t sweep_frame(const double* centers, const double* rho, int64_t g, int64_t f,
                                     double* lo, int64_t* order, int64_t* out, int64_t cap) {
  int axis = 0;
  double widest = -1.0;
  for (int k = 0; k < 3; ++k) {
    const double spread = g ? array_max(centers + k, 3, g) - array_min(centers + k, 3, g) : 0.0;
    if (spread > widest) axis = k, widest = spread;
  }
  for (int64_t i = 0; i < g; ++i) lo[i] = centers[3 * i + axis] - rho[i];
  argsort(lo, 1, g, order);
  int64_t n = 0;
  for (int64_t a = 0; a < g; ++a) {
    const int64_t i = order[a];
    const double hi = centers[3 * i + axis] + rho[i];
    for (int64_t b = a + 1; b < g; ++b) {
      const int64_t j = order[b];
      if (lo[j] > hi) break;
      const double dx = centers[3 * i] - centers[3 * j];
      const double dy = centers[3 * i + 1] - centers[3 * j + 1];
      const double dz = centers[3 * i + 2] - centers[3 * j + 2];
      const double r = rho[i] + rho[j];
      if (dx * dx + dy * dy + dz * dz <= r * r) {
        if (n < cap) {
          out[3 * n] = f;
          out[3 * n + 1] = min2(i, j);
          out[3 * n + 2] = max2(i, j);
        }
        n += 1;
      }
    }
  }
  return n;
}

// --- between two frames ---------------------------------------------------------------------------------

// _block_pairs for block bk: geoms whose boxes of centres over the block's frames, grown by rho (and rounding
// room), overlap (and allowed[i, j], unless allowed is null): sweep and prune along the axis of widest spread.
// centers (F, g, 3); lo3, hi3 (g, 3) and order (g) scratch, g >= 1.  Its pairs (i, j), i < j, go to
// out[:cap] (rows of 2); returns how many there are (more than cap asks for a rerun with more room).
ELLIPSIM_HD int64_t sweep_block(const double* centers, int64_t F, int64_t g, const double* rho,
                                     int64_t block, const bool* allowed, int64_t bk, double* lo3, double* hi3,
                                     int64_t* order, int32_t* out, int64_t cap) {
  const int64_t f0 = bk * block, f1 = min2((bk + 1) * block, F - 1);  // frames f0..f1
  for (int64_t i = 0; i < g; ++i) {
    const double room = rho[i] * (1 + 8 * tol::U);
    for (int k = 0; k < 3; ++k) {
      double a = centers[(f0 * g + i) * 3 + k], b = a;
      for (int64_t f = f0 + 1; f < f1 + 1; ++f) {
        a = min2(a, centers[(f * g + i) * 3 + k]);
        b = max2(b, centers[(f * g + i) * 3 + k]);
      }
      const double r = room + 32 * tol::U * max2(math::fabs(a), math::fabs(b));
      lo3[3 * i + k] = a - r, hi3[3 * i + k] = b + r;
    }
  }
  int axis = 0;
  double widest = -1.0;
  for (int k = 0; k < 3; ++k) {
    const double spread = array_max(hi3 + k, 3, g) - array_min(lo3 + k, 3, g);
    if (spread > widest) axis = k, widest = spread;
  }
  argsort(lo3 + axis, 3, g, order);
  int64_t n = 0;
  for (int64_t a = 0; a < g; ++a) {
    const int64_t i = order[a];
    const double top = hi3[3 * i + axis];
    for (int64_t b = a + 1; b < g; ++b) {
      const int64_t j = order[b];
      if (lo3[3 * j + axis] > top) break;
      if (lo3[3 * j] > hi3[3 * i] || lo3[3 * i] > hi3[3 * j] || lo3[3 * j + 1] > hi3[3 * i + 1] ||
          lo3[3 * i + 1] > hi3[3 * j + 1] || lo3[3 * j + 2] > hi3[3 * i + 2] || lo3[3 * i + 2] > hi3[3 * j + 2])
        continue;
      if (allowed && !allowed[i * g + j]) continue;
      if (n < cap) {
        out[2 * n] = static_cast<int32_t>(min2(i, j));
        out[2 * n + 1] = static_cast<int32_t>(max2(i, j));
      }
      n += 1;
    }
  }
  return n;
}

// _block_pairs: block bk is swept by the call whose [lo, hi) holds bk * g_unit (threads.run's ranges); its
// pairs go to out[bk] (nb, cap, 2), their number to count[bk].
ELLIPSIM_HD void block_pairs(const double* centers, int64_t F, int64_t g, const double* rho,
                             int64_t block, int64_t g_unit, const bool* allowed, int32_t* out,
                             int64_t cap, int64_t* count, int64_t lo, int64_t hi, double* lo3,
                             double* hi3, int64_t* order) {
  for (int64_t bk = floor_div(lo + g_unit - 1, g_unit); bk < floor_div(hi + g_unit - 1, g_unit); ++bk)
    count[bk] = sweep_block(centers, F, g, rho, block, allowed, bk, lo3, hi3, order, out + bk * cap * 2, cap);
}

// blocks (sum(count), 3): (block, i, j) of out[bk, :count[bk]] (out (nb, cap, 2)), block by block.
ELLIPSIM_HD void compact(const int32_t* out, int64_t cap, const int64_t* count, int64_t nb,
                         int64_t* blocks) {
  int64_t n = 0;
  for (int64_t bk = 0; bk < nb; ++bk) {
    for (int64_t m = 0; m < count[bk]; ++m) {
      blocks[3 * n] = bk, blocks[3 * n + 1] = out[(bk * cap + m) * 2], blocks[3 * n + 2] = out[(bk * cap + m) * 2 + 1];
      n += 1;
    }
  }
}

// Distance between segments p + s d1 and q + t d2, s, t in [0, 1], on the offset r = p - q of their starts:
// Ericson, Real-Time Collision Detection (2005) 5.1.9, ClosestPtSegmentSegment.
ELLIPSIM_HD double segment_distance_scaled(double r0, double r1, double r2, double d10, double d11, double d12,
                                           double d20, double d21, double d22) {
  const double a = d10 * d10 + d11 * d11 + d12 * d12;
  const double e = d20 * d20 + d21 * d21 + d22 * d22;
  const double f = d20 * r0 + d21 * r1 + d22 * r2;
  double s = 0.0, t = 0.0;
  if (a == 0.0) {
    if (e > 0.0) t = min2(max2(f / e, 0.0), 1.0);
  } else {
    const double c = d10 * r0 + d11 * r1 + d12 * r2;
    if (e == 0.0) {
      s = min2(max2(-c / a, 0.0), 1.0);
    } else {
      const double b = d10 * d20 + d11 * d21 + d12 * d22;
      const double denom = a * e - b * b;
      s = denom > 0.0 ? min2(max2((b * f - c * e) / denom, 0.0), 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = min2(max2(-c / a, 0.0), 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = min2(max2((b - c) / a, 0.0), 1.0);
      }
    }
  }
  const double x0 = r0 + s * d10 - t * d20;
  const double x1 = r1 + s * d11 - t * d21;
  const double x2 = r2 + s * d12 - t * d22;
  return math::sqrt(x0 * x0 + x1 * x1 + x2 * x2);
}

// Distance between segments p + s d1 and q + t d2, s, t in [0, 1] (segment_distance_scaled).  Computed on the
// offsets scaled by a power of two to the order of 1 (exact: same result bit for bit at ordinary scales), since
// its denominator is of the fourth power of the scale: at 2^+-260 it overflowed or underflowed.
ELLIPSIM_HD double segment_distance(double p0, double p1, double p2, double q0, double q1, double q2, double d10,
                                    double d11, double d12, double d20, double d21, double d22) {
  using math::fabs;
  const double r0 = p0 - q0, r1 = p1 - q1, r2 = p2 - q2;
  const double m = max2(
      max2(max2(max2(max2(max2(max2(max2(fabs(r0), fabs(r1)), fabs(r2)), fabs(d10)), fabs(d11)), fabs(d12)), fabs(d20)),
           fabs(d21)),
      fabs(d22));
  int k = 0;
  if (0.0 < m && m < INFINITY) math::frexp(m, &k);
  if (-200 < k && k < 200)  // a * e - b * b within float64's range: as written
    return segment_distance_scaled(r0, r1, r2, d10, d11, d12, d20, d21, d22);
  const double u = math::ldexp(1.0, -k);
  const double dist =
      segment_distance_scaled(r0 * u, r1 * u, r2 * u, d10 * u, d11 * u, d12 * u, d20 * u, d21 * u, d22 * u);
  return math::ldexp(dist, k);
}

// Per geom i of frame f: ends (2, 3), the capsule segment's two ends (centre -/+ half along its axis, the column
// `axis` of its rotation).  centers (g, 3) and rotations (g, 3, 3) of the frame; ends (g, 2, 3).
ELLIPSIM_HD void capsule_ends(const double* centers, const double* rotations, const int64_t* axis,
                              const double* half, int64_t i, double* ends) {
  const double h = half[i];
  const int64_t ax = axis[i];
  for (int k = 0; k < 3; ++k) {
    const double c = centers[3 * i + k], d = h * rotations[9 * i + 3 * k + ax];
    ends[6 * i + k] = c - d, ends[6 * i + 3 + k] = c + d;
  }
}

// Per step and geom: how far the rotating segment strays from the lerp of its ends, inf beyond PLAIN_COS.
// R0, R1: the geom's rotations (3, 3) at the step's two frames.
//
// A point at distance h from the centre turns on a circle, by theta, so it stays within h theta^2 / 8 of the
// chord's point at the same t (interpolation error: t (1 - t) / 2 max |f''|), and
// theta / 2 <= tan(theta / 2) = sqrt((1 - c) / (1 + c)), c = cos theta = (tr R0^T R1 - 1) / 2.
ELLIPSIM_HD double capsule_bend(const double* R0, const double* R1, double half) {
  double tr = 0.0;
  for (int k = 0; k < 3; ++k)
    for (int m = 0; m < 3; ++m) tr += R0[3 * k + m] * R1[3 * k + m];
  const double c = 0.5 * (tr - 1.0);
  if (c < PLAIN_COS) return INFINITY;
  return half * min2(0.5 * max2(1.0 - c, 0.0) / (1.0 + c), 2.0);
}

// _capsule_motion: per frame and geom, ends (F, g, 2, 3); per step and geom, bend (F - 1, g).  centers
// (F, g, 3), rotations (F, g, 3, 3); axis, half (g,).
ELLIPSIM_HD void capsule_motion(const double* centers, const double* rotations, int64_t F, int64_t g,
                                const int64_t* axis, const double* half, double* ends, double* bend) {
  for (int64_t f = 0; f < F; ++f)
    for (int64_t i = 0; i < g; ++i)
      capsule_ends(centers + 3 * g * f, rotations + 9 * g * f, axis, half, i, ends + 6 * g * f);
  for (int64_t f = 0; f < F - 1; ++f)
    for (int64_t i = 0; i < g; ++i)
      bend[f * g + i] = capsule_bend(rotations + 9 * (f * g + i), rotations + 9 * ((f + 1) * g + i), half[i]);
}

// Distance less `reach` at t of the segments whose ends (2, 3) move linearly from a0 to a1 and from b0 to b1.
ELLIPSIM_HD double capsule_gap(const double* a0, const double* a1, const double* b0, const double* b1, double t,
                               double reach) {
  const double pa0 = a0[0] + t * (a1[0] - a0[0]), pa1 = a0[1] + t * (a1[1] - a0[1]), pa2 = a0[2] + t * (a1[2] - a0[2]);
  const double qa0 = a0[3] + t * (a1[3] - a0[3]), qa1 = a0[4] + t * (a1[4] - a0[4]), qa2 = a0[5] + t * (a1[5] - a0[5]);
  const double pb0 = b0[0] + t * (b1[0] - b0[0]), pb1 = b0[1] + t * (b1[1] - b0[1]), pb2 = b0[2] + t * (b1[2] - b0[2]);
  const double qb0 = b0[3] + t * (b1[3] - b0[3]), qb1 = b0[4] + t * (b1[4] - b0[4]), qb2 = b0[5] + t * (b1[5] - b0[5]);
  return segment_distance(pa0, pa1, pa2, pb0, pb1, pb2, qa0 - pa0, qa1 - pa1, qa2 - pa2, qb0 - pb0, qb1 - pb1,
                          qb2 - pb2) -
         reach;
}

// True when the segments whose ends (2, 3) move linearly from a0 to a1 and from b0 to b1 stay further apart than
// `reach` for every t in [0, 1]: conservative advancement (with a gap d - reach > 0 at t, every t' within
// gap / speed of t is apart: `speed` bounds the rate of change of their distance), from the middle outwards,
// CAPSULE_STEPS distances at most.
ELLIPSIM_HD bool capsules_apart(const double* a0, const double* a1, const double* b0, const double* b1, double speed,
                                double reach) {
  double gap = capsule_gap(a0, a1, b0, b1, 0.5, reach);
  if (gap <= 0.0) return false;                      // the capsules meet at t = 1/2
  double reach_up = 0.5 + gap / speed * (1 - 1e-9);  // proven: (0.5 - gap / speed, reach_up)
  double reach_down = 0.5 - gap / speed * (1 - 1e-9);
  for (int step = 0; step < CAPSULE_STEPS - 1; ++step) {
    if (reach_up >= 1.0 && reach_down <= 0.0) return true;
    const bool up = reach_up < 1.0 && (reach_down <= 0.0 || 1.0 - reach_up <= reach_down);  // the shorter side first
    const double t = up ? reach_up : reach_down;
    gap = capsule_gap(a0, a1, b0, b1, t, reach);
    if (gap <= 0.0) return false;
    if (up)
      reach_up = t + gap / speed * (1 - 1e-9);
    else
      reach_down = t - gap / speed * (1 - 1e-9);
  }
  return reach_up >= 1.0 && reach_down <= 0.0;
}

// The arrays of one swept_pairs call that the per-step tests read: centers (F, g, 3), rho (g,), ends
// (F, g, 2, 3), bend (F - 1, g), cap and big (g,).
struct StepScene {
  const double* centers;
  int64_t F, g;
  const double *rho, *ends, *bend, *cap, *big;
};

// keep[k]: the pair (i, j) passes the per-step tests at step s = s0 + k of its block, k < block.
ELLIPSIM_HD void step_pair(const StepScene& S, int64_t bk, int64_t i, int64_t j, int64_t block,
                           bool* keep) {
  const int64_t g = S.g;
  const double* C = S.centers;
  for (int64_t s = bk * block; s < bk * block + block; ++s) {
    keep[s - bk * block] = false;
    if (s >= S.F - 1) continue;
    // the closest approach of the centres' straight paths against the bounding radii, with room for the
    // rounding of the differences (a few ulps of the coordinates)
    const double* ci = C + (s * g + i) * 3;
    const double* cj = C + (s * g + j) * 3;
    const double* ni = C + ((s + 1) * g + i) * 3;
    const double* nj = C + ((s + 1) * g + j) * 3;
    const double d0x = cj[0] - ci[0];
    const double d0y = cj[1] - ci[1];
    const double d0z = cj[2] - ci[2];
    const double ex = (nj[0] - ni[0]) - d0x;
    const double ey = (nj[1] - ni[1]) - d0y;
    const double ez = (nj[2] - ni[2]) - d0z;
    const double ee = ex * ex + ey * ey + ez * ez;
    const double t = min2(max2(-(d0x * ex + d0y * ey + d0z * ez) / (ee > 0.0 ? ee : 1.0), 0.0), 1.0);
    const double cx = d0x + t * ex, cy = d0y + t * ey, cz = d0z + t * ez;
    double coord = 0.0;
    for (int f = 0; f < 2; ++f) {
      const double* pi = f ? ni : ci;
      const double* pj = f ? nj : cj;
      for (int k = 0; k < 3; ++k) coord = max2(max2(coord, math::fabs(pi[k])), math::fabs(pj[k]));
    }
    const double rr = (S.rho[i] + S.rho[j]) * (1 + 8 * tol::U) + 64 * tol::U * coord;
    if (cx * cx + cy * cy + cz * cz > rr * rr) continue;
    const double bi = S.bend[s * g + i], bj = S.bend[s * g + j];
    if (bi < INFINITY && bj < INFINITY) {
      const double* a0 = S.ends + (s * g + i) * 6;
      const double* a1 = S.ends + ((s + 1) * g + i) * 6;
      const double* b0 = S.ends + (s * g + j) * 6;
      const double* b1 = S.ends + ((s + 1) * g + j) * 6;
      // a point of one lerped segment less one of the other moves by a convex combination of the four
      // differences of their ends' displacements: the distance's speed is at most the largest of them
      double speed = 0.0;
      for (int x = 0; x < 2; ++x) {
        for (int y = 0; y < 2; ++y) {
          double m = 0.0;
          for (int k = 0; k < 3; ++k) {
            const double v = (a1[3 * x + k] - a0[3 * x + k]) - (b1[3 * y + k] - b0[3 * y + k]);
            m += v * v;
          }
          speed = max2(speed, m);
        }
      }
      speed = math::sqrt(speed);
      const double room = S.cap[i] + S.cap[j] + bi + bj + CAPSULE_SLACK * (S.big[i] + S.big[j]) + 1e-12 * coord;
      if (capsules_apart(a0, a1, b0, b1, speed * (1 + 1e-9), room)) continue;
    }
    keep[s - bk * block] = true;
  }
}

}  // namespace ellipsim::motion
