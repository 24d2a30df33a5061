"""Exact first derivatives of the signed distance of an ellipsoid E and a capsule, box or cylinder K, of
its normal and of its contact point, on the feature of K that carries the contact (issue 24).

sigma(n) = n.d - h_E(n) - h_K(n), d = c_K - c_E (box.py, capsule.py, cylinder.py), is smooth except on
the kinks of h_K.  The maximiser n* lies on one stratum, where (Rockafellar & Wets, Variational Analysis,
10.C: a piecewise-smooth max is smooth on each stratum)

    h_K(n) = n.w + rho |n|_P   subject to   G n = 0   (G: k orthonormal rows, all orthogonal to n*)

    box    VERTEX  w = sum_j s_j r_j v_j                        k = 0
           EDGE    w = the sum over the two free axes            k = 1, G = (v_i)     (n* along no v_i)
           FACE    w = s_i r_i v_i                               k = 2, G = the other two axes
    capsule END    w = s L u, rho = r, P = I (the end's ball)    k = 0
           SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
    cylinder RIM   w = s L u, rho = r, P = I - u u^T            k = 0
           SIDE    w = 0, rho = r, P = I                         k = 1, G = (u)
           CAP     w = s L u, rho = 0                            k = 2, G = a basis of u^perp

(s: the sign of n*.v on the free axes; |n|_P = sqrt(n^T P n); on SIDE, r |P n| and r |n| agree to second
order on the stratum, so the simpler one.)  KKT on {|n| = 1, G n = 0}: grad sigma = sigma n + G^T mu.
Implicit function theorem on it: the part of dn along G's rows is -G^T (dG n); the rest, in the stratum's
tangent space T (2 - k dimensions), solves (T^T H T) a = -T^T (b + H dn_G), H = hess sigma - sigma I,
b = d grad sigma / d theta - dG^T mu.  The envelope theorem with the constraints' multipliers:
d dist / d theta = d sigma / d theta (n* held) - mu . (dG n*).  The contact point, pos = c_E + g_E(n*) +
dist n* / 2 (contact_in_world), follows by the chain rule.  Parameters, 18 columns (PARAMETERS): E's
centre, rotation vector and semi-axes, K's centre, rotation vector (both as derivatives.py: a turn about
the body's centre about a world axis) and MuJoCo's geom_size (box: half-sizes; capsule and cylinder:
radius, half-length, and a third column that is zero).

Status (status.DerivativeStatus):
* the subgradient of the kinks' terms bounds the multipliers (|mu_j| <= r_j on a box face or edge,
  |mu| <= L on a side, |mu| <= r on a cap: the contact point inside its face, side or cap); one within
  DERIV_KINK_REL S of its bound puts the contact where two features meet, and the derivatives given
  (the named feature's, held) are one-sided: ONE_SIDED;
* otherwise the feature stays active under a small change and, separated (the maximiser is then unique:
  E is strictly convex), these are the derivatives: SMOOTH; touching or penetrating, BRANCH (as
  derivatives.py: another maximiser could tie);
* a reduced Hessian not negative definite to DERIV_FLAT_REL S (a circle of maxima, as a spheroid
  coaxial with a cylinder has): FLAT, NaN; an unproven maximum (a cylinder's rim): UNPROVEN, NaN.
n* is first polished by Newton's method on the stratum, as derivatives.py does.

The kernels are C++, ellipsim/native/include/ellipsim/pairs/derivatives.hpp (bound in the _ellipsim module).
"""

from typing import NamedTuple

import numpy as np

#: the 18 columns, 3 each: (name, metres or radians)
PARAMETERS = ("center_e", "rotation_e", "radii_e", "center_k", "rotation_k", "size_k")

#: a fifth DerivativeStatus code (status.py): the feature held, at the edge of its normal cone
ONE_SIDED = 4

#: The feature of K that carries the contact (status.ContactFeature by name)
FACE, EDGE, VERTEX, SIDE, END, CAP, RIM = 0, 1, 2, 3, 4, 5, 6

#: the kernel's codes for K's type
CAPSULE, BOX, CYLINDER = 0, 1, 2

_Z = (0.0, 0.0, 0.0)


class ShapeDerivatives(NamedTuple):
    """shape_distance(..., derivatives=True)'s fifth result; columns as PARAMETERS, 3 each.

    dist : (n, 18) d dist / d parameter
    normal : (n, 3, 18) d normal / d parameter
    pos : (n, 3, 18) d contact point / d parameter
    status : (n,) int8, DerivativeStatus (SMOOTH, BRANCH, ONE_SIDED: defined; FLAT, UNPROVEN: NaN)
    feature : (n,) int8, ContactFeature: the feature of the other body that carries the contact
    """

    dist: np.ndarray
    normal: np.ndarray
    pos: np.ndarray
    status: np.ndarray
    feature: np.ndarray
