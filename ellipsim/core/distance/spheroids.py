"""Proven maximum of sigma for two spheroids with parallel axes of revolution (issue 18).

When A and B are spheroids (or a spheroid and a sphere) whose axes of revolution are parallel to a
line w, sigma(n) = n.e - h_A(n) - h_B(n) depends on n only through its angle t to w and its azimuth
phi about w, and only the offset e sees the azimuth: sigma = f(t) + |e_perp| sin t cos(phi - phi_e).
For every t the maximum over phi is at phi_e, so the maximum over the sphere is the maximum of two
coaxial ellipses' sigma in the plane of w and e_perp (Schneider & Eberly, Geometric Tools 10.5.2:
h(n) = |D R^T n|, which for a spheroid depends on (n.w)^2 only):
  g(z, r) = e_k z + |e_perp| r - sqrt(qa^2 z^2 + pa^2 r^2) - sqrt(qb^2 z^2 + pb^2 r^2),  (z, r) = (cos t, sin t),
maximised by a branch and bound over t in [0, pi] with the concave majorant of branch_and_bound.py's module
docstring, part 1, in two dimensions (g is concave and 1-homogeneous on R^2: on an arc of chord
radius rho around the unit c, g <= g(c) + |G_T| rho + max(-G.c, 0) rho^2 / 2).  With the axes on one
line through both centres (e_perp = 0) the maxima form circles about w, which branch_and_bound.py's branch
and bound over the sphere cannot isolate; with parallel axes and the centres off that line (a grid,
a line or a keyframe of equal rotations) they are isolated, but so nearly flat along the circle that
it runs out of budget there too.

In A's frame (e, a, U, b as in branch_and_bound.py) w is A's axis k; qa = a_k, pa = the mean of A's other
two semi-axes, qb = b_j for B's axis j nearest to w, pb = the mean of B's other two.  The pair need
not be exactly of revolution nor exactly parallel: for every unit n, with n's own (z, r) in the plane,
sigma(n) <= g(z, r) + delta and sigma(n*) >= g(z*, r*) - delta at the returned n* (in the plane), with
  delta = |a_k1 - a_k2| / 2                                 (A not exactly of revolution)
        + max|b - b0| (1 + 3 def) + |qb^2 - pb^2| eps (2 + eps) / min(qb, pb) + 1.5 pb^2 def / min(qb, pb)
b0 = (qb, pb, pb) in B's order, eps = |u_j - s e_k| (B's axis off w, s its sign) and def =
max |U U^T - I| (h_B(n)^2 - h_B0(n)^2 = (qb^2 - pb^2)((u_j.n)^2 - n_k^2) + pb^2 (|U^T n|^2 - 1) for
B's semi-axes made b0; |(u_j.n)^2 - n_k^2| <= eps (|u_j| + 1), and |x - y| <= |x^2 - y^2| / (x + y)), plus
the roundings of the means, squares and |e_perp| (6 u S, S = |e| + max a + max b).  The answer is
proven within tol when the 1-D branch and bound is run to tol - 2 delta - ERR_G - ERR_SIGMA (g at the
returned angle and sigma at the returned n as computed): axes tilted by more than about tol / max b
go to tilted_max below, a branch and bound over both angles about A's axis that keeps B's tilt exactly
and bounds sigma on a cell by its second-order Taylor expansion (the section's comment).

The kernels are C++, ellipsim/native/include/ellipsim/distance/spheroids.hpp (bound in the _ellipsim module).
"""

U64 = 2.0**-53
MAX_LEVEL = 52  # arcs of pi 2^-52: far below any tolerance reached
# Rounding, S = |e| + max a + max b: g at a float point c = (cos t, sin t) errs by <= 3 u |e| (two
# products, a sum) + 2.5 u max a + 2.5 u max b (each root of a sum of two rounded products of rounded
# squares) + 2 u S (the subtractions) + u S (|c| = 1 +- u, g is 1-homogeneous): ERR_G = 8 u S covers it;
# an arc's bound adds ~4 u S of its own sum to that (the gradient's error is epsg, times rho):
ERR_G_ULPS = 8.0
ARC_SLACK_ULPS = 12.0


# --- Nearly parallel axes: a branch and bound over (t, phi) with second-order bounds -----------------
#
# For spheroids whose axes are tilted by tau from parallel, the maxima of sigma are no longer a circle
# nor nearly flat isolated points of the parallel model: along the circle sigma varies by O(tau max b)
# and across it by O(max b).  The cap bound of branch_and_bound.py pays |sigma| rho^2 / 2 in every direction
# (the sphere's curvature), so it needs caps of radius sqrt(tol / |sigma|) all along the circle.  Here
# n = (cos t, sin t cos phi, sin t sin phi) along A's axes (k, k + 1, k + 2), and the model
#   sigma_m(t, phi) = n.e - sqrt(qa^2 cos^2 t + pa^2 sin^2 t) - sqrt(pb^2 + (qb^2 - pb^2) (u.n)^2)
# (u = B's axis j in A's frame, as given: no tilt is modelled away; |sigma - sigma_m| <= delta0, the
# parallel model's delta without its tilt term) is smooth in (t, phi), poles included.  On a cell
# [tc +- ht] x [pc +- hp], Taylor's theorem with the Lagrange remainder along the segment gives
#   sigma_m <= sigma_m(c) + q(s_t, Mtt, ht) + q(s_p, Mpp, hp) + Ktp ht hp,
#   q(g, M, h) = max_{|d| <= h} g d + M d^2 / 2,
# with Mtt, Mpp upper bounds of the second partials over the cell and Ktp of |s_tp|, evaluated in
# midpoint-radius (ball) interval arithmetic from cos, sin of the cell's centre (|cos(x + d) - cos x|
# <= |sin x| |d| + d^2 / 2).  Along phi s_pp is O(|e_perp| + tau max b), so cells there stay long
# where they are thin across the circle: each cell is split in the direction whose term is larger.
# Every ball operation widens its radius by its own rounding; the centre values carry ERR_C (sigma_m)
# and the gradient's epsg, as parallel_max's.

ERR_C_ULPS = 16.0  # sigma_m at a float centre: cos, sin rounded (n within ~3 u), the two roots, the sums
TILT_LEVELS = 52  # cells of pi 2^-52 in either direction: far below any tolerance's width
TILT_DEPTH = 62  # splits along one root-to-leaf path (their directions are bits of one int64)
ROOT_T, ROOT_P = 2, 3  # 4 x 8 root cells over [0, T] x [-T, T]
T_DOMAIN = 3.1415926535897936  # the float above pi: the cells cover [0, pi] x [-pi, pi]
U4 = 4.0 * U64
