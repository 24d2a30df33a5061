"""The Perram-Wertheim contact function: how far two ellipsoids are from touching.

Perram & Wertheim (J. Comput. Phys. 58, 1985): F = max_s min_x [s q_A(x) + (1 - s) q_B(x)], with
q the quadratic forms (x - c)^T Q (x - c).  Scaling both ellipsoids about their centres by
sqrt(F) makes them touch, so contact_scale = sqrt(F): > 1 separated, < 1 overlapping.

In A's frame (pair_frame.py) with mu = alpha s / (1 - s) it is F(mu) = mu N(mu) / ((mu + alpha) P(mu)),
concave in s, so d F / d mu has one positive root.  We find it by Newton's method on the
logarithmic slope G = d log F / d log mu, safeguarded by its sign bracket.  (Newton on the
degree-6 numerator of F' took 18 steps on average and up to 60 on random pairs; G takes ~4.)
"""

import math

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..ellipsoids import check_pair, check_parallel
from ..tolerances import PW_MAX_ITER, PW_RTOL
from ..vec3 import load, matvec, norm2, reciprocal, scaled, unit_scale
from .pair_frame import invariants, offset, shape


@stage
def initial_mu(ee, qb, alpha):
    """Starting point alpha * sqrt(q_B(c_a) / q_A(c_b)): exact for two spheres (mu* = alpha r_a / r_b)."""
    return alpha * math.sqrt(qb / ee)


@stage
def log_slope(mu, inv, alpha):
    """G = d log F / d log mu = 1 + mu N'/N - mu / (mu + alpha) - mu P'/P, dG/dmu, and F(mu).

    G falls from +1 (mu -> 0) to -1 (mu -> inf) through its one root mu*; each term is O(1), so G
    is accurate to a few ulps and Newton on it converges in ~4 steps from initial_mu.
    """
    t1, t2, t3, p1, q, s3 = inv
    n = (p1 * mu + q) * mu + s3
    p = ((mu + t1) * mu + t2) * mu + t3
    dn = 2.0 * p1 * mu + q
    dp = (3.0 * mu + 2.0 * t1) * mu + t2
    i_n, i_p, i_m = 1.0 / n, 1.0 / p, 1.0 / (mu + alpha)
    a = dn * i_n
    b = dp * i_p
    g = 1.0 + mu * (a - i_m - b)
    dg = a - b - alpha * i_m * i_m + mu * (2.0 * p1 * i_n - a * a - (6.0 * mu + 2.0 * t1) * i_p + b * b)
    return g, dg, mu * n * i_p * i_m


@stage
def pw_step(mu, inv, alpha, lo, hi):
    """One safeguarded Newton step on G from mu: (next mu, lo, hi, F(mu)).

    (lo, hi) brackets mu* (G > 0 left of it, G < 0 right of it).
    """
    g, dg, value = log_slope(mu, inv, alpha)
    if g > 0.0:
        lo = mu
    elif g < 0.0:
        hi = mu
    else:
        return mu, mu, mu, value
    new = mu - g / dg
    if not (lo < new < hi):  # also catches dg == 0 and NaN: bisect (geometrically) instead
        if hi == math.inf:
            new = 4.0 * mu
        elif lo == 0.0:
            new = 0.25 * mu
        else:
            new = math.sqrt(lo * hi)
    return new, lo, hi, value


@stage
def pw_maximize(inv, alpha, mu, rtol):
    """mu* maximising F(mu) = mu N / ((mu + alpha) P) on (0, inf), to relative step `rtol`."""
    lo, hi = 0.0, math.inf
    for _ in range(PW_MAX_ITER):
        new, lo, hi, _ = pw_step(mu, inv, alpha, lo, hi)
        if abs(new - mu) <= rtol * mu:
            return new
        mu = new
    return mu


@stage
def pw_value(mu, inv, alpha):
    """F(mu) = mu N(mu) / ((mu + alpha) P(mu)); all terms are nonnegative, so it is accurate."""
    t1, t2, t3, p1, q, s3 = inv
    n = (p1 * mu + q) * mu + s3
    p = ((mu + t1) * mu + t2) * mu + t3
    return mu * n / ((mu + alpha) * p)


@jit
def contact_scale_pair(A, B):
    """F is quadratic in the centre offset d, so it is computed for d / max|d_i| and scaled back:
    offsets of 1e-200 or 1e200 neither underflow nor overflow; the pair is first scaled by
    vec3.unit_scale, so neither do semi-axes of 1e-200 or 1e200."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    p = unit_scale(ra, rb)  # s is scale-free: semi-axes of 1e160 must not overflow |e|^2
    ra, rb = scaled(ra, p), scaled(rb, p)
    d = ((cb[0] - ca[0]) * p, (cb[1] - ca[1]) * p, (cb[2] - ca[2]) * p)
    k = max(abs(d[0]), abs(d[1]), abs(d[2]))
    if k == 0.0:
        return 0.0
    e, me = offset((0.0, 0.0, 0.0), Ra, ra, (d[0] / k, d[1] / k, d[2] / k))
    ee = norm2(e)
    W, mW, alpha, _ = shape(Ra, ra, Rb, reciprocal(rb), True)
    v = matvec(W, e)
    inv, _ = invariants(W, mW, e, me, v, v)
    mu = pw_maximize(inv, alpha, initial_mu(ee, inv[3] / alpha, alpha), PW_RTOL)
    return k * math.sqrt(pw_value(mu, inv, alpha))


@jit
def _contact_scales(Ca, Ra, ra, Cb, Rb, rb, out, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(lo, hi):
        out[i] = contact_scale_pair(load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb))


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
