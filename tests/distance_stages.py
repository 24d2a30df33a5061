"""The C++ stages of the core's distance/ folder as the tests call them: each takes the arguments of the
Python stage of the same name (tuples of floats, vec3.load's (c, R (9,), r) for an ellipsoid) and returns
what that stage returned (tuples of floats, bools and ints), through _ellipsim.testing's functions on
one row of numbers (ellipsim/native/python/distance.cpp).  The constants the stages compare with are the
C++ ones."""

import numpy as np

from ellipsim.core.tolerances import BB_ERR_SIGMA_ULPS, BB_MAX_PATCHES
from ellipsim.native import ext

T = ext.testing
CODES = T.DISTANCE_CODES
CONSTANTS = T.DISTANCE_CONSTANTS

# sphere_newton
CONVERGED = CONSTANTS["sphere_newton.CONVERGED"]
NOT_CONVERGED = CONSTANTS["sphere_newton.NOT_CONVERGED"]
ABANDONED = CONSTANTS["sphere_newton.ABANDONED"]
# branch_and_bound
GLOBAL = CODES["branch_and_bound.GLOBAL"]
UNPROVEN = CODES["branch_and_bound.UNPROVEN"]
SEPARATED_MAX = CODES["branch_and_bound.SEPARATED_MAX"]
ERR_SIGMA_ULPS = BB_ERR_SIGMA_ULPS
MAX_PATCHES = BB_MAX_PATCHES
RHO_LEVELS = CONSTANTS["branch_and_bound.RHO_LEVELS"]
RHO_TABLE = np.array(T.rho_table())
# spheroids
ERR_C_ULPS = CONSTANTS["spheroids.ERR_C_ULPS"]


def _flat(parts):
    out = []
    for x in parts:
        if isinstance(x, (tuple, list, np.ndarray)):
            out.extend(_flat(x))
        else:
            out.append(float(x))
    return out


def _row(fn, width, *args):
    """fn on the one row of args' numbers (flattened in order): the row it writes (width floats)."""
    inp = np.array([_flat(args)], dtype=np.float64)
    out = np.full((1, width), np.nan)
    fn(inp, out, 0, 1)
    return out[0].tolist()


def _pair(A, B):
    """A, B (vec3.load tuples) as the arrays of two batches of one."""
    arrays = []
    for c, R, r in (A, B):
        arrays += [
            np.array([_flat(c)], dtype=np.float64),
            np.array(_flat(R), dtype=np.float64).reshape(1, 3, 3),
            np.array([_flat(r)], dtype=np.float64),
        ]
    return arrays


def _v(x):
    return tuple(x)


# --- sphere_newton ----------------------------------------------------------------------------------


def a_frame(A, B):
    r = _row(T.sphere_newton_a_frame, 24, A, B)
    return _v(r[0:3]), _v(r[3:6]), _v(r[6:15]), _v(r[15:24])


def sigma(n, e, a2, M):
    return _row(T.sphere_newton_sigma, 1, n, e, a2, M)[0]


def unit(v):
    return _v(_row(T.sphere_newton_unit, 3, v))


def tangent_basis(n):
    r = _row(T.sphere_newton_tangent_basis, 6, n)
    return _v(r[0:3]), _v(r[3:6])


def newton(n, e, a2, M, scale, target, max_iter):
    r = _row(T.sphere_newton_newton, 6, n, e, a2, M, scale, target, max_iter)
    return _v(r[0:3]), r[3], int(r[4]), int(r[5])


def bisector_seed(e, a2, U, rb2):
    return _v(_row(T.sphere_newton_bisector_seed, 3, e, a2, U, rb2))


def rolling_radius(r):
    return _row(T.sphere_newton_rolling_radius, 1, r)[0]


# --- branch_and_bound -------------------------------------------------------------------------------


def sigma_grad(c, e, a, U, b):
    r = _row(T.sigma_grad, 7, c, e, a, U, b)
    return r[0], _v(r[1:4]), r[4], r[5]


def sigma_only(c, e, a, U, b):
    return _row(T.sigma_grad, 7, c, e, a, U, b)[6]


def patch_cap(face, level, i, j, Q):
    r = _row(T.patch_point, 10, face, level, i, j, Q)
    return _v(r[6:9]), r[9]


def certify_region_call(m, e, a, U, b, amax, bmax, S, err_sigma, tol):
    r = _row(T.certify_region, 27, m, e, a, U, b, amax, bmax, S, err_sigma, tol)
    return bool(r[0]), _v(r[1:4]), r[4], _v(r[5:27])


def in_region(c, rho, region):
    return bool(_row(T.in_region, 1, c, rho, region)[0])


def climb(c, e, a, M, scale):
    r = _row(T.climb, 5, c, e, a, M, scale)
    return bool(r[0]), _v(r[1:4]), r[4]


def global_max(n0, v0, have0, e, a, U, b, M, scale, tol, max_patches):
    r = _row(T.global_max, 7, n0, v0, have0, e, a, U, b, M, scale, tol, max_patches)
    return int(r[0]), _v(r[1:4]), r[4], int(r[5]), int(r[6])


# --- inner_sum, spheroids ---------------------------------------------------------------------------


def inner_sum_bound(n, e, a, Ub, b, value):
    return _row(T.inner_sum_bound, 1, n, e, a, Ub, b, value)[0]


def parallel_max(e, a, U, b, tol, S):
    r = _row(T.parallel_max, 5, e, a, U, b, tol, S)
    return bool(r[0]), _v(r[1:4]), int(r[4])


def tilted_max(e, a, U, b, tol, S, n0):
    r = _row(T.tilted_max, 5, e, a, U, b, tol, S, n0)
    return bool(r[0]), _v(r[1:4]), int(r[4])


def ring_max(e, a, U, b, tol, S, n0):
    r = _row(T.ring_max, 5, e, a, U, b, tol, S, n0)
    return bool(r[0]), _v(r[1:4]), int(r[4])


def axis_bb(ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, tol1, S, curv, t0, p0):
    r = _row(T.axis_bb, 5, ek, ex, ey, hk, h1, h2, kb, pb2, wz, wx, wy, tol1, S, curv, t0, p0)
    return bool(r[0]), r[1], r[2], bool(r[3]), int(r[4])


# --- ellipsoid_pair: two ellipsoids as vec3.load tuples ----------------------------------------------


def _pair_result(r):
    return int(r[0]), r[1], _v(r[2:5]), _v(r[5:8]), int(r[8])


def pair_signed_distance(A, B, max_iter=None):
    """(status, dist, normal, pos, work); max_iter: NEWTON_MAX_ITER when None."""
    out = np.full((1, 9), np.nan)
    steps = T.TOLERANCES["NEWTON_MAX_ITER"] if max_iter is None else int(max_iter)
    T.pair_signed_distance(*_pair(A, B), steps, out, 0, 1)
    return _pair_result(out[0].tolist())


def pair_signed_distance_from(A, B, seed):
    out = np.full((1, 9), np.nan)
    T.pair_signed_distance_from(*_pair(A, B), np.array([_flat(seed)], dtype=np.float64), out, 0, 1)
    return _pair_result(out[0].tolist())


def contact_at(A, B, n):
    out = np.full((1, 7), np.nan)
    T.contact_at(*_pair(A, B), np.array([_flat(n)], dtype=np.float64), out, 0, 1)
    r = out[0].tolist()
    return r[0], _v(r[1:4]), _v(r[4:7])


def sigma_lower_bound(A, B, n):
    out = np.full((1, 1), np.nan)
    T.sigma_lower_bound(*_pair(A, B), np.array([_flat(n)], dtype=np.float64), out, 0, 1)
    return float(out[0, 0])
