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

// --- MuJoCo contact filter (the MuJoCo glue) ---------------------------------------------------------

// The filter grows each body by half of margin + gap + FILTER_CCD_FACTOR * ccd_tolerance.  MuJoCo's
// GJK declares the margin-grown bodies in contact once its iterate is within ccd_tolerance of the
// origin (engine_collision_gjk.c, min_norm), so pairs closer than that must reach MuJoCo.
constexpr double FILTER_CCD_FACTOR = 2.0;

// And by this fraction of the pair's largest semi-axis, against rounding in the growth itself.
constexpr double FILTER_RELATIVE_SLACK = 1e-12;

// --- Narrow phase (distance/ellipsoid_pair.hpp) -----------------------------------------------------------

// Newton on the unit sphere: at most this many steps per run (most pairs need 3-6) ...
constexpr int NEWTON_MAX_ITER = 40;
// ... and converged once a negative definite Newton step is below this many radians: Newton is
// quadratic there, so the point it lands on is ~1e-12 rad from the maximiser and sigma (flat there)
// is exact to rounding (checked against 40-digit mpmath in tests/test_distance.py).
constexpr double NEWTON_STEP_TOL = 1e-5;

// The first Newton run (from the bisector seed) gets this many steps before the branch and bound
// takes over: touching pairs converge in 3-5; a needle seen along its length can bounce indefinitely.
constexpr int FIRST_RUN_ITER = 10;

// --- Warm start of the MuJoCo narrow phase -----------------------------------------------------------------

// sigma_lower_bound: sigma along a stored normal minus this many ulps of the pair's scale
// |d|_1 + max r_A + max r_B (<= 34 u S counted in its docstring); a persistent pair is dropped as
// apart beyond the margin only when that bound is >= the margin.
constexpr double WARM_SIGMA_SLACK_ULPS = 64.0;
// ... and only for semi-axes >= WARM_SCALE_MIN and a scale <= WARM_SCALE_MAX: squares of 2^-400
// (2^-800) are still normal floats and 2^400 squared does not overflow, so the ulp count holds.
constexpr double WARM_SCALE_MIN = 0x1p-400;
constexpr double WARM_SCALE_MAX = 0x1p400;

// --- Proven global maximum for deep penetrations (distance/branch_and_bound.hpp) ------------------------
// u = 2^-53; S = |e| + max semi-axis of A + max semi-axis of B in A's frame (the scale of sigma).

// A returned signed distance is proven within max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of
// the global maximum (r_min the shortest of the six semi-axes, delta R_A's orthonormality defect).
constexpr double BB_TOL_REL = 1e-12;
constexpr double BB_TOL_ULPS = 96.0;
// Rounding of sigma at a float point, <= 11 u S counted: 24 u S covers it ...
constexpr double BB_ERR_SIGMA_ULPS = 24.0;
// ... of a patch's upper bound (gradient, |c|^2 - 1, the bound's own sum), <= 41 u S counted ...
constexpr double BB_PATCH_SLACK_ULPS = 48.0;
// ... and of the change to A's frame (e and U rounded), <= 10 u S counted; 6 delta S is added for
// a rotation orthonormal only to delta.
constexpr double BB_FRAME_ULPS = 16.0;
// Budget of branch-and-bound nodes per pair (a node: a patch and its antipode; ~55 ns each): about
// twice the most the stress suite's near-tangent pairs of aspect 1e4 need (70 558).
constexpr int BB_MAX_PATCHES = 150000;
// Budget of arcs for near-coaxial spheroids (~25 ns each).
constexpr int COAXIAL_MAX_NODES = 2000;
// Budget of cells for spheroids with nearly parallel axes and a cylinder on a spheroid's axis
// (spheroids' axis_bb; ~0.3 us each): 230-3400 for tilted spheroids, 10 000-30 000 for a cylinder whose
// side and rim maxima are within 1e-10 of each other.
constexpr int TILTED_MAX_NODES = 60000;
// Spheroids whose axes are this close to parallel but not close enough for its proof: the parallel
// model's maximiser seeds global_max (a heuristic, the proof does not use it; issue 18).
constexpr double PARALLEL_CANDIDATE_TILT = 0.2;

// --- Ellipsoid x capsule, box and cylinder (pairs/) -------------------------------------------------------

// A capsule, box or cylinder distance is certified when its upper bound is within this fraction of
// the smaller shortest half-size of the pair of the value returned (as BB_TOL_REL for two ellipsoids).
constexpr double PAIR_CERT_REL = 1e-12;
// Rounding allowance of sigma along a direction, in ulps of the pair's scale |e| + largest size: the
// MuJoCo glue drops a pair only when sigma at some direction minus this much is beyond the margin.
constexpr double PAIR_SIGMA_SLACK_ULPS = 64.0;
// Budget of the cylinder rim's azimuth branch and bound: lunes per rim, and bisections of a quarter
// lune (pi/2 / 2^40 ~ 1.4e-12 rad); beyond either the pair is UNPROVEN.
constexpr int RIM_BB_NODES = 400;
constexpr int RIM_BB_LEVELS = 40;
// Newton on the point-ellipsoid secular equation takes its last step once a step is below this
// fraction of t + min(a2), the root's distance from the pole, or below 4 u of |t| + min(a2).
constexpr double SECULAR_LAST = 1e-8;
constexpr int SECULAR_MAX_ITER = 80;
// A secular root within this fraction of min(a2) from the pole -min(a2) is degenerate: the foot
// point comes from Eberly's limit formula (the q_k = 0 case), exact there.
constexpr double POLE_RTOL = 1e-9;
// Steps allowed to each root and split search of the deep-penetration enumeration.
constexpr int CRITICAL_MAX_ITER = 100;

// --- Motion and time of impact (motion/) ---------------------------------------------------------------

// The contract's resolution in t (issue 12): separation proven on [0, toi - TOI_TOL], and a pose that is
// not separated at toi.
constexpr double TOI_TOL = 1e-9;
// A relative rotation within this many radians of a half turn has no well-defined shortest arc.
constexpr double HALF_TURN_TOL = 1e-6;
// |w| below this is no rotation at all (E = I exactly).
constexpr double OMEGA_ZERO = 0x1p-500;
// motion's sincos errs by less than this (absolute) for |x| <= 1.6: gamma_23 cosh(1.6) for Horner's rule
// on the Taylor polynomials, the rounding of x^2 and the tail.
constexpr double SINCOS_ERR = 62.0 * U;
// Rodrigues' E~^T p errs by at most (RODRIGUES_ERR + 12 |alpha|) u |p| (3 SINCOS_ERR/u + 28.8 = 214.8).
constexpr double RODRIGUES_ERR = 216.0;
// Spectral-norm bound on fl(R_p E~(phi)) - R_p E(phi): 4.7e-14 < 2^-44.
constexpr double DELTA_R = 0x1p-44;
// Where time_of_impact looks for the first pose that is not separated once the sweep stalls at its
// proven end a: a + TOI_PROBE, then a + TOI_PROBE2, before exact arithmetic.
constexpr double TOI_PROBE = 0.5 * TOI_TOL;
constexpr double TOI_PROBE2 = 0.999 * TOI_TOL;
// A step whose certificate fails within TOI_PROBE of its end b probes beyond b only when b is within
// this of the step's start a (or the step stalled).
constexpr double TOI_PROBE_REACH = 1e-5;
// The sweep has stalled when a step advances less than this ...
constexpr double TOI_STALL = 0.25 * TOI_TOL;
// ... and after this many stalls in a row, each probed and found separated, the pair is UNRESOLVED.
constexpr int TOI_STALL_LIMIT = 6;
// Sweep steps before a pair is declared UNRESOLVED (a guard; the tests' largest count is 20).
constexpr int TOI_MAX_STEPS = 4000;
// Regula-falsi steps for the largest certified end of a step, stopping once the failing end is within
// this fraction of the certified span.
constexpr int TOI_FALSI_STEPS = 6;
constexpr double TOI_FALSI_RTOL = 0.05;
// Exact relations a pair's search may ask for before it is declared UNRESOLVED.
constexpr int TOI_MAX_ORACLE = 16;
// Batches of at most this many pairs take time_of_impact's one compiled call (checks, set-up and kernel; issue 20).
constexpr int SMALL_BATCH_PAIRS = 16;

// --- Containment (exact/containment.hpp) -------------------------------------------------------------------

// B inside A forces each sorted semi-axis of B to be at most A's times this (BOUNDING_INFLATION each way).
constexpr double AXIS_SLACK = BOUNDING_INFLATION * BOUNDING_INFLATION;
// Cyclic Jacobi sweeps for K_c's eigenbasis and safeguarded Newton steps on the secular equation.
constexpr int JACOBI_SWEEPS = 6;
constexpr int CONTAIN_NEWTON_STEPS = 40;
// ... ending once a step is below CONTAIN_RTOL (relative); a pair left undecided gets its multiplier
// polished to CONTAIN_RTOL_FINE and the certificates once more before exact arithmetic.
constexpr double CONTAIN_RTOL = 1e-9;
constexpr double CONTAIN_RTOL_FINE = 1e-15;

// --- Derivatives of the signed distance (distance/derivatives.hpp) -----------------------------------------

// A maximum is flat (no isolated maximiser) when the larger eigenvalue of sigma's Riemannian Hessian on
// the tangent plane is above -DERIV_FLAT_REL S.
constexpr double DERIV_FLAT_REL = 1e-8;
// Newton steps polishing the proven maximiser before differentiating, and the drop of sigma, in ulps of
// S, beyond which a step is refused.
constexpr int DERIV_POLISH_STEPS = 4;
constexpr double DERIV_POLISH_SLACK_ULPS = 32.0;

// --- Derivatives of the first-contact time (motion/impact_derivatives.hpp) ---------------------------------

// Newton steps on dist(t) = 0 from toi, and the step below which t* counts as converged.
constexpr int TOI_DERIV_NEWTON_STEPS = 4;
constexpr double TOI_DERIV_NEWTON_TOL = 1e-14;
// A first contact is transversal when d dist / dt < -TOI_TRANSVERSAL_REL V at t*.
constexpr double TOI_TRANSVERSAL_REL = 1e-8;

// --- Derivatives of ellipsoid x capsule / box / cylinder distances (pairs/derivatives.hpp) ------------------

// The maximiser lies on a kink of the other body's support function when the cosine is at most this.
constexpr double DERIV_KINK_COS = 1e-10;
// A multiplier of an active kink within DERIV_KINK_REL S of its bound: the derivatives are one-sided.
constexpr double DERIV_KINK_REL = 1e-10;

}  // namespace ellipsim::tol
