"""Proving f(n) <= floor < 0 over a whole cone of directions by tangent planes, cheaply: the pruning
step of the box's and the cylinder's branch and bound (box.enumerate_max, cylinder._rim_bb).

f(n) = n.q - h_E(n) - r |P n| (P = I - u u^T; r = 0 for the box's pieces, r |P n| the support of the
cylinder's disc for its rim) is concave and 1-homogeneous, and for any point x of E and y of the disc,
h_E(n) + r |P n| >= n.(x + y), so f(n) <= g.n with g = q - x - y, linear.  A linear function below
floor < 0 at every corner c_k of a cone is below it on all of the cone's unit directions:
g.sum l_k c_k <= floor sum l_k |c_k| <= floor |sum l_k c_k| (triangle inequality, floor < 0), so a
node costs a support point and three dot products, the corners need not be unit, and a cone splits
at its flat midpoints (sums of corners).  x + y is the support point of E + disc at the node's centre,
or, for the box (r = 0), at the incumbent's normal when the node holds it (there the bound is exact at
the incumbent and falls with f as long as f falls: a kink of sigma, as a flush face; a cylinder's
rim incumbent is a smooth maximum, where the plane rises: 5% slower to try).  The planes are the same
weak-duality step as the point-ellipsoid bounds (Schneider & Eberly, GTCG 10.5.2; Boyd &
Vandenberghe 5.1), taken on pieces of the sphere instead of its whole.

The kernels are C++, ellipsim/native/include/ellipsim/pairs/tangent_cones.hpp (bound in the _ellipsim module).
"""

#: levels of halvings of an arc before arc_below gives up (a cone gets 4 levels of quarters)
ARC_DEPTH = 5
