"""Positive-root tests on the characteristic quartic, as in the thesis (section 4.2), uncertified.

Both take the coefficients (c4, c3, c2, c1, c0) of c4 x^4 + ... + c0 and return a relation code
(0 separated, 1 touching, 2 overlapping), using that the quartic of two ellipsoids has at least
two negative roots and c4, c0 < 0 (thesis 4.1.1.1).  They run in the precision of their inputs
(float64 or float32) and are kept to be measured: neither is reliable near repeated roots.
"""

from .._jit import jit
from ..relation import OVERLAPPING, SEPARATED, TOUCHING


@jit
def _variations(s0, s1, s2, s3, s4):
    """Sign changes in a sequence, zeros skipped."""
    count = 0
    last = 0.0
    for s in (s0, s1, s2, s3, s4):
        if s != 0:
            if last != 0 and (s > 0) != (last > 0):
                count += 1
            last = s
    return count


@jit
def sturm_relation(a, b, c, d, e):
    """Sturm sequence of the quartic (thesis 4.2.1): distinct positive roots = V(0) - V(+inf).

    f = a x^4 + b x^3 + c x^2 + d x + e,  f1 = f',
    f2 = -rem(f, f1) = p x^2 + q x + r,  f3 = -rem(f1, f2) = s x + t,  f4 = -rem(f2, f3) = u,
    with the thesis's special cases p = 0 and s = 0 (the sequence ends early).
    Two distinct positive roots: separated; one (a double root): touching; none: overlapping.
    """
    T = type(a)
    zero = T(0.0)
    p = T(3.0) * b * b / (T(16.0) * a) - c / T(2.0)
    q = b * c / (T(8.0) * a) - T(3.0) * d / T(4.0)
    r = b * d / (T(16.0) * a) - e
    # Values at +inf are leading coefficients, values at 0 are constant terms; f1 = 4a x^3 + ... + d.
    if p != 0:
        al = T(4.0) * a / p
        be = (T(3.0) * b - al * q) / p
        s = al * r + be * q - T(2.0) * c
        t = be * r - d
        if s != 0:
            ga = p / s
            de = (q - ga * t) / s
            u = de * t - r
            at_inf = _variations(a, a, p, s, u)
            at_zero = _variations(e, d, r, t, u)
        else:  # f3 = t is constant (or zero: the sequence ends at f2)
            at_inf = _variations(a, a, p, t, zero)
            at_zero = _variations(e, d, r, t, zero)
    elif q != 0:  # f2 = q x + r; f3 = -f1(-r / q)
        x = -r / q
        f3 = -(((T(4.0) * a * x + T(3.0) * b) * x + T(2.0) * c) * x + d)
        at_inf = _variations(a, a, q, f3, zero)
        at_zero = _variations(e, d, r, f3, zero)
    else:  # f2 = r constant, or zero (f1 divides f)
        at_inf = _variations(a, a, r, zero, zero)
        at_zero = _variations(e, d, r, zero, zero)
    count = at_zero - at_inf
    if count == 2:
        return SEPARATED
    if count == 1:
        return TOUCHING
    return OVERLAPPING


@jit
def discriminant(a, b, c, d, e):
    """Discriminant of the quartic times 27: 4 D0^3 - D1^2 (via the resolvent cubic's invariants)."""
    T = type(a)
    d0 = c * c - T(3.0) * b * d + T(12.0) * a * e
    d1 = T(2.0) * c * c * c - T(9.0) * b * c * d + T(27.0) * b * b * e + T(27.0) * a * d * d - T(72.0) * a * c * e
    return T(4.0) * d0 * d0 * d0 - d1 * d1


@jit
def descartes_relation(a, b, c, d, e):
    """Discriminant + Descartes' rule of signs (thesis 4.2.2).

    Discriminant < 0: two complex roots, the real ones negative, so overlapping.  Discriminant > 0:
    all four roots real and distinct, and V+ (sign changes of the coefficients) counts the
    positive ones exactly.  Discriminant == 0 (a repeated root) with V+ = 2 is read as touching;
    that is where this test breaks for spheres and coaxial spheroids, whose repeated root is
    negative.
    """
    disc = discriminant(a, b, c, d, e)
    if disc < 0:
        return OVERLAPPING
    vplus = _variations(a, b, c, d, e)
    if vplus == 2:
        return SEPARATED if disc > 0 else TOUCHING
    return OVERLAPPING
