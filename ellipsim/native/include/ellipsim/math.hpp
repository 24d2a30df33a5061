// The few C math functions the kernels call, and the integer types, wherever the core is compiled: the host
// compilers (with <cmath> and <stdint.h>), and Warp's kernel compilers, which see no C or C++ library header
// (WP_NO_CRT; warp/native/crt.h): its CPU JIT is clang, its CUDA path NVRTC.  Every kernel header calls
// math::sqrt and the rest, never std::, so one source compiles in all three.  INFINITY and NAN come from
// <cmath> or from Warp's crt.h.  sqrt, fabs, copysign, fmax, fmod, frexp, ldexp, floor and ceil are exact (correctly
// rounded) in every C library and in CUDA; pow, sin, cos, atan and atan2 are not (glibc within 1 ulp, CUDA's
// double versions within 2: CUDA Math API), so where a search calls them (spheroids.hpp's angles, the cylinder's
// rims, point_ellipsoid's starts) a GPU's result may differ from the CPU's by rounding, not bit for bit.
#pragma once

#if defined(WP_NO_CRT)
// Warp's crt.h has made int8_t ... uint64_t global typedefs.
#else
#include <stdint.h>

#include <cmath>
#endif

#include "config.hpp"

namespace ellipsim::math {

#if defined(WP_NO_CRT) && defined(__CUDACC__)
// NVRTC: CUDA's math library, declared without headers.
ELLIPSIM_HD double sqrt(double x) { return ::sqrt(x); }
ELLIPSIM_HD double fabs(double x) { return ::fabs(x); }
ELLIPSIM_HD double copysign(double x, double y) { return ::copysign(x, y); }
ELLIPSIM_HD double fmax(double x, double y) { return ::fmax(x, y); }
ELLIPSIM_HD double fmod(double x, double y) { return ::fmod(x, y); }
ELLIPSIM_HD double frexp(double x, int* e) { return ::frexp(x, e); }
ELLIPSIM_HD double ldexp(double x, int e) { return ::ldexp(x, e); }
ELLIPSIM_HD double pow(double x, double y) { return ::pow(x, y); }
ELLIPSIM_HD double sin(double x) { return ::sin(x); }
ELLIPSIM_HD double cos(double x) { return ::cos(x); }
ELLIPSIM_HD double atan(double x) { return ::atan(x); }
ELLIPSIM_HD double atan2(double y, double x) { return ::atan2(y, x); }
ELLIPSIM_HD double floor(double x) { return ::floor(x); }
ELLIPSIM_HD double ceil(double x) { return ::ceil(x); }
ELLIPSIM_HD float sqrt(float x) { return ::sqrtf(x); }
ELLIPSIM_HD float fabs(float x) { return ::fabsf(x); }
#elif defined(WP_NO_CRT)
// Warp's CPU JIT (clang): its builtins, the libm calls among them resolved in the running process.
ELLIPSIM_HD double sqrt(double x) { return __builtin_sqrt(x); }
ELLIPSIM_HD double fabs(double x) { return __builtin_fabs(x); }
ELLIPSIM_HD double copysign(double x, double y) { return __builtin_copysign(x, y); }
ELLIPSIM_HD double fmax(double x, double y) { return __builtin_fmax(x, y); }
ELLIPSIM_HD double fmod(double x, double y) { return __builtin_fmod(x, y); }
ELLIPSIM_HD double frexp(double x, int* e) { return __builtin_frexp(x, e); }
ELLIPSIM_HD double ldexp(double x, int e) { return __builtin_ldexp(x, e); }
ELLIPSIM_HD double pow(double x, double y) { return __builtin_pow(x, y); }
ELLIPSIM_HD double sin(double x) { return __builtin_sin(x); }
ELLIPSIM_HD double cos(double x) { return __builtin_cos(x); }
ELLIPSIM_HD double atan(double x) { return __builtin_atan(x); }
ELLIPSIM_HD double atan2(double y, double x) { return __builtin_atan2(y, x); }
ELLIPSIM_HD double floor(double x) { return __builtin_floor(x); }
ELLIPSIM_HD double ceil(double x) { return __builtin_ceil(x); }
ELLIPSIM_HD float sqrt(float x) { return __builtin_sqrtf(x); }
ELLIPSIM_HD float fabs(float x) { return __builtin_fabsf(x); }
#else
using std::atan;
using std::atan2;
using std::ceil;
using std::copysign;
using std::cos;
using std::fabs;
using std::floor;
using std::fmax;
using std::fmod;
using std::frexp;
using std::ldexp;
using std::pow;
using std::sin;
using std::sqrt;
#endif

// IEEE: only NaN compares unequal to itself (no -ffast-math: config.hpp refuses it).
template <typename T>
ELLIPSIM_HD bool isnan(T x) {
  return x != x;
}

// Finite: x - x is 0, and NaN for an infinity or a NaN.
template <typename T>
ELLIPSIM_HD bool isfinite(T x) {
  return x - x == T(0);
}

}  // namespace ellipsim::math
