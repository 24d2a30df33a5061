"""The certified float64 filter: decides a pair only when a rigorous error bound proves it.

Every decision is a certificate about the exact ellipsoids the float64 inputs define:

* separated: a separating direction (the centre line: bounding spheres, then the exact support
  functions), or some mu > 0 with f(mu) > 0.  f(0) = -alpha t3 < 0 and f(+inf) < 0, so
  f(mu) > 0 forces two distinct positive roots of the pencil: separated by the theorem of Wang,
  Wang & Kim (thesis ch. 4, Theorem 1).
* overlapping: a point strictly inside both.  First a point c_a + t (c_b - c_a) of the centre
  segment (t = 0 and t = 1 are the centres), then the Perram-Wertheim point y(mu*) in A's frame,
  where q_A and q_B are equal at the optimum: |y|^2 < 1 and (y - e)^T K_c (y - e) < alpha.

Each test compares a computed value with gamma_n * mag + TAU (exact/pair_frame.hpp, tolerances.py).  Touching
pairs, and pairs too close to touching for float64, come back UNDECIDED for exact arithmetic.
Unlike tolerance-based tests (e.g. HOOMD-blue's ShapeEllipsoid.h, relative 1e-6), a decision
here is never wrong; an ill-conditioned float only makes the answer slower.

The centre-line tests settle ~80% of random pairs for ~20 ns; the rest pay for A's frame, its
error magnitudes and a few Newton steps of the Perram-Wertheim maximisation (`ellipsim bench`).
"""

import numpy as np

from ...native import ext
from .. import threads


def certify(a, b, n, parallel):
    """int8 (n,): SEPARATED / OVERLAPPING where the float path is certain, UNDECIDED (-1) elsewhere."""
    out = np.empty(n, dtype=np.int8)
    threads.run(ext.certify, n, parallel, a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out)
    return out
