"""The C++ pairs/cylinder.hpp and shape_distance's batch kernel (issue 46): outputs in range, bounds on the right
side, the same bits twice, broadcasting, ranges, threads and refusals.

cylinder (ext.testing.cylinder_ellipsoid and cylinder_stages): on test_cylinder's poses (separated, touching,
shallow, deep, flush caps and sides, inside), the coaxial spheroids that reach axis_max, the pair benchmark's poses
(rim branch and bound, mirrored rims), every sample set read as cylinders, degenerate poses, float32 rotations and
hypothesis's random poses: a status CERTIFIED, ENUMERATED or UNPROVEN, a finite distance, normal and point, a unit
normal, the bound ub above the distance and the centre-line bound and sigma at the stages' directions below it, the
distance equal to an independent numpy sigma at the kernel's normal (test_cylinder.ref_sigma); on arbitrary finite
floats: the same bits twice, no failure.  Its stages on rows of their own arguments, as test_cylinder calls them
(the rim Newton, the rim's branch and bound, the second-order model and certificate, the split certificate, the
polygon and arc bounds, the tangent-plane envelope and the small helpers): codes and flags in range, both answers
reached, Python's float % for py_mod, the same bits twice.  (Against dense references: tests/test_cylinder.py.)

shape_distances, the drop-in for shape_distance._distances: every kind is its testing kernel's row (status 1
exactly where the kernel is UNPROVEN or not finite), chunked [lo, hi) calls, broadcasting, a thread pool, and its
refusals.
"""

import math
import threading
import types

import numpy as np
import pytest
import test_cylinder as tc  # its stage adapters (tuples in, cylinder.py's results out)
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import as_shapes, assert_same_bits, finite, pose_args, positive, quaternion, rotation, size
from test_native_pairs import _degenerate_poses

import ellipsim.native as native
from ellipsim.core import samples, threads
from ellipsim.core.tolerances import BB_TOL_ULPS, PAIR_CERT_REL, PAIR_SIGMA_SLACK_ULPS, U

ext = native.ext
T = ext.testing
cylinder = types.SimpleNamespace(**T.CYLINDER_CONSTANTS)

# (kernel, columns, input columns): pose kernels take (Ce, Re, re, Ck, Rk, sk, out, lo, hi), row kernels
# (x, out, lo, hi).
POSES = {
    "cylinder_ellipsoid": (T.cylinder_ellipsoid, 9),
    "cylinder_stages": (T.cylinder_stages, 47),
}
ROWS = {
    "rim_newton": (T.rim_newton, 5, 15),
    "rim_bb": (T.rim_bb, 5, 19),
    "cert_stages": (T.cert_stages, 20, 26),
    "split_settles": (T.split_settles, 1, 28),
    "polygon_stages": (T.polygon_stages, 12, 22),
    "small_stages": (T.small_stages, 8, 8),
}
KERNELS = {**POSES, **ROWS}


def run(name, args, n, lo=0, hi=None):
    """Kernel `name` into rows [lo, hi) of an output of n rows filled with 7."""
    kernel, k = KERNELS[name][:2]
    out = np.full((n, k), 7.0)
    with np.errstate(all="ignore"):
        kernel(*args, out, lo, n if hi is None else hi)
    return out


def twice(name, args, n, lo=0, hi=None):
    """Kernel `name` run twice: the same bits; returns the output."""
    out = run(name, args, n, lo, hi)
    assert_same_bits(run(name, args, n, lo, hi), out, name)
    return out


def assert_poses_sane(P, unit=1e-14, reference=False):
    """The kernel and its stages on the poses P (dict cE, RE, rE, cK, RK, sK): a status CERTIFIED, ENUMERATED or
    UNPROVEN, finite distance, normal and point, a unit normal (to `unit`), ub at or above the distance; the
    centre-line bound and sigma at the centre line's direction and at the local maximum at or below it, the local
    solve's stratum and flags in range; the same bits twice; with `reference`, the distance test_cylinder's numpy
    sigma at the kernel's normal.  Returns the kernel's rows (status, dist, normal, pos, ub)."""
    args = pose_args(P)
    n = len(args[0])
    out, stages = twice("cylinder_ellipsoid", args, n), twice("cylinder_stages", args, n)
    status, dist = out[:, 0], out[:, 1]
    assert set(status.tolist()) <= {cylinder.CERTIFIED, cylinder.ENUMERATED, cylinder.UNPROVEN}
    assert np.isfinite(out[:, 1:8]).all()
    assert np.abs(np.linalg.norm(out[:, 2:5], axis=1) - 1.0).max() < unit
    scale = np.linalg.norm(args[3] - args[0], axis=1) + np.maximum(args[2].max(1), args[5][:, :2].max(1))
    eps = 1e-13 * scale
    assert np.all(out[:, 8] >= dist - eps)
    for col in (46, 14, 20):  # centre_line_bound, sigma at unit(e), sigma at local_max's n
        assert np.all(stages[:, col] <= dist + eps), col
    assert set(stages[:, 12].tolist()) <= {
        cylinder.SIDE,
        cylinder.CAP_P,
        cylinder.CAP_M,
        cylinder.RIM_P,
        cylinder.RIM_M,
    }
    for col in (13, 33, 38, 39, 40):  # converged, deep_search's proven (twice), mirrored, axis_max's ok
        assert set(stages[:, col].tolist()) <= {0.0, 1.0}, col
    if reference:
        from test_cylinder import ref_sigma

        at_ours = ref_sigma(P, out[:, None, 2:5])[:, 0]
        np.testing.assert_allclose(at_ours, dist, rtol=0, atol=1e-14 * scale.max())
    return out


def statuses(out):
    return set(out[:, 0].astype(int).tolist())


# --- the kernel and its pose stages: the cylinder tests' poses, the benchmark's, every sample set ---------------


def test_the_cylinder_tests_poses():
    """test_cylinder's seven categories (separated, touching at 0 and +-1e-9, shallow, deep, a cap or the side
    flush against a tip of E, a small cylinder inside E), with both proofs taken, and the same poses with float32
    rotations (MuJoCo Warp's: to_frame normalises an axis unit only to ~1e-7)."""
    from test_cylinder import make_poses

    P, cat, _ = make_poses(seed=0, per=60)
    out = assert_poses_sane(P, reference=True)
    assert {cylinder.CERTIFIED, cylinder.ENUMERATED} <= statuses(out)
    assert_poses_sane(make_poses(seed=5, per=12)[0], reference=True)
    P32 = {k: (v.astype(np.float32).astype(float) if k in ("RE", "RK") else v) for k, v in P.items()}
    assert_poses_sane(P32, unit=1e-6)


@pytest.mark.parametrize("seed", [0, 1])
def test_coaxial_spheroids_reach_axis_max(seed):
    """test_cylinder's coaxial spheroid and cylinder (issue 18: a rim along which sigma is constant, proven by
    axis_max through spheroids' axis_bb), exactly on the axis and tilted by 1e-12 to 1e-2 rad."""
    from pair_types import coaxial_poses

    P = coaxial_poses(seed)
    out = assert_poses_sane(P)
    e = run("cylinder_stages", pose_args(P), len(out))[:, 0:3]  # to_frame's e
    tol = np.maximum(
        PAIR_CERT_REL * np.minimum(P["rE"].min(1), P["sK"][:, :2].min(1)),
        2 * BB_TOL_ULPS * U * (np.linalg.norm(e, axis=1) + np.maximum(P["rE"].max(1), P["sK"][:, :2].max(1))),
    )
    assert (out[:, 8] == out[:, 1] + tol).sum() > 10  # ub = value + tol: axis_max's proof
    assert cylinder.UNPROVEN not in statuses(out)


def bench_poses(category, n, seed):
    from ellipsim.app.bench import pair_types as bench

    cE, RE, rE, cK, RK, sK = bench.poses("cylinder", category, n, np.random.default_rng(seed))
    return dict(cE=cE, RE=RE, rE=rE, cK=cK, RK=RK, sK=sK)


@pytest.mark.parametrize("category", ["separated", "touching", "penetrating", "deep"])
def test_the_pair_benchmarks_poses(category):
    """The pair benchmark's poses (ellipsim.app.bench.pair_types): its penetrating and deep ones reach the rim's
    branch and bound, its split certificate, its tangent cones, the mirrored rim and the capsule bound."""
    P = bench_poses(category, 300 if category in ("penetrating", "deep") else 100, 11)
    out = assert_poses_sane(P, reference=True)
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
    assert_poses_sane(as_shapes(*make()))


def test_degenerate_poses():
    """test_native_pairs' degenerate poses: spheres and spheroids, concentric bodies (e = 0), bodies on each other's
    axes, a needle ellipsoid through a cylinder, a cylinder inside a sphere."""
    assert_poses_sane(_degenerate_poses())


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
    out = assert_poses_sane(P, reference=True)
    assert out[0, 1] == pytest.approx(0.25, abs=1e-15) and out[1, 1] == pytest.approx(0.25, abs=1e-15)


def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice():
    a, b = samples.near_contact_pairs(60, seed=8)
    P = pose_args(as_shapes(a, b))
    for name in POSES:
        full = run(name, P, 60)
        once = tuple(x[:1].copy() for x in P[:3]) + P[3:]
        assert_same_bits(run(name, once, 60), run(name, tuple(x[[0] * 60] for x in P[:3]) + P[3:], 60), name)
        once = P[:3] + tuple(x[5:6].copy() for x in P[3:])
        assert_same_bits(run(name, once, 60), run(name, P[:3] + tuple(x[[5] * 60] for x in P[3:]), 60), name)
        out = run(name, P, 60, 7, 41)  # rows outside [7, 41) keep their fill
        assert np.all(out[:7] == 7.0) and np.all(out[41:] == 7.0)
        assert_same_bits(out[7:41], full[7:41], name)
    x = np.abs(np.random.default_rng(1).normal(size=(60, 28)))
    for name, (_, _, k) in ROWS.items():
        rows = (np.ascontiguousarray(x[:, :k]),)
        out = run(name, rows, 60, 7, 41)
        assert np.all(out[:7] == 7.0) and np.all(out[41:] == 7.0)
        assert_same_bits(out[7:41], run(name, rows, 60)[7:41], name)
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
def test_random_poses_give_sane_results(cE, qE, rE, cK, qK, sK):
    P = dict(cE=[cE], RE=[rotation(qE)], rE=[rE], cK=[cK], RK=[rotation(qK)], sK=[sK])
    assert_poses_sane({k: np.array(v, float) for k, v in P.items()})


@settings(max_examples=300, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)
def test_arbitrary_finite_floats_give_the_same_bits_twice(c, R, r):
    """Any finite float (the Python layer validates; the kernels must not fail): extreme exponents, subnormal
    sizes, rotations that are not rotations."""
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    args = (C[0], M[0], S[0], C[1], M[1], S[1])
    for name in POSES:
        twice(name, args, 1)


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
    out = twice("rim_newton", (x,), len(x))
    codes = out[:, 4].astype(int)
    assert (
        {cylinder.CONVERGED, cylinder.AT_CAP}
        <= set(codes.tolist())
        <= {
            cylinder.CONVERGED,
            cylinder.AT_CAP,
            cylinder.STALLED,
        }
    )
    converged = codes == cylinder.CONVERGED
    assert np.abs(np.linalg.norm(out[converged, :3], axis=1) - 1.0).max() < 1e-14  # a unit maximiser


def _poses_frames(P):
    """to_frame's (e, a2, u) of each pose (cylinder_stages' first columns)."""
    out = run("cylinder_stages", pose_args(P), len(P["cE"]))
    return [(row[0:3], row[3:6], row[6:9]) for row in out]


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
            n = tc._row(T.cylinder_local_max, (a2, e, u, L, r), 5)[:3]
            best = tc.sigma_cylinder(a2, e, u, L, r, n)
            w1, w2 = tc.tangent_basis(u)
            _, side_ub = tc.circle_max_bound(a2, e, w1, w2)
            for sg in (1.0, -1.0):
                for b, t in ((best, tol), (best, 0.01 * tol), (-np.inf, tol)):
                    rows.append(np.concatenate([a2, e, u, [L, r, sg, b], n, [t, slack, side_ub - r]]))
    x = np.array(rows)
    out = twice("rim_bb", (x,), len(x))
    assert set(out[:, 4].tolist()) == {0.0, 1.0}  # proven and not
    assert np.all(out[:, 0] >= x[:, 12])  # never below the incumbent it starts from


def test_second_order_certificate():
    """_cert_model and _cert_region as test_cylinder checks them: at rim maxima found by Newton (and random
    directions), on quadrilaterals of four sizes about them, at three rooms; both answers taken."""
    rng = np.random.default_rng(1)
    rows = []
    for _ in range(80):
        a2, e, u, L, r, n0 = _random_rim(rng)
        q = e - L * u
        m, _, code = tc._rim_newton(a2, e, u, L, r, 1.0, n0)
        if code == cylinder.CONVERGED and rng.random() < 0.8:
            n0 = np.asarray(m)
        for radius in (1e-3, 1e-2, 0.05, 0.2):
            V = _quad(rng, n0, radius)
            for room in (1e-13, 1e-6, 1e-3):
                rows.append(np.concatenate([a2, q, u, [r], n0, V.ravel(), [room]]))
    x = np.array(rows)
    out = twice("cert_stages", (x,), len(x))
    assert set(out[:, 19].tolist()) == {0.0, 1.0} and out[:, 0].all()


def test_split_certificate():
    """_split_settles as _rim_bb calls it on lunes about rim maxima (test_cylinder's construction: lunes of three
    widths within the reach, floors just above and below the maximum, with and without the equator's bound)."""
    rng = np.random.default_rng(2)
    rows = []
    for _ in range(120):
        a2, e, u, L, r, n0 = _random_rim(rng)
        q = e - L * u
        m, _, code = tc._rim_newton(a2, e, u, L, r, 1.0, n0)
        if code != cylinder.CONVERGED:
            continue
        n0 = np.asarray(m)
        cm = tc._cert_model(a2, q, u, r, n0)
        w1, w2 = (np.asarray(w) for w in tc.tangent_basis(u))
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
    out = twice("split_settles", (x,), len(x))
    assert set(out[:, 0].tolist()) == {0.0, 1.0}


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
        exact, _ = tc._poly_bound(a2, p, *V, 0.0, -np.inf, np.inf, np.inf)
        scale = np.linalg.norm(p) + np.sqrt(a2.max())
        for level in (-np.inf, exact - 0.3 * scale, exact - 1e-9 * scale, exact + 1e-9 * scale):
            stop = np.inf if level == -np.inf else level
            for edge12 in (np.inf, exact - scale):
                rows.append(np.concatenate([a2, p, V.ravel(), [64 * U * scale, level, stop, edge12]]))
    x = np.array(rows)
    out = twice("polygon_stages", (x,), len(x))
    free = x[:, 19] == -np.inf  # no level: the polygon's maximum, at or above its edges' (v0 v1, v1 v2)
    scale = np.linalg.norm(x[:, 3:6], axis=1) + np.sqrt(x[:, :3].max(1))
    assert free.sum() == 300  # (with and without edge12)
    assert np.all(out[free, 0] >= np.maximum(out[free, 4], out[free, 8]) - 1e-13 * scale[free])


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
    out = twice("small_stages", (np.ascontiguousarray(x),), m)
    assert set(out[:, 3].tolist()) <= {0.0, 1.0}  # plane_pole's ok
    assert_same_bits(out[:, 6], np.array([_py_mod(a, b) for a, b in x[:, 4:6]]), "py_mod")


def _py_mod(a, b):
    """Python's float %, NaN for a zero divisor (where Python raises)."""
    return a % b if b != 0.0 else math.nan


@pytest.mark.parametrize("name", sorted(ROWS))
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_stages_on_arbitrary_floats(name, data):
    """Any finite floats (signed zeros among them) in every column of a stage's row."""
    k = ROWS[name][2]
    x = data.draw(st.lists(st.one_of(finite, st.floats(-1, 1), st.sampled_from([0.0, -0.0])), min_size=k, max_size=k))
    twice(name, (np.array([x]),), 1)


# --- shape_distances: the drop-in for shape_distance._distances -------------------------------------------------

KIND_CODES = {"capsule": 0, "box": 1, "cylinder": 2}


def shape_distances(args, code, n, lo=0, hi=None):
    out = (np.full(n, 7.0), np.full((n, 3), 7.0), np.full((n, 3), 7.0), np.full(n, 7, np.int8))
    ext.shape_distances(*args, code, *out, lo, n if hi is None else hi)
    return out


def assert_same_outputs(got, want, what="shape_distances"):
    for g, w, name in zip(got, want, ("dist", "normal", "pos", "status")):
        assert_same_bits(np.atleast_2d(g.astype(np.float64)), np.atleast_2d(w.astype(np.float64)), f"{what} {name}")


def assert_drop_in_is_the_kernel(args, code, n):
    """shape_distances of kind `code` is its testing kernel's (capsule_ellipsoid, box_ellipsoid,
    cylinder_ellipsoid) distance, normal and point, status 1 exactly where the kernel's distance is not finite or a
    cylinder's is UNPROVEN, 0 elsewhere; returns shape_distances' outputs."""
    got = shape_distances(args, code, n)
    kind = {v: k for k, v in KIND_CODES.items()}[code]
    row = np.full((n, 9), 7.0)
    with np.errstate(all="ignore"):
        getattr(T, f"{kind}_ellipsoid")(*args, row, 0, n)
    proven = row[:, 0] != cylinder.UNPROVEN if kind == "cylinder" else np.ones(n, bool)
    status = np.where(proven & np.isfinite(row[:, 1]), 0, 1).astype(np.int8)
    assert_same_outputs(got, (row[:, 1], row[:, 2:5], row[:, 5:8], status), f"shape_distances ({kind})")
    return got


def pose_arrays(P):
    return tuple(np.array(P[k], dtype=float) for k in ("cE", "RE", "rE", "cK", "RK", "sK"))


@pytest.mark.parametrize("kind", sorted(KIND_CODES))
def test_shape_distances_is_each_kinds_kernel(kind):
    """Every kind on test_cylinder's poses (read as capsules and boxes too), the benchmark's deep poses, a sample
    set's pairs and the degenerate poses: the kind's own kernel, row for row."""
    from test_cylinder import make_poses

    for P in (make_poses(seed=0, per=30)[0], bench_poses("deep", 100, 5), as_shapes(*samples.generic_pairs(300, seed=6)),
              _degenerate_poses()):  # fmt: skip
        args = pose_arrays(P)
        assert_drop_in_is_the_kernel(args, KIND_CODES[kind], len(args[0]))


def test_shape_distances_status_flags_unproven_and_non_finite_results():
    """status 1 where the kernel's result is not finite (sizes and offsets beyond float64's squares) or a
    cylinder's rim is UNPROVEN; 0 elsewhere."""
    big = dict(cE=[[0.0, 0.0, 0.0]] * 2, RE=[np.eye(3)] * 2, rE=[[1e300, 1e300, 1e300], [0.3, 0.2, 0.1]],
               cK=[[1e300, 0.0, 0.0], [0.0, 0.0, 0.5]], RK=[np.eye(3)] * 2, sK=[[0.05, 0.15, 0.0]] * 2)  # fmt: skip
    args = pose_arrays(big)
    for code in KIND_CODES.values():
        dist, _, _, status = assert_drop_in_is_the_kernel(args, code, 2)
        assert status[0] == 1 and status[1] == 0
    a, b = samples.stress_pairs("identical and contained", 2000, seed=5)
    pick = [228, 427, 0]  # two cylinders whose rim's branch and bound runs out of budget, and one proven
    args = pose_arrays({k: v[pick] for k, v in as_shapes(a, b).items()})
    out = twice("cylinder_ellipsoid", args, 3)
    assert out[:, 0].tolist() == [cylinder.UNPROVEN, cylinder.UNPROVEN, cylinder.CERTIFIED]
    twice("cylinder_stages", args, 3)
    dist, _, _, status = assert_drop_in_is_the_kernel(args, KIND_CODES["cylinder"], 3)
    assert np.isfinite(dist).all() and status.tolist() == [1, 1, 0]


def test_shape_distances_in_chunks_broadcast_and_on_threads():
    """Chunked [lo, hi) calls write only their slice and together give the whole call's bits; a batch of one on
    either side broadcasts (the same bits as the batch repeated); threads.run cuts a large batch into chunks on
    its pool (as shape_distance does) and three threads calling at once each get the serial call's bits."""
    a, b = samples.near_contact_pairs(200, seed=9)
    args = pose_arrays(as_shapes(a, b))
    n = len(args[0])
    for code in KIND_CODES.values():
        whole = shape_distances(args, code, n)
        one = tuple(x[:1].copy() for x in args[:3]) + args[3:]
        assert_same_outputs(shape_distances(one, code, n), shape_distances(tuple(x[[0] * n] for x in one[:3]) +
                                                                           args[3:], code, n))  # fmt: skip
        one = args[:3] + tuple(x[4:5].copy() for x in args[3:])
        assert_same_outputs(shape_distances(one, code, n), shape_distances(args[:3] + tuple(x[[0] * n] for x in
                                                                                            one[3:]), code, n))  # fmt: skip
        out = shape_distances(args, code, n, 17, 131)
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
    serial = shape_distances(args, 2, n)
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
