"""Ellipsim's Riemannian Newton for max sigma on the unit sphere as Warp functions: a float64 port of
core/distance/sphere_newton.py (newton without the abandon test, sigma, the tangent frame) and the vec3
helpers it needs, written out component by component as the CPU code computes them; shared by the
contact kernel (kernels.py) and the branch and bound (branch_and_bound.py)."""

import warp as wp

from ..core.tolerances import NEWTON_STEP_TOL

F64 = wp.float64
STEP_TOL2 = NEWTON_STEP_TOL * NEWTON_STEP_TOL  # (a module constant: Warp would square the literal in float32)
#: How a run ended (sphere_newton.py), or APART: stopped at a lower bound beyond the cutoff.
CONVERGED, NOT_CONVERGED, APART = 0, 1, 2
NO_CUTOFF = 1e300


@wp.func
def _mv(U: wp.mat33d, x: wp.vec3d) -> wp.vec3d:
    """vec3.matvec: U x."""
    return wp.vec3d(
        U[0, 0] * x[0] + U[0, 1] * x[1] + U[0, 2] * x[2],
        U[1, 0] * x[0] + U[1, 1] * x[1] + U[1, 2] * x[2],
        U[2, 0] * x[0] + U[2, 1] * x[1] + U[2, 2] * x[2],
    )


@wp.func
def _mtv(U: wp.mat33d, d: wp.vec3d) -> wp.vec3d:
    """vec3.rotate_t: U^T d."""
    return wp.vec3d(
        U[0, 0] * d[0] + U[1, 0] * d[1] + U[2, 0] * d[2],
        U[0, 1] * d[0] + U[1, 1] * d[1] + U[2, 1] * d[2],
        U[0, 2] * d[0] + U[1, 2] * d[1] + U[2, 2] * d[2],
    )


@wp.func
def _dot(x: wp.vec3d, y: wp.vec3d) -> wp.float64:
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@wp.func
def _cross(x: wp.vec3d, y: wp.vec3d) -> wp.vec3d:
    return wp.vec3d(x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])


@wp.func
def _unit(v: wp.vec3d) -> wp.vec3d:
    s = _dot(v, v)
    if s == F64(0.0):
        return wp.vec3d(F64(1.0), F64(0.0), F64(0.0))
    s = F64(1.0) / wp.sqrt(s)
    return wp.vec3d(v[0] * s, v[1] * s, v[2] * s)


@wp.func
def _tangent1(n: wp.vec3d) -> wp.vec3d:
    """sphere_newton.tangent_basis's t1."""
    t = wp.vec3d(-n[2], F64(0.0), n[0])  # e_y x n
    if wp.abs(n[0]) < F64(0.6):
        t = wp.vec3d(F64(0.0), n[2], -n[1])  # e_x x n
    s = F64(1.0) / wp.sqrt(_dot(t, t))
    return wp.vec3d(t[0] * s, t[1] * s, t[2] * s)


@wp.func
def _tangent2(n: wp.vec3d, t1: wp.vec3d) -> wp.vec3d:
    return wp.vec3d(n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])


@wp.func
def sigma(n: wp.vec3d, e: wp.vec3d, a2: wp.vec3d, M: wp.mat33d) -> wp.float64:
    """sphere_newton.sigma: sigma(n) for any nonzero n, scaled to unit length."""
    s = F64(1.0) / wp.sqrt(_dot(n, n))
    u = wp.vec3d(n[0] * s, n[1] * s, n[2] * s)
    ha = wp.sqrt(a2[0] * u[0] * u[0] + a2[1] * u[1] * u[1] + a2[2] * u[2] * u[2])
    mu = _mv(M, u)
    hb = wp.sqrt(u[0] * mu[0] + u[1] * mu[1] + u[2] * mu[2])
    return u[0] * e[0] + u[1] * e[1] + u[2] * e[2] - ha - hb


@wp.func
def newton(n0: wp.vec3d, e: wp.vec3d, a2: wp.vec3d, M: wp.mat33d, scale: wp.float64, max_iter: int, cutoff: wp.float64):
    """sphere_newton.newton without the abandon test, from the unit n0: (n*, sigma before the last step,
    CONVERGED, NOT_CONVERGED or APART: sigma at an iterate reached cutoff, a lower bound on the distance,
    and the run stopped there; NO_CUTOFF for none)."""
    n = n0
    value = F64(0.0)
    for _it in range(max_iter):
        a = wp.vec3d(a2[0] * n[0], a2[1] * n[1], a2[2] * n[2])
        b = _mv(M, n)
        ha = wp.sqrt(a[0] * n[0] + a[1] * n[1] + a[2] * n[2])
        hb = wp.sqrt(b[0] * n[0] + b[1] * n[1] + b[2] * n[2])
        inv = F64(1.0) / (ha * hb)
        ia = hb * inv
        ib = ha * inv
        value = n[0] * e[0] + n[1] * e[1] + n[2] * e[2] - ha - hb
        if value >= cutoff:
            return n, value, APART
        t1 = _tangent1(n)
        t2 = _tangent2(n, t1)
        at1 = a[0] * t1[0] + a[1] * t1[1] + a[2] * t1[2]
        at2 = a[0] * t2[0] + a[1] * t2[1] + a[2] * t2[2]
        bt1 = b[0] * t1[0] + b[1] * t1[1] + b[2] * t1[2]
        bt2 = b[0] * t2[0] + b[1] * t2[1] + b[2] * t2[2]
        g1 = e[0] * t1[0] + e[1] * t1[1] + e[2] * t1[2] - at1 * ia - bt1 * ib
        g2 = e[0] * t2[0] + e[1] * t2[1] + e[2] * t2[2] - at2 * ia - bt2 * ib
        gg = g1 * g1 + g2 * g2
        m1 = _mv(M, t1)
        m2 = _mv(M, t2)
        ia3 = ia * ia * ia
        ib3 = ib * ib * ib
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
        shift = F64(0.0)
        if not (h11 < F64(-1e-12) * scale and det > F64(1e-24) * scale * scale):
            top = F64(0.5) * (h11 + h22) + wp.sqrt(F64(0.25) * ((h11 - h22) * (h11 - h22)) + h12 * h12)
            if gg <= (F64(1e-14) * scale) * (F64(1e-14) * scale) and top <= F64(1e-10) * scale:
                return n, value, CONVERGED
            if gg < F64(1e-4) * top * top:
                v1 = top - h22
                v2 = h12
                if v1 * v1 + v2 * v2 < h12 * h12 + (top - h11) * (top - h11):
                    v1 = h12
                    v2 = top - h11
                if not (v1 * v1 + v2 * v2 > F64(0.0)):
                    v1 = F64(1.0)
                    v2 = F64(0.0)
                    if not (h11 >= h22):
                        v1 = F64(0.0)
                        v2 = F64(1.0)
                vs = F64(0.3) / wp.sqrt(v1 * v1 + v2 * v2)
                v1 = v1 * vs
                v2 = v2 * vs
                p = wp.vec3d(
                    n[0] + v1 * t1[0] + v2 * t2[0], n[1] + v1 * t1[1] + v2 * t2[1], n[2] + v1 * t1[2] + v2 * t2[2]
                )
                q = wp.vec3d(
                    n[0] - v1 * t1[0] - v2 * t2[0], n[1] - v1 * t1[1] - v2 * t2[1], n[2] - v1 * t1[2] - v2 * t2[2]
                )
                if sigma(p, e, a2, M) >= sigma(q, e, a2, M):
                    n = _unit(p)
                else:
                    n = _unit(q)
                continue
            shift = wp.max(top, F64(0.0)) + F64(1e-3) * scale + wp.sqrt(gg)
            h11 = h11 - shift
            h22 = h22 - shift
            det = h11 * h22 - h12 * h12
        idet = F64(1.0) / det
        x1 = -(h22 * g1 - h12 * g2) * idet
        x2 = -(h11 * g2 - h12 * g1) * idet
        step2 = x1 * x1 + x2 * x2
        if step2 > F64(0.25):
            f = F64(0.5) / wp.sqrt(step2)
            x1 = x1 * f
            x2 = x2 * f
            step2 = F64(0.25)
        m = wp.vec3d(n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2])
        if step2 > F64(1e-2):
            for _k in range(10):
                if sigma(m, e, a2, M) >= value:
                    break
                x1 = F64(0.5) * x1
                x2 = F64(0.5) * x2
                step2 = F64(0.25) * step2
                m = wp.vec3d(
                    n[0] + x1 * t1[0] + x2 * t2[0], n[1] + x1 * t1[1] + x2 * t2[1], n[2] + x1 * t1[2] + x2 * t2[2]
                )
        s = F64(1.0) / wp.sqrt(F64(1.0) + step2)
        n = wp.vec3d(m[0] * s, m[1] * s, m[2] * s)
        if step2 <= F64(STEP_TOL2) and shift == F64(0.0):
            return n, value, CONVERGED
    return n, value, NOT_CONVERGED
