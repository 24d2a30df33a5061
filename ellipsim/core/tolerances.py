"""Every tolerance and threshold of ellipsim, each with where its number comes from."""

#: Unit roundoff of float64 (round to nearest): |fl(x op y) - x op y| <= U |x op y|.
U = 2.0**-53


def gamma(n):
    """Higham's gamma_n = n u / (1 - n u): bound on the relative error of n roundings."""
    return n * U / (1.0 - n * U)


# --- Input validation ------------------------------------------------------------------------

#: A rotation is accepted when max_ij |(R^T R - I)_ij| <= this.  MuJoCo's geom_xmat comes from
#: normalised quaternions and sits near 1e-16; 1e-6 admits float32-built rotations too.
ORTHONORMAL_TOL = 1e-6

# --- Certified filter (ellipsim/core/exact/certified_filter.py) -------------------------------------------------

#: Inflation of the bounding-sphere radius max(r).  A point of E is c + R^{-T} D u with |u| <= 1,
#: so |x - c| <= r_max / sigma_min(R).  With the validated |(R^T R - I)_ij| <= 1e-6,
#: ||R^T R - I||_2 <= 3e-6 and 1 / sigma_min(R) <= 1 + 1.6e-6 < 1 + 2^-16.
BOUNDING_INFLATION = 1.0 + 2.0**-16

#: The float path only runs when max/min over the six semi-axes of a pair is at most RATIO_MAX and
#: the largest semi-axis lies in [SCALE_MIN, SCALE_MAX]; other pairs go to exact arithmetic.
#: Together with |c_b - c_a| <= 2 r_max (else the bounding spheres decide) this keeps every
#: intermediate below 2^700 and bounds what an underflow can do (see TAU).
RATIO_MAX = 2.0**40
SCALE_MIN = 2.0**-500
SCALE_MAX = 2.0**500

#: Absolute slack added to every certified comparison.  An underflowing multiplication errs by at
#: most 2^-1075 (additions are exact there); on its way to a certified value it is amplified at most
#: by 2^540 (1 / r in q(c)) or 2^600 (in A's frame, with mu in [MU_MIN, MU_MAX]); a few thousand
#: operations stay far below 2^-400.
TAU = 2.0**-400

#: Relative error coefficients for the certified signs: an expression evaluated with at most n
#: roundings on any path (leaf roundings included) errs by at most gamma_n times its absolute
#: polynomial ("mag", evaluated alongside with |leaves|).  The constants cover the depth counted in
#: certified_filter.py with a margin for the rounding of the bound itself.
ERR_SHORT = gamma(16) * 1.01  # the bounding-sphere and centre-inside tests (depth <= 13)
ERR_POLY = gamma(48) * 1.01  # f(mu) = mu N(mu) - (mu + alpha) P(mu) (depth <= 32)
ERR_WITNESS = gamma(16) * 1.01  # |y|^2 < 1 and |W (y - e)|^2 < alpha (depth <= 13)

#: mu (the pencil parameter in A's frame) is clamped to this range on the float path.
MU_MIN = 2.0**-120
MU_MAX = 2.0**120

#: The centre-axis separation test uses |D R^T d| for the support |D R^{-1} d|.  For a validated
#: rotation ||R^{-1} - R^T||_2 <= ||E|| (1 + ||E||) / (1 - ||E||) < 3.1e-6 (E = R^T R - I,
#: ||E||_2 <= ||E||_F <= 3e-6), and the float evaluation adds < 1e-14 r_max |d|: 5e-6 covers both.
SUPPORT_SLACK = 5e-6

#: Perram-Wertheim maximisation (contact_scale.py): Newton steps at most, and the relative step that
#: ends it.  mu* is only determined to ~1e-9 by float64 (F is flat there); F(mu) is then exact to
#: ~1e-16, which is what contact_scale reports.
PW_MAX_ITER = 60
PW_RTOL = 1e-13

#: The certified filter tries f(mu) > 0 as soon as F(mu) exceeds 1 by this (F is accurate to a few
#: ulps, so below it the certificate would fail on its error bound anyway).
PW_TRY_SEPARATED = 1e-12

# --- Dispatch -------------------------------------------------------------------------------

#: Batches at least this long run on several threads by default (core/threads.py).  On the 2-core
#: machine, 2 threads over 1 (median of interleaved calls, 2026-12-01): classify 10^4 pairs 0.79x,
#: 3*10^4 0.55x, 10^5-10^6 0.52-0.53x; contact_scale 10^4 0.61x; signed_distance 10^4 0.61x.
PARALLEL_MIN_PAIRS = 10_000

#: A parallel call cuts its batch into at most CHUNKS_PER_THREAD chunks per thread (pairs differ in
#: cost: a chunk of deep pairs must not hold up the call) of at least CHUNK_MIN_PAIRS pairs (a chunk
#: costs a task submission and a call into the compiled kernel, ~10 us).
CHUNKS_PER_THREAD = 4
CHUNK_MIN_PAIRS = 2_000

#: Batches up to this long take the small-batch paths of the public calls (issue 20): the kernel called
#: without threads.run (which runs batches below 2 CHUNK_MIN_PAIRS in one piece too), a Python scan of a
#: few codes instead of numpy's ~1.3 us np.flatnonzero, and time_of_impact's checks, set-up and kernel in
#: one compiled call.  The results are the same on either path (tests/test_single_pair.py).
SMALL_BATCH_PAIRS = 16

# --- MuJoCo contact filter (ellipsim/native/mujoco/contact_filter.hpp) -----------------------------------

#: The filter grows each body by half of margin + gap + FILTER_CCD_FACTOR * ccd_tolerance.  MuJoCo's
#: GJK declares the margin-grown bodies in contact once its iterate is within ccd_tolerance of the
#: origin (engine_collision_gjk.c, min_norm), so pairs closer than that must reach MuJoCo.
FILTER_CCD_FACTOR = 2.0

#: And by this fraction of the pair's largest semi-axis, against rounding in the growth itself.
FILTER_RELATIVE_SLACK = 1e-12

# --- Narrow phase (ellipsim/core/distance/ellipsoid_pair.py) ------------------------------------------------------

#: Newton on the unit sphere: at most this many steps per run (most pairs need 3-6) ...
NEWTON_MAX_ITER = 40
#: ... and converged once a negative definite Newton step is below this many radians: Newton is
#: quadratic there, so the point it lands on is ~1e-12 rad from the maximiser and sigma (flat there)
#: is exact to rounding (checked against 40-digit mpmath in tests/test_distance.py).
NEWTON_STEP_TOL = 1e-5

#: The first Newton run (from the bisector seed) gets this many steps before the branch and bound
#: takes over: touching pairs converge in 3-5; a needle seen along its length can bounce indefinitely.
FIRST_RUN_ITER = 10

# --- Warm start of the MuJoCo narrow phase (ellipsim/native/mujoco/narrowphase.hpp, distance/ellipsoid_pair.hpp) --

#: sigma_lower_bound (distance/ellipsoid_pair.hpp): sigma along a stored normal minus this many ulps of the pair's scale
#: |d|_1 + max r_A + max r_B (<= 34 u S counted in its comment); a persistent pair is dropped as
#: apart beyond the margin only when that bound is >= the margin.
WARM_SIGMA_SLACK_ULPS = 64.0
#: ... and only for semi-axes >= WARM_SCALE_MIN and a scale <= WARM_SCALE_MAX: squares of 2^-400
#: (2^-800) are still normal floats and 2^400 squared does not overflow, so the ulp count holds.
WARM_SCALE_MIN = 2.0**-400
WARM_SCALE_MAX = 2.0**400

# --- Proven global maximum for deep penetrations (ellipsim/core/distance/branch_and_bound.py) -------------------
# u = 2^-53; S = |e| + max semi-axis of A + max semi-axis of B in A's frame (the scale of sigma).

#: A returned signed distance is proven within max(BB_TOL_REL r_min, (BB_TOL_ULPS u + 6 delta) S) of
#: the global maximum (r_min the shortest of the six semi-axes, delta R_A's orthonormality defect):
#: the issue's 1e-12 of the smaller shortest semi-axis, floored by what float64 evaluates sigma to.
BB_TOL_REL = 1e-12
BB_TOL_ULPS = 96.0
#: Rounding of sigma at a float point, <= 11 u S counted (branch_and_bound.py docstring): 24 u S covers it ...
BB_ERR_SIGMA_ULPS = 24.0
#: ... of a patch's upper bound (gradient, |c|^2 - 1, the bound's own sum), <= 41 u S counted ...
BB_PATCH_SLACK_ULPS = 48.0
#: ... and of the change to A's frame (e and U rounded), <= 10 u S counted; 6 delta S is added for
#: a rotation orthonormal only to delta.
BB_FRAME_ULPS = 16.0
#: Budget of branch-and-bound nodes per pair (a node: a patch and its antipode; ~55 ns each).  Deep
#: leaves.xml contacts and random 25:1 and 100:1 crossings need at most a few hundred; the stress
#: suite's near-tangent pairs of aspect up to 1e3 / 1e4 need up to 22 538 / 70 558 (5000 each; at 6000,
#: 14 and 2137 of them were UNPROVEN): about twice the most seen, ~8 ms for a pair that uses it all.
BB_MAX_PATCHES = 150000
#: Budget of arcs for near-coaxial spheroids (core/coaxial.py; ~25 ns each): the arcs undecided at a
#: level are those around the maximum, 2-4 a level down to widths of ~sqrt(tol / curvature).
COAXIAL_MAX_NODES = 2000
#: Budget of cells for spheroids with nearly parallel axes and a cylinder on a spheroid's axis
#: (core/spheroids.axis_bb; ~0.3 us each): 230-3400 for tilted spheroids; a cylinder whose side and
#: rim maxima are within 1e-10 of each other took 10 000-30 000 (the side's kink is refined to ~tol / L).
TILTED_MAX_NODES = 60000
#: Spheroids whose axes are this close to parallel (radians, and semi-axes / offsets within this of
#: the parallel model, relative to S) but not close enough for its proof: the model's maximiser seeds
#: global_max (a heuristic, the proof does not use it): tilts of 1e-12-1e-1 rad left global_max with
#: a lower local maximum (off by up to 0.35 r_min) on deep prolate pairs (issue 18).
PARALLEL_CANDIDATE_TILT = 0.2

# --- Ellipsoid x capsule and box (ellipsim/core/pairs/capsule.py, box.py, pairs/point_ellipsoid.hpp) ------------

#: The contract: a capsule or box distance is certified when its upper bound is within this fraction
#: of the smaller shortest half-size of the pair (ellipsoid semi-axis, capsule radius, box half-size) of the value
#: returned: the issue's 1e-12, as BB_TOL_REL for two ellipsoids.  The float evaluation of both
#: sides errs by a few ulps of the pair's scale, far below it for sizes within 1e3 of the distance.
PAIR_CERT_REL = 1e-12
#: Rounding allowance of sigma along a direction, in ulps of the pair's scale |e| + largest size
#: (a few dozen operations on quantities of that size; the prototype's 10 000-pose validation saw
#: at most 1.4e-15 of the scale, /work/scratch/pairtypes/results/validation_capsule.md): the MuJoCo
#: glue drops a pair only when sigma at some direction minus this much is beyond the margin.
PAIR_SIGMA_SLACK_ULPS = 64.0
#: Budget of the cylinder rim's azimuth branch and bound (cylinder._rim_bb): lunes per rim, and
#: bisections of a quarter lune (pi/2 / 2^40 ~ 1.4e-12 rad); beyond either the pair is UNPROVEN.
RIM_BB_NODES = 400
RIM_BB_LEVELS = 40
#: Newton on the point-ellipsoid secular equation takes its last step once a step is below this
#: fraction of t + min(a2), the root's distance from the pole (quadratic convergence: the next would
#: be ~1e-16 of it), or below 4 u of |t| + min(a2); relative to |t| + min(a2) alone, a root 2e-9 from
#: the pole stopped 1 % of that off and the normal with it; SECULAR_MAX_ITER never reached.
SECULAR_LAST = 1e-8
SECULAR_MAX_ITER = 80
#: A secular root within this fraction of min(a2) from the pole -min(a2) is degenerate: the foot
#: point comes from Eberly's limit formula (the q_k = 0 case), exact there.
POLE_RTOL = 1e-9
#: Steps allowed to each root and split search of the deep-penetration enumeration (monotone
#: safeguarded Newton inside a bracket: they end on a 1e-15 relative step long before).
CRITICAL_MAX_ITER = 100

# --- Narrow-phase validation against MuJoCo (mujoco/compare.py) --------------------------
# The acceptance bounds of issue 4: MuJoCo's GJK/EPA works to ccd_tolerance (1e-6 by default), so
# contacts within 2e-6 of touching may exist on one side only, and per contact the two may differ
# by these much before a difference is reported.
NEAR_TANGENT = 2e-6  # metres: |dist| below this, a contact on one side only is not a difference
DIST_TOL = 2e-6  # metres
ANGLE_TOL = 1e-3  # radians between the normals
POS_TOL = 1e-3  # metres between the contact points

#: The third opinion of compare_narrowphase for deep penetrations: MuJoCo's GJK/EPA run to this
#: tolerance (its default is 1e-6; at 1e-11 its contacts agree with ellipsim's to ~1e-11).
TIGHT_CCD_TOLERANCE = 1e-11
TIGHT_CCD_ITERATIONS = 1000

# --- Motion and time of impact (core/motion/interpolation.py, core/motion/time_of_impact.py) --------------------------

#: The contract's resolution in t (issue 12): time_of_impact proves separation on [0, toi - TOI_TOL]
#: and finds a pose that is not separated at toi, which lies within TOI_TOL of the proven range.
TOI_TOL = 1e-9

#: A relative rotation within this many radians of a half turn has no well-defined shortest arc
#: (validated rotations are orthonormal to 1e-6 only, so the axis of a turn by pi - 1e-7 is noise):
#: ValueError.  It also keeps |alpha| = |w| |phi| <= pi/2 for the sin/cos polynomials of interpolation.py.
HALF_TURN_TOL = 1e-6

#: |w| below this is no rotation at all (E = I exactly): 2^-500 rad would only add underflow.
OMEGA_ZERO = 2.0**-500

#: motion.sincos errs by less than this (absolute) for |x| <= 1.6: gamma_23 cosh(1.6) for Horner's
#: rule on the Taylor polynomials, the rounding of x^2 and the tail (derivation in its docstring).
#: Its own polynomials rather than libm's sin/cos, whose accuracy is documented but not proven.
SINCOS_ERR = 62.0 * U

#: Rodrigues' E~^T p errs by at most (RODRIGUES_ERR + 12 |alpha|) u |p| (rodrigues_apply in motion/interpolation.hpp:
#: 3 SINCOS_ERR/u + 28.8 = 214.8; mpmath over random cases in tests/test_toi.py).
RODRIGUES_ERR = 216.0

#: Spectral-norm bound on fl(R_p E~(phi)) - R_p E(phi), the float pose's rotation against the exact
#: motion's: each column of E~ within (RODRIGUES_ERR + 12 pi/2) u = 2.61e-14, sqrt(3) of that for the
#: matrix, times ||R_p|| <= 1 + 1.6e-6, plus the product's rounding gamma_3 * 3: 4.7e-14 < 2^-44.
DELTA_R = 2.0**-44

#: Where time_of_impact looks for the first pose that is not separated once the sweep stalls at its
#: proven end a: a + TOI_PROBE, then a + TOI_PROBE2 (a deeper pose when the first is within rounding
#: of touching) before asking for rationals.  Both within TOI_TOL of the proven range.
TOI_PROBE = 0.5 * TOI_TOL
TOI_PROBE2 = 0.999 * TOI_TOL

#: A step whose certificate fails within TOI_PROBE of its end b probes beyond b only when b is within
#: this of the step's start a (or the step stalled): the step's normal is the contact normal at a, which
#: misses the contact time by ~C (b - a)^2 with C = 0.1-5 on the benchmark's motions, so a probe after a
#: longer step finds the pose still separated, and the next step (from b) is what gets there.
TOI_PROBE_REACH = 1e-5

#: The sweep has stalled when a step advances less than this ...
TOI_STALL = 0.25 * TOI_TOL
#: ... and after this many stalls in a row, each probed and found separated, the pair is UNRESOLVED:
#: the certificates resolve margins to ~1e-14 of the pair's size, so the pair stays within float64
#: resolution of touching over several TOI_TOL (a grazing contact, a near miss, a very slow approach).
TOI_STALL_LIMIT = 6

#: Sweep steps before a pair is declared UNRESOLVED (a guard; never reached in the tests, where the
#: mean is 1.6-4 and the largest count 20).
TOI_MAX_STEPS = 4000

#: Regula-falsi steps for the largest certified end of a step, stopping once the failing end is within
#: this fraction of the certified span: more steps buy less than a new sweep step costs.
TOI_FALSI_STEPS = 6
TOI_FALSI_RTOL = 0.05

#: Exact relations (rationals) a pair's search may ask for before it is declared UNRESOLVED: each
#: costs ~1-4 ms, and a pair needs one or two (a touching pose at t = 0 or a grazing probe).
TOI_MAX_ORACLE = 16

# --- Containment (core/exact/containment.py) ------------------------------------------------------------

#: B inside A forces each sorted semi-axis of B to be at most A's times this: widths are monotone
#: under inclusion, and a validated rotation's singular values lie within 1 +- 1.6e-6
#: (BOUNDING_INFLATION), so the axes of R^{-T} D differ from r by at most that factor each way.
AXIS_SLACK = BOUNDING_INFLATION**2

#: Cyclic Jacobi sweeps for K_c's eigenbasis (3x3: converged to rounding in 3-4) and the safeguarded
#: Newton steps on the secular equation (converges in < 10; both only guide the certificates).
JACOBI_SWEEPS = 6
CONTAIN_NEWTON_STEPS = 40
#: ... ending once a step is below CONTAIN_RTOL (relative): the certificates are flat in the multiplier
#: at the optimum, and 1e-9 decides all but ~1 in 50 000 random near-containment pairs in ~6 steps
#: (624 ns/pair; to 1e-12 from the start: 837 ns/pair).  A pair left undecided gets its multiplier
#: polished to CONTAIN_RTOL_FINE and the certificates once more before rationals (~2 ms).
CONTAIN_RTOL = 1e-9
CONTAIN_RTOL_FINE = 1e-15

# --- Derivatives of the signed distance (core/distance/derivatives.py) --------------------------------

#: A maximum is flat (no isolated maximiser: the derivatives are not given) when the larger eigenvalue of
#: sigma's Riemannian Hessian on the tangent plane is above -DERIV_FLAT_REL S (S = |c_B - c_A| + the two
#: largest semi-axes, the scale of its entries).  The stationarity residual rounds to ~u S, which moves
#: the maximiser by ~u S / |eigenvalue|: at this bound d n* / d theta keeps ~1e-8 relative accuracy
#: (issue 24's bound), and circles of maxima (coaxial spheroids: an eigenvalue of ~u S) fall below it.
DERIV_FLAT_REL = 1e-8
#: Newton steps polishing the proven maximiser before differentiating (quadratic convergence: from the
#: proof's ~sqrt(TOL) along a flat direction to rounding in 2-3), and the drop of sigma, in ulps of S,
#: beyond which a step is refused (sigma is evaluated to ~11 u S: a genuine step never loses more).
DERIV_POLISH_STEPS = 4
DERIV_POLISH_SLACK_ULPS = 32.0

# --- Derivatives of the first-contact time (core/motion/impact_derivatives.py) -------------------------

#: Newton steps on dist(t) = 0 from toi (within TOI_TOL = 1e-9 of t*: quadratic convergence reaches
#: rounding in two), and the step below which t* counts as converged (a few ulps of t in [0, 1]).
TOI_DERIV_NEWTON_STEPS = 4
TOI_DERIV_NEWTON_TOL = 1e-14
#: A first contact is transversal when d dist / dt < -TOI_TRANSVERSAL_REL V at t* (V: the motion's speed
#: scale, |c1 - c0| + |w| max r of both bodies): d t* / d theta divides by d dist / dt, whose rounding is
#: ~u V, so below this the quotient keeps fewer than ~8 digits (issue 24's 1e-8) and the contact is
#: reported GRAZING instead.
TOI_TRANSVERSAL_REL = 1e-8

# --- Derivatives of ellipsoid x capsule / box / cylinder distances (core/pairs/derivatives.py) ----------

#: The maximiser n* lies on a kink of the other body's support function (n*.v = 0 for a box axis or a
#: capsule / cylinder axis v; |P n*| = 0 at a cylinder cap) when the cosine is at most this: the narrow
#: phase puts edge, face, side and cap maximisers there to rounding (~1e-16), and a vertex or end contact
#: within 1e-10 rad of a kink is, to the derivatives, one on it (then ONE_SIDED by the multiplier test).
DERIV_KINK_COS = 1e-10
#: A multiplier of an active kink within DERIV_KINK_REL S of its bound (the contact point within that of
#: the edge of its face, side or cap): the contact sits where two features meet, and the derivatives of
#: the held feature are one-sided (ONE_SIDED).
DERIV_KINK_REL = 1e-10
