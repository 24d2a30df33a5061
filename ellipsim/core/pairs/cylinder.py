"""Signed distance of an ellipsoid and a cylinder (MuJoCo's ellipsoid x cylinder narrow phase): the
maximum proven global, or reported UNPROVEN (a rim branch and bound out of budget; the MuJoCo glue
then falls back to MuJoCo's own function and counts it).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), with the cylinder
K = segment [-L, L] u + disc(r) (the disc perpendicular to u) centred at e in E's principal frame:
h_K(n) = L |n.u| + r |P n|, P = I - u u^T, so

    sigma(n) = n.e - h_E(n) - L |n.u| - r |P n|.

Strata: the caps n = +-u (face contacts: no unknown), the side circle n.u = 0 (sigma = f_e(n) - r, the
2-D point-ellipse problem in E's projection along u; pairs/point_ellipsoid.hpp, after Eberly, "Distance from
a point to an ellipse, an ellipsoid, or a hyperellipsoid", and GTCG 10.5.2), and the two rim regions
sign(n.u) = s where sigma = f_rim(n) = n.(e - s L u) - h_E(n) - r |P n| is smooth (rim-circle
contacts).  Local solve: Newton on the rim facing E, in polar coordinates about its cap (the cone
point of r |P n| at the cap is then just the boundary b = 0); if it leaves its region, the caps and the
side, checked by KKT (the witness's radial part within r on a cap, its axial part within L on the
side), hand back to the rim the violation points to.

Certificates (global upper bounds on max sigma):
* ub1 = sd(e - s_E(n) + rho n, K) - rho (rho the rolling radius of E; the exact point-cylinder sd);
* ub2 = sd(e - c, E) - t for a ball(c, t) inside K at the witness (t > 0 for cap and side contacts);
* ub3 (side contacts of a cylinder crossing E): the ball of radius delta + r around e lies in E + K
  when the chords of E along u, lengthened by L, cover it (_sweep_bound);
* ub4 (side contacts): a capsule inside K with K's support at the contact normal bounds sigma above
  everywhere; its maximum is proven by capsule.py (_capsule_bound).
When none closes: caps and side are exact; a rim piece is bounded above by the maximum of f_{q - r c}
over its closed hemisphere (h_K(m) >= m.(s L u + r c) for any unit c perpendicular to u), tried for c
on lunes of azimuths about u: c at the incumbent's azimuth on the lune holding it, at the lune's
middle elsewhere, the maximum of f_{q - r c} over the lune found from every critical point on its
boundary arcs and inside it; lunes are bisected until each bound is within the tolerance of the
incumbent (_rim_bb).  That linear bound exceeds sigma by r |P n| (1 - cos) of the azimuth from c,
which near the incumbent outgrows sigma's own fall once the crossing is deeper than E's radius of
curvature along the rim: ~20 bisections for 1e-12.  So lunes near the incumbent are split at its
polar band instead (_split_settles): the band by a second-order certificate, sigma = G(x) / |x| for
the concave 1-homogeneous G on the gnomonic chart at the incumbent, Taylor with a proven third-
derivative bound (_cert_model, _cert_region), the rest of the lune by f_{q - r c} over spherical
polygons (_poly_bound).  Before either, a lune that tangent planes of h_E + r |P n| close
(tangent_cones.py) is skipped.  A rim whose branch and bound runs out of budget leaves the pair UNPROVEN.

Ported from the pair-type prototype (10 000 poses: never below a 20 000-direction reference by more
than 1e-12 of the smaller shortest half-size), with the rim's branch and bound in place of its
bounds at 8 fixed azimuths and 7-start Newton climb, which left half of its deep crossings unproven.
"""

#: How cylinder_ellipsoid ended: CERTIFIED (an upper bound within PAIR_CERT_REL of the smaller
#: shortest half-size of the value), ENUMERATED (every piece bounded or solved) or UNPROVEN.
CERTIFIED, ENUMERATED, UNPROVEN = 0, 1, 2


NEWTON_MAX_ITER = 30
#: Newton's last step: below this many radians the next would be ~1e-18 (quadratic convergence).
NEWTON_STEP_TOL = 1e-8
#: A polar angle from the axis below this many radians is the cap (the rim function's cone point).
CAP_TOL = 1e-12

SIDE, CAP_P, CAP_M, RIM_P, RIM_M = 0, 1, 2, 3, 4
CONVERGED, AT_CAP, STALLED = 0, 1, 2


#: ub4 is not tried when its capsule's radius t is below this fraction of the cylinder's (a witness within
#: r / 2 of an end): on the pair benchmark's deep poses it proved 2 of the 126 such side contacts (15% at
#: t in [0.6 r, r), 85% at t = r), at ~1.4 us a failure; deep 2.7% faster (A/B, the same values; a pose
#: it would have certified is proven by the rim's branch and bound instead, ENUMERATED).
CAPSULE_MIN_FIT = 0.5


#: The split certificate (_split_settles) takes lunes whose far end lies within this multiple of the
#: incumbent's reach (_reach) along the rim, with a polar band of that half-width (1.4: the fastest of
#: 0.7, 1.4 and 2.5 on the pair benchmark's penetrating and deep poses; the certificate is checked
#: whatever the multiple).
SPLIT_REACH = 1.4
#: Band half-widths _split_settles tries, halving from the reach, before it gives the lune back: a band
#: as wide as the reach often leaves the model's concavity to the cubic remainder (the certificate
#: failed 7.2 times per uncertified penetrating pair at one try; penetrating 9% faster with three).
SPLIT_TRIES = 3
#: A lune holding the incumbent's azimuth, out of its reach, is split without a bound when the last
#: failed bound of such a lune, scaled by 4 a level (the linear bound's excess r |P n| (1 - cos) is
#: quadratic in the width), predicts an excess above this many tol: on a flat maximum the descent to the
#: reach fails one bound a level (penetrating 9%, deep 6% faster on the pair benchmark's poses; 8 gained
#: nothing more).  A skipped bound only costs its two children: the proof is theirs.
SKIP_EXCESS = 64.0
#: The rim's branch and bound starts from this many equal lunes, the first centred on the incumbent's
#: azimuth (6: deep and penetrating 7% faster than 4 quarters on the pair benchmark's poses, 5 and 7 the
#: same as 6; a narrower first lune leaves its linear bound less excess and its tangent cones less to do).
#: At least 3: a lune's bound (_poly_bound, cone_below) needs its ends less than pi apart (with 2, half
#: circles, it missed maxima by up to 1e-3 on the deep poses).
RIM_LUNES = 6
#: |D^3 |z|[w, w, w]| <= 3 |a| b^2 / |z|^2 with a^2 + b^2 = |w|^2, at most 2 / sqrt(3) |w|^3 / |z|^2.
D3_NORM = 1.1548
#: Steps of _reach's fixed-point iteration (odd: the radius then stays below the fixed point; 3 and 5
#: measured the same on the pair benchmark's deep poses).
REACH_STEPS = 5
