// The floating-point contract every ellipsim kernel is proved under, and the host/device marker.
//
// The error bounds of the certified filters (tolerances.hpp) count one rounding per +, -, *, / and
// sqrt in IEEE double, round to nearest: no fused multiply-add, no reassociation, no flush to zero.
// The build states it once (CMakeLists.txt: -ffp-contract=off, no -ffast-math); the pragma below
// states it again to the compilers that honour it, and tests/test_native.py checks the built module.
#pragma once

#pragma STDC FP_CONTRACT OFF

#if defined(__FAST_MATH__)
#error "ellipsim's certified kernels assume IEEE arithmetic: build without -ffast-math"
#endif

// (Warp's kernel compilers see no C++ library header: math.hpp; their double is IEEE binary64 by design.)
#if !defined(WP_NO_CRT)
#include <limits>
static_assert(std::numeric_limits<double>::is_iec559, "ellipsim needs IEEE 754 double");
#endif

// Every per-pair stage is inlined into its kernel (as numba's inline="always" stages were): a stage's
// error magnitudes ("mags") that a caller does not read are then dropped by the compiler.
#if defined(__CUDACC__)
#define ELLIPSIM_HD __host__ __device__ __forceinline__
#elif defined(__GNUC__)
#define ELLIPSIM_HD inline __attribute__((always_inline))
#else
#define ELLIPSIM_HD inline
#endif

// The few large searches numba kept as calls of their own (its @jit functions, not inlined stages): inlined
// into every caller they bloat it and cost 10-20% (the cylinder's rim searches, measured), so they stay calls.
#if defined(__CUDACC__)
#define ELLIPSIM_HD_CALL __host__ __device__ __noinline__
#elif defined(__GNUC__)
#define ELLIPSIM_HD_CALL inline __attribute__((noinline))
#else
#define ELLIPSIM_HD_CALL inline
#endif
