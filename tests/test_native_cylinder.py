"""The C++ pairs/cylinder.hpp and shape_distance's batch kernel (issue 46) against the numba kernels, bit for bit.

cylinder: the kernel's whole result, and per pose the frame, the local solve, every certificate at the centre
line's direction and at the local maximum, the witness, deep_search (from an incumbent and from nothing),
_mirrored, axis_max, the point-cylinder distance and the centre-line bound; on test_cylinder's poses (separated,
touching, shallow, deep, flush caps and sides, inside), the coaxial spheroids that reach axis_max, the pair
benchmark's penetrating and deep poses (rim branch and bound, mirrored rims), every sample set read as
cylinders, degenerate poses, float32 rotations, hypothesis's random poses and arbitrary finite floats.  Its stages
on rows of their own arguments, as test_cylinder calls them: the rim Newton, the rim's branch and bound, the
second-order model and certificate, the split certificate, the polygon and arc bounds, the tangent-plane envelope
and the small helpers (the plane pole, Python's float %, the equator bound).

shape_distances, the drop-in for shape_distance._distances: every kind, chunked [lo, hi) calls, broadcasting, a
thread pool, and its refusals.
"""

import math
import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_native import finite, positive
from test_native_pairs import _degenerate_poses, _rotation, as_shapes, pose_args, quaternion, size

import ellipsim.native as native
from ellipsim.core import samples, threads
from ellipsim.core._jit import jit
from ellipsim.core.distance.sphere_newton import rolling_radius, tangent_basis, unit
from ellipsim.core.pairs import cylinder
from ellipsim.core.pairs.shape_distance import _distances
from ellipsim.core.tolerances import BB_TOL_ULPS, PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U
from ellipsim.core.vec3 import load, norm2

ext = native.ext
T = ext.testing

# --- the numba twins of the testing kernels (python/cylinder.cpp), column for column ----------------------------


@jit
def _cylinder_ellipsoid(Ce, Re, re, Ck, Rk, sk, out, lo, hi):
    sa, sb = int(Ce.shape[0] > 1), int(Ck.shape[0] > 1)
    for i in range(lo, hi):
        st_, d, n, p, ub = cylinder.cylinder_ellipsoid(load(Ce, Re, re, i * sa), load(Ck, Rk, sk, i * sb))
        row = (float(st_), d) + n + p + (ub,)
        for k in range(9):
            out[i, k] = row[k]


@jit
def _cylinder_stages(Ce, Re, re, Ck, Rk, sk, out, lo, hi):
    sa, sb = int(Ce.shape[0] > 1), int(Ck.shape[0] > 1)
    for i in range(lo, hi):
        E, K = load(Ce, Re, re, i * sa), load(Ck, Rk, sk, i * sb)
        e, a2, u = cylinder.to_frame(E, K)
        r, L = K[2][0], K[2][1]
        ra = E[2]
        rho = rolling_radius(ra)
        scale = math.sqrt(norm2(e)) + max(ra[0], ra[1], ra[2], r, L)
        tol = max(PAIR_CERT_REL * min(ra[0], ra[1], ra[2], r, L), 2.0 * BB_TOL_ULPS * U * scale)
        slack = PAIR_SIGMA_SLACK_ULPS * U * scale
        n, stratum, conv = cylinder.local_max(a2, e, u, L, r)
        head = e + a2 + u + n + (float(stratum), 1.0 if conv else 0.0)
        for k in range(14):
            out[i, k] = head[k]
        nc = unit(e)
        for j in range(2):  # one call site each: numba inlines a stage per call site
            m = nc if j == 0 else n
            v = cylinder.sigma_cylinder(a2, e, u, L, r, m)
            row = (
                v,
                cylinder.upper_bound1(a2, e, u, L, r, rho, m),
                cylinder.upper_bound2(a2, e, u, L, r, m, v),
                cylinder._sweep_bound(a2, e, u, L, r, m),
                cylinder._capsule_bound(a2, e, u, L, r, rho, m, v, tol, slack),
                cylinder.upper_bound(a2, e, u, L, r, rho, m, v, tol, slack),
            )
            for k in range(6):
                out[i, 14 + 6 * j + k] = row[k]
        wit = cylinder._witness(a2, e, n, cylinder.sigma_cylinder(a2, e, u, L, r, n))
        v1, m1, p1 = cylinder.deep_search(a2, e, u, L, r, cylinder.sigma_cylinder(a2, e, u, L, r, nc), nc, tol, slack)
        v2, m2, p2 = cylinder.deep_search(a2, e, u, L, r, -math.inf, (1.0, 0.0, 0.0), tol, slack)
        ok, ma, va = cylinder.axis_max(a2, e, u, L, r, tol, scale, nc)
        row = (
            wit + (v1,) + m1 + (1.0 if p1 else 0.0, v2) + m2 + (1.0 if p2 else 0.0,)
            + (1.0 if cylinder._mirrored(a2, e, u) else 0.0, 1.0 if ok else 0.0) + ma + (va,)
            + (cylinder.sd_point_cylinder(e, u, L, r), cylinder.centre_line_bound(E, K))
        )  # fmt: skip
        for k in range(21):
            out[i, 26 + k] = row[k]


@jit
def _rim_newton(x, out, lo, hi):
    for i in range(lo, hi):
        a2, e, u = (x[i, 0], x[i, 1], x[i, 2]), (x[i, 3], x[i, 4], x[i, 5]), (x[i, 6], x[i, 7], x[i, 8])
        n0 = (x[i, 12], x[i, 13], x[i, 14])
        m, v, code = cylinder._rim_newton(a2, e, u, x[i, 9], x[i, 10], x[i, 11], n0)
        row = m + (v, float(code))
        for k in range(5):
            out[i, k] = row[k]


@jit
def _rim_bb(x, out, lo, hi):
    for i in range(lo, hi):
        a2, e, u = (x[i, 0], x[i, 1], x[i, 2]), (x[i, 3], x[i, 4], x[i, 5]), (x[i, 6], x[i, 7], x[i, 8])
        bn = (x[i, 13], x[i, 14], x[i, 15])
        best, m, proven = cylinder._rim_bb(
            a2, e, u, x[i, 9], x[i, 10], x[i, 11], x[i, 12], bn, x[i, 16], x[i, 17], x[i, 18]
        )
        row = (best,) + m + (1.0 if proven else 0.0,)
        for k in range(5):
            out[i, k] = row[k]


@jit
def _cert_stages(x, out, lo, hi):
    for i in range(lo, hi):
        a2, q, su = (x[i, 0], x[i, 1], x[i, 2]), (x[i, 3], x[i, 4], x[i, 5]), (x[i, 6], x[i, 7], x[i, 8])
        r, n = x[i, 9], (x[i, 10], x[i, 11], x[i, 12])
        v0, v1 = (x[i, 13], x[i, 14], x[i, 15]), (x[i, 16], x[i, 17], x[i, 18])
        v2, v3 = (x[i, 19], x[i, 20], x[i, 21]), (x[i, 22], x[i, 23], x[i, 24])
        cm = cylinder._cert_model(a2, q, su, r, n)
        ok, (t1, t2), g, H, value, h, ss, bt, eg, eh, reach = cm
        row = (1.0 if ok else 0.0,) + t1 + t2 + g + H + (value, h, ss, bt, eg, eh, reach)
        row = row + (1.0 if cylinder._cert_region(cm, n, r, v0, v1, v2, v3, x[i, 25]) else 0.0,)
        for k in range(20):
            out[i, k] = row[k]


@jit
def _split_settles(x, out, lo, hi):
    for i in range(lo, hi):
        a2, q, p = (x[i, 0], x[i, 1], x[i, 2]), (x[i, 3], x[i, 4], x[i, 5]), (x[i, 6], x[i, 7], x[i, 8])
        su, ca, cb = (x[i, 9], x[i, 10], x[i, 11]), (x[i, 12], x[i, 13], x[i, 14]), (x[i, 15], x[i, 16], x[i, 17])
        n, r = (x[i, 18], x[i, 19], x[i, 20]), x[i, 23]
        cm = cylinder._cert_model(a2, q, su, r, n)
        ok = cylinder._split_settles(
            a2, p, su, ca, cb, x[i, 21], cm, n, x[i, 22], r, x[i, 24], x[i, 25], x[i, 26], x[i, 27]
        )
        out[i, 0] = 1.0 if ok else 0.0


@jit
def _polygon_stages(x, out, lo, hi):
    for i in range(lo, hi):
        a2, p = (x[i, 0], x[i, 1], x[i, 2]), (x[i, 3], x[i, 4], x[i, 5])
        v0, v1 = (x[i, 6], x[i, 7], x[i, 8]), (x[i, 9], x[i, 10], x[i, 11])
        v2, v3 = (x[i, 12], x[i, 13], x[i, 14]), (x[i, 15], x[i, 16], x[i, 17])
        slack, floor, stop, edge12 = x[i, 18], x[i, 19], x[i, 20], x[i, 21]
        b, m = cylinder._poly_bound(a2, p, v0, v1, v2, v3, slack, floor, stop, edge12)
        b1, m1 = cylinder._edge_max(a2, p, v0, v1, slack, floor, stop)
        b2, m2 = cylinder._edge_max(a2, p, v1, v2, slack, floor, stop)
        row = (b,) + m + (b1,) + m1 + (b2,) + m2
        for k in range(12):
            out[i, k] = row[k]


@jit
def _small_stages(x, out, lo, hi):
    for i in range(lo, hi):
        g0, gm, g2 = (x[i, 0], x[i, 1]), (x[i, 2], x[i, 3]), (x[i, 4], x[i, 5])
        cs, sn = x[i, 6], x[i, 7]
        ok, na, nb = cylinder._plane_pole(g0[0], g0[1], gm[0])
        row = (
            cylinder._envelope(g0, gm, g2, cs, sn),
            cylinder._sub_max(g0, 1.0, 0.0, cs, sn),
            cylinder._split_max(g0, gm, 1.0, 0.0, cs, sn),
            1.0 if ok else 0.0,
            na,
            nb,
            g2[0] % g2[1],
            cylinder._equator_bound(cs, sn, (g0[0], g0[1], gm[0]), (gm[1], g2[0], g2[1]), (cs, sn, g0[0]), g0[1]),
        )
        for k in range(8):
            out[i, k] = row[k]


# (C++ kernel, numba kernel, columns): pose kernels take (Ce, Re, re, Ck, Rk, sk, out, lo, hi), row kernels
# (x, out, lo, hi).
POSES = {
    "cylinder_ellipsoid": (T.cylinder_ellipsoid, _cylinder_ellipsoid, 9),
    "cylinder_stages": (T.cylinder_stages, _cylinder_stages, 47),
}
ROWS = {
    "rim_newton": (T.rim_newton, _rim_newton, 5, 15),
    "rim_bb": (T.rim_bb, _rim_bb, 5, 19),
    "cert_stages": (T.cert_stages, _cert_stages, 20, 26),
    "split_settles": (T.split_settles, _split_settles, 1, 28),
    "polygon_stages": (T.polygon_stages, _polygon_stages, 12, 22),
    "small_stages": (T.small_stages, _small_stages, 8, 8),
}
KERNELS = {**POSES, **ROWS}


def assert_same_bits(name, args, n, lo=0, hi=None):
    """The C++ and numba kernels `name` write the same bits into out[lo:hi] (and nothing elsewhere); a NaN for a
    NaN (its sign and payload are the compiler's choice).  Returns the C++ output."""
    hi = n if hi is None else hi
    cxx, nb, k = KERNELS[name][:3]
    got, want = np.full((n, k), 7.0), np.full((n, k), 7.0)
    with np.errstate(all="ignore"):
        cxx(*args, got, lo, hi)
        nb(*args, want, lo, hi)
    differ = (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))
    bad = np.argwhere(differ)
    assert not len(bad), (
        f"{name}: row {bad[0][0]} column {bad[0][1]}: {got[tuple(bad[0])]!r} in C++, {want[tuple(bad[0])]!r} in numba"
        f" ({len(bad)} differ)"
    )
    return got


def assert_poses_same(P):
    """The kernel and its stages give the numba bits on the poses P (dict cE, RE, rE, cK, RK, sK); returns the
    kernel's rows (status, dist, normal, pos, ub)."""
    args = pose_args(P)
    n = len(args[0])
    assert_same_bits("cylinder_stages", args, n)
    return assert_same_bits("cylinder_ellipsoid", args, n)


def statuses(out):
    return set(out[:, 0].astype(int).tolist())


def test_the_constants_are_cylinder_pys():
    for name, value in T.CYLINDER_CONSTANTS.items():
        assert getattr(cylinder, name) == value and type(getattr(cylinder, name)) is type(value), name


# --- the kernel and its pose stages: the cylinder tests' poses, the benchmark's, every sample set ---------------


def test_the_cylinder_tests_poses():
    """test_cylinder's seven categories (separated, touching at 0 and +-1e-9, shallow, deep, a cap or the side
    flush against a tip of E, a small cylinder inside E), with both proofs taken, and the same poses with float32
    rotations (MuJoCo Warp's: to_frame normalises an axis unit only to ~1e-7)."""
    from test_cylinder import make_poses

    P, cat, _ = make_poses(seed=0, per=60)
    out = assert_poses_same(P)
    assert {cylinder.CERTIFIED, cylinder.ENUMERATED} <= statuses(out)
    assert_poses_same(make_poses(seed=5, per=12)[0])
    P32 = {k: (v.astype(np.float32).astype(float) if k in ("RE", "RK") else v) for k, v in P.items()}
    assert_poses_same(P32)


@pytest.mark.parametrize("seed", [0, 1])
def test_coaxial_spheroids_reach_axis_max(seed):
    """test_cylinder's coaxial spheroid and cylinder (issue 18: a rim along which sigma is constant, proven by
    axis_max through spheroids' axis_bb), exactly on the axis and tilted by 1e-12 to 1e-2 rad."""
    from pair_types import coaxial_poses

    P = coaxial_poses(seed)
    out = assert_poses_same(P)
    args = pose_args(P)
    e, a2, u = (np.array(x) for x in zip(*(_frame(args, i) for i in range(len(out)))))
    tol = np.maximum(
        PAIR_CERT_REL * np.minimum(P["rE"].min(1), P["sK"][:, :2].min(1)),
        2 * BB_TOL_ULPS * U * (np.linalg.norm(e, axis=1) + np.maximum(P["rE"].max(1), P["sK"][:, :2].max(1))),
    )
    assert (out[:, 8] == out[:, 1] + tol).sum() > 10  # ub = value + tol: axis_max's proof


def _frame(args, i):
    E = (tuple(args[0][i]), tuple(args[1][i].ravel()), tuple(args[2][i]))
    K = (tuple(args[3][i]), tuple(args[4][i].ravel()), tuple(args[5][i]))
    return cylinder.to_frame(E, K)


def bench_poses(category, n, seed):
    from ellipsim.app.bench import pair_types as bench

    cE, RE, rE, cK, RK, sK = bench.poses("cylinder", category, n, np.random.default_rng(seed))
    return dict(cE=cE, RE=RE, rE=rE, cK=cK, RK=RK, sK=sK)


@pytest.mark.parametrize("category", ["separated", "touching", "penetrating", "deep"])
def test_the_pair_benchmarks_poses(category):
    """The pair benchmark's poses (ellipsim.app.bench.pair_types): its penetrating and deep ones reach the rim's
    branch and bound, its split certificate, its tangent cones, the mirrored rim and the capsule bound."""
    out = assert_poses_same(bench_poses(category, 300 if category in ("penetrating", "deep") else 100, 11))
    if category in ("penetrating", "deep"):
        assert cylinder.ENUMERATED in statuses(out)


SETS = [
    ("generic", lambda: samples.generic_pairs(400, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(400, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 60, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_every_sample_set_as_cylinders(label, make):
    """ellipsim.core.samples' pairs, the second ellipsoid read as a cylinder (radius r_0, half-length r_1): near
    tangency to 1e-15, spheres and coaxial spheroids, identical and contained bodies, aspects to 1e4 (needles and
    disks), offsets to 1e7 and scales from 1e-6 to 1e6."""
    assert_poses_same(as_shapes(*make()))


def test_degenerate_poses():
    """test_native_pairs' degenerate poses: spheres and spheroids, concentric bodies (e = 0), bodies on each other's
    axes, a needle ellipsoid through a cylinder, a cylinder inside a sphere."""
    assert_poses_same(_degenerate_poses())


def test_hand_picked_cases():
    """test_cylinder's hand-picked cap-on and side-on contacts, and a cylinder exactly along each of E's axes,
    centred on it, crossing it and touching its tip."""
    I = np.eye(3)
    Ry = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    rows = [
        ((0.0, 0.0, 0.5), I, (0.05, 0.15, 0.0)),
        ((0.0, 0.0, 0.4), Ry, (0.05, 0.2, 0.0)),
        ((0.3, 0.4, 0.2), Ry, (0.05, 0.2, 0.0)),
    ]
    for k in range(3):
        R = np.roll(I, k, axis=1)
        for c in (0.0, 0.05, 0.25, 0.45):
            for s in ((0.05, 0.15, 0.0), (0.3, 0.01, 0.0), (0.01, 0.5, 0.0)):
                rows.append((tuple(R[:, 2] * c), R, s))
    m = len(rows)
    P = dict(
        cE=np.zeros((m, 3)),
        RE=np.tile(I, (m, 1, 1)),
        rE=np.tile([0.3, 0.2, 0.1], (m, 1)),
        cK=np.array([r[0] for r in rows], float),
        RK=np.array([r[1] for r in rows], float),
        sK=np.array([r[2] for r in rows], float),
    )
    out = assert_poses_same(P)
    assert out[0, 1] == pytest.approx(0.25, abs=1e-15) and out[1, 1] == pytest.approx(0.25, abs=1e-15)


def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice():
    a, b = samples.near_contact_pairs(60, seed=8)
    P = pose_args(as_shapes(a, b))
    for name in POSES:
        assert_same_bits(name, tuple(x[:1].copy() for x in P[:3]) + P[3:], 60)
        assert_same_bits(name, P[:3] + tuple(x[5:6].copy() for x in P[3:]), 60)
        assert_same_bits(name, P, 60, 7, 41)  # rows outside [7, 41) keep their fill
    out = np.full((60, 9), 7.0)
    T.cylinder_ellipsoid(*P, out, 7, 41)
    assert np.all(out[:7] == 7.0) and np.all(out[41:] == 7.0) and not np.any(out[7:41] == 7.0)
    with pytest.raises(IndexError, match="range"):
        T.cylinder_ellipsoid(*P, out, 0, 61)
    with pytest.raises(IndexError, match="range"):
        T.cylinder_ellipsoid(*(x[:30].copy() for x in P), out, 0, 60)
    with pytest.raises(TypeError):  # a strided array is refused, never copied
        T.cylinder_ellipsoid(*P, np.empty((60, 10))[:, :9], 0, 60)
    x = np.zeros((60, 15))
    with pytest.raises(IndexError, match="range"):
        T.rim_newton(x, np.empty((60, 5)), 0, 61)
    with pytest.raises(ValueError, match="same length"):
        T.rim_newton(x, np.empty((59, 5)), 0, 59)


@settings(max_examples=300, deadline=None)
@given(
    st.tuples(*[st.floats(-1, 1)] * 3),
    quaternion,
    st.tuples(*[size] * 3),
    st.tuples(*[st.floats(-1, 1)] * 3),
    quaternion,
    st.tuples(*[size] * 3),
)
def test_random_poses_give_the_numba_bits(cE, qE, rE, cK, qK, sK):
    P = dict(cE=[cE], RE=[_rotation(qE)], rE=[rE], cK=[cK], RK=[_rotation(qK)], sK=[sK])
    assert_poses_same({k: np.array(v, float) for k, v in P.items()})


@settings(max_examples=300, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)
def test_arbitrary_finite_floats_give_the_numba_bits(c, R, r):
    """Any finite float (the Python layer validates; the kernels agree anyway): extreme exponents, subnormal
    sizes, rotations that are not rotations."""
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    assert_poses_same(dict(cE=C[0], RE=M[0], rE=S[0], cK=C[1], RK=M[1], sK=S[1]))


# --- the stages on rows: as test_cylinder calls them -----------------------------------------------------------


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _quad(rng, centre, size):
    """test_cylinder's random convex spherical quadrilateral about the unit centre (corners in angular order)."""
    t1 = _unit(np.cross(centre, rng.normal(size=3)))
    t2 = np.cross(centre, t1)
    ang = np.sort(rng.uniform(0, 2 * np.pi, 4))
    return _unit(centre + size * (np.cos(ang)[:, None] * t1 + np.sin(ang)[:, None] * t2))


def _random_rim(rng):
    """test_cylinder's random ellipsoid and rim: (a2, e, u, L, r, n0)."""
    a2 = rng.uniform(0.02, 0.3, 3) ** 2
    u = _unit(rng.normal(size=3))
    L, r = rng.uniform(0.01, 0.3), rng.uniform(0.01, 0.15)
    e = rng.normal(size=3) * 0.1
    n0 = _unit(u + rng.normal(size=3))
    return a2, e, u, L, r, n0


def rows_of(*cols):
    return np.ascontiguousarray(np.concatenate([np.atleast_2d(np.asarray(c, float)).reshape(len(cols[0]), -1)
                                                for c in cols], 1))  # fmt: skip


def _rim_newton_rows(seed, m=400):
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(m):
        a2, e, u, L, r, n0 = _random_rim(rng)
        sg = 1.0 if k % 2 else -1.0
        if k % 5 == 0:
            n0 = _unit(rng.normal(size=3))  # anywhere, the other hemisphere too
        elif k % 5 == 1:
            n0 = _unit(sg * u + 1e-9 * rng.normal(size=3))  # at the cap
        rows.append(np.concatenate([a2, e, u, [L, r, sg], n0]))
    return np.array(rows)


def test_rim_newton():
    """The rim Newton from test_cylinder's random rims and starts, at the cap and anywhere: CONVERGED, AT_CAP and
    STALLED all reached."""
    x = _rim_newton_rows(0)
    out = assert_same_bits("rim_newton", (x,), len(x))
    assert {cylinder.CONVERGED, cylinder.AT_CAP} <= set(out[:, 4].astype(int).tolist())


def _poses_frames(P):
    args = pose_args(P)
    return [tuple(np.array(x) for x in _frame(args, i)) for i in range(len(args[0]))]


def test_rim_branch_and_bound():
    """_rim_bb on the benchmark's penetrating and deep poses, both rims, from the local solve's incumbent at the
    kernel's tolerance, at a hundredth of it (budgets run out: UNPROVEN) and from nothing (-inf)."""
    rows = []
    for category in ("penetrating", "deep"):
        P = bench_poses(category, 60, 3)
        for i, (e, a2, u) in enumerate(_poses_frames(P)):
            r, L = P["sK"][i, 0], P["sK"][i, 1]
            ra = P["rE"][i]
            scale = np.linalg.norm(e) + max(ra.max(), r, L)
            tol = max(PAIR_CERT_REL * min(ra.min(), r, L), 2 * BB_TOL_ULPS * U * scale)
            slack = PAIR_SIGMA_SLACK_ULPS * U * scale
            n, _, _ = cylinder.local_max(tuple(a2), tuple(e), tuple(u), L, r)
            best = cylinder.sigma_cylinder(tuple(a2), tuple(e), tuple(u), L, r, n)
            w1, w2 = tangent_basis(tuple(u))
            _, side_ub = cylinder.circle_max_bound(tuple(a2), tuple(e), w1, w2)
            for sg in (1.0, -1.0):
                for b, t in ((best, tol), (best, 0.01 * tol), (-np.inf, tol)):
                    rows.append(np.concatenate([a2, e, u, [L, r, sg, b], n, [t, slack, side_ub - r]]))
    x = np.array(rows)
    out = assert_same_bits("rim_bb", (x,), len(x))
    assert 0 < out[:, 4].sum() < len(x)  # proven and not


def test_second_order_certificate():
    """_cert_model and _cert_region as test_cylinder checks them: at rim maxima found by Newton (and random
    directions), on quadrilaterals of four sizes about them, at three rooms; both answers taken."""
    rng = np.random.default_rng(1)
    rows = []
    for _ in range(80):
        a2, e, u, L, r, n0 = _random_rim(rng)
        q = e - L * u
        m, _, code = cylinder._rim_newton(tuple(a2), tuple(e), tuple(u), L, r, 1.0, tuple(n0))
        if code == cylinder.CONVERGED and rng.random() < 0.8:
            n0 = np.asarray(m)
        for radius in (1e-3, 1e-2, 0.05, 0.2):
            V = _quad(rng, n0, radius)
            for room in (1e-13, 1e-6, 1e-3):
                rows.append(np.concatenate([a2, q, u, [r], n0, V.ravel(), [room]]))
    x = np.array(rows)
    out = assert_same_bits("cert_stages", (x,), len(x))
    assert 0 < out[:, 19].sum() < len(x) and out[:, 0].all()


def test_split_certificate():
    """_split_settles as _rim_bb calls it on lunes about rim maxima (test_cylinder's construction: lunes of three
    widths within the reach, floors just above and below the maximum, with and without the equator's bound)."""
    rng = np.random.default_rng(2)
    rows = []
    for _ in range(120):
        a2, e, u, L, r, n0 = _random_rim(rng)
        q = e - L * u
        m, _, code = cylinder._rim_newton(tuple(a2), tuple(e), tuple(u), L, r, 1.0, tuple(n0))
        if code != cylinder.CONVERGED:
            continue
        n0 = np.asarray(m)
        cm = cylinder._cert_model(tuple(a2), tuple(q), tuple(u), r, tuple(n0))
        w1, w2 = (np.asarray(w) for w in tangent_basis(tuple(u)))
        phi = np.arctan2(n0 @ w2, n0 @ w1)
        theta = np.arctan2(np.linalg.norm(np.cross(n0, u)), n0 @ u)
        scale = np.linalg.norm(q) + np.sqrt(a2.max()) + r
        slack = 64 * U * scale
        reach = cylinder.SPLIT_REACH * cm[10]
        if not reach > 0.0:
            continue
        for width in (0.3, 0.05, 0.01) * np.asarray(reach / max(cm[6], 1e-9)):
            a = phi - rng.uniform(0.0, 1.0) * width
            ca, cb = (np.cos(t) * w1 + np.sin(t) * w2 for t in (a, a + width))
            p = q - r * (np.cos(phi) * w1 + np.sin(phi) * w2)
            for tl in (1e-13, 1e-6, -1e-9):
                floor = cm[4] + tl * scale
                room = floor - cm[4] - slack
                for equator in (np.inf, floor - scale, floor + scale):
                    rows.append(
                        np.concatenate([a2, q, p, u, ca, cb, n0, [reach, theta, r, room, floor, slack, equator]])
                    )
    x = np.array(rows)
    out = assert_same_bits("split_settles", (x,), len(x))
    assert 0 < out[:, 0].sum() < len(x)


def test_polygon_and_arc_bounds():
    """_poly_bound and _edge_max on test_cylinder's quadrilaterals and triangles and on rim lunes (pole, two
    equator points: the shape _rim_bb gives it), with no level and asked about levels around the maximum, with
    and without an edge12 bound."""
    rng = np.random.default_rng(3)
    rows = []
    for k in range(150):
        a2 = rng.uniform(0.02, 0.3, 3) ** 2
        p = rng.normal(size=3) * rng.choice([0.05, 0.3])
        if k % 3 == 2:  # a lune: pole, two points of its equator
            su = _unit(rng.normal(size=3))
            w1 = _unit(np.cross(su, rng.normal(size=3)))
            w2 = np.cross(su, w1)
            a, width = rng.uniform(0, 2 * np.pi), rng.choice([1e-6, 1e-3, 0.3, np.pi / 3])
            V = np.array([su, np.cos(a) * w1 + np.sin(a) * w2, np.cos(a + width) * w1 + np.sin(a + width) * w2, su])
        else:
            V = _quad(rng, _unit(rng.normal(size=3)), rng.choice([0.05, 0.3, 1.0]))
            if k % 3 == 1:
                V[3] = V[0]  # a triangle
        exact, _ = cylinder._poly_bound(tuple(a2), tuple(p), *map(tuple, V), 0.0, -np.inf, np.inf, np.inf)
        scale = np.linalg.norm(p) + np.sqrt(a2.max())
        for level in (-np.inf, exact - 0.3 * scale, exact - 1e-9 * scale, exact + 1e-9 * scale):
            stop = np.inf if level == -np.inf else level
            for edge12 in (np.inf, exact - scale):
                rows.append(np.concatenate([a2, p, V.ravel(), [64 * U * scale, level, stop, edge12]]))
    x = np.array(rows)
    assert_same_bits("polygon_stages", (x,), len(x))


def test_envelope_and_small_helpers():
    """_envelope, _sub_max, _split_max on test_cylinder's arcs (1e-3 rad to a half circle), _plane_pole, Python's
    float % (negative, zero, signed zero and huge dividends and divisors) and _equator_bound, on random rows."""
    rng = np.random.default_rng(4)
    m = 3000
    x = rng.normal(size=(m, 8)) * rng.choice([1e-3, 1.0, 1e3], (m, 8))
    span = rng.choice([1e-3, 0.1, 1.0, np.pi / 2, 2.5, np.pi], m)
    x[: m // 2, 6], x[: m // 2, 7] = np.cos(span[: m // 2]), np.sin(span[: m // 2])
    x[::7, 4] = rng.choice([0.0, -0.0, 2 * np.pi, -2 * np.pi, 4 * np.pi, 1e300, -1e-300], len(x[::7]))
    x[::5, 5] = rng.choice([2 * np.pi, -2 * np.pi, 1e-300, 0.0], len(x[::5]))
    assert_same_bits("small_stages", (np.ascontiguousarray(x),), m)


@pytest.mark.parametrize("name", sorted(ROWS))
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_stages_on_arbitrary_floats(name, data):
    """Any finite floats (signed zeros among them) in every column of a stage's row."""
    k = ROWS[name][3]
    x = data.draw(st.lists(st.one_of(finite, st.floats(-1, 1), st.sampled_from([0.0, -0.0])), min_size=k, max_size=k))
    assert_same_bits(name, (np.array([x]),), 1)


# --- shape_distances: the drop-in for shape_distance._distances -------------------------------------------------

KIND_CODES = {"capsule": 0, "box": 1, "cylinder": 2}


def shape_distances(kernel, args, code, n, lo=0, hi=None):
    out = (np.full(n, 7.0), np.full((n, 3), 7.0), np.full((n, 3), 7.0), np.full(n, 7, np.int8))
    kernel(*args, code, *out, lo, n if hi is None else hi)
    return out


def assert_drop_in_same(args, code, n, lo=0, hi=None):
    got = shape_distances(ext.shape_distances, args, code, n, lo, hi)
    want = shape_distances(_distances, args, code, n, lo, hi)
    for g, w, what in zip(got, want, ("dist", "normal", "pos", "status")):
        differ = (
            g != w if g.dtype != np.float64 else (g.view(np.int64) != w.view(np.int64)) & ~(np.isnan(g) & np.isnan(w))
        )
        bad = np.argwhere(differ)
        assert not len(bad), (
            f"shape_distances {what} at {tuple(bad[0])}: {g[tuple(bad[0])]!r}, numba {w[tuple(bad[0])]!r}"
        )
    return want


def pose_arrays(P):
    return tuple(np.array(P[k], dtype=float) for k in ("cE", "RE", "rE", "cK", "RK", "sK"))


@pytest.mark.parametrize("kind", sorted(KIND_CODES))
def test_shape_distances_gives_the_numba_bits_for_every_kind(kind):
    """Every kind on test_cylinder's poses (read as capsules and boxes too), the benchmark's deep poses, a sample
    set's pairs and the degenerate poses; statuses 0 and, for a non-finite result, 1."""
    from test_cylinder import make_poses

    for P in (make_poses(seed=0, per=30)[0], bench_poses("deep", 100, 5), as_shapes(*samples.generic_pairs(300, seed=6)),
              _degenerate_poses()):  # fmt: skip
        args = pose_arrays(P)
        assert_drop_in_same(args, KIND_CODES[kind], len(args[0]))


def test_shape_distances_status_flags_unproven_and_non_finite_results():
    """status 1 where the kernel's result is not finite (sizes and offsets beyond float64's squares) or a
    cylinder's rim is UNPROVEN, as numba's; 0 elsewhere."""
    big = dict(cE=[[0.0, 0.0, 0.0]] * 2, RE=[np.eye(3)] * 2, rE=[[1e300, 1e300, 1e300], [0.3, 0.2, 0.1]],
               cK=[[1e300, 0.0, 0.0], [0.0, 0.0, 0.5]], RK=[np.eye(3)] * 2, sK=[[0.05, 0.15, 0.0]] * 2)  # fmt: skip
    args = pose_arrays(big)
    for code in KIND_CODES.values():
        dist, _, _, status = assert_drop_in_same(args, code, 2)
        assert status[0] == 1 and status[1] == 0
    a, b = samples.stress_pairs("identical and contained", 2000, seed=5)
    pick = [228, 427, 0]  # two cylinders whose rim's branch and bound runs out of budget, and one proven
    args = pose_arrays({k: v[pick] for k, v in as_shapes(a, b).items()})
    out = assert_same_bits("cylinder_ellipsoid", args, 3)
    assert out[:, 0].tolist() == [cylinder.UNPROVEN, cylinder.UNPROVEN, cylinder.CERTIFIED]
    assert_same_bits("cylinder_stages", args, 3)
    dist, _, _, status = assert_drop_in_same(args, KIND_CODES["cylinder"], 3)
    assert np.isfinite(dist).all() and status.tolist() == [1, 1, 0]


def test_shape_distances_in_chunks_broadcast_and_on_threads():
    """Chunked [lo, hi) calls write only their slice and together give the whole call's bits; a batch of one on
    either side broadcasts; threads.run cuts a large batch into chunks on its pool (as shape_distance would)."""
    a, b = samples.near_contact_pairs(200, seed=9)
    args = pose_arrays(as_shapes(a, b))
    n = len(args[0])
    for code in KIND_CODES.values():
        whole = assert_drop_in_same(args, code, n)
        assert_drop_in_same(tuple(x[:1].copy() for x in args[:3]) + args[3:], code, n)
        assert_drop_in_same(args[:3] + tuple(x[4:5].copy() for x in args[3:]), code, n)
        out = shape_distances(ext.shape_distances, args, code, n, 17, 131)
        assert np.all(out[0][:17] == 7.0) and np.all(out[0][131:] == 7.0) and np.all(out[3][131:] == 7)
        chunked = tuple(np.full_like(x, 7) for x in whole)
        cuts = [0, 1, 1, 50, 51, 120, n]
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            ext.shape_distances(*args, code, *chunked, lo, hi)
        for x, y in zip(chunked, whole):
            np.testing.assert_array_equal(x.view(np.uint8), y.view(np.uint8))
    c, d = samples.generic_pairs(4200, seed=10)
    args = pose_arrays(as_shapes(c, d))
    n = len(args[0])
    serial = shape_distances(_distances, args, 2, n)
    chunked = tuple(np.empty_like(x) for x in serial)
    with threads.limit(2):
        threads.run(ext.shape_distances, n, True, *args, 2, *chunked)
    for x, y in zip(chunked, serial):
        np.testing.assert_array_equal(x.view(np.uint8), y.view(np.uint8))
    outs = [tuple(np.empty_like(x) for x in serial) for _ in range(3)]
    workers = [threading.Thread(target=ext.shape_distances, args=(*args, 2, *o, 0, n)) for o in outs]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    for o in outs:
        for x, y in zip(o, serial):
            np.testing.assert_array_equal(x.view(np.uint8), y.view(np.uint8))


def test_shape_distances_refuses_bad_ranges_arrays_and_kinds():
    a, b = samples.generic_pairs(10, seed=1)
    args = pose_arrays(as_shapes(a, b))
    out = (np.empty(10), np.empty((10, 3)), np.empty((10, 3)), np.empty(10, np.int8))
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.shape_distances(*args, 2, *out, 0, 11)
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.shape_distances(*args, 2, *out, 5, 4)
    with pytest.raises(IndexError, match="pair range outside the output"):
        ext.shape_distances(*args, 2, *out, -1, 4)
    with pytest.raises(IndexError, match="pair range outside the batches"):
        ext.shape_distances(*(x[:5].copy() for x in args[:3]), *args[3:], 2, *out, 0, 10)
    with pytest.raises(ValueError, match="same length"):
        ext.shape_distances(*args, 2, out[0], out[1][:9], out[2], out[3], 0, 9)
    with pytest.raises(ValueError, match="same length"):
        ext.shape_distances(*args, 2, *out[:3], out[3][:9], 0, 9)
    with pytest.raises(ValueError, match="kind"):
        ext.shape_distances(*args, 3, *out, 0, 10)
    with pytest.raises(ValueError, match="same length"):  # rotations of another length than their centres
        ext.shape_distances(args[0], args[1][:9].copy(), *args[2:], 2, *out, 0, 10)
    with pytest.raises(TypeError):  # a strided output is refused, never copied
        ext.shape_distances(*args, 2, np.empty(20)[::2], *out[1:], 0, 10)
    with pytest.raises(TypeError):  # a status array of another dtype is refused
        ext.shape_distances(*args, 2, *out[:3], np.empty(10, np.int32), 0, 10)
    with pytest.raises(TypeError):  # float32 poses are refused, never converted
        ext.shape_distances(args[0].astype(np.float32), *args[1:], 2, *out, 0, 10)
    with pytest.raises(TypeError):  # a (n, 4) array of sizes
        ext.shape_distances(*args[:5], np.empty((10, 4)), 2, *out, 0, 10)
