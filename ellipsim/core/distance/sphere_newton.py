"""sigma(n) = n.(c_B - c_A) - h_A(n) - h_B(-n) in A's principal frame, and its local maximisation on
the unit sphere by Riemannian Newton (the narrow phase's building blocks).

h(n) = |D R^T n| is an ellipsoid's support function (Schneider & Eberly, Geometric Tools 10.5.2).
sigma is concave and positively homogeneous of degree 1 on R^3; its maximum over unit n is the
signed distance (ellipsoid_pair.py), and a local maximum found here is proven global there (the
rolling-radius argument, or branch_and_bound.py's branch and bound).
"""

import math

from .._jit import stage
from ..tolerances import NEWTON_STEP_TOL
from ..vec3 import matvec, norm2, rotate_t, sandwich

#: How one Newton run ended: at a local maximum, not within its steps, or abandoned (its quadratic
#: bound stays below a value another run already reached).
CONVERGED, NOT_CONVERGED, ABANDONED = 0, 1, 2


@stage
def _tmatmul(A, B):
    """A^T B for row-major 3x3 tuples."""
    return (
        A[0] * B[0] + A[3] * B[3] + A[6] * B[6], A[0] * B[1] + A[3] * B[4] + A[6] * B[7], A[0] * B[2] + A[3] * B[5] + A[6] * B[8],
        A[1] * B[0] + A[4] * B[3] + A[7] * B[6], A[1] * B[1] + A[4] * B[4] + A[7] * B[7], A[1] * B[2] + A[4] * B[5] + A[7] * B[8],
        A[2] * B[0] + A[5] * B[3] + A[8] * B[6], A[2] * B[1] + A[5] * B[4] + A[8] * B[7], A[2] * B[2] + A[5] * B[5] + A[8] * B[8],
    )  # fmt: skip


@stage
def a_frame(A, B):
    """The pair in A's principal frame: (e = R_A^T (c_B - c_A), a2 = r_A^2, M = U diag(r_B^2) U^T as a
    symmetric 9-tuple, U = R_A^T R_B (columns: B's axes in A's frame))."""
    (ca, Ra, ra), (cb, Rb, rb) = A, B
    e = rotate_t(Ra, (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]))
    U = _tmatmul(Ra, Rb)
    b0, b1, b2 = rb[0] * rb[0], rb[1] * rb[1], rb[2] * rb[2]
    m00, m01, m02, m11, m12, m22 = sandwich(U, b0, b1, b2)
    M = (m00, m01, m02, m01, m11, m12, m02, m12, m22)
    return e, (ra[0] * ra[0], ra[1] * ra[1], ra[2] * ra[2]), M, U


@stage
def sigma(n, e, a2, M):
    """sigma(n) for any nonzero n, scaled to unit length."""
    s = 1.0 / math.sqrt(norm2(n))
    u = (n[0] * s, n[1] * s, n[2] * s)
    ha = math.sqrt(a2[0] * u[0] * u[0] + a2[1] * u[1] * u[1] + a2[2] * u[2] * u[2])
    mu = matvec(M, u)
    hb = math.sqrt(u[0] * mu[0] + u[1] * mu[1] + u[2] * mu[2])
    return u[0] * e[0] + u[1] * e[1] + u[2] * e[2] - ha - hb


@stage
def unit(v):
    s = norm2(v)
    if s == 0.0:
        return (1.0, 0.0, 0.0)
    s = 1.0 / math.sqrt(s)
    return (v[0] * s, v[1] * s, v[2] * s)


@stage
def tangent_basis(n):
    """Two unit vectors completing the unit n to an orthonormal frame."""
    if abs(n[0]) < 0.6:
        t = (0.0, n[2], -n[1])  # e_x x n
    else:
        t = (-n[2], 0.0, n[0])  # e_y x n
    s = 1.0 / math.sqrt(norm2(t))
    t1 = (t[0] * s, t[1] * s, t[2] * s)
    t2 = (n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])
    return t1, t2


@stage
def newton(n, e, a2, M, scale, target, max_iter):
    """Maximise sigma on the unit sphere from the unit vector n: (n*, sigma before the last step,
    status, steps); the last step is below NEWTON_STEP_TOL, so sigma(n*) differs by O(tol^2).

    Riemannian Newton with the retraction n <- (n + x) / |n + x|, x in the tangent plane: a step of at
    most 0.5 rad, halved while it would decrease sigma (steps over 0.1 rad), a Levenberg shift where
    the tangent Hessian is not negative definite, and a 0.3 rad escape along the curvature direction
    from saddles.  Converged when a negative definite Newton step falls below NEWTON_STEP_TOL rad.

    target: a value another run already reached.  Where the tangent Hessian is negative definite
    with smallest curvature lam >= det / -trace, the quadratic model bounds this run's maximum by
    sigma + |g|^2 / (2 lam); a run whose bound stays below target is ABANDONED (-inf for none).
    """
    value = 0.0
    for it in range(max_iter):
        a = (a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
        b = matvec(M, n)
        ha = math.sqrt(a[0] * n[0] + a[1] * n[1] + a[2] * n[2])
        hb = math.sqrt(b[0] * n[0] + b[1] * n[1] + b[2] * n[2])
        inv = 1.0 / (ha * hb)
        ia, ib = hb * inv, ha * inv
        value = n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - ha - hb
        t1, t2 = tangent_basis(n)
        # gradient e - a/ha - b/hb in the tangent basis
        at1, at2 = a[0] * t1[0] + a[1] * t1[1] + a[2] * t1[2], a[0] * t2[0] + a[1] * t2[1] + a[2] * t2[2]
        bt1, bt2 = b[0] * t1[0] + b[1] * t1[1] + b[2] * t1[2], b[0] * t2[0] + b[1] * t2[1] + b[2] * t2[2]
        g1 = e[0] * t1[0] + e[1] * t1[1] + e[2] * t1[2] - at1 * ia - bt1 * ib
        g2 = e[0] * t2[0] + e[1] * t2[1] + e[2] * t2[2] - at2 * ia - bt2 * ib
        gg = g1 * g1 + g2 * g2
        # Hessian of sigma: -(diag(a2)/ha - a a^T/ha^3) - (M/hb - b b^T/hb^3), then minus sigma I
        m1, m2 = matvec(M, t1), matvec(M, t2)
        ia3, ib3 = ia * ia * ia, ib * ib * ib
        d11 = a2[0] * t1[0] * t1[0] + a2[1] * t1[1] * t1[1] + a2[2] * t1[2] * t1[2]
        d12 = a2[0] * t1[0] * t2[0] + a2[1] * t1[1] * t2[1] + a2[2] * t1[2] * t2[2]
        d22 = a2[0] * t2[0] * t2[0] + a2[1] * t2[1] * t2[1] + a2[2] * t2[2] * t2[2]
        q11 = t1[0] * m1[0] + t1[1] * m1[1] + t1[2] * m1[2]
        q12 = t2[0] * m1[0] + t2[1] * m1[1] + t2[2] * m1[2]
        q22 = t2[0] * m2[0] + t2[1] * m2[1] + t2[2] * m2[2]
        h11 = -(d11 * ia - at1 * at1 * ia3) - (q11 * ib - bt1 * bt1 * ib3) - value
        h12 = -(d12 * ia - at1 * at2 * ia3) - (q12 * ib - bt1 * bt2 * ib3)
        h22 = -(d22 * ia - at2 * at2 * ia3) - (q22 * ib - bt2 * bt2 * ib3) - value
        det = h11 * h22 - h12 * h12
        shift = 0.0
        if h11 < -1e-12 * scale and det > 1e-24 * scale * scale:  # negative definite
            if value - 0.5 * gg * (h11 + h22) / det < target:
                return n, value, ABANDONED, it + 1
        else:
            top = 0.5 * (h11 + h22) + math.sqrt(0.25 * (h11 - h22) ** 2 + h12 * h12)
            if gg <= (1e-14 * scale) ** 2 and top <= 1e-10 * scale:
                return n, value, CONVERGED, it + 1  # a flat maximum (concentric spheres): any n is optimal
            if gg < 1e-4 * top * top:
                # near a saddle or a minimum: leave along the direction of positive curvature,
                # 0.3 rad to the side where sigma is larger (gradient steps would stall here)
                v1, v2 = top - h22, h12  # eigenvector of top: the larger of its two forms
                if v1 * v1 + v2 * v2 < h12 * h12 + (top - h11) ** 2:
                    v1, v2 = h12, top - h11
                if not v1 * v1 + v2 * v2 > 0.0:  # underflow: h is diagonal to rounding
                    v1, v2 = (1.0, 0.0) if h11 >= h22 else (0.0, 1.0)
                vs = 0.3 / math.sqrt(v1 * v1 + v2 * v2)
                v1, v2 = v1 * vs, v2 * vs
                p = (n[0] + v1 * t1[0] + v2 * t2[0], n[1] + v1 * t1[1] + v2 * t2[1], n[2] + v1 * t1[2] + v2 * t2[2])
                q = (n[0] - v1 * t1[0] - v2 * t2[0], n[1] - v1 * t1[1] - v2 * t2[1], n[2] - v1 * t1[2] - v2 * t2[2])
                n = unit(p) if sigma(p, e, a2, M) >= sigma(q, e, a2, M) else unit(q)
                continue
            shift = max(top, 0.0) + 1e-3 * scale + math.sqrt(gg)
            h11, h22 = h11 - shift, h22 - shift
            det = h11 * h22 - h12 * h12
        idet = 1.0 / det
        x1 = -(h22 * g1 - h12 * g2) * idet
        x2 = -(h11 * g2 - h12 * g1) * idet
        step2 = x1 * x1 + x2 * x2
        if step2 > 0.25:
            f = 0.5 / math.sqrt(step2)
            x1, x2, step2 = x1 * f, x2 * f, 0.25
        m = (n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2])
        if step2 > 1e-2:  # beyond 0.1 rad the quadratic model may overshoot: backtrack until sigma grows
            for _ in range(10):
                if sigma(m, e, a2, M) >= value:
                    break
                x1, x2, step2 = 0.5 * x1, 0.5 * x2, 0.25 * step2
                m = (n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2])
        s = 1.0 / math.sqrt(1.0 + step2)  # |n + x|^2 = 1 + |x|^2: x is tangent, n unit
        n = (m[0] * s, m[1] * s, m[2] * s)
        if step2 <= NEWTON_STEP_TOL * NEWTON_STEP_TOL and shift == 0.0:
            return n, value, CONVERGED, it + 1
    return n, value, NOT_CONVERGED, max_iter


@stage
def bisector_seed(e, a2, U, rb2):
    """The bisector of Q_A d and Q_B d (the normals where the centre line leaves A and B), in A's frame;
    the start that needs the fewest Newton steps on touching pairs (the first release's narrow-phase benchmark).
    Q d is taken times det(D)^2 (no divisions) and the bisector of u and w is u |w| + w |u|."""
    na = (e[0] * a2[1] * a2[2], e[1] * a2[0] * a2[2], e[2] * a2[0] * a2[1])
    z = rotate_t(U, e)  # in B's axes
    nb = matvec(U, (z[0] * rb2[1] * rb2[2], z[1] * rb2[0] * rb2[2], z[2] * rb2[0] * rb2[1]))
    la, lb = math.sqrt(norm2(na)), math.sqrt(norm2(nb))
    return unit((na[0] * lb + nb[0] * la, na[1] * lb + nb[1] * la, na[2] * lb + nb[2] * la))


@stage
def rolling_radius(r):
    """Smallest radius of curvature of an ellipsoid, c^2 / a: a ball of this radius rolls freely inside it."""
    lo, hi = min(r[0], r[1], r[2]), max(r[0], r[1], r[2])
    return lo * lo / hi
