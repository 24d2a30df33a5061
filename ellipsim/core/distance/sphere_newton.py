"""sigma(n) = n.(c_B - c_A) - h_A(n) - h_B(-n) in A's principal frame, and its local maximisation on
the unit sphere by Riemannian Newton (the narrow phase's building blocks).

h(n) = |D R^T n| is an ellipsoid's support function (Schneider & Eberly, Geometric Tools 10.5.2).
sigma is concave and positively homogeneous of degree 1 on R^3; its maximum over unit n is the
signed distance (ellipsoid_pair.py), and a local maximum found here is proven global there (the
rolling-radius argument, or branch_and_bound.py's branch and bound).

The kernels are C++, ellipsim/native/include/ellipsim/distance/sphere_newton.hpp (bound in the _ellipsim module).
"""

#: How one Newton run ended: at a local maximum, not within its steps, or abandoned (its quadratic
#: bound stays below a value another run already reached).
CONVERGED, NOT_CONVERGED, ABANDONED = 0, 1, 2
