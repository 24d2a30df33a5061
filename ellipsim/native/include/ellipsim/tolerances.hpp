// The tolerances and thresholds the compiled kernels use, each with where its number comes from.
// The same names and values as ellipsim/core/tolerances.py (tests/test_native.py compares them).
#pragma once

namespace ellipsim::tol {

// Unit roundoff of float64 (round to nearest): |fl(x op y) - x op y| <= U |x op y|.
constexpr double U = 0x1p-53;

// Higham's gamma_n = n u / (1 - n u): bound on the relative error of n roundings.
constexpr double gamma(int n) { return n * U / (1.0 - n * U); }

// --- Certified filter (exact/certified_filter.hpp) ----------------------------------------------

// Inflation of the bounding-sphere radius max(r).  A point of E is c + R^{-T} D u with |u| <= 1,
// so |x - c| <= r_max / sigma_min(R).  With the validated |(R^T R - I)_ij| <= 1e-6,
// ||R^T R - I||_2 <= 3e-6 and 1 / sigma_min(R) <= 1 + 1.6e-6 < 1 + 2^-16.
constexpr double BOUNDING_INFLATION = 1.0 + 0x1p-16;

// The float path only runs when max/min over the six semi-axes of a pair is at most RATIO_MAX and
// the largest semi-axis lies in [SCALE_MIN, SCALE_MAX]; other pairs go to exact arithmetic.
// Together with |c_b - c_a| <= 2 r_max (else the bounding spheres decide) this keeps every
// intermediate below 2^700 and bounds what an underflow can do (see TAU).
constexpr double RATIO_MAX = 0x1p40;
constexpr double SCALE_MIN = 0x1p-500;
constexpr double SCALE_MAX = 0x1p500;

// Absolute slack added to every certified comparison.  An underflowing multiplication errs by at
// most 2^-1075 (additions are exact there); on its way to a certified value it is amplified at most
// by 2^540 (1 / r in q(c)) or 2^600 (in A's frame, with mu in [MU_MIN, MU_MAX]); a few thousand
// operations stay far below 2^-400.
constexpr double TAU = 0x1p-400;

// Relative error coefficients for the certified signs: an expression evaluated with at most n
// roundings on any path (leaf roundings included) errs by at most gamma_n times its absolute
// polynomial ("mag", evaluated alongside with |leaves|).  The constants cover the depth counted in
// certified_filter.hpp with a margin for the rounding of the bound itself.
constexpr double ERR_SHORT = gamma(16) * 1.01;    // the bounding-sphere and centre-inside tests (depth <= 13)
constexpr double ERR_POLY = gamma(48) * 1.01;     // f(mu) = mu N(mu) - (mu + alpha) P(mu) (depth <= 32)
constexpr double ERR_WITNESS = gamma(16) * 1.01;  // |y|^2 < 1 and |W (y - e)|^2 < alpha (depth <= 13)

// mu (the pencil parameter in A's frame) is clamped to this range on the float path.
constexpr double MU_MIN = 0x1p-120;
constexpr double MU_MAX = 0x1p120;

// The centre-axis separation test uses |D R^T d| for the support |D R^{-1} d|.  For a validated
// rotation ||R^{-1} - R^T||_2 <= ||E|| (1 + ||E||) / (1 - ||E||) < 3.1e-6 (E = R^T R - I,
// ||E||_2 <= ||E||_F <= 3e-6), and the float evaluation adds < 1e-14 r_max |d|: 5e-6 covers both.
constexpr double SUPPORT_SLACK = 5e-6;

// Perram-Wertheim maximisation (exact/contact_scale.hpp): Newton steps at most, and the relative
// step that ends it.  mu* is only determined to ~1e-9 by float64 (F is flat there); F(mu) is then
// exact to ~1e-16, which is what contact_scale reports.
constexpr int PW_MAX_ITER = 60;
constexpr double PW_RTOL = 1e-13;

// The certified filter tries f(mu) > 0 as soon as F(mu) exceeds 1 by this (F is accurate to a few
// ulps, so below it the certificate would fail on its error bound anyway).
constexpr double PW_TRY_SEPARATED = 1e-12;

}  // namespace ellipsim::tol
