"""The C++ distance/ folder (issue 46) against the numba stages it replaces, bit for bit.

sphere_newton: the bisector seed, sigma, a whole Newton run (its point, value, status and step count), the
rolling radius, the tangent basis and unit() on random, near-contact and every stress category's pairs and
on arbitrary finite floats.
"""

import math

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_native import arrays, finite, positive

import ellipsim.native as native
from ellipsim.core import samples
from ellipsim.core.distance.sphere_newton import (
    a_frame,
    bisector_seed,
    newton,
    rolling_radius,
    sigma,
    tangent_basis,
    unit,
)
from ellipsim.core.tolerances import NEWTON_MAX_ITER
from ellipsim.core.vec3 import load, norm2

ext = native.ext


@numba.njit(cache=False, error_model="numpy")
def _sphere_newton_stages(Ca, Ra, ra, Cb, Rb, rb, out, lo, hi):
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)
    for i in range(lo, hi):
        A, B = load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb)
        e, a2, M, U = a_frame(A, B)
        rB = B[2]
        n0 = bisector_seed(e, a2, U, (rB[0] * rB[0], rB[1] * rB[1], rB[2] * rB[2]))
        rA = A[2]
        scale = math.sqrt(norm2(e)) + max(rA[0], rA[1], rA[2]) + max(rB[0], rB[1], rB[2])
        n, value, status, steps = newton(n0, e, a2, M, scale, -math.inf, NEWTON_MAX_ITER)
        t1, t2 = tangent_basis(n0)
        u = unit(e)
        row = (n0[0], n0[1], n0[2], sigma(n0, e, a2, M), n[0], n[1], n[2], value, float(status), float(steps),
               rolling_radius(rA), t1[0], t1[1], t1[2], t2[0], t2[1], t2[2], u[0], u[1])  # fmt: skip
        for k in range(19):
            out[i, k] = row[k]


def assert_same_bits(args, n):
    got, want = np.full((n, 19), 7.0), np.full((n, 19), 7.0)
    ext.testing.sphere_newton_stages(*args, got, 0, n)
    _sphere_newton_stages(*args, want, 0, n)
    differ = (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))
    bad = np.argwhere(differ)
    assert not len(bad), (
        f"pair {bad[0][0]} column {bad[0][1]}: {got[tuple(bad[0])]!r} in C++, {want[tuple(bad[0])]!r} in numba"
    )


SETS = [
    ("generic", lambda: samples.generic_pairs(3000, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(3000, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 600, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_sphere_newton_gives_the_numba_bits(label, make):
    a, b = make()
    assert_same_bits(arrays(a, b), len(a))


@settings(max_examples=300, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)
def test_sphere_newton_gives_the_numba_bits_on_any_floats(c, R, r):
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    with np.errstate(all="ignore"):
        assert_same_bits((C[0], M[0], S[0], C[1], M[1], S[1]), 1)
