"""The rigid motion between two poses that time_of_impact assumes, and its float64 evaluation with
proven error bounds.

Each body keeps its semi-axes; its centre moves linearly and its rotation turns at constant angular
velocity along the shortest arc (issue 12):

    c(t) = c0 + t (c1 - c0),    R(t) = R0 exp(t [w]x),    w = log(R0^T R1) as a float64 axis-angle vector.

The motion is defined *exactly* (real arithmetic) by the float64 data c0, c1, R0, R1 and w.  So that it
ends exactly on the given pose, the second half is written from the far end: R(t) = R1 exp((t - 1) [w]x)
on [1/2, 1].  The halves meet at t = 1/2 to within the rounding of w (~1e-16); time_of_impact covers
both, and at t = 0 and t = 1 the motion is exactly the input poses.  R0, R1 need only be invertible
(validated rotations are orthonormal to 1e-6): exp(phi [w]x) is an exact rotation.

Float64 evaluation, E(phi) = exp(phi [w]x) by Rodrigues' formula (u = 2^-53, alpha = |w| phi):

* sin and cos come from `sincos`, Taylor polynomials with a proven error (not libm, whose accuracy is
  documented but not proven): within SINCOS_ERR of the exact values for |x| <= 1.6 (|alpha| <= pi/2
  here: |w| < pi, |phi| <= 1/2).
* E~^T p errs by at most (RODRIGUES_ERR + 12 |alpha|) u |p| (derivation at `rodrigues_apply` in the header), and the
  float pose fl(R_p E~) lies within DELTA_R (spectral norm) of the exact R_p E (tolerances.py).

The kernels are C++, ellipsim/native/include/ellipsim/motion/interpolation.hpp (bound in the _ellipsim module).
"""

import math

import numpy as np

from ...native import ext
from ..ellipsoids import Ellipsoids
from ..tolerances import HALF_TURN_TOL


def rotation_vectors(x0, x1, name0="x0", name1="x1"):
    """(n, 3) float64 axis-angle vectors w of R0^T R1 for the batches x0, x1 (Ellipsoids, equal length).

    ValueError naming the arguments and the index for a turn within HALF_TURN_TOL of a half turn, whose
    shortest arc is not defined.
    """
    w, angle = np.empty((len(x0), 3)), np.empty(len(x0))
    ext.rotation_vectors(x0.rotations, x1.rotations, w, angle)
    half = np.flatnonzero(math.pi - angle < HALF_TURN_TOL)
    if len(half):
        i = int(half[0])
        raise ValueError(
            f"a half turn between {name0}[{i}] and {name1}[{i}] (angle {float(angle[i])!r} rad, within {HALF_TURN_TOL:g} of pi): "
            "the shortest arc is not defined; add an intermediate pose"
        )
    return w


def poses_at(x0, x1, t):
    """The bodies of the motion from x0 to x1 at times t, as an Ellipsoids batch (x0 itself at t = 0,
    x1 at t = 1; elsewhere the float pose, within DELTA_R of the exact rotation).

    x0, x1 : Ellipsoids of equal length and semi-axes (one body per row, at t = 0 and t = 1).
    t : float or (n,) float64 in [0, 1].
    """
    for name, value in (("x0", x0), ("x1", x1)):
        if not isinstance(value, Ellipsoids):
            raise ValueError(f"{name} must be an ellipsim.Ellipsoids batch, got {type(value).__name__}")
    if len(x0) != len(x1):
        raise ValueError(f"x0 and x1 must have the same length, got {len(x0)} and {len(x1)}")
    bad = np.flatnonzero(np.any(x0.radii != x1.radii, axis=1))
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"x1.radii[{i}] must equal x0.radii[{i}], got {x1.radii[i].tolist()} and {x0.radii[i].tolist()}"
        )
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if t.ndim != 1 or len(t) not in (1, len(x0)):
        raise ValueError(f"t must be a number or have shape ({len(x0)},), got shape {t.shape}")
    out = np.flatnonzero(~((t >= 0.0) & (t <= 1.0)))
    if len(out):
        raise ValueError(f"t[{int(out[0])}] must lie in [0, 1], got {float(t[out[0]])!r}")
    C, R = np.empty((len(x0), 3)), np.empty((len(x0), 3, 3))
    ext.poses_at(x0.centers, x0.rotations, x1.centers, x1.rotations, rotation_vectors(x0, x1), t, C, R)
    return Ellipsoids(C, R, x0.radii)
