"""The C++ motion/ folder's kernels (issue 46): what the public tests do not reach.

The sort under sweep_and_prune (a valid argsort: ties and NaNs included) and sweep_and_prune on arbitrary
floats and NaNs (valid pairs, none twice); each kernel of swept_pairs (block_pairs with its crowded-block
rerun and `allowed`, compact, capsule_motion, step_pairs) on the scenes of test_broad_phase.py, at their
thresholds, on a replay of MuJoCo figures and on arbitrary floats: the kernels' pairs are bp.swept_pairs',
chunked calls on threads give the serial call's bits, and the crowded-block rerun, `allowed`, the bend's
threshold and the rounding room act as meant.  The constants against broad_phase.py and the binding's
refusals.  (Against references: tests/test_broad_phase.py, tests/test_interpolation.py, tests/test_toi.py.)
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import finite, positive
from scipy.spatial.transform import Rotation as Rot

import ellipsim.native as native
from ellipsim.core import threads
from ellipsim.core.motion import broad_phase as bp

ext = native.ext
T = ext.testing


def assert_same(got, want, what=""):
    """The same bits (floats: NaN for NaN), the same integers or booleans, the same shape."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape and got.dtype == want.dtype, (what, got.shape, want.shape, got.dtype, want.dtype)
    if got.dtype == np.float64:
        differ = (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))
    else:
        differ = got != want
    bad = np.argwhere(differ)
    assert not len(bad), f"{what} at {tuple(bad[0])}: {got[tuple(bad[0])]!r} expected {want[tuple(bad[0])]!r}"


def floats(n, rng):
    """n arbitrary finite floats: random bit patterns (every exponent), with some zeros and subnormals."""
    x = rng.integers(0, 2**64, n, dtype=np.uint64).view(np.float64).copy()
    x[~np.isfinite(x)] = 0.0
    x[rng.uniform(size=n) < 0.02] = 0.0
    return x


def test_the_constants_are_the_python_modules():
    c = T.MOTION
    for name in ("SWEEP_BLOCK", "BLOCK_ROOM", "CAPSULE_SLACK", "CAPSULE_STEPS", "PLAIN_COS"):
        assert c[name] == getattr(bp, name) and type(c[name]) is type(getattr(bp, name)), name


# --- broad phase: the sort and sweep_and_prune ----------------------------------------------------------


def test_argsort_is_a_sort_ties_and_nans_included():
    """The sort under sweep_and_prune (numba's quicksort's order): a permutation that sorts, NaNs last."""
    rng = np.random.default_rng(5)
    cases = [np.zeros(0), np.ones(1), np.arange(40.0), np.arange(40.0)[::-1].copy(), np.zeros(100)]
    for n in (2, 5, 15, 16, 17, 31, 64, 200, 1000):
        cases.append(rng.integers(0, 4, n).astype(float))  # many ties
        cases.append(rng.normal(size=n))
        x = rng.normal(size=n)
        x[rng.uniform(size=n) < 0.2] = np.nan
        x[rng.uniform(size=n) < 0.1] = -np.inf
        cases.append(x)
        cases.append(np.repeat(rng.normal(size=(n + 2) // 3), 3)[:n])
    for x in cases:
        got = np.full(len(x), -7, np.int64)
        T.argsort(x, got)
        assert sorted(got.tolist()) == list(range(len(x))), f"argsort of {len(x)}: not a permutation"
        y = x[got]
        nan = np.isnan(y)
        k = int(np.count_nonzero(~nan))
        assert not nan[:k].any() and np.all(y[: k - 1] <= y[1:k]), f"argsort of {len(x)}: not sorted"
        got2 = np.full(len(x), -7, np.int64)
        T.argsort(x, got2)
        assert_same(got2, got, "argsort twice")


def assert_valid_pairs(pairs, F, g):
    """(P, 3) int64 rows (frame, i, j): 0 <= frame < F, 0 <= i < j < g, sorted by frame, none twice."""
    assert pairs.dtype == np.int64 and pairs.ndim == 2 and pairs.shape[1] == 3
    f, i, j = pairs.T
    assert np.all((0 <= f) & (f < F) & (0 <= i) & (i < j) & (j < g))
    assert np.all(np.diff(f) >= 0)
    assert len({tuple(r) for r in pairs.tolist()}) == len(pairs)


def random_walk(rng, F, g, box=1.0, step=0.1):
    return rng.uniform(-box, box, (g, 3))[None] + np.cumsum(rng.normal(scale=step, size=(F, g, 3)), axis=0)


def check_sweep(centers, rho):
    centers, rho = np.ascontiguousarray(centers, dtype=np.float64), np.ascontiguousarray(rho, dtype=np.float64)
    with np.errstate(all="ignore"):
        got = ext.sweep_and_prune(centers, rho)
        again = ext.sweep_and_prune(centers, rho)
    assert_valid_pairs(got, centers.shape[0], centers.shape[1])
    assert_same(again, got, "sweep_and_prune twice")
    return got


@settings(max_examples=150, deadline=None)
@given(
    st.integers(1, 4),
    st.integers(0, 12),
    st.data(),
)
def test_sweep_and_prune_gives_valid_pairs_on_any_floats(F, g, data):
    c = data.draw(
        st.lists(
            st.one_of(finite, st.floats(-1, 1), st.sampled_from([0.0, 0.5])), min_size=3 * F * g, max_size=3 * F * g
        )
    )
    r = data.draw(st.lists(st.one_of(positive, st.floats(0, 1), st.just(0.25)), min_size=g, max_size=g))
    check_sweep(np.array(c, dtype=float).reshape(F, g, 3), np.array(r, dtype=float))


def test_sweep_and_prune_with_nans_gives_valid_pairs():
    """A NaN centre overlaps nothing: the other pairs are those of the frame without it."""
    rng = np.random.default_rng(7)
    c = rng.uniform(-1, 1, (5, 30, 3))
    rho = rng.uniform(0.1, 0.5, 30)
    clean = {tuple(p) for p in check_sweep(c, rho).tolist()}
    bad = rng.uniform(size=c.shape[:2]) < 0.05
    c[bad] = np.nan
    got = {tuple(p) for p in check_sweep(c, rho).tolist()}
    assert got == {(f, i, j) for f, i, j in clean if not bad[f, i] and not bad[f, j]}


def figure_replay(n_figures, frames, seed):
    """(centers, rotations, radii, rules) of the ellipsoid geoms of n MuJoCo figures under random controls,
    one frame per 4 steps (falling, flailing limbs: touching, turning pairs)."""
    mujoco = pytest.importorskip("mujoco")
    from ellipsim.app.scenes import scene_xml
    from ellipsim.mujoco.geoms import ellipsoid_geoms

    model = mujoco.MjModel.from_xml_string(scene_xml(n_figures, layout="grid", spacing=0.7, drop_height=0.1))
    data = mujoco.MjData(model)
    ids, radii, rules = ellipsoid_geoms(model)
    rng = np.random.default_rng(seed)
    C, R = np.empty((frames, len(ids), 3)), np.empty((frames, len(ids), 3, 3))
    for f in range(frames):
        data.ctrl[:] = rng.uniform(-1, 1, model.nu) * 2.0
        for _ in range(4):
            mujoco.mj_step(model, data)
        C[f], R[f] = data.geom_xpos[ids], data.geom_xmat[ids].reshape(-1, 3, 3)
    return C, R, radii, rules


@pytest.fixture(scope="module")
def replay():
    return figure_replay(6, 60, seed=8)


# --- broad phase: swept_pairs, kernel by kernel ----------------------------------------------------------


def swept(centers, rotations, radii, rho, allowed=None, chunks=1):
    """bp.swept_pairs's steps, kernel by kernel; every intermediate, and the pairs.  Outputs are filled with 7
    first: a chunked call must leave what the serial call leaves."""
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    rotations = np.ascontiguousarray(rotations, dtype=np.float64)
    rho = np.ascontiguousarray(rho, dtype=np.float64)
    F, g = centers.shape[0], centers.shape[1]
    B = bp.SWEEP_BLOCK
    nb = (F - 2) // B + 1
    matrix = allowed if isinstance(allowed, np.ndarray) else np.zeros((0, 0), dtype=bool)
    run = lambda kernel, n, *args: threads.run(kernel, n, chunks > 1, *args)  # noqa: E731
    out, count = np.full((nb, bp.BLOCK_ROOM * g, 2), 7, dtype=np.int32), np.full(nb, 7, dtype=np.int64)
    run(ext.block_pairs, nb * g, centers, rho, B, g, matrix, out, count)
    first = (out.copy(), count.copy())
    if count.max() > out.shape[1]:
        out = np.full((nb, int(count.max()), 2), 7, dtype=np.int32)
        run(ext.block_pairs, nb * g, centers, rho, B, g, matrix, out, count)
    blocks = np.full((int(count.sum()), 3), 7, dtype=np.int64)
    ext.compact(out, count, blocks)
    if callable(allowed):
        blocks = np.ascontiguousarray(blocks[allowed(blocks[:, 1], blocks[:, 2])])
    axis, half, cap = bp.capsules(radii)
    big = np.asarray(radii, dtype=np.float64).max(axis=1)
    ends, bend = np.full((F, g, 2, 3), 7.0), np.full((F - 1, g), 7.0)
    ext.capsule_motion(centers, rotations, axis, half, ends, bend)
    keep = np.ones((len(blocks), B), dtype=bool)
    run(ext.step_pairs, len(blocks), blocks, B, centers, rho, ends, bend, cap, big, keep)
    p, s = np.nonzero(keep)
    pairs = np.column_stack([blocks[p, 0] * B + s, blocks[p, 1], blocks[p, 2]])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    return dict(first_out=first[0], first_count=first[1], out=out, count=count, blocks=blocks, ends=ends, bend=bend,
                keep=keep, pairs=pairs)  # fmt: skip


def check_swept(centers, rotations, radii, rho, allowed=None, chunks=1):
    """The kernels' pairs: valid, found again by a rerun (chunked on threads if chunks > 1: the serial call's
    bits in every intermediate), and bp.swept_pairs' (for finite poses)."""
    with np.errstate(all="ignore"):
        got = swept(centers, rotations, radii, rho, allowed)
        again = swept(centers, rotations, radii, rho, allowed, chunks)
    for name in got:
        assert_same(again[name], got[name], name)
    F, g = np.shape(centers)[:2]
    assert_valid_pairs(got["pairs"].astype(np.int64), F - 1, g)
    if chunks == 1 and np.all(np.isfinite(centers)) and np.all(np.isfinite(rotations)):
        with threads.limit(1), np.errstate(all="ignore"):
            assert_same(got["pairs"].astype(np.int64), bp.swept_pairs(centers, rotations, radii, rho, allowed), "pairs")
    return got


def turning_scene(rng, F, g, turn=1.9, box=0.7, step=0.12):
    radii = rng.uniform(0.05, 0.45, (g, 3))
    radii[:3] = radii[:3, :1]
    radii[3:8, 1:] = rng.uniform(0.01, 0.04, (5, 2))
    C = random_walk(rng, F, g, box=box, step=step)
    R = np.empty((F, g, 3, 3))
    R[0] = Rot.random(g, random_state=rng).as_matrix()
    for f in range(1, F):
        v = rng.normal(size=(g, 3))
        v *= (rng.uniform(0, turn, g) / np.linalg.norm(v, axis=1))[:, None]
        R[f] = (Rot.from_matrix(R[f - 1]) * Rot.from_rotvec(v)).as_matrix()
    return C, R, radii, radii.max(axis=1)


def test_swept_pairs_kernels_on_the_broad_phase_scenes():
    rng = np.random.default_rng(9)
    kept = 0
    for seed in range(4):  # spheres turning any way: test_broad_phase's closest-approach scenes
        r = np.random.default_rng(seed)
        C, rho = random_walk(r, 9, 30, step=0.15), r.uniform(0.03, 0.3, 30)
        R = np.stack([Rot.random(30, random_state=r).as_matrix() for _ in range(9)])
        kept += len(check_swept(C, R, np.repeat(rho[:, None], 3, axis=1), rho)["pairs"])
    for seed in range(3):  # rods, plates and spheres turning up to ~110 degrees a step
        kept += len(check_swept(*turning_scene(np.random.default_rng(100 + seed), 6, 14))["pairs"])
    C, R, radii, rho = turning_scene(rng, 11, 16, turn=3.1)  # past PLAIN_COS: sphere tests only
    kept += len(check_swept(C, R, radii, rho)["pairs"])
    for scale in (2.0**-300, 2.0**-200, 2.0**30, 2.0**300):  # power-of-two scales: the same
        kept += len(check_swept(C * scale, R, radii * scale, rho * scale)["pairs"])
    g = 40  # every body in one spot: the crowded-block rerun
    radii = rng.uniform(0.01, 0.5, (g, 3))
    got = check_swept(
        np.zeros((7, g, 3)) + [1.0, 2.0, 3.0],
        np.stack([Rot.random(g, random_state=rng).as_matrix()] * 7),
        radii,
        radii.max(axis=1),
    )
    assert got["first_count"].max() > bp.BLOCK_ROOM * g and len(got["pairs"]) == 6 * g * (g - 1) // 2
    C = np.array([[[-5.0, 0.0, 0.0], [5.0, 0.1, 0.0]], [[5.0, 0.0, 0.0], [-5.0, 0.1, 0.0]]])  # tunnelling
    check_swept(C, np.stack([np.eye(3)] * 4).reshape(2, 2, 3, 3), np.full((2, 3), 0.1), np.full(2, 0.1))
    C = np.broadcast_to(rng.uniform(-1, 1, (40, 3)), (6, 40, 3)).copy()  # not moving
    rho = rng.uniform(0.05, 0.3, 40)
    check_swept(C, np.broadcast_to(np.eye(3), (6, 40, 3, 3)).copy(), np.repeat(rho[:, None], 3, axis=1), rho)
    for F, g in ((2, 2), (3, 5), (5, 2)):
        check_swept(np.zeros((F, g, 3)), np.broadcast_to(np.eye(3), (F, g, 3, 3)).copy(), np.ones((g, 3)), np.ones(g))
    assert kept > 300


def test_swept_pairs_kernels_at_their_thresholds():
    """Pairs whose closest approach is within the rounding room (64 u of the coordinates) of rho_i + rho_j,
    coordinates up to 1e3; steps whose cos theta is PLAIN_COS exactly and one ulp either side."""
    P = bp.PLAIN_COS
    d = 1.0 + np.arange(-40, 80) * 1e-13
    n = len(d)
    C = np.zeros((2, 2 * n + 3, 3))
    C[:, :n, 0], C[:, n : 2 * n, 0] = 1e3, 1e3 + d
    C[:, :n, 1] = C[:, n : 2 * n, 1] = 10.0 * np.arange(n)
    C[1, n : 2 * n, 2] = 1e-9  # a step's motion too
    C[:, 2 * n :] = [[-50.0, 0.0, 0.0], [-50.0, 0.5, 0.0], [-50.0, 1.0, 0.0]]
    R = np.broadcast_to(np.eye(3), C.shape + (3,)).copy()
    for k, v in enumerate((np.nextafter(P, -1), P, np.nextafter(P, 1))):
        R[1, 2 * n + k] = np.diag([v, v, 1.0])  # cos theta = v exactly
    rho = np.full(C.shape[1], 0.5)
    radii = np.column_stack([rho, rho * 0.9, rho * 0.5])
    got = check_swept(C, R, radii, rho)
    assert np.isinf(got["bend"][0, 2 * n]) and np.isfinite(got["bend"][0, 2 * n + 2])
    kept = {(int(i), int(j)) for _, i, j in got["pairs"]}
    near = [(k, n + k) in kept for k in range(n)]
    assert any(near) and not all(near)


def test_swept_pairs_kernels_with_allowed_and_on_a_figure_replay(replay):
    C, R, radii, rules = replay
    rho = radii.max(axis=1) * (1 + 2.0**-16)
    every = check_swept(C, R, radii, rho)
    matrix = check_swept(C, R, radii, rho, rules.matrix())
    check_swept(C, R, radii, rho, rules.allowed)
    assert len(matrix["pairs"]) < len(every["pairs"]) and len(matrix["pairs"]) > 50
    rng = np.random.default_rng(10)
    allowed = rng.uniform(size=(len(radii),) * 2) < 0.5
    check_swept(C, R, radii, rho, allowed | allowed.T)


def test_chunked_calls_on_threads_give_the_serial_bits(replay):
    C, R, radii, _ = replay
    rho = radii.max(axis=1)
    C, R = np.concatenate([C] * 6), np.concatenate([R] * 6)  # enough blocks and pairs for several chunks
    with threads.limit(2):
        got = check_swept(C, R, radii, rho, chunks=2)
    assert len(got["blocks"]) > 2000


@settings(max_examples=100, deadline=None)
@given(st.integers(2, 7), st.integers(2, 7), st.data())
def test_swept_pairs_kernels_give_valid_pairs_on_any_floats(F, g, data):
    """Arbitrary finite centres (extreme exponents, overflowing boxes), matrices that are not rotations
    (bends of NaN and inf), radii from subnormal up."""
    near = st.one_of(finite, st.floats(-2, 2), st.sampled_from([0.0, 1.0]))
    c = np.array(data.draw(st.lists(near, min_size=3 * F * g, max_size=3 * F * g))).reshape(F, g, 3)
    m = np.array(data.draw(st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=9 * F * g, max_size=9 * F * g)))
    radii = np.array(data.draw(st.lists(st.one_of(positive, st.floats(0.01, 1)), min_size=3 * g, max_size=3 * g)))
    radii = radii.reshape(g, 3)
    check_swept(c, m.reshape(F, g, 3, 3), radii, radii.max(axis=1))


# --- the binding's refusals ----------------------------------------------------------------------------


def test_the_binding_refuses_what_it_would_read_out_of_bounds():
    C, R = np.zeros((5, 4, 3)), np.broadcast_to(np.eye(3), (5, 4, 3, 3)).copy()
    rho = np.ones(4)
    with pytest.raises(ValueError, match="rho"):
        ext.sweep_and_prune(C, np.ones(3))
    with pytest.raises(TypeError):  # no silent copy: a strided or wrongly typed array is not taken
        ext.sweep_and_prune(C[::2], rho)
    out, count = np.zeros((2, 64, 2), np.int32), np.zeros(2, np.int64)
    no = np.zeros((0, 0), bool)
    with pytest.raises(IndexError, match="blocks"):
        ext.block_pairs(C, rho, 4, 4, no, out, count, 0, 12)  # block 2 starts past the last frame
    with pytest.raises(ValueError, match="allowed"):
        ext.block_pairs(C, rho, 4, 4, np.ones((3, 3), bool), out, count, 0, 8)
    with pytest.raises(ValueError, match="zero-size"):  # the error of a max over no bodies
        ext.block_pairs(np.zeros((5, 0, 3)), np.zeros(0), 4, 1, no, out, count, 0, 1)
    with pytest.raises(IndexError, match="count"):
        ext.compact(out, np.array([65, 0]), np.zeros((65, 3), np.int64))
    with pytest.raises(IndexError, match="rows"):
        ext.compact(out, np.array([3, 2]), np.zeros((4, 3), np.int64))
    ends, bend = np.zeros((5, 4, 2, 3)), np.zeros((4, 4))
    with pytest.raises(IndexError, match="axis"):
        ext.capsule_motion(C, R, np.array([0, 1, 2, 3]), np.ones(4), ends, bend)
    with pytest.raises(ValueError, match="bend"):
        ext.capsule_motion(C, R, np.zeros(4, np.int64), np.ones(4), ends, np.zeros((5, 4)))
    keep = np.zeros((1, 4), bool)
    with pytest.raises(IndexError, match="index"):
        ext.step_pairs(np.array([[0, 1, 4]]), 4, C, rho, ends, bend, rho, rho, keep, 0, 1)
    with pytest.raises(IndexError, match="range"):
        ext.step_pairs(np.array([[0, 1, 2]]), 4, C, rho, ends, bend, rho, rho, keep, 0, 2)
    with pytest.raises(ValueError, match="keep"):
        ext.step_pairs(np.array([[0, 1, 2]]), 8, C, rho, ends, bend, rho, rho, keep, 0, 1)
    with pytest.raises(ValueError, match="one time"):
        ext.poses_at(C[0], R[0], C[0], R[0], C[0], np.zeros(2), np.empty((4, 3)), np.empty((4, 3, 3)))
    with pytest.raises(ValueError, match="same length"):
        ext.rotation_vectors(R[0], R[0], np.empty((3, 3)), np.empty(4))
