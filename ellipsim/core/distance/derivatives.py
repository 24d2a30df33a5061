"""Exact first derivatives of the signed distance of two ellipsoids, of its normal and of its contact point,
with respect to both poses and semi-axes.

At a unique, nondegenerate maximiser n* of sigma(n; theta) = n.d - h_A(n) - h_B(n) over the unit sphere
(ellipsoid_pair.py; h(n) = |D R^T n|, h_B(-n) = h_B(n)), the distance is differentiable and
(envelope theorem, Danskin; Bertsekas, Nonlinear Programming, Prop. B.25)

    d dist / d theta = d sigma(n*; theta) / d theta   at n* held fixed;

n* follows from the implicit function theorem on the stationarity condition P grad sigma = 0 on the
sphere (P = I - n n^T): with the Riemannian Hessian H = P hess(sigma) P - sigma P (sigma is positively
homogeneous of degree 1, so n.grad sigma = sigma) and a tangent basis T,

    d n* / d theta = -T (T^T H T)^-1 T^T d grad sigma / d theta,

and the contact point, the midpoint of the support points c_A + g_A(n*) and c_B - g_B(n*) with
g = grad h = R D^2 R^T n / h, by the chain rule through n*.  hess h = (R D^2 R^T - g g^T) / h.

Parameters, 9 per body, 18 columns in this order (PARAMETERS): the centre (metres), a rotation vector
omega (radians: R -> expm([omega]_x) R, a turn about the body's centre about a world axis, the
angular-velocity convention of MuJoCo's mj_jac), the semi-axes (metres).

The derivative is defined where the maximiser is unique and isolated.  Status per pair
(status.DerivativeStatus; the kernels' int8 codes below):
* SMOOTH: sigma's maximum exceeds -(rho_A + rho_B) (separated, or penetrating by less than the sum of
  the rolling radii: max sigma + rho is then the distance from the centre offset to a convex set, whose
  nearest point is unique, ellipsoid_pair.py) and the Hessian is negative definite: the derivatives.
* BRANCH: a deeper proven maximum (or concentric bodies, where sigma(n) = sigma(-n)): the derivatives
  of the maximum found, which is the distance's own derivative where that maximiser is the only one; where
  another maximiser ties (not excluded here) the distance has a kink and these are the derivatives of
  one of its active branches (an element of its Clarke generalised gradient), still a valid descent
  direction for pushing the pair apart.
* FLAT: the Hessian is singular to within rounding (a circle of maxima, as coaxial spheroids have, or
  nearly so): NaN.
* UNPROVEN: the maximum itself is not proven: NaN.

Before differentiating, n* is polished by Newton's method on the sphere with the same Hessian (at most
POLISH_STEPS steps, kept only when sigma does not drop by more than rounding): the proven maximum is
exact to the proof's tolerance in value, which leaves the maximiser itself accurate only to about the
square root of it along a flat direction.

The kernels are C++, ellipsim/native/include/ellipsim/distance/derivatives.hpp (bound in the _ellipsim module).
"""

from typing import NamedTuple

import numpy as np

#: the 18 columns of each derivative, 3 each: (name, metres or radians)
PARAMETERS = ("center_a", "rotation_a", "radii_a", "center_b", "rotation_b", "radii_b")

#: the kernels' codes, status.DerivativeStatus by name (tests/test_derivatives.py checks they agree)
SMOOTH, BRANCH, FLAT, UNPROVEN = 0, 1, 2, 3


class DistanceDerivatives(NamedTuple):
    """signed_distance(..., derivatives=True)'s fifth result; columns as PARAMETERS, 3 each.

    dist : (n, 18) d dist / d parameter
    normal : (n, 3, 18) d normal / d parameter
    pos : (n, 3, 18) d contact point / d parameter
    status : (n,) int8, DerivativeStatus
    """

    dist: np.ndarray
    normal: np.ndarray
    pos: np.ndarray
    status: np.ndarray
