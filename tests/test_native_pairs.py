"""The C++ pairs/ folder's testing kernels (issue 46): broadcasting, ranges, refusals, and outputs in range.

The capsule and box kernels (capsule_ellipsoid, box_ellipsoid: status, distance, normal, position, bound) and
their stages, point_ellipsoid's and tangent_cones' stages (ellipsim.native.ext.testing): a batch of one
broadcasts and a [lo, hi) range writes only its slice (the full call's rows there); on the capsule and box
tests' poses, every sample set's pairs read as an ellipsoid and a capsule or box, degenerate poses and
hypothesis's random poses: a status of 0 or 1, a finite distance and a unit normal; on arbitrary finite floats:
the same bits twice, no failure.  (Against references: tests/test_capsule.py, test_box.py,
test_point_ellipsoid.py, test_tangent_cones.py.)
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import as_shapes, assert_same_bits, finite, pose_args, positive, quaternion, rotation, size
from scipy.spatial.transform import Rotation as Rot

import ellipsim.native as native
from ellipsim.core import samples

ext = native.ext

# (kernel, columns): pose kernels take (Ce, Re, re, Ck, Rk, sk, out, lo, hi), row kernels (x, out, lo, hi).
POSES = {
    "capsule_ellipsoid": (ext.testing.capsule_ellipsoid, 9),
    "capsule_stages": (ext.testing.capsule_stages, 24),
    "box_ellipsoid": (ext.testing.box_ellipsoid, 9),
    "box_stages": (ext.testing.box_stages, 61),
}
ROWS = {
    "point_ellipsoid_stages": (ext.testing.point_ellipsoid_stages, 56),
    "tangent_cones_stages": (ext.testing.tangent_cones_stages, 7),
}
KERNELS = {**POSES, **ROWS}


def run(name, args, n, lo=0, hi=None):
    """Kernel `name` into rows [lo, hi) of an output of n rows filled with 7."""
    kernel, k = KERNELS[name]
    out = np.full((n, k), 7.0)
    with np.errstate(all="ignore"):
        kernel(*args, out, lo, n if hi is None else hi)
    return out


def assert_pairs_sane(P, kinds=("capsule", "box"), unit=1e-14):
    """Each kind's kernel on the poses P (dict cE, RE, rE, cK, RK, sK, rotations proper): status 0 or 1
    (CERTIFIED, ENUMERATED), a finite distance, a unit normal (to `unit`); its stages run; the same bits twice."""
    args = pose_args(P)
    n = len(args[0])
    for kind in kinds:
        out = run(f"{kind}_ellipsoid", args, n)
        assert set(out[:, 0].tolist()) <= {0.0, 1.0} and np.isfinite(out[:, 1:8]).all(), kind
        assert np.abs(np.linalg.norm(out[:, 2:5], axis=1) - 1.0).max() < unit, kind
        assert_same_bits(run(f"{kind}_ellipsoid", args, n), out, kind)
        run(f"{kind}_stages", args, n)


# --- capsule and box: the kernels' own test poses, every sample set, degenerate cases ----------------------------


def test_capsule_on_the_capsule_tests_poses():
    """test_capsule's seven categories (separated, touching, shallow, deep, parallel, inside, around the segment)
    and its coaxial spheroids (a capsule on or a hair off a spheroid's axis: roots hugging the poles)."""
    from pair_types import coaxial_poses
    from test_capsule import make_poses

    P, cat, _ = make_poses(seed=0, per=60)
    assert_pairs_sane(P, ("capsule",))
    out = run("capsule_ellipsoid", pose_args(P), len(cat))
    assert set(out[:, 0].tolist()) == {0.0, 1.0}  # both statuses reached
    for seed in (0, 1):
        assert_pairs_sane(coaxial_poses(seed), ("capsule",))


def test_box_on_the_box_tests_poses():
    """test_box's seven categories (separated, touching, shallow, deep, flush faces, inside, floors), the deep
    poses of test_tangent_cones, and the same poses with float32 rotations (MuJoCo Warp's: axes orthonormal only
    to ~1e-7, where face_normal, edge_plane, sd_point_box and upper_bound2 compute for a parallelepiped)."""
    from test_box import make_poses

    P, cat, _ = make_poses(seed=0, per=60)
    assert_pairs_sane(P, ("box",))
    out = run("box_ellipsoid", pose_args(P), len(cat))
    assert set(out[:, 0].tolist()) == {0.0, 1.0}  # both statuses reached
    assert_pairs_sane(make_poses(seed=3, per=12)[0], ("box",))
    P32 = {k: (v.astype(np.float32).astype(float) if k in ("RE", "RK") else v) for k, v in P.items()}
    assert_pairs_sane(P32, unit=1e-6)  # axes orthonormal to ~1e-7 only


SETS = [
    ("generic", lambda: samples.generic_pairs(600, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(600, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 100, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_every_sample_set_as_capsules_and_boxes(label, make):
    """ellipsim.core.samples' pairs, the second ellipsoid read as a capsule or a box of the same sizes: near
    tangency to 1e-15, spheres and coaxial spheroids (degenerate poles), identical and contained bodies, aspects
    to 1e4 (needles and disks), offsets to 1e7 and scales from 1e-6 to 1e6."""
    assert_pairs_sane(as_shapes(*make()))


def _degenerate_poses():
    """Spheres and spheroids (equal a2: coinciding poles), concentric bodies (e = 0: no centre line), bodies on
    each other's axes, a needle ellipsoid through a box and a capsule, a box and a capsule inside a sphere."""
    I = np.eye(3)
    R = Rot.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()
    rows = []
    for rE in ([0.2, 0.2, 0.2], [0.3, 0.3, 0.1], [0.1, 0.3, 0.3], [1.0, 1e-4, 1e-4], [0.3, 0.2, 0.1]):
        for RE, RK in ((I, I), (I, R), (R, I), (R, R)):
            for cK in ([0, 0, 0], [0, 0, 0.25], [0.5, 0, 0], [0.1, 0.1, 0.1], [0, 0.4, 0.3], [1e-9, 0, 0]):
                for sK in ([0.05, 0.1, 0.15], [0.1, 0.1, 0.1], [1e-4, 1.0, 1e-4], [0.01, 0.02, 0.5]):
                    rows.append((np.zeros(3), RE, rE, RE @ np.array(cK, float), RK, sK))
    return {k: np.array([r[j] for r in rows], float) for j, k in enumerate(("cE", "RE", "rE", "cK", "RK", "sK"))}


def test_degenerate_poses():
    assert_pairs_sane(_degenerate_poses())


def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice():
    a, b = samples.near_contact_pairs(60, seed=8)
    for name in POSES:
        P = pose_args(as_shapes(a, b))
        full = run(name, P, 60)
        once = tuple(x[:1].copy() for x in P[:3]) + P[3:]
        assert_same_bits(run(name, once, 60), run(name, tuple(x[[0] * 60] for x in P[:3]) + P[3:], 60), name)
        once = P[:3] + tuple(x[5:6].copy() for x in P[3:])
        assert_same_bits(run(name, once, 60), run(name, P[:3] + tuple(x[[5] * 60] for x in P[3:]), 60), name)
        out = run(name, P, 60, 7, 41)  # rows outside [7, 41) keep their fill
        assert np.all(out[:7] == 7.0) and np.all(out[41:] == 7.0)
        assert_same_bits(out[7:41], full[7:41], name)
    x = np.abs(np.random.default_rng(1).normal(size=(60, 24)))
    for name in ROWS:
        rows = (np.ascontiguousarray(x[:, : 13 if name.startswith("point") else 24]),)
        out = run(name, rows, 60, 7, 41)
        assert np.all(out[:7] == 7.0) and np.all(out[41:] == 7.0)
        assert_same_bits(out[7:41], run(name, rows, 60)[7:41], name)
    out = run("box_ellipsoid", pose_args(as_shapes(a, b)), 60, 7, 41)
    assert not np.any(out[7:41] == 7.0)
    with pytest.raises(IndexError, match="range"):
        ext.testing.box_ellipsoid(*pose_args(as_shapes(a, b)), out, 0, 61)
    with pytest.raises(IndexError, match="range"):
        ext.testing.point_ellipsoid_stages(x[:, :13].copy(), np.empty((60, 56)), 0, 61)
    with pytest.raises(TypeError):  # a strided array is refused, never copied
        ext.testing.box_ellipsoid(*pose_args(as_shapes(a, b)), np.empty((60, 10))[:, :9], 0, 60)


@settings(max_examples=500, deadline=None)
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
    assert_pairs_sane({k: np.array(v, float) for k, v in P.items()})


@settings(max_examples=500, deadline=None)
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
        assert_same_bits(run(name, args, 1), run(name, args, 1), name)


# --- point_ellipsoid ----------------------------------------------------------------------------------------


def check_rows(name, x):
    """A row kernel on x: every row written, the same bits twice; returns the rows."""
    out = run(name, (x,), len(x))
    assert_same_bits(run(name, (x,), len(x)), out, name)
    return out


def point_rows(a2, q, w1=None, w2=None, t=None, seed=0):
    """Rows (a2, q, w1, w2, t) of point_ellipsoid_stages; w1, w2 random orthonormal and t random (in
    (-min a2, 10)) unless given."""
    a2, q = np.atleast_2d(np.asarray(a2, float)), np.atleast_2d(np.asarray(q, float))
    n = len(a2)
    rng = np.random.default_rng(seed)
    if w1 is None:
        R = Rot.random(n, random_state=rng).as_matrix()
        w1, w2 = R[:, :, 0], R[:, :, 1]
    if t is None:
        amin = a2.min(1)
        t = np.where(rng.random(n) < 0.5, -amin * rng.uniform(0, 1, n), 10 ** rng.uniform(-3, 1, n))
    cols = (a2, q, np.atleast_2d(w1), np.atleast_2d(w2), np.reshape(t, (n, 1)))
    return np.ascontiguousarray(np.concatenate([np.broadcast_to(c, (n, c.shape[1])) for c in cols], 1))


HAND_PICKED = [  # tests/test_point_ellipsoid.py's cases: centres, axes, planes, poles, circles, disks
    ((1.0, 0.25, 0.04), (0.0, 0.0, 0.0)),
    ((1.0, 0.25, 0.04), (0.5, 0.0, 0.0)),
    ((1.0, 0.25, 0.04), (0.0, 0.3, 0.0)),
    ((1.0, 0.25, 0.04), (0.99, 0.0, 0.0)),
    ((1.0, 0.25, 0.04), (2.0, 0.0, 0.0)),
    ((1.0, 0.25, 0.04), (0.0, 0.0, 0.5)),
    ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)),
    ((1.0, 1.0, 1.0), (0.3, -0.2, 0.1)),
    ((1.0, 1.0, 0.01), (0.2, 0.1, 0.0)),
    ((0.01, 1.0, 1.0), (0.0, 0.3, 0.0)),
    ((1.0, 0.25, 1e-12), (0.3, 0.2, 1e-7)),
    ((1.0, 0.25, 1e-12), (0.3, 0.2, 3e-6)),
    ((1.0, 0.25, 1e-12), (0.9, 0.3, 0.0)),
    ((1.0, 0.25, 0.04), (0.5, 0.0, 1e-12)),
    ((1.0, 0.25, 0.04), (0.5, 1e-12, 0.0)),
    ((1.0, 0.25, 0.04), (0.01, 0.01, 0.01)),
    ((1.0, 0.25, 0.04), (3.0, 2.0, 1.0)),
    ((1.0, 0.25, 0.04), (0.5, 1e-9, 1e-8)),
    ((1.0, 0.25, 0.04), (0.1, 0.2, 1e-9)),
    ((0.04, 0.04, 1.0), (3e-12, -4e-12, 0.0)),
    ((0.04 * (1 + 1e-11), 0.04, 1.0), (3e-12, -4e-12, 0.0)),
    ((0.04, 0.04 * (1 + 1e-12), 1.0), (1e-13, 2e-11, 0.0)),
    ((0.09, 0.09 * (1 - 2e-10), 1.0), (-2e-9, 1e-10, 0.0)),
    ((0.04, 0.04, 1.0), (-5e-11, 0.0, 0.0)),
] + [((1.0, 0.25, 0.04), (0.5, 0.0, qk)) for qk in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)]
HAND_PICKED += [((1.0, 0.04, 0.5), (0.5, qk, 0.0)) for qk in (1e-6, 1e-7, 1e-8, 1e-10)]


def test_point_ellipsoid_on_hand_picked_cases():
    """Every case of test_point_ellipsoid (the pole limits, roots hugging the poles, near-circles), each with
    planes along the axes and random ones, at foot3's t and at random t."""
    a2 = np.array([c[0] for c in HAND_PICKED])
    q = np.array([c[1] for c in HAND_PICKED])
    n = len(a2)
    I = np.eye(3)
    for k, (w1, w2) in enumerate(((I[0], I[1]), (I[1], I[2]), (I[2], I[0]), (None, None))):
        x = point_rows(
            a2, q, None if w1 is None else np.tile(w1, (n, 1)), None if w2 is None else np.tile(w2, (n, 1)), seed=k
        )
        check_rows("point_ellipsoid_stages", x)


def test_point_ellipsoid_on_random_points():
    """Generic, flat (aspect to 1e6) and spheroidal ellipsoids; points inside, outside, near the boundary, deep, at
    the centre, on coordinate planes and axes."""
    rng = np.random.default_rng(2)
    n = 3000
    a = rng.uniform(0.05, 2.0, (n, 3))
    flat = rng.random(n) < 0.3
    a[flat, rng.integers(3, size=flat.sum())] *= 10.0 ** -rng.integers(1, 7, flat.sum())
    sph = rng.random(n) < 0.3
    a[sph, 1] = a[sph, 0]
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    a2 = a * a
    edge = np.sqrt(1.0 / np.sum(u * u / a2, 1))
    rho = rng.choice([0.0, 0.01, 0.5, 0.99, 1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.01, 3.0], n)
    q = u * (edge * rho)[:, None]
    zero = rng.random((n, 3)) < 0.2
    q[zero] = 0.0
    check_rows("point_ellipsoid_stages", point_rows(a2, q, seed=3))


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(finite, st.floats(-2, 2)), min_size=13, max_size=13))
def test_point_ellipsoid_on_arbitrary_floats(x):
    """Any finite floats, negative or zero squared semi-axes and non-orthonormal planes included."""
    check_rows("point_ellipsoid_stages", np.array([x]))


# --- tangent_cones ------------------------------------------------------------------------------------------


def _tangent_rows():
    """test_tangent_cones' inputs: a box's eight octants on deep poses (r = 0; the incumbent the kernel's own
    normal; bare planes and the rolling ball's) and a cylinder's quarter lunes (r > 0), each at floors from below
    to well above f's maximum."""
    from test_box import make_poses

    rng = np.random.default_rng(7)
    P, cat, _ = make_poses(seed=3, per=12)
    res = np.empty((len(cat), 9))
    ext.testing.box_ellipsoid(*pose_args(P), res, 0, len(cat))
    rows = []
    for i in np.flatnonzero(cat >= 2):
        RE, RK, r = P["RE"][i], P["RK"][i], P["sK"][i]
        a2, e, V = P["rE"][i] ** 2, RE.T @ (P["cK"][i] - P["cE"][i]), (RE.T @ RK).T
        bn = RE.T @ res[i, 2:5]
        scale = float(np.linalg.norm(e) + r.max() + np.sqrt(a2.max()))
        for s in np.array(np.meshgrid([1.0, -1.0], [1.0, -1.0], [1.0, -1.0])).reshape(3, -1).T:
            q = e - (s * r) @ V
            top = float(bn @ q - np.sqrt(bn * bn @ a2))
            for floor in (top - 1e-9 * scale, top + 1e-3 * scale, top + 0.02 * scale, top + 0.2 * scale, -1e-12):
                for rho in (0.0, a2.min() / np.sqrt(a2.max())):  # the bare planes, the rolling ball's
                    rows.append(np.concatenate([a2, q, [0.0, 0.0, 1.0], [0.0], bn, *(s[:, None] * V), [floor, rho]]))
    for _ in range(16):
        a2 = rng.uniform(0.02, 0.3, 3) ** 2
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        r, L = rng.uniform(0.01, 0.15), rng.uniform(0.02, 0.3)
        e = rng.uniform(-0.1, 0.1, 3)
        w1 = np.cross(u, rng.normal(size=3))
        w1 /= np.linalg.norm(w1)
        w2 = np.cross(u, w1)
        bn = rng.normal(size=3)
        bn /= np.linalg.norm(bn)
        scale = float(np.linalg.norm(e) + L + r + math.sqrt(max(a2)))
        for sg in (1.0, -1.0):
            q = e - sg * L * u
            for k in range(4):
                ca, cb = (math.cos(t) * w1 + math.sin(t) * w2 for t in (k * math.pi / 2, (k + 1) * math.pi / 2))
                for floor in (-0.3 * scale, -0.1 * scale, -0.02 * scale, -1e-3 * scale):
                    rows.append(np.concatenate([a2, q, u, [r], bn, sg * u, ca, cb, [floor, 0.0]]))
    return np.ascontiguousarray(rows)


def test_tangent_cones_on_box_octants_and_cylinder_lunes():
    x = _tangent_rows()
    out = check_rows("tangent_cones_stages", x)
    for k in range(3, 7):  # every test both proven and refused somewhere
        assert 0 < out[:, k].sum() < len(x), k


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=24, max_size=24))
def test_tangent_cones_on_arbitrary_floats(x):
    check_rows("tangent_cones_stages", np.array([x]))
