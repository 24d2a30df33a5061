"""The Perram-Wertheim contact function: how far two ellipsoids are from touching.

Perram & Wertheim (J. Comput. Phys. 58, 1985): F = max_s min_x [s q_A(x) + (1 - s) q_B(x)], with
q the quadratic forms (x - c)^T Q (x - c).  Scaling both ellipsoids about their centres by
sqrt(F) makes them touch, so contact_scale = sqrt(F): > 1 separated, < 1 overlapping.

In A's frame (exact/pair_frame.hpp) with mu = alpha s / (1 - s) it is F(mu) = mu N(mu) / ((mu + alpha) P(mu)),
concave in s, so d F / d mu has one positive root.  We find it by Newton's method on the
logarithmic slope G = d log F / d log mu, safeguarded by its sign bracket.  (Newton on the
degree-6 numerator of F' took 18 steps on average and up to 60 on random pairs; G takes ~4.)
"""

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import check_pair, check_parallel


def contact_scale(a, b, *, parallel=None):
    """Perram-Wertheim factor s for the pairs (a[i], b[i]).

    Scaling both ellipsoids about their centres by s makes them touch: s > 1 separated, s = 1
    touching, s < 1 overlapping; 0 for concentric ellipsoids.  Float64, not certified (use
    classify for decisions); relative error ~1e-15 for well-conditioned pairs.

    a, b : Ellipsoids (a batch of length 1 broadcasts)
    parallel : run on all cores; default: when there are at least PARALLEL_MIN_PAIRS pairs.
    returns : (n,) float64
    """
    n = check_pair(a, b)
    out = np.empty(n)
    arrays = (a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii)
    threads.run(ext.contact_scales, n, check_parallel(parallel, n), *arrays, out)
    return out
