"""The characteristic polynomial det(lambda A + B) of two ellipsoids, set up the thesis's two ways.

A and B are the 4x4 homogeneous quadrics X^T A X <= 0 (interior negative):
    A = [[Q, -Q c], [-c^T Q, c^T Q c - 1]],  Q = R diag(1/r^2) R^T.

"cofactor" (thesis 4.1.2): build A and B in world coordinates and expand the pencil's determinant
by 2x2 minors of its first and last column pairs, reusing each minor (thesis 4.1.2.2).
"rearranged" (thesis 4.1.3): det(lambda I + A^{-1} B) in A's frame (see exact/pair_frame.hpp), scaled back to
det(lambda A + B).  Both assume R^{-1} = R^T, as the thesis does.
"""

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import check_choice, check_pair, check_parallel

SETUPS = ("rearranged", "cofactor")


def characteristic_polynomial(a, b, *, setup="rearranged", parallel=None):
    """Coefficients of det(lambda A + B) for the pairs (a[i], b[i]).

    a, b : Ellipsoids (a batch of length 1 broadcasts)
    setup : "rearranged" (thesis 4.1.3) or "cofactor" (thesis 4.1.2)
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (n, 5) float64, columns lambda^4, lambda^3, lambda^2, lambda, 1
    """
    n = check_pair(a, b)
    check_choice("setup", setup, SETUPS)
    parallel = check_parallel(parallel, n)
    out = np.empty((n, 5))
    arrays = (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    threads.run(ext.polynomials, n, parallel, *arrays, setup == "cofactor", out)
    return out
