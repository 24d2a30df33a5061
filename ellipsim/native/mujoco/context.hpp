// What the MuJoCo callbacks share with Python: the context words and the registry of attached datas
// (ellipsim/mujoco/context.py holds both as numpy arrays and documents their layout; this is its C++ side).
//
// MuJoCo's hooks (mjcb_contactfilter, the mjCOLLISIONFUNC table) are process-global, so the callbacks
// find the data they are called for in the registry, and MuJoCo's own functions (the fallbacks) in the
// context.  Python hands the context's address over once, on the first attach (set_context); the
// callbacks never run before (nothing is installed).
#pragma once

#include <atomic>
#include <cstdint>

#include <mujoco/mujoco.h>

namespace ellipsim::glue {

// Context words (context.py): the registry's address and rows, MuJoCo's original collision functions.
constexpr int REGISTRY_ADDRESS = 0, REGISTRY_ROWS = 1, FALLBACK_ELLIPSOID = 2, FALLBACK_SPHERE = 3;
constexpr int FALLBACK_CAPSULE = 15, FALLBACK_BOX = 16, FALLBACK_CYLINDER = 17, FALLBACK_MESH = 18,
              FALLBACK_HFIELD = 19;
// MuJoCo's arena functions (mj_markStack, mj_freeStack, mj_stackAllocNum): a mesh's scratch per call.
constexpr int MARK_STACK = 4, FREE_STACK = 5, STACK_ALLOC_NUM = 6;
// Registry columns: data address (0: free), counters address, mode, pair buffer, its capacity,
// warm-start table address, its slots - 1, the hull table's address.  Row 0 holds the highest slot ever used.
constexpr int REGISTRY_COLUMNS = 8, WARM_ADDRESS = 5, WARM_MASK = 6, HULLS = 7;
// The hull table: HULL_WORDS int64 words per mesh of the model, [nv, ne, nf, vertices (float64 nv x 3),
// edges (int32 ne x 2), outward normals (float64 nf x 3), triangles (int32 nf x 3), its adjacency (int32:
// adj_start, adj, vface_start, vface; polytope::build_adjacency's), 0]; nv 0: no hull.
constexpr int HULL_WORDS = 12;
constexpr std::int64_t FILTER = 1, RECORD = 2, NARROW = 3;
// Per-data counters (int64 words).
constexpr int SEEN = 0, DISCARDED = 1, PASSED = 2, RECORDED = 3;
constexpr int SEPARATED = 1, CONTACTS = 2, APART = 3, FALLBACKS = 4;
constexpr int WARM_TIME = 0, WARM_EPOCH = 5, CAPPED = 6;
constexpr int WARM_SLOT_WORDS = 8;
constexpr double WARM_JUMP = 1.5;

// The context, published by Python before any callback is installed.
inline std::atomic<const std::int64_t*>& context_pointer() {
  static std::atomic<const std::int64_t*> pointer{nullptr};
  return pointer;
}

inline const std::int64_t* context() { return context_pointer().load(std::memory_order_acquire); }

// Registry row `k` (k >= 1 a slot; row 0 the header).
inline const std::int64_t* registry_row(const std::int64_t* ctx, std::int64_t k) {
  return reinterpret_cast<const std::int64_t*>(ctx[REGISTRY_ADDRESS]) + REGISTRY_COLUMNS * k;
}

// The registry slot of data d, 0 when it is not attached.
inline std::int64_t slot_of(const std::int64_t* ctx, const mjData* d) {
  const std::int64_t address = static_cast<std::int64_t>(reinterpret_cast<std::uintptr_t>(d));
  const std::int64_t used = registry_row(ctx, 0)[0];
  for (std::int64_t k = 1; k <= used; ++k)
    if (registry_row(ctx, k)[0] == address) return k;
  return 0;
}

// counters[word] += 1, atomically (MuJoCo may run one data's collisions on several threads); the value before.
inline std::int64_t count(std::int64_t counters, int word) {
  return __atomic_fetch_add(reinterpret_cast<std::int64_t*>(counters) + word, std::int64_t(1), __ATOMIC_RELAXED);
}

}  // namespace ellipsim::glue
