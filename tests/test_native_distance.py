"""The C++ distance/ folder (issue 46) against the numba stages it replaces, bit for bit.

sphere_newton: the bisector seed, sigma, a whole Newton run (its point, value, status and step count), the
rolling radius, the tangent basis and unit() on random, near-contact and every stress category's pairs and
on arbitrary finite floats.

The narrow phase: the drop-in kernels signed_distances and derivatives (ellipsoid_pair._distances and
derivatives._derivatives) on every sample set, on the deep, thin, spheroid, concentric and UNPROVEN pairs of
the Python module's own tests, with every max_iter, on hypothesis's hard and random pairs and on arbitrary finite
floats; their broadcasting, ranges, threads and refusals.  Their stages through the testing submodule, each
on rows of its own arguments (so that the special inputs of test_global_max, test_inner_sum, test_spheroids
reach them directly): inner_sum_bound, sigma_grad, patch_point, certify_region, in_region, climb, global_max
(seeded or not, small budgets, flat maxima, separated pairs), parallel_max, tilted_max, axis_bb (spheroids
and cylinders, refusals), pair_signed_distance(_from), contact_at and sigma_lower_bound.
"""

import math
import threading

import leaves_poses
import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation as Rot
from strategies import hard_pair, random_pair
from test_native import arrays, finite, positive
from test_spheroids import model_pair, spheroid_pair

import ellipsim.native as native
from ellipsim import ContactFeature, DerivativeStatus, DistanceStatus, Ellipsoids
from ellipsim.core import samples, threads
from ellipsim.core.distance import branch_and_bound as bb
from ellipsim.core.distance import derivatives as dv
from ellipsim.core.distance import ellipsoid_pair as ep
from ellipsim.core.distance.branch_and_bound import (
    certify_region_call,
    climb,
    global_max,
    in_region,
    patch_cap,
    patch_point,
    sigma_grad,
    sigma_only,
)
from ellipsim.core.distance.ellipsoid_pair import (
    _deep_tolerance,
    _distances,
    contact_at,
    pair_signed_distance,
    pair_signed_distance_from,
    sigma_lower_bound,
)
from ellipsim.core.distance.inner_sum import inner_sum_bound
from ellipsim.core.distance.sphere_newton import (
    CONVERGED,
    a_frame,
    bisector_seed,
    newton,
    rolling_radius,
    sigma,
    tangent_basis,
    unit,
)
from ellipsim.core.distance.spheroids import axis_bb, parallel_max, tilted_max
from ellipsim.core.samples import random_ellipsoids
from ellipsim.core.tolerances import BB_ERR_SIGMA_ULPS, BB_MAX_PATCHES, FIRST_RUN_ITER, NEWTON_MAX_ITER, U
from ellipsim.core.vec3 import load, norm2, scaled, unit_scale

ext = native.ext
T = ext.testing


def assert_same_bits(got, want, what=""):
    """Equal bits, NaN for NaN (its sign and payload are the compiler's choice); any dtype."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape and got.dtype == want.dtype
    if got.dtype == np.float64:
        differ = (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))
    else:
        differ = got != want
    bad = np.argwhere(differ)
    assert not len(bad), f"{what} at {tuple(bad[0])}: {got[tuple(bad[0])]!r} in C++, {want[tuple(bad[0])]!r} in numba"


# --- sphere_newton -------------------------------------------------------------------------------------------


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


def assert_sphere_newton_bits(args, n):
    got, want = np.full((n, 19), 7.0), np.full((n, 19), 7.0)
    T.sphere_newton_stages(*args, got, 0, n)
    _sphere_newton_stages(*args, want, 0, n)
    assert_same_bits(got, want, "sphere_newton_stages")


SETS = [
    ("generic", lambda: samples.generic_pairs(3000, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(3000, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 600 if c != "aspect 1e4" else 100, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_sphere_newton_gives_the_numba_bits(label, make):
    a, b = make()
    assert_sphere_newton_bits(arrays(a, b), len(a))


any_pair = (
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)


def one_pair(c, R, r):
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    return C[0], M[0], S[0], C[1], M[1], S[1]


@settings(max_examples=300, deadline=None)
@given(*any_pair)
def test_sphere_newton_gives_the_numba_bits_on_any_floats(c, R, r):
    with np.errstate(all="ignore"):
        assert_sphere_newton_bits(one_pair(c, R, r), 1)


# --- the drop-in kernels: signed_distances and derivatives -----------------------------------------------------


def distances(kernel, args, n, max_iter=NEWTON_MAX_ITER, lo=0, hi=None):
    out = (np.full(n, 7.0), np.full((n, 3), 7.0), np.full((n, 3), 7.0), np.full(n, 7, np.int8))
    kernel(*args, max_iter, *out, lo, n if hi is None else hi)
    return out


def derivatives(kernel, args, normal, status, n, lo=0, hi=None):
    out = (np.full((n, 18), 7.0), np.full((n, 3, 18), 7.0), np.full((n, 3, 18), 7.0), np.full(n, 7, np.int8))
    kernel(*args, normal, status, *out, lo, n if hi is None else hi)
    return out


def assert_kernels_agree(args, n, max_iter=NEWTON_MAX_ITER, lo=0, hi=None):
    """signed_distances and derivatives (at numba's normals and statuses) give numba's bits in [lo, hi) and
    leave the rest of their outputs alone; returns numba's (dist, normal, pos, status)."""
    got = distances(ext.signed_distances, args, n, max_iter, lo, hi)
    want = distances(_distances, args, n, max_iter, lo, hi)
    for g, w, name in zip(got, want, ("dist", "normal", "pos", "status")):
        assert_same_bits(g, w, f"signed_distances {name}")
    normal, status = want[1], want[3]
    if lo == 0 and (hi is None or hi == n):  # derivatives read every row of normal and status
        got = derivatives(ext.derivatives, args, normal, status, n)
        want_d = derivatives(dv._derivatives, args, normal, status, n)
        for g, w, name in zip(got, want_d, ("grad", "jn", "jp", "status")):
            assert_same_bits(g, w, f"derivatives {name}")
    return want


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_signed_distances_and_derivatives_give_the_numba_bits(label, make):
    a, b = make()
    assert_kernels_agree(arrays(a, b), len(a))


def deep_elongated(n, seed):
    """test_distance's random deep crossings of elongated ellipsoids (centres within 5 cm)."""
    rng = np.random.default_rng(seed)
    rot = lambda: Rot.random(n, random_state=rng).as_matrix()  # noqa: E731
    radii = lambda: np.c_[rng.uniform(0.15, 0.4, n), rng.uniform(0.02, 0.06, (n, 2))]  # noqa: E731
    return Ellipsoids(np.zeros((n, 3)), rot(), radii()), Ellipsoids(rng.uniform(-0.03, 0.03, (n, 3)), rot(), radii())


def thin_pairs(n, seed):
    """test_global_max's thin pairs: plates 1 x 1/k x 0.5 across 0.3 x 0.3 x 1/k (k = 100, 1000), and leaves of
    25:10:1 nearly coplanar and crossing, alternately."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        Ra, Rb = Rot.random(2, random_state=rng).as_matrix()
        if i % 2:
            Rb = Ra @ Rot.from_rotvec([*rng.uniform(-0.1, 0.1, 2), rng.uniform(0, 2 * np.pi)]).as_matrix()
            ra, rb = [0.025, 0.01, 0.001], list(np.array([0.025, 0.01, 0.001]) * rng.uniform(0.5, 1.5))
            cb = Ra @ (rng.uniform(-0.01, 0.01, 3) * np.array([1, 1, 0.1]))
        else:
            big = 10.0 ** rng.integers(2, 4)
            ra, rb, cb = [1.0, 1.0 / big, 0.5], [0.3, 0.3, 1.0 / big], rng.uniform(-0.3, 0.3, 3)
        rows.append((Ra, ra, cb, Rb, rb))
    return (Ellipsoids(np.zeros((n, 3)), [r[0] for r in rows], [r[1] for r in rows]),
            Ellipsoids([r[2] for r in rows], [r[3] for r in rows], [r[4] for r in rows]))  # fmt: skip


def spheroid_pairs(n, seed, tilts=(0.0,)):
    """test_distance's parallel and nearly parallel spheroids: prolate and oblate (aspect 1.15-8), equal
    rotations or B turned about the common axis, then tilted; centres on the axis, in a plane through it or
    anywhere, deep to shallow."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        rs = []
        for scale in (1.0, rng.uniform(0.3, 1.5)):
            aspect, s = rng.uniform(1.15, 8.0), scale * rng.uniform(0.3, 1.0)
            rs.append([aspect * s, s, s] if rng.random() < 0.5 else [s, aspect * s, aspect * s])
        R = Rot.random(random_state=rng).as_matrix() if i % 3 else np.eye(3)
        Rb = R if i % 2 else R @ Rot.from_rotvec([rng.uniform(0, 2 * np.pi), 0, 0]).as_matrix()
        tilt = tilts[i % len(tilts)]
        if tilt:
            Rb = Rot.from_rotvec(Rot.random(random_state=rng).as_matrix()[:, 0] * tilt).as_matrix() @ Rb
        u = R[:, 0] if i % 5 < 2 else R @ np.array([np.cos(i), np.sin(i), 0.0])
        rows.append((R, rs[0], Rb, rs[1], u * rng.uniform(0.0, 1.1) * (max(rs[0]) + max(rs[1]))))
    return (Ellipsoids(np.zeros((n, 3)), [r[0] for r in rows], [r[1] for r in rows]),
            Ellipsoids([r[4] for r in rows], [r[2] for r in rows], [r[3] for r in rows]))  # fmt: skip


def unprovable_pair():
    """test_reproducible's needle 1.6 m x 1.6 um x 2.4 um touching a 5 um ellipsoid (aspect 1e6): UNPROVEN."""
    a = Ellipsoids([0.0, 0.0, 0.0],
                   [[-0.8858523243500376, -0.4506434993467114, -0.11039065150721275],
                    [0.41799977102158176, -0.8784223908338515, 0.23162533261205656],
                    [-0.2013500704483154, 0.15904257221980264, 0.9665213962205738]],
                   [1.6224973443468789, 1.6224973443468789e-06, 2.4427303617707426e-06])  # fmt: skip
    b = Ellipsoids([-6.24467982719238e-06, -4.052033129888916e-07, 6.337104017519303e-07],
                   [[0.8411274064382803, -0.07250239556231587, -0.535955304830671],
                    [0.21159180117918552, 0.95610043430146, 0.20273349304519864],
                    [0.4977284358082829, -0.28392844550394214, 0.8195431910653367]],
                   [5.108196567307761e-06, 1.9218478692137188e-07, 1.921847869213719e-06])  # fmt: skip
    return a, b


def special_pairs():
    """The hand-made pairs of test_distance, test_derivatives and test_reproducible: concentric spheres and
    spheroids (same axes, turned about the common axis), coaxial needles, identical prolate spheroids on their
    axis, a sphere on a turned spheroid's axis, spheroids turned by 2e-9 rad, MuJoCo's leaves.xml contacts,
    a separated pair, the same pair scaled by 2^60 and 2^-60, and the UNPROVEN needle."""
    E = lambda c, R, r: Ellipsoids(np.asarray(c, float), np.asarray(R, float), np.asarray(r, float))  # noqa: E731
    I3 = np.eye(3)
    flip = np.diag([-1.0, -1.0, 1.0])
    pairs = [
        (E([1, 2, 3], I3, [1, 1, 1]), E([1, 2, 3], I3, [0.5, 0.5, 0.5])),
        (E([1, 2, 3], I3, [2, 1, 0.5]), E([1, 2, 3], I3, [0.5, 0.5, 0.5])),
        (E([0, 0, 0], I3, [0.1, 0.1, 1.0]), E([0, 0, 0.3], I3, [0.1, 0.1, 1.0])),
        (E([0, 0, 1], flip, [0.5, 0.5, 1.0]), E([0, 0, 0], flip, [0.5, 0.5, 1.0])),
        (E([0, 0, 0], I3, [2.0, 1.0, 1.0]), E([2, 0, 0], I3, [2.0, 1.0, 1.0])),
        (E([0.5, 0, 0], I3, [0.3, 0.2, 0.1]), Ellipsoids.from_quaternions([0.5, 0, 0], [0.9, 0.1, 0.3, 0.2], [0.35, 0.25, 0.15])),
        (E([0, 0, 0], I3, [1.0, 0.5, 0.25]), E([3, 0, 0], I3, [0.5, 0.5, 0.5])),
        (E([0, 0, 0], I3, [0.1, 0.1, 0.2]), E([0, 0, 0.00001], Rot.from_rotvec([0, 0, 2e-9]).as_matrix(), [0.1, 0.1, 0.2])),
        unprovable_pair(),
    ]  # fmt: skip
    for angle in (np.pi / 2, 0.3, 2.0):
        c, s = np.cos(angle), np.sin(angle)
        for ra, rb in (((0.5, 0.5, 1.0), (0.5, 0.5, 1.0)), ((0.3, 0.3, 0.2), (0.6, 0.6, 0.1))):
            turned = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
            pairs.append((E([0, 0, 0], flip, ra), E([0, 0, 0], turned, rb)))
    R = Rot.from_rotvec([0.3, -0.7, 0.4]).as_matrix()
    for offset in (0.0, 0.05, 0.3):
        pairs.append((E([0, 0, 0], I3, [0.3, 0.3, 0.3]), E(R[:, 2] * 0.1 + R[:, 0] * offset * 0, R, [0.25, 0.25, 0.8])))
    for p in leaves_poses.POSES:
        pairs.append((E(p["ca"], p["Ra"], p["ra"]), E(p["cb"], p["Rb"], p["rb"])))
    a, b = samples.generic_pairs(20, seed=4)
    for s in (2.0**60, 2.0**-60):
        pairs += [(Ellipsoids(a.centers[i:i + 1] * s, a.rotations[i:i + 1], a.radii[i:i + 1] * s),
                   Ellipsoids(b.centers[i:i + 1] * s, b.rotations[i:i + 1], b.radii[i:i + 1] * s)) for i in range(20)]  # fmt: skip
    return Ellipsoids.concatenate([p[0] for p in pairs]), Ellipsoids.concatenate([p[1] for p in pairs])


DEEP = [
    ("deep", lambda: (random_ellipsoids(np.random.default_rng(1), 600, box=0.05, radii=(0.15, 1.0)),
                      random_ellipsoids(np.random.default_rng(2), 600, box=0.05, radii=(0.15, 1.0)))),
    ("deep elongated crossings", lambda: deep_elongated(400, 2026)),
    ("thin plates and leaves", lambda: thin_pairs(40, 19)),
    ("parallel spheroids", lambda: spheroid_pairs(300, 18)),
    ("nearly parallel spheroids", lambda: spheroid_pairs(120, 7, (1e-12, 1e-9, 1e-6, 1e-4, 1e-2, 1e-1))),
    ("special", special_pairs),
]  # fmt: skip


@pytest.mark.parametrize("label, make", DEEP, ids=[s[0] for s in DEEP])
def test_deep_and_special_pairs_give_the_numba_bits(label, make):
    """The pairs that reach inner_sum, spheroids and branch_and_bound (most of them deep), and the special cases
    of the Python module's tests: the same bits, every path taken (GLOBAL and UNPROVEN, SMOOTH, BRANCH, FLAT)."""
    a, b = make()
    dist, normal, pos, status = assert_kernels_agree(arrays(a, b), len(a))
    if label == "special":
        assert (status == ep.UNPROVEN).any() and (status == ep.GLOBAL).any()
        out = derivatives(dv._derivatives, arrays(a, b), normal, status, len(a))
        assert {dv.SMOOTH, dv.BRANCH, dv.FLAT, dv.UNPROVEN} <= set(out[3].tolist())


@pytest.mark.parametrize("max_iter", [1, 2, 3, 5, 9, 10, 11, 40, 1000, 1_000_000])
def test_every_max_iter_gives_the_numba_bits(max_iter):
    a, b = samples.generic_pairs(400, seed=7)
    c, d = deep_elongated(100, 8)
    a, b = Ellipsoids.concatenate([a, c]), Ellipsoids.concatenate([b, d])
    assert_kernels_agree(arrays(a, b), len(a), max_iter)


def test_derivatives_of_unproven_pairs_and_any_status_give_the_numba_bits():
    """dist_status as the caller gives it (test_derivatives: UNPROVEN rows are NaN, any nonzero code is)."""
    a, b = samples.generic_pairs(40, seed=2)
    dist, normal, pos, status = distances(_distances, arrays(a, b), 40)
    status = np.array([0, 1, 0, 2, -1, 0, 127, 0] * 5, dtype=np.int8)
    got = derivatives(ext.derivatives, arrays(a, b), normal, status, 40)
    want = derivatives(dv._derivatives, arrays(a, b), normal, status, 40)
    for g, w in zip(got, want):
        assert_same_bits(g, w, "derivatives")
    assert np.isnan(got[0][status != 0]).all() and (got[3][status != 0] == dv.UNPROVEN).all()


def test_derivatives_at_any_normal_give_the_numba_bits():
    """Any direction (unit or not, zero included) as the normal: the polish and the status follow it."""
    a, b = samples.generic_pairs(300, seed=12)
    rng = np.random.default_rng(3)
    normal = rng.normal(size=(300, 3)) * 10.0 ** rng.integers(-3, 3, (300, 1))
    normal[:10] = 0.0
    status = np.zeros(300, np.int8)
    with np.errstate(all="ignore"):
        got = derivatives(ext.derivatives, arrays(a, b), normal, status, 300)
        want = derivatives(dv._derivatives, arrays(a, b), normal, status, 300)
    for g, w in zip(got, want):
        assert_same_bits(g, w, "derivatives")


def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice():
    a, b = samples.near_contact_pairs(300, seed=8)
    c, d = deep_elongated(20, 3)
    a, b = Ellipsoids.concatenate([a, c]), Ellipsoids.concatenate([b, d])
    n = len(a)
    assert_kernels_agree(arrays(a[0], b), n)
    assert_kernels_agree(arrays(a, b[n - 1]), n)
    assert_kernels_agree(arrays(a, b), n, NEWTON_MAX_ITER, 17, 311)  # the rest keeps its fill (compared too)
    out = distances(ext.signed_distances, arrays(a, b), n, NEWTON_MAX_ITER, 17, 311)
    assert np.all(out[0][:17] == 7.0) and np.all(out[0][311:] == 7.0) and np.all(out[3][311:] == 7)
    dist, normal, pos, status = distances(_distances, arrays(a, b), n)
    got = derivatives(ext.derivatives, arrays(a, b), normal, status, n, 17, 311)
    want = derivatives(dv._derivatives, arrays(a, b), normal, status, n, 17, 311)
    for g, w in zip(got, want):
        assert_same_bits(g, w, "derivatives")
    assert np.all(got[1][:17] == 7.0) and np.all(got[3][311:] == 7)


def test_chunks_on_threads_and_concurrent_callers_get_the_serial_bits():
    a, b = samples.generic_pairs(6000, seed=10)
    args, n = arrays(a, b), len(a)
    serial = distances(ext.signed_distances, args, n)
    chunked = tuple(np.empty_like(x) for x in serial)
    with threads.limit(2):
        threads.run(ext.signed_distances, n, True, *args, NEWTON_MAX_ITER, *chunked)
    for x, y in zip(chunked, serial):
        assert_same_bits(x, y, "chunked")
    outs = [tuple(np.empty_like(x) for x in serial) for _ in range(3)]
    workers = [threading.Thread(target=ext.signed_distances, args=(*args, NEWTON_MAX_ITER, *o, 0, n)) for o in outs]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    for o in outs:
        for x, y in zip(o, serial):
            assert_same_bits(x, y, "concurrent")
    d_serial = derivatives(ext.derivatives, args, serial[1], serial[3], n)
    d_chunked = tuple(np.empty_like(x) for x in d_serial)
    with threads.limit(2):
        threads.run(ext.derivatives, n, True, *args, serial[1], serial[3], *d_chunked)
    for x, y in zip(d_chunked, d_serial):
        assert_same_bits(x, y, "chunked derivatives")


def test_the_kernels_refuse_bad_ranges_and_arrays():
    a, b = samples.generic_pairs(10, seed=1)
    args = arrays(a, b)
    out = (np.empty(10), np.empty((10, 3)), np.empty((10, 3)), np.empty(10, np.int8))
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.signed_distances(*args, 40, *out, 0, 11)
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.signed_distances(*args, 40, *out, 5, 4)
    with pytest.raises(IndexError, match="pair range outside the batches"):
        ext.signed_distances(*arrays(a[:5], b), 40, *out, 0, 10)
    with pytest.raises(ValueError, match="same length"):
        ext.signed_distances(*args, 40, out[0], out[1][:9], out[2], out[3], 0, 9)
    with pytest.raises(TypeError):  # a strided output is refused, never copied
        ext.signed_distances(*args, 40, np.empty(20)[::2], *out[1:], 0, 10)
    with pytest.raises(TypeError):  # a status array of another dtype is refused
        ext.signed_distances(*args, 40, *out[:3], np.empty(10, np.int32), 0, 10)
    d = (np.empty((10, 18)), np.empty((10, 3, 18)), np.empty((10, 3, 18)), np.empty(10, np.int8))
    with pytest.raises(ValueError, match="same length"):
        ext.derivatives(*args, out[1], np.zeros(9, np.int8), *d, 0, 9)
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.derivatives(*args, out[1], np.zeros(10, np.int8), *d, 0, 11)
    with pytest.raises(TypeError):
        ext.derivatives(*args, out[1], np.zeros(10, np.int8), np.empty((10, 17)), *d[1:], 0, 10)


@settings(max_examples=150, deadline=None)
@given(st.one_of(hard_pair, random_pair()))
def test_hard_pairs_give_the_numba_bits(pair):
    assert_kernels_agree(arrays(*pair), 1)


@settings(max_examples=150, deadline=None)
@given(*any_pair)
def test_arbitrary_finite_floats_give_the_numba_bits(c, R, r):
    """Any finite float the kernels may meet (the Python layer validates; the kernels must agree anyway):
    extreme exponents, subnormal radii, rotations that are not rotations."""
    with np.errstate(all="ignore"):
        assert_kernels_agree(one_pair(c, R, r), 1)


def test_the_status_codes_are_status_py():
    codes = T.DISTANCE_CODES
    for enum in (DistanceStatus, DerivativeStatus, ContactFeature):
        for m in enum:
            assert codes[f"{enum.__name__}.{m.name}"] == int(m)
    assert len([k for k in codes if "." in k and k.split(".")[0] in ("DistanceStatus", "DerivativeStatus",
                                                                     "ContactFeature")]) == 14  # fmt: skip
    assert (codes["ellipsoid_pair.GLOBAL"], codes["ellipsoid_pair.UNPROVEN"]) == (ep.GLOBAL, ep.UNPROVEN)
    assert [codes[f"branch_and_bound.{k}"] for k in ("GLOBAL", "UNPROVEN", "SEPARATED_MAX")] == [
        bb.GLOBAL,
        bb.UNPROVEN,
        bb.SEPARATED_MAX,
    ]
    assert [codes[f"derivatives.{k}"] for k in ("SMOOTH", "BRANCH", "FLAT", "UNPROVEN")] == [
        dv.SMOOTH,
        dv.BRANCH,
        dv.FLAT,
        dv.UNPROVEN,
    ]


def test_the_rho_table_is_branch_and_bounds():
    assert_same_bits(np.array(T.rho_table()), bb.RHO_TABLE, "RHO_TABLE")


# --- the stages, on rows of their arguments --------------------------------------------------------------------


@numba.njit(inline="always")
def _v(r, k):
    return (r[k], r[k + 1], r[k + 2])


@numba.njit(inline="always")
def _m(r, k):
    return (r[k], r[k + 1], r[k + 2], r[k + 3], r[k + 4], r[k + 5], r[k + 6], r[k + 7], r[k + 8])


@numba.njit(cache=False, error_model="numpy")
def _nb_inner_sum_bound(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        out[i, 0] = inner_sum_bound(_v(r, 0), _v(r, 3), _v(r, 6), _m(r, 9), _v(r, 18), r[21])


@numba.njit(cache=False, error_model="numpy")
def _nb_sigma_grad(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        c, e, a, U, b = _v(r, 0), _v(r, 3), _v(r, 6), _m(r, 9), _v(r, 18)
        s, G, ha, hb = sigma_grad(c, e, a, U, b)
        row = (s, G[0], G[1], G[2], ha, hb, sigma_only(c, e, a, U, b))
        for k in range(7):
            out[i, k] = row[k]


@numba.njit(cache=False, error_model="numpy")
def _nb_patch_point(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        face, level, pi, pj, Q = int(r[0]), int(r[1]), int(r[2]), int(r[3]), _m(r, 4)
        p, inv, pc, rho = patch_point(face, level, pi, pj, Q)
        c, rc = patch_cap(face, level, pi, pj, Q)
        row = (p[0], p[1], p[2], inv, pc, rho, c[0], c[1], c[2], rc)
        for k in range(10):
            out[i, k] = row[k]


@numba.njit(cache=False, error_model="numpy")
def _nb_certify_region(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        ok, m, v, reg = certify_region_call(
            _v(r, 0), _v(r, 3), _v(r, 6), _m(r, 9), _v(r, 18), r[21], r[22], r[23], r[24], r[25]
        )
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = (1.0 if ok else 0.0), m[0], m[1], m[2], v
        for k in range(22):
            out[i, 5 + k] = reg[k]


@numba.njit(cache=False, error_model="numpy")
def _nb_in_region(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        reg = (r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11], r[12], r[13], r[14], r[15], r[16], r[17], r[18],
               r[19], r[20], r[21], r[22], r[23], r[24], r[25])  # fmt: skip
        out[i, 0] = 1.0 if in_region(_v(r, 0), r[3], reg) else 0.0


@numba.njit(cache=False, error_model="numpy")
def _nb_climb(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        conv, m, v = climb(_v(r, 0), _v(r, 3), _v(r, 6), _m(r, 9), r[18])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = (1.0 if conv else 0.0), m[0], m[1], m[2], v


@numba.njit(cache=False, error_model="numpy")
def _nb_global_max(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        status, n, v, count, runs = global_max(
            _v(r, 0), r[3], r[4] != 0.0, _v(r, 5), _v(r, 8), _m(r, 11), _v(r, 20), _m(r, 23), r[32], r[33], int(r[34])
        )
        row = (float(status), n[0], n[1], n[2], v, float(count), float(runs))
        for k in range(7):
            out[i, k] = row[k]


@numba.njit(cache=False, error_model="numpy")
def _nb_parallel_max(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        ok, n, nodes = parallel_max(_v(r, 0), _v(r, 3), _m(r, 6), _v(r, 15), r[18], r[19])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = (1.0 if ok else 0.0), n[0], n[1], n[2], float(nodes)


@numba.njit(cache=False, error_model="numpy")
def _nb_tilted_max(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        ok, n, nodes = tilted_max(_v(r, 0), _v(r, 3), _m(r, 6), _v(r, 15), r[18], r[19], _v(r, 20))
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = (1.0 if ok else 0.0), n[0], n[1], n[2], float(nodes)


@numba.njit(cache=False, error_model="numpy")
def _nb_axis_bb(inp, out, lo, hi):
    for i in range(lo, hi):
        r = inp[i]
        ok, t, p, moved, nodes = axis_bb(r[0], r[1], r[2], int(r[3]), r[4], r[5], r[6], r[7], r[8], r[9], r[10],
                                         r[11], r[12], r[13], r[14], r[15])  # fmt: skip
        row = (1.0 if ok else 0.0, t, p, 1.0 if moved else 0.0, float(nodes))
        for k in range(5):
            out[i, k] = row[k]


STAGES = {  # name: (C++, numba, input columns, output columns)
    "inner_sum_bound": (T.inner_sum_bound, _nb_inner_sum_bound, 22, 1),
    "sigma_grad": (T.sigma_grad, _nb_sigma_grad, 21, 7),
    "patch_point": (T.patch_point, _nb_patch_point, 13, 10),
    "certify_region": (T.certify_region, _nb_certify_region, 26, 27),
    "in_region": (T.in_region, _nb_in_region, 26, 1),
    "climb": (T.climb, _nb_climb, 19, 5),
    "global_max": (T.global_max, _nb_global_max, 35, 7),
    "parallel_max": (T.parallel_max, _nb_parallel_max, 20, 5),
    "tilted_max": (T.tilted_max, _nb_tilted_max, 23, 5),
    "axis_bb": (T.axis_bb, _nb_axis_bb, 16, 5),
}


def assert_stage(name, inp):
    """The C++ stage and its numba twin give the same bits on every row; returns numba's rows."""
    cxx, nb, k_in, k_out = STAGES[name]
    inp = np.ascontiguousarray(inp, dtype=np.float64)
    assert inp.shape[1] == k_in, (name, inp.shape)
    n = len(inp)
    got, want = np.full((n, k_out), 7.0), np.full((n, k_out), 7.0)
    with np.errstate(all="ignore"):
        cxx(inp, got, 0, n)
        nb(inp, want, 0, n)
    assert_same_bits(got, want, name)
    return want


@numba.njit(cache=False, error_model="numpy")
def _frames(Ca, Ra, ra, Cb, Rb, rb, out):
    """Per pair, what the narrow phase hands its stages (ellipsoid_pair._pair): e (3), a (3), U (9), b (3), M (9),
    scale, S, tol_bb, err_sigma, the first run's n (3), value, converged: 36 columns."""
    for i in range(len(out)):
        (ca, R_a, r_a), (cb, R_b, r_b) = load(Ca, Ra, ra, i), load(Cb, Rb, rb, i)
        u = unit_scale(r_a, r_b)
        r_a, r_b = scaled(r_a, u), scaled(r_b, u)
        d = ((cb[0] - ca[0]) * u, (cb[1] - ca[1]) * u, (cb[2] - ca[2]) * u)
        e, a2, M, Ub = a_frame(((0.0, 0.0, 0.0), R_a, r_a), (d, R_b, r_b))
        rb2 = (r_b[0] * r_b[0], r_b[1] * r_b[1], r_b[2] * r_b[2])
        scale = max(r_a[0], r_a[1], r_a[2], r_b[0], r_b[1], r_b[2])
        n, value, run, _ = newton(bisector_seed(e, a2, Ub, rb2), e, a2, M, scale, -math.inf, FIRST_RUN_ITER)
        _, S, _, tol_bb = _deep_tolerance(e, R_a, r_a, r_b)
        tail = (scale, S, tol_bb, BB_ERR_SIGMA_ULPS * U * S) + n + (value, 1.0 if run == CONVERGED else 0.0)
        row = e + r_a + Ub + r_b + M + tail
        for k in range(36):
            out[i, k] = row[k]


def frames(a, b):
    out = np.empty((len(a), 36))
    with np.errstate(all="ignore"):
        _frames(a.centers, a.rotations, a.radii, b.centers, b.rotations, b.radii, out)
    return out


# column slices of frames()
E, A, UB, B, M, SCALE, S_, TOL, ERR, N, VALUE, CONV = (
    slice(0, 3), slice(3, 6), slice(6, 15), slice(15, 18), slice(18, 27), slice(27, 28), slice(28, 29),
    slice(29, 30), slice(30, 31), slice(31, 34), slice(34, 35), slice(35, 36),
)  # fmt: skip


def stage_pairs():
    """Frames of pairs for the stages: deep, deep elongated, thin, random and near-contact, leaves."""
    parts = [
        (random_ellipsoids(np.random.default_rng(5), 150, box=0.05, radii=(0.15, 1.0)),
         random_ellipsoids(np.random.default_rng(6), 150, box=0.05, radii=(0.15, 1.0))),
        deep_elongated(150, 9),
        thin_pairs(16, 21),
        samples.generic_pairs(100, seed=11),
        samples.near_contact_pairs(100, seed=12),
        special_pairs(),
    ]  # fmt: skip
    a = Ellipsoids.concatenate([p[0] for p in parts])
    b = Ellipsoids.concatenate([p[1] for p in parts])
    return frames(a, b)


@pytest.fixture(scope="module")
def F():
    return stage_pairs()


def unit_rows(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def test_inner_sum_bound_gives_the_numba_bits(F):
    """At the first run's maximum (the narrow phase's call), at random directions (any n: the bound holds from
    any), at sigma(n) >= 0 (inf) and at a few axes (aligned ellipsoids: the exact depth)."""
    rng = np.random.default_rng(1)
    n = len(F)
    dirs = [F[:, N], unit_rows(rng, n), np.tile(np.eye(3), (n // 3 + 1, 1))[:n]]
    rows = []
    for d in dirs:
        with np.errstate(all="ignore"):
            v = [sigma_only(tuple(x), tuple(f[E]), tuple(f[A]), tuple(f[UB]), tuple(f[B])) for x, f in zip(d, F)]
        rows.append(np.c_[d, F[:, E], F[:, A], F[:, UB], F[:, B], v])
    rows.append(np.c_[F[:, N], F[:, E], F[:, A], F[:, UB], F[:, B], np.abs(F[:, VALUE])])  # value >= 0: inf
    out = assert_stage("inner_sum_bound", np.concatenate(rows))
    assert np.isfinite(out).any() and np.isinf(out).any()


def test_sigma_grad_and_patches_give_the_numba_bits(F):
    rng = np.random.default_rng(2)
    n = len(F)
    c = unit_rows(rng, n) * rng.uniform(0.1, 3.0, (n, 1))  # any nonzero c: sigma is homogeneous
    assert_stage("sigma_grad", np.c_[c, F[:, E], F[:, A], F[:, UB], F[:, B]])
    rows = []
    for level in range(1, 31):
        m = 40 if level <= 12 else 10
        k = 1 << level
        Q = Rot.random(m, random_state=rng).as_matrix().reshape(m, 9)
        Q[: m // 4] = np.eye(3).ravel()
        ij = rng.integers(0, k, (m, 2))
        ij[0], ij[1] = (0, 0), (k - 1, k - 1)
        rows.append(np.c_[rng.integers(0, 6, m), np.full(m, level), ij, Q])
    assert_stage("patch_point", np.concatenate(rows))


@pytest.fixture(scope="module")
def certified(F):
    """certify_region at the climbs' maxima from the first run's point and from 2 random directions, and at
    unpolished random directions: the rows (compared) and numba's outputs."""
    rng = np.random.default_rng(3)
    n = len(F)
    starts = np.concatenate([F[:, N], unit_rows(rng, n), unit_rows(rng, n)])
    G = np.tile(F, (3, 1))
    climbs = assert_stage("climb", np.c_[starts, G[:, E], G[:, A], G[:, M], G[:, SCALE]])
    m = np.concatenate([climbs[:, 1:4], unit_rows(rng, n)])
    G = np.tile(F, (4, 1))
    amax, bmax = G[:, A].max(1, keepdims=True), G[:, B].max(1, keepdims=True)
    rows = np.c_[m, G[:, E], G[:, A], G[:, UB], G[:, B], amax, bmax, G[:, S_], G[:, ERR], G[:, TOL]]
    return rows, assert_stage("certify_region", rows)


def test_climb_and_certify_region_give_the_numba_bits(certified):
    rows, out = certified
    assert out[:, 0].sum() > 100 and (out[:, 0] == 0).sum() > 100  # regions certified, and refused


def test_in_region_gives_the_numba_bits(certified):
    """Caps of every size around and beyond each certified region's maximum (test_global_max's sampling)."""
    _, out = certified
    regions = out[out[:, 0] == 1.0][:, 5:27]
    rng = np.random.default_rng(4)
    rows = []
    for _ in range(12):
        m, R_out = regions[:, 0:3], regions[:, 19:20]
        rho = R_out * 10.0 ** rng.uniform(-3, 0, (len(regions), 1))
        off = unit_rows(rng, len(regions))
        c = m + off * R_out * rng.uniform(0, 1.2, (len(regions), 1))
        c /= np.linalg.norm(c, axis=1)[:, None]
        rows.append(np.c_[c, rho, regions])
    rows.append(np.c_[regions[:, 0:3], np.full(len(regions), 1.5), regions])  # rho > 1
    inside = assert_stage("in_region", np.concatenate(rows))
    assert inside.sum() > 100 and (inside == 0).sum() > 100


def global_rows(F, have, budget):
    n = len(F)
    return np.c_[F[:, N], F[:, VALUE], float(have) * F[:, CONV], F[:, E], F[:, A], F[:, UB], F[:, B],
                 F[:, M], F[:, SCALE], F[:, TOL], np.full(n, float(budget))]  # fmt: skip


def test_global_max_gives_the_numba_bits(F):
    """Seeded with the first run's maximum (the narrow phase's call) and unseeded, with the full budget and
    budgets that run out (UNPROVEN after budget + 1 nodes); SEPARATED_MAX for separated pairs."""
    deep = F[F[:, VALUE].ravel() < 0.0]
    rows = [global_rows(deep, True, BB_MAX_PATCHES), global_rows(deep[::3], False, BB_MAX_PATCHES)]
    rows += [global_rows(deep[::5], True, k) for k in (0, 1, 10, 100)]
    rows.append(global_rows(F[F[:, VALUE].ravel() > 0.0][::10], False, BB_MAX_PATCHES))
    out = assert_stage("global_max", np.concatenate(rows))
    assert {bb.GLOBAL, bb.UNPROVEN, bb.SEPARATED_MAX} <= set(out[:, 0].astype(int).tolist())


def test_global_max_on_flat_maxima_gives_the_numba_bits():
    """test_global_max's concentric spheres (sigma constant) and concentric coaxial spheroids (circles of
    maxima), with its budget of 2000 and the full one."""
    rows = []
    for ra, rb in [((0.5,) * 3, (0.3,) * 3), ((0.5, 0.5, 0.2), (0.3, 0.3, 0.7))]:
        e, I9 = (0.0, 0.0, 0.0), np.eye(3).ravel()
        Mm = (np.diag(np.array(rb) ** 2)).ravel()
        S = max(ra) + max(rb)
        tol = max(1e-12 * min(min(ra), min(rb)), 96 * U * S) - 16 * U * S
        for budget in (2000, BB_MAX_PATCHES):
            rows.append([1.0, 0.0, 0.0, -math.inf, 0.0, *e, *ra, *I9, *rb, *Mm, max(max(ra), max(rb)), tol, budget])
    assert_stage("global_max", np.array(rows))


def spheroid_frames(rng, k):
    """test_spheroids' pairs in A's frame (e, a, U, b, tol, S): parallel (every placement, spheres, elongated,
    exact signed permutations), tilted by 1e-12 .. 1.5 rad, not spheroids at all."""
    pairs = []
    for where in ("axis", "concentric", "anywhere", "deep", "near axis"):
        for b_kind in ("spheroid", "sphere", "prolate", "oblate"):
            pairs += [spheroid_pair(rng, where, b_kind=b_kind) for _ in range(k)]
            pairs += [spheroid_pair(rng, where, b_kind=b_kind, aspect_max=1000.0, turn=False) for _ in range(k // 2)]
        for tilt in (1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 1e-2, 1e-1, 0.4, 1.0, 1.5):
            pairs += [spheroid_pair(rng, where, tilt=tilt) for _ in range(k // 2)]
    rows = [[*P.e, *P.a, *P.U, *P.b, P.tol, P.S] for P in pairs]
    U9 = (0.0009933943657067068, -0.9999994499282266, -0.00033661681204483684, -0.6547255352311844,
          -0.000904838413277805, 0.7558661619517604, -0.7558660507549425, -0.0005304815640773613,
          -0.6547260739465298)  # fmt: skip
    e = (11.321365599734023, -1.4005662552673624e-08, -5.985947511310058e-09)
    a = (18.17368773339926, 0.8968984351937361, 0.8968984351937361)
    b = (0.5302268314547841, 0.3208842764971259, 0.5302268314547841)
    S = float(np.linalg.norm(e) + max(a) + max(b))
    rows.append([*e, *a, *U9, *b, max(1e-12 * 0.32, 96 * U * S) - 16 * U * S, S])  # the sharp peak
    rows.append([2.0, 0.0, 0.0, 2.0, 1.0, 1.0, *np.eye(3).ravel(), 2.0, 1.0, 1.0, 5e-14, 6.0])  # coaxial closed form
    rows.append([0.0, 0.0, 0.0, 0.5, 0.5, 0.2, *np.eye(3).ravel(), 0.3, 0.3, 0.7, 5e-14, 1.2])
    rows.append([0.1, 0.2, 0.3, 1.0, 0.5, 0.4, *np.eye(3).ravel(), 0.6, 0.3, 0.3, 5e-14, 2.0])  # not spheroids
    return np.array(rows)


def test_parallel_and_tilted_max_give_the_numba_bits(F):
    """parallel_max on test_spheroids' pairs and on the narrow phase's; tilted_max from a random incumbent, from
    parallel_max's candidate and from the first run's maximum."""
    rng = np.random.default_rng(5)
    R = spheroid_frames(rng, 4)
    R = np.concatenate([R, np.c_[F[:, E], F[:, A], F[:, UB], F[:, B], F[:, TOL], F[:, S_]]])
    par = assert_stage("parallel_max", R)
    assert par[:, 0].sum() > 50 and (par[:, 0] == 0).sum() > 50
    cand = par[:, 1:4]
    n0 = np.concatenate([unit_rows(rng, len(R)), cand])
    out = assert_stage("tilted_max", np.c_[np.tile(R, (2, 1)), n0])
    assert out[:, 0].sum() > 50 and (out[:, 0] == 0).sum() > 50
    assert_stage("tilted_max", np.c_[F[:, E], F[:, A], F[:, UB], F[:, B], F[:, TOL], F[:, S_], F[:, N]])


def test_axis_bb_gives_the_numba_bits():
    """test_spheroids' model pairs at every angle between the axes, as a cylinder (hk = 1, curv 0) too, and the
    refusals (tol1 <= 0, B's model not positive)."""
    rng = np.random.default_rng(6)
    rows = []
    for angle in (0.0, 1e-7, 0.3, 0.9, 1.5):
        for _ in range(6):
            P = model_pair(rng, angle)
            qa, pa, qb, pb = P.a[0], P.a[1], P.b[0], P.b[1]
            w = P.Um[:, 0]
            t0, p0 = rng.uniform(0, np.pi), rng.uniform(-np.pi, np.pi)
            tol1 = P.tol - 64 * U * P.S
            rows.append([*P.e, 0, qa * qa, pa * pa, qb * qb - pb * pb, pb * pb, *w, tol1, P.S, max(P.a) ** 2, t0, p0])
            rows.append([*P.e, 1, qa, pa, qb * qb - pb * pb, pb * pb, *w, tol1, P.S, 0.0, t0, p0])  # a cylinder
    base = [0.1, 0.2, 0.0, 0, 1.0, 0.25, 0.5, 0.25, 1.0, 0.0, 0.0]
    rows += [base + [0.0, 2.0, 1.0, 0.4, 0.5], base + [-1e-9, 2.0, 1.0, 0.4, 0.5]]
    bad = [0.1, 0.2, 0.0, 0, 1.0, 0.25, -0.5, 0.25, 1.0, 0.0, 0.0]
    rows.append(bad + [1e-9, 2.0, 1.0, 0.4, 0.5])
    out = assert_stage("axis_bb", np.array(rows))
    assert out[:, 0].sum() >= 40 and (out[:-3, 3] == 1).any() and (out[-3:, 4] == 0).all()


# --- the pair-level stages: pair_signed_distance(_from), contact_at, sigma_lower_bound ----------------------------


@numba.njit(cache=False, error_model="numpy")
def _nb_pair_stages(Ca, Ra, ra, Cb, Rb, rb, x, max_iter, out, lo, hi):
    """Per pair: pair_signed_distance (max_iter), pair_signed_distance_from (x), contact_at (x) and
    sigma_lower_bound (x): 9 + 9 + 7 + 1 columns."""
    sa, sb = int(Ca.shape[0] > 1), int(Cb.shape[0] > 1)
    for i in range(lo, hi):
        A, B = load(Ca, Ra, ra, i * sa), load(Cb, Rb, rb, i * sb)
        v = (x[i, 0], x[i, 1], x[i, 2])
        st1, d1, n1, p1, w1 = pair_signed_distance(A, B, max_iter)
        st2, d2, n2, p2, w2 = pair_signed_distance_from(A, B, v)
        row = (float(st1), d1, n1[0], n1[1], n1[2], p1[0], p1[1], p1[2], float(w1),
               float(st2), d2, n2[0], n2[1], n2[2], p2[0], p2[1], p2[2], float(w2))  # fmt: skip
        for j in range(18):
            out[i, j] = row[j]
        s, nrm, p = contact_at(A, B, v)
        row = (s, nrm[0], nrm[1], nrm[2], p[0], p[1], p[2], sigma_lower_bound(A, B, v))
        for j in range(8):
            out[i, 18 + j] = row[j]


def assert_pair_stages(args, x, max_iter=NEWTON_MAX_ITER):
    n = len(x)
    want = np.full((n, 26), 7.0)
    with np.errstate(all="ignore"):
        parts = (np.full((n, 9), 7.0), np.full((n, 9), 7.0), np.full((n, 7), 7.0), np.full((n, 1), 7.0))
        T.pair_signed_distance(*args, max_iter, parts[0], 0, n)
        T.pair_signed_distance_from(*args, x, parts[1], 0, n)
        T.contact_at(*args, x, parts[2], 0, n)
        T.sigma_lower_bound(*args, x, parts[3], 0, n)
        got = np.concatenate(parts, axis=1)
        _nb_pair_stages(*args, np.ascontiguousarray(x, dtype=np.float64), max_iter, want, 0, n)
    assert_same_bits(got, want, "pair stages")
    return want


def seeds(rng, n, normal):
    """The previous step's normal (the warm start), its perturbations, random directions of any length, zero,
    too short and too long ones (bisector seed instead), NaN."""
    far = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-4, 4, (n, 1))
    x = np.concatenate([normal, normal + rng.normal(size=(n, 3)) * 0.01, far])
    x[n::17] = 0.0
    x[n + 1 :: 19] = 1e-4
    x[n + 2 :: 23] = 1e4
    x[n + 3 :: 29] = np.nan
    return x


@pytest.mark.parametrize("label, make", SETS[:2] + DEEP, ids=[s[0] for s in SETS[:2] + DEEP])
def test_pair_stages_give_the_numba_bits(label, make):
    a, b = make()
    a, b = a[:300], b[:300]
    n = len(a)
    rng = np.random.default_rng(7)
    dist, normal, pos, status = distances(_distances, arrays(a, b), n)
    x = seeds(rng, n, normal)
    args = arrays(Ellipsoids.concatenate([a] * 3), Ellipsoids.concatenate([b] * 3))
    assert_pair_stages(args, x, 3 if label == "generic" else NEWTON_MAX_ITER)


def test_sigma_lower_bound_at_the_scale_limits_gives_the_numba_bits():
    """Semi-axes and offsets around WARM_SCALE_MIN and WARM_SCALE_MAX (-inf beyond them)."""
    a, b = samples.generic_pairs(60, seed=13)
    rng = np.random.default_rng(8)
    for s in (2.0**-401, 2.0**-400, 2.0**-399, 2.0**380, 2.0**398, 2.0**399, 2.0**400):
        A = Ellipsoids(a.centers * s, a.rotations, a.radii * s)
        B = Ellipsoids(b.centers * s, b.rotations, b.radii * s)
        assert_pair_stages(arrays(A, B), rng.normal(size=(60, 3)))


@settings(max_examples=120, deadline=None)
@given(st.one_of(hard_pair, random_pair()), st.tuples(*[st.one_of(finite, st.floats(-1, 1))] * 3))
def test_pair_stages_on_hard_pairs_give_the_numba_bits(pair, x):
    assert_pair_stages(arrays(*pair), np.array([x]))


@settings(max_examples=120, deadline=None)
@given(*any_pair, st.tuples(*[st.one_of(finite, st.floats(-1, 1))] * 3), st.integers(1, 50))
def test_pair_stages_on_any_floats_give_the_numba_bits(c, R, r, x, max_iter):
    assert_pair_stages(one_pair(c, R, r), np.array([x]), max_iter)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(finite, st.floats(-2, 2)), min_size=22, max_size=22))
def test_inner_sum_bound_and_sigma_grad_on_any_floats_give_the_numba_bits(r):
    """The stages that take any numbers (no loop, no budget) on arbitrary finite floats."""
    r = np.array([r])
    assert_stage("inner_sum_bound", r)
    assert_stage("sigma_grad", r[:, :21])
