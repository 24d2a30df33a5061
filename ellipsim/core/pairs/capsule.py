"""Signed distance of an ellipsoid and a capsule with a proven global maximum (MuJoCo's capsule x
ellipsoid narrow phase).

Method: max over unit n of sigma(n) = n.e - h_E(n) - h_K(n) (ellipsoid_pair.py), split into the smooth
strata of the capsule's support function, each solved globally by Eberly's secular equation ("Distance
from a point to an ellipse, an ellipsoid, or a hyperellipsoid", Geometric Tools, sec. 2-3; GTCG
10.5.2), certified by the two convex-duality bounds below or by enumerating every critical point.

The pair in E's principal frame: E = {x : sum x_i^2 / a2_i <= 1} (a2 the squared semi-axes), the
capsule K = segment [-L, L] u + ball(r) centred at e, so

    sigma(n) = n.e - h_E(n) - L |n.u| - r = min(f_{e+Lu}(n), f_{e-Lu}(n)) - r,   f_q(n) = n.q - h_E(n),

n pointing from E to K, smooth except on the great circle n.u = 0 (the contact on the capsule's side).
Strata and their maximisers:
* side (n.u = 0): the 2-D point-ellipse problem of e projected along u onto the plane u^perp, against
  E's projection (an ellipse); valid when the segment parameter t = (s_E(n) - e).u lies in [-L, L];
* end point e + sL u (s = +-1, region s n.u <= 0): the point-ellipsoid problem for q = e + sL u.
The local solve takes the side stratum when its segment parameter is admissible, else the end it
points to.

Certificates (global upper bounds on max sigma, from concavity of h on R^3; any unit n):
* ub1 = sd(e - s_E(n) + rho n, K) - rho with rho the rolling radius of E (E = E' + ball(rho)):
  h_E(m) >= rho + m.(s_E(n) - rho n) for unit m, so sigma(m) <= m.w - h_K(m) - rho <= sd(w, K) - rho.
  Tight when separated or shallow.
* ub2 = sd(e - c, E) - r, c the segment point at the contact: h_K(m) >= m.c + r (ball(c, r) in K), so
  sigma(m) <= f_{e-c}(m) - r <= sd(e - c, E) - r, bounded above by weak duality (sd_upper).
  Tight when the capsule's axis point is deep in E.
When neither closes (deep crossings), a branch and bound over the three smooth pieces (enumerate_max):
a piece whose extended smooth function's certified maximum does not beat the incumbent is skipped, one
whose maximiser lies inside it is taken whole, and the rest have every critical point evaluated
(secular_roots, pole_normal): a complete case analysis, status ENUMERATED.

The point-ellipsoid primitives (secular equation, certified bounds, critical points) are in
pairs/point_ellipsoid.hpp, shared with box.py.

Ported from the validated pair-type prototype (10 000 poses: never below a 20 000-direction reference
by more than 1e-12 of the smaller shortest half-size; every maximum certified or enumerated).
"""

#: How capsule_ellipsoid proved its maximum: CERTIFIED (an upper bound within PAIR_CERT_REL of the
#: smaller shortest half-size of the value) or ENUMERATED (every critical point of every smooth piece
#: evaluated).  Both are proofs; the MuJoCo glue falls back to MuJoCo only on a non-finite result.
CERTIFIED, ENUMERATED = 0, 1

# --- the pair, sigma, and the way back to world coordinates ---------------------------------------


# --- the kernel -----------------------------------------------------------------------------------
