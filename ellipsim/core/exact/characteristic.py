"""The characteristic polynomial det(lambda A + B) of two ellipsoids, set up the thesis's two ways.

A and B are the 4x4 homogeneous quadrics X^T A X <= 0 (interior negative):
    A = [[Q, -Q c], [-c^T Q, c^T Q c - 1]],  Q = R diag(1/r^2) R^T.

"cofactor" (thesis 4.1.2): build A and B in world coordinates and expand the pencil's determinant
by 2x2 minors of its first and last column pairs, reusing each minor (thesis 4.1.2.2).
"rearranged" (thesis 4.1.3): det(lambda I + A^{-1} B) in A's frame (see pair_frame.py), scaled back to
det(lambda A + B).  Both assume R^{-1} = R^T, as the thesis does.
"""

import numpy as np

from ...native import ext
from .. import threads
from .._jit import jit, stage
from ..ellipsoids import check_choice, check_pair, check_parallel
from ..vec3 import load, matvec, reciprocal, sandwich
from .pair_frame import coefficients, invariants, offset, shape

SETUPS = ("rearranged", "cofactor")


@stage
def _world_quadric(E):
    """The 10 distinct entries of the world quadric (row-major upper triangle of the 4x4)."""
    c, R, r = E
    one = type(r[0])(1.0)
    w0, w1, w2 = one / (r[0] * r[0]), one / (r[1] * r[1]), one / (r[2] * r[2])
    q00, q01, q02, q11, q12, q22 = sandwich(R, w0, w1, w2)
    g0 = -(q00 * c[0] + q01 * c[1] + q02 * c[2])
    g1 = -(q01 * c[0] + q11 * c[1] + q12 * c[2])
    g2 = -(q02 * c[0] + q12 * c[1] + q22 * c[2])
    k = -(g0 * c[0] + g1 * c[1] + g2 * c[2]) - one
    return q00, q01, q02, g0, q11, q12, g1, q22, g2, k


@stage
def _full(u):
    """4x4 symmetric matrix as a 16-tuple (row-major) from its upper triangle."""
    q00, q01, q02, g0, q11, q12, g1, q22, g2, k = u
    return (q00, q01, q02, g0, q01, q11, q12, g1, q02, q12, q22, g2, g0, g1, g2, k)


@stage
def _pencil_minor(xai, xbj, xaj, xbi, yai, ybj, yaj, ybi):
    """2x2 minor (rows i, j; columns a, b) of lambda X + Y as (lambda^2, lambda, 1) coefficients."""
    return (
        xai * xbj - xaj * xbi,
        (xai * ybj - xaj * ybi) + (yai * xbj - yaj * xbi),
        yai * ybj - yaj * ybi,
    )


@stage
def _product(a, b):
    """(a2 l^2 + a1 l + a0)(b2 l^2 + b1 l + b0) as 5 coefficients."""
    return (
        a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[0] * b[2] + a[1] * b[1] + a[2] * b[0],
        a[1] * b[2] + a[2] * b[1],
        a[2] * b[2],
    )


@jit
def cofactor_coefficients(A, B):
    """Coefficients (lambda^4 ... 1) of det(lambda A + B) by Laplace expansion on column pairs (0,1), (2,3).

    det M = sum over row pairs (i<j) of sign * M[ij; 01] * M[kl; 23], (k, l) the complementary rows,
    sign = (-1)^(i + j + 1) (taken into the minor by swapping k and l); each of the 12 pencil
    minors is a quadratic in lambda computed once (thesis 4.1.2.2).  Literal indices only: numba
    lowers a tuple index it cannot see at compile time to a jump table.
    """
    X = _full(_world_quadric(A))
    Y = _full(_world_quadric(B))
    a0 = _pencil_minor(X[0], X[5], X[4], X[1], Y[0], Y[5], Y[4], Y[1])
    b0 = _pencil_minor(X[10], X[15], X[14], X[11], Y[10], Y[15], Y[14], Y[11])
    a1 = _pencil_minor(X[0], X[9], X[8], X[1], Y[0], Y[9], Y[8], Y[1])
    b1 = _pencil_minor(X[14], X[7], X[6], X[15], Y[14], Y[7], Y[6], Y[15])
    a2 = _pencil_minor(X[0], X[13], X[12], X[1], Y[0], Y[13], Y[12], Y[1])
    b2 = _pencil_minor(X[6], X[11], X[10], X[7], Y[6], Y[11], Y[10], Y[7])
    a3 = _pencil_minor(X[4], X[9], X[8], X[5], Y[4], Y[9], Y[8], Y[5])
    b3 = _pencil_minor(X[2], X[15], X[14], X[3], Y[2], Y[15], Y[14], Y[3])
    a4 = _pencil_minor(X[4], X[13], X[12], X[5], Y[4], Y[13], Y[12], Y[5])
    b4 = _pencil_minor(X[10], X[3], X[2], X[11], Y[10], Y[3], Y[2], Y[11])
    a5 = _pencil_minor(X[8], X[13], X[12], X[9], Y[8], Y[13], Y[12], Y[9])
    b5 = _pencil_minor(X[2], X[7], X[6], X[3], Y[2], Y[7], Y[6], Y[3])
    p0, p1, p2 = _product(a0, b0), _product(a1, b1), _product(a2, b2)
    p3, p4, p5 = _product(a3, b3), _product(a4, b4), _product(a5, b5)
    return (
        p0[0] + p1[0] + p2[0] + p3[0] + p4[0] + p5[0],
        p0[1] + p1[1] + p2[1] + p3[1] + p4[1] + p5[1],
        p0[2] + p1[2] + p2[2] + p3[2] + p4[2] + p5[2],
        p0[3] + p1[3] + p2[3] + p3[3] + p4[3] + p5[3],
        p0[4] + p1[4] + p2[4] + p3[4] + p4[4] + p5[4],
    )


@jit
def rearranged_frame_coefficients(A, B):
    """Coefficients of det(lambda A_y + B_y) in A's frame (pair_frame.py), assuming R_a^{-1} = R_a^T."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    e, me = offset(ca, Ra, ra, cb)
    W, mW, alpha, malpha = shape(Ra, ra, Rb, reciprocal(rb), False)
    v, mv = matvec(W, e), matvec(mW, me)
    inv, _ = invariants(W, mW, e, me, v, mv)
    return coefficients(inv, alpha)


@jit
def rearranged_coefficients(A, B):
    """det(lambda A + B) = det(lambda A_y + B_y) * det(R_a)^2 / (r_a0 r_a1 r_a2)^2, R_a orthonormal."""
    c4, c3, c2, c1, c0 = rearranged_frame_coefficients(A, B)
    ra = A[2]
    one = type(ra[0])(1.0)
    s = one / (ra[0] * ra[1] * ra[2])
    s = s * s
    return c4 * s, c3 * s, c2 * s, c1 * s, c0 * s


@jit
def _polynomials(Ca, Ra, ra, Cb, Rb, rb, cofactor, out, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)  # stride 0 broadcasts a batch of one
    for i in range(lo, hi):
        ia, ib = i * sa, i * sb
        if cofactor:
            c = cofactor_coefficients(load(Ca, Ra, ra, ia), load(Cb, Rb, rb, ib))
        else:
            c = rearranged_coefficients(load(Ca, Ra, ra, ia), load(Cb, Rb, rb, ib))
        for k in range(5):
            out[i, k] = c[k]


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
