"""The C++ motion/ folder (issue 46) against the numba kernels it replaces, bit for bit.

interpolation: sincos, rodrigues, rodrigues_apply, rodrigues_matrix and matmul, the rotation vectors (generic,
tiny, flushed and half turns, exact quarter turns, arbitrary matrices), rotation_at and the poses at t (both
halves, the endpoints, one time for all or one per body, arbitrary floats).

broad_phase: numba's argsort (ties and NaNs in its order), sweep_and_prune (the scenes of test_broad_phase.py,
a crowded frame past the first buffer, a replay of MuJoCo figures, arbitrary floats), each kernel of
swept_pairs (_block_pairs with its crowded-block rerun and `allowed`, _compact, _capsule_motion, _step_pairs)
and the pipeline's pairs, the segment distance (parallel, degenerate, 2^+-300 scales, arbitrary floats),
_capsule_gap and _capsules_apart; chunked calls on threads and the binding's refusals.
"""

import math

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation as Rot
from strategies import SIGNED_PERMUTATIONS
from test_native import finite, positive

import ellipsim.native as native
from ellipsim.core import threads
from ellipsim.core.motion import broad_phase as bp
from ellipsim.core.motion import interpolation as ip
from ellipsim.core.tolerances import OMEGA_ZERO

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
    assert not len(bad), f"{what} at {tuple(bad[0])}: {got[tuple(bad[0])]!r} in C++, {want[tuple(bad[0])]!r} in numba"


def floats(n, rng):
    """n arbitrary finite floats: random bit patterns (every exponent), with some zeros and subnormals."""
    x = rng.integers(0, 2**64, n, dtype=np.uint64).view(np.float64).copy()
    x[~np.isfinite(x)] = 0.0
    x[rng.uniform(size=n) < 0.02] = 0.0
    return x


def turned(rng, n, angle):
    R0 = Rot.random(n, random_state=rng)
    v = rng.normal(size=(n, 3))
    v *= (angle / np.linalg.norm(v, axis=1))[:, None]
    return R0.as_matrix(), (R0 * Rot.from_rotvec(v)).as_matrix()


def test_the_constants_are_the_python_modules():
    c = T.MOTION
    for name in ("SWEEP_BLOCK", "BLOCK_ROOM", "CAPSULE_SLACK", "CAPSULE_STEPS", "PLAIN_COS"):
        assert c[name] == getattr(bp, name) and type(c[name]) is type(getattr(bp, name)), name


# --- interpolation --------------------------------------------------------------------------------------


@numba.njit(cache=False, error_model="numpy")
def _sincos(x, out):
    for i in range(x.shape[0]):
        out[i, 0], out[i, 1] = ip.sincos(x[i])


@numba.njit(cache=False, error_model="numpy")
def _rodrigues_stages(w, phi, p, Rp, out):
    for i in range(out.shape[0]):
        rod = ip.rodrigues((w[i, 0], w[i, 1], w[i, 2]), phi[i])
        c, s, om, k, al = rod
        a = ip.rodrigues_apply(rod, (p[i, 0], p[i, 1], p[i, 2]))
        E = ip.rodrigues_matrix(rod)
        R = (Rp[i, 0, 0], Rp[i, 0, 1], Rp[i, 0, 2], Rp[i, 1, 0], Rp[i, 1, 1], Rp[i, 1, 2], Rp[i, 2, 0], Rp[i, 2, 1], Rp[i, 2, 2])  # fmt: skip
        M = ip.matmul(R, E)
        head = (c, s, om, k[0], k[1], k[2], al, a[0], a[1], a[2])
        for m in range(10):
            out[i, m] = head[m]
        for m in range(9):
            out[i, 10 + m] = E[m]
            out[i, 19 + m] = M[m]


def check_sincos(x):
    x = np.ascontiguousarray(x, dtype=np.float64)
    got, want = np.full((len(x), 2), 7.0), np.full((len(x), 2), 7.0)
    with np.errstate(all="ignore"):
        T.sincos(x, got)
        _sincos(x, want)
    assert_same(got, want, "sincos")


def test_sincos_gives_the_numba_bits():
    rng = np.random.default_rng(1)
    x = np.concatenate([np.linspace(-1.6, 1.6, 20001), rng.uniform(-math.pi, math.pi, 20000), [0.0, -0.0, 5e-324]])
    check_sincos(x)
    check_sincos(floats(20000, rng))  # far outside its range, overflow: the same bits anyway


def check_rodrigues(w, phi, p, Rp):
    n = len(phi)
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (w, phi, p, Rp)]
    got, want = np.full((n, 28), 7.0), np.full((n, 28), 7.0)
    with np.errstate(all="ignore"):
        T.rodrigues_stages(*args, got)
        _rodrigues_stages(*args, want)
    assert_same(got, want, "rodrigues")


def test_rodrigues_stages_give_the_numba_bits():
    rng = np.random.default_rng(2)
    ws, phis = [], []
    for angle in (0.3, 1.0, 2.0, 3.0, 1e-3, 1e-9, math.pi - 1e-3, math.pi - 2e-6):
        w = rng.normal(size=(500, 3))
        ws.append(w * (angle / np.linalg.norm(w, axis=1))[:, None])
        phis.append(rng.uniform(-0.5, 0.5, 500))
    for scale in (OMEGA_ZERO, OMEGA_ZERO * 7, 1e-100, 1e-8):  # tiny turns: a unit axis from |w|^2 still normal
        w = rng.normal(size=(200, 3))
        ws.append(w * (scale / np.linalg.norm(w, axis=1))[:, None])
        phis.append(rng.uniform(-0.5, 0.5, 200))
    ws.append(np.zeros((3, 3)))  # w = 0 and phi = 0: exactly the identity
    phis.append(np.array([0.3, 0.0, -0.5]))
    ws.append(rng.normal(size=(3, 3)))
    phis.append(np.zeros(3))
    w, phi = np.concatenate(ws), np.concatenate(phis)
    n = len(phi)
    check_rodrigues(
        w,
        phi,
        rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-5, 6, (n, 1)),
        Rot.random(n, random_state=rng).as_matrix(),
    )
    check_rodrigues(
        floats(3 * n, rng).reshape(n, 3),
        floats(n, rng),
        floats(3 * n, rng).reshape(n, 3),
        floats(9 * n, rng).reshape(n, 3, 3),
    )


def check_rotation_vectors(R0, R1):
    n = len(R0)
    R0, R1 = np.ascontiguousarray(R0, dtype=np.float64), np.ascontiguousarray(R1, dtype=np.float64)
    got, want = (np.full((n, 3), 7.0), np.full(n, 7.0)), (np.full((n, 3), 7.0), np.full(n, 7.0))
    with np.errstate(all="ignore"):
        ext.rotation_vectors(R0, R1, *got)
        ip._rotation_vectors(R0, R1, *want)
    assert_same(got[0], want[0], "rotation_vectors w")
    assert_same(got[1], want[1], "rotation_vectors angle")
    for i in range(0, n, max(1, n // 50)):  # the single-pair kernel (it does not flush below OMEGA_ZERO)
        with np.errstate(all="ignore"):
            assert_same(np.array(ext.rotation_vector(R0[i], R1[i])), np.array(ip.rotation_vector(R0[i], R1[i])), i)


def motion_set(rng):
    """(R0, R1): turns by every angle of test_interpolation.py, identity, negligible and half turns."""
    angles = [
        0.3,
        1.0,
        2.0,
        3.0,
        1e-3,
        1e-6,
        1e-9,
        1e-12,
        math.pi - 1e-3,
        math.pi - 1e-4,
        math.pi - 1e-5,
        math.pi - 2e-6,
    ]
    pairs = [turned(rng, 300, a) for a in angles]
    pairs.append(turned(rng, 300, 0.0))  # R0 = R1 (to rounding)
    P = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
    tiny = [P @ np.array([[1.0, -a, 0.0], [a, 1.0, 0.0], [0.0, 0.0, 1.0]]) for a in (1e-140, 1e-160, 1e-300)]
    pairs.append((np.stack([P] * 4), np.stack([P, *tiny])))  # kept, flushed below OMEGA_ZERO
    half = [np.diag(d) for d in ([-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, -1.0])]
    pairs.append((np.stack([np.eye(3)] * 3), np.stack(half)))  # exactly pi about each axis: kn from the diagonal
    pairs.append((np.zeros((1, 3, 3)), np.zeros((1, 3, 3))))  # kn == 0
    S = np.array(SIGNED_PERMUTATIONS)  # every pair: exact quarter and half turns (c = 0, -1), reflections
    pairs.append((np.repeat(S, len(S), axis=0), np.tile(S, (len(S), 1, 1))))
    return np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])


def test_rotation_vectors_give_the_numba_bits():
    rng = np.random.default_rng(3)
    check_rotation_vectors(*motion_set(rng))
    n = 3000
    check_rotation_vectors(floats(9 * n, rng).reshape(n, 3, 3), floats(9 * n, rng).reshape(n, 3, 3))
    check_rotation_vectors(rng.uniform(-1, 1, (n, 3, 3)), rng.uniform(-1, 1, (n, 3, 3)))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18))
def test_rotation_vectors_give_the_numba_bits_on_any_floats(m):
    R = np.array(m).reshape(2, 1, 3, 3)
    check_rotation_vectors(R[0], R[1])


def check_poses(C0, R0, C1, R1, W, t):
    n = len(C0)
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (C0, R0, C1, R1, W, np.atleast_1d(t))]
    got, want = (np.full((n, 3), 7.0), np.full((n, 3, 3), 7.0)), (np.full((n, 3), 7.0), np.full((n, 3, 3), 7.0))
    with np.errstate(all="ignore"):
        ext.poses_at(*args, *got)
        ip._poses_at(*args, *want)
    assert_same(got[0], want[0], "poses_at C")
    assert_same(got[1], want[1], "poses_at R")


@numba.njit(cache=False, error_model="numpy")
def _rotation_at(R0, R1, w, t, out):
    for i in range(out.shape[0]):
        a, b = R0[i], R1[i]
        M = ip.rotation_at(
            (a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0], a[2, 1], a[2, 2]),
            (b[0, 0], b[0, 1], b[0, 2], b[1, 0], b[1, 1], b[1, 2], b[2, 0], b[2, 1], b[2, 2]),
            (w[i, 0], w[i, 1], w[i, 2]),
            t[i],
        )
        for k in range(9):
            out[i, k // 3, k % 3] = M[k]


def check_rotation_at(R0, R1, W, t):
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (R0, R1, W, t)]
    got, want = np.full((len(t), 3, 3), 7.0), np.full((len(t), 3, 3), 7.0)
    with np.errstate(all="ignore"):
        T.rotation_at(*args, got)
        _rotation_at(*args, want)
    assert_same(got, want, "rotation_at")


def test_poses_at_gives_the_numba_bits():
    rng = np.random.default_rng(4)
    R0, R1 = motion_set(rng)
    keep = np.flatnonzero(np.abs(np.einsum("nij,nij->n", R0, R1) - 1.0 + 2.0) > 1e-3)  # no half turns
    R0, R1 = R0[keep], R1[keep]
    n = len(R0)
    C0 = rng.uniform(-1, 1, (n, 3)) * 10.0 ** rng.integers(-3, 4, (n, 1))
    C1 = C0 + rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-12, 2, (n, 1))
    W, angle = np.empty((n, 3)), np.empty(n)
    ip._rotation_vectors(R0, R1, W, angle)
    ts = [0.0, 1e-300, 1e-9, 0.25, 0.5, np.nextafter(0.5, 1), 0.75, 1 - 2**-40, np.nextafter(1.0, 0), 1.0]
    for t in ts:
        check_poses(C0, R0, C1, R1, W, t)
    t = rng.choice(np.concatenate([ts, rng.uniform(0, 1, 50)]), n)
    check_poses(C0, R0, C1, R1, W, t)
    check_rotation_at(R0, R1, W, t)
    check_poses(C0[:0], R0[:0], C1[:0], R1[:0], W[:0], np.zeros(1))
    m = 2000
    args = [floats(k * m, rng).reshape(m, *s) for k, s in ((3, (3,)), (9, (3, 3)), (3, (3,)), (9, (3, 3)), (3, (3,)))]
    check_poses(*args, rng.uniform(0, 1, m))
    check_poses(*args, floats(m, rng))  # t outside [0, 1] too (poses_at refuses it; the kernels agree anyway)
    check_rotation_at(args[1], args[3], args[4], floats(m, rng))


# --- broad phase: the sort and sweep_and_prune ----------------------------------------------------------


@numba.njit(cache=False, error_model="numpy")
def _argsort(values):
    return np.argsort(values)


def test_argsort_is_numbas_quicksort_ties_and_nans_included():
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
        assert_same(got, _argsort(x), f"argsort of {len(x)}")


def random_walk(rng, F, g, box=1.0, step=0.1):
    return rng.uniform(-box, box, (g, 3))[None] + np.cumsum(rng.normal(scale=step, size=(F, g, 3)), axis=0)


def check_sweep(centers, rho):
    centers, rho = np.ascontiguousarray(centers, dtype=np.float64), np.ascontiguousarray(rho, dtype=np.float64)
    with np.errstate(all="ignore"):
        got, want = ext.sweep_and_prune(centers, rho), bp.sweep_and_prune(centers, rho)
    assert_same(got, want, "sweep_and_prune")  # the same pairs in the same order
    return len(got)


def sweep_scenes():
    rng = np.random.default_rng(6)
    out = []
    for _ in range(8):  # test_broad_phase's random scenes
        g = int(rng.integers(2, 80))
        out.append(
            (
                rng.uniform(-1, 1, (4, g, 3)) * rng.permutation([0.1, 1.0, 4.0]),
                rng.uniform(0.01, 0.5, g) * rng.choice([1.0, 3.0], g),
            )
        )
    for axis in range(3):  # in a line, neighbours exactly tangent
        c = np.zeros((2, 33, 3))
        c[0, :, axis], c[1, :, axis] = np.arange(33) * 0.5, np.arange(33) * 0.75
        out.append((c, np.full(33, 0.25)))
    d = np.array([3.0, 4.0, 12.0]) / 8  # tangent off axis
    out.append((np.array([[[0.0, 0.0, 0.0], d], [[0.0, 0.0, 0.0], d * (1 + 2.0**-40)]]), np.array([1.0, 0.625])))
    out.append((np.zeros((3, 50, 3)) + np.array([0.3, -2.0, 7.0]), rng.uniform(1e-9, 1.0, 50)))  # 3675 pairs > 1024
    c = rng.uniform(-3, 3, (3, 50, 3))
    c[:, 1::2] = c[:, ::2]  # coincident in pairs
    out.append((c, np.full(50, 1e-3)))
    base_c, base_r = rng.uniform(-1, 1, (3, 40, 3)), rng.uniform(0.05, 0.4, 40)
    for scale in (2.0**-400, 2.0**-60, 2.0**60, 2.0**450):
        out.append((base_c * scale, base_r * scale))
    for F, g in ((0, 0), (0, 5), (3, 0), (3, 1)):
        out.append((np.zeros((F, g, 3)), np.ones(g)))
    out.append((random_walk(rng, 200, 64, box=2.0, step=0.05), rng.uniform(0.05, 0.3, 64)))  # 64 bodies, 200 frames
    return out


def test_sweep_and_prune_gives_the_numba_pairs_in_order():
    found = [check_sweep(c, r) for c, r in sweep_scenes()]
    assert sum(found) > 5000 and found[12] == 3 * 50 * 49 // 2


@settings(max_examples=150, deadline=None)
@given(
    st.integers(1, 4),
    st.integers(0, 12),
    st.data(),
)
def test_sweep_and_prune_gives_the_numba_pairs_on_any_floats(F, g, data):
    c = data.draw(
        st.lists(
            st.one_of(finite, st.floats(-1, 1), st.sampled_from([0.0, 0.5])), min_size=3 * F * g, max_size=3 * F * g
        )
    )
    r = data.draw(st.lists(st.one_of(positive, st.floats(0, 1), st.just(0.25)), min_size=g, max_size=g))
    check_sweep(np.array(c, dtype=float).reshape(F, g, 3), np.array(r, dtype=float))


def test_sweep_and_prune_with_nans_gives_the_numba_pairs():
    rng = np.random.default_rng(7)
    c = rng.uniform(-1, 1, (5, 30, 3))
    c[rng.uniform(size=c.shape) < 0.05] = np.nan
    check_sweep(c, rng.uniform(0.1, 0.5, 30))


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


def test_sweep_and_prune_of_a_figure_replay(replay):
    C, _, radii, _ = replay
    assert check_sweep(C, radii.max(axis=1)) > 100


# --- broad phase: swept_pairs, kernel by kernel ----------------------------------------------------------


NUMBA = dict(
    block_pairs=bp._block_pairs, compact=bp._compact, capsule_motion=bp._capsule_motion, step_pairs=bp._step_pairs
)
CXX = dict(
    block_pairs=ext.block_pairs, compact=ext.compact, capsule_motion=ext.capsule_motion, step_pairs=ext.step_pairs
)


def swept(k, centers, rotations, radii, rho, allowed=None, chunks=1):
    """bp.swept_pairs's steps with the kernels k (NUMBA or CXX); every intermediate, and the pairs.  Outputs
    are filled with 7 first: a kernel must leave what numba leaves."""
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    rotations = np.ascontiguousarray(rotations, dtype=np.float64)
    rho = np.ascontiguousarray(rho, dtype=np.float64)
    F, g = centers.shape[0], centers.shape[1]
    B = bp.SWEEP_BLOCK
    nb = (F - 2) // B + 1
    matrix = allowed if isinstance(allowed, np.ndarray) else np.zeros((0, 0), dtype=bool)
    run = lambda kernel, n, *args: threads.run(kernel, n, chunks > 1, *args)  # noqa: E731
    out, count = np.full((nb, bp.BLOCK_ROOM * g, 2), 7, dtype=np.int32), np.full(nb, 7, dtype=np.int64)
    run(k["block_pairs"], nb * g, centers, rho, B, g, matrix, out, count)
    first = (out.copy(), count.copy())
    if count.max() > out.shape[1]:
        out = np.full((nb, int(count.max()), 2), 7, dtype=np.int32)
        run(k["block_pairs"], nb * g, centers, rho, B, g, matrix, out, count)
    blocks = np.full((int(count.sum()), 3), 7, dtype=np.int64)
    k["compact"](out, count, blocks)
    if callable(allowed):
        blocks = np.ascontiguousarray(blocks[allowed(blocks[:, 1], blocks[:, 2])])
    axis, half, cap = bp.capsules(radii)
    big = np.asarray(radii, dtype=np.float64).max(axis=1)
    ends, bend = np.full((F, g, 2, 3), 7.0), np.full((F - 1, g), 7.0)
    k["capsule_motion"](centers, rotations, axis, half, ends, bend)
    keep = np.ones((len(blocks), B), dtype=bool)
    run(k["step_pairs"], len(blocks), blocks, B, centers, rho, ends, bend, cap, big, keep)
    p, s = np.nonzero(keep)
    pairs = np.column_stack([blocks[p, 0] * B + s, blocks[p, 1], blocks[p, 2]])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    return dict(first_out=first[0], first_count=first[1], out=out, count=count, blocks=blocks, ends=ends, bend=bend,
                keep=keep, pairs=pairs)  # fmt: skip


def check_swept(centers, rotations, radii, rho, allowed=None, chunks=1):
    with np.errstate(all="ignore"):
        got = swept(CXX, centers, rotations, radii, rho, allowed, chunks)
        want = swept(NUMBA, centers, rotations, radii, rho, allowed)
    for name in want:
        assert_same(got[name], want[name], name)
    if chunks == 1 and np.all(np.isfinite(centers)) and np.all(np.isfinite(rotations)):
        with threads.limit(1), np.errstate(all="ignore"):
            assert_same(
                want["pairs"].astype(np.int64), bp.swept_pairs(centers, rotations, radii, rho, allowed), "pairs"
            )
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


def test_swept_pairs_kernels_give_the_numba_bits():
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
def test_swept_pairs_kernels_give_the_numba_bits_on_any_floats(F, g, data):
    """Arbitrary finite centres (extreme exponents, overflowing boxes), matrices that are not rotations
    (bends of NaN and inf), radii from subnormal up."""
    near = st.one_of(finite, st.floats(-2, 2), st.sampled_from([0.0, 1.0]))
    c = np.array(data.draw(st.lists(near, min_size=3 * F * g, max_size=3 * F * g))).reshape(F, g, 3)
    m = np.array(data.draw(st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=9 * F * g, max_size=9 * F * g)))
    radii = np.array(data.draw(st.lists(st.one_of(positive, st.floats(0.01, 1)), min_size=3 * g, max_size=3 * g)))
    radii = radii.reshape(g, 3)
    check_swept(c, m.reshape(F, g, 3, 3), radii, radii.max(axis=1))


# --- broad phase: the segment distance and the capsule tests ---------------------------------------------


@numba.njit(cache=False, error_model="numpy")
def _segment_distances(args, out):
    for i in range(args.shape[0]):
        a = args[i]
        out[i] = bp._segment_distance(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11])


@numba.njit(cache=False, error_model="numpy")
def _capsule_gaps(a0, a1, b0, b1, t, reach, out):
    for i in range(out.shape[0]):
        out[i] = bp._capsule_gap(a0[i], a1[i], b0[i], b1[i], t[i], reach[i])


@numba.njit(cache=False, error_model="numpy")
def _capsules_apart(a0, a1, b0, b1, speed, reach, out):
    for i in range(out.shape[0]):
        out[i] = bp._capsules_apart(a0[i], a1[i], b0[i], b1[i], speed[i], reach[i])


def check_segments(args):
    args = np.ascontiguousarray(args, dtype=np.float64).reshape(-1, 12)
    got, want = np.full(len(args), 7.0), np.full(len(args), 7.0)
    with np.errstate(all="ignore"):
        T.segment_distance(args, got)
        _segment_distances(args, want)
    assert_same(got, want, "segment_distance")


def test_segment_distance_gives_the_numba_bits():
    rng = np.random.default_rng(11)
    rows = []
    for k in range(3000):  # test_broad_phase's segments: generic, parallel, a point, two points
        p, d1, q, d2 = rng.normal(size=(4, 3))
        if k % 5 == 1:
            d2 = d1 * rng.uniform(-2, 2)
        elif k % 5 == 2:
            d1 = np.zeros(3)
        elif k % 5 == 3:
            d1, d2 = np.zeros(3), np.zeros(3)
        elif k % 5 == 4:
            d2 = -d1 + rng.normal(size=3) * 1e-9  # nearly parallel
        rows.append(np.concatenate([p, q, d1, d2]))
    rows = np.array(rows)
    for scale in (1.0, 2.0**-300, 2.0**-200, 2.0**-199, 2.0**200, 2.0**300, 2.0**1000, 1e-320):
        check_segments(rows * scale)
    check_segments(floats(12 * 5000, rng))
    # mixed magnitudes around the scaling's threshold (largest offset 2^-260 ... 2^260): products of the small
    # components underflow differently with and without the scaling
    top = rng.integers(-260, 261, (20000, 1))
    check_segments(rng.normal(size=(20000, 12)) * np.exp2(np.maximum(top - rng.integers(0, 700, (20000, 12)), -1070)))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(finite, st.floats(-2, 2), st.just(0.0)), min_size=12, max_size=12))
def test_segment_distance_gives_the_numba_bits_on_any_floats(x):
    check_segments(np.array(x))


def check_capsules(a0, a1, b0, b1, x, reach):
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (a0, a1, b0, b1, x, reach)]
    n = len(x)
    got, want = np.full(n, 7.0), np.full(n, 7.0)
    with np.errstate(all="ignore"):
        T.capsule_gap(*args, got)
        _capsule_gaps(*args, want)
    assert_same(got, want, "capsule_gap")
    got, want = np.zeros(n, bool), np.ones(n, bool)
    with np.errstate(all="ignore"):
        T.capsules_apart(*args, got)
        _capsules_apart(*args, want)
    assert_same(got, want, "capsules_apart")


def test_capsule_gap_and_capsules_apart_give_the_numba_bits():
    rng = np.random.default_rng(12)
    n = 4000
    a0 = rng.normal(size=(n, 2, 3))
    b0 = a0 + rng.normal(size=(n, 2, 3)) * 0.5 + rng.uniform(0, 2, (n, 1, 1))
    a1 = a0 + rng.normal(size=(n, 2, 3)) * 0.1 * rng.uniform(0, 3, (n, 1, 1))
    b1 = b0 + rng.normal(size=(n, 2, 3)) * 0.1 * rng.uniform(0, 3, (n, 1, 1))
    disp = np.stack([(a1[:, x] - a0[:, x]) - (b1[:, y] - b0[:, y]) for x in range(2) for y in range(2)], axis=1)
    speed = np.sqrt(np.einsum("npk,npk->np", disp, disp).max(axis=1)) * (1 + 1e-9)
    reach = rng.uniform(0, 0.5, n)
    check_capsules(a0, a1, b0, b1, speed, reach)
    check_capsules(a0, a1, b0, b1, rng.uniform(0, 1, n), reach)  # capsule_gap at t
    check_capsules(a0, a0, b0, b0, np.zeros(n), reach)  # not moving: speed 0
    f = [floats(6 * n, rng).reshape(n, 2, 3) for _ in range(4)]
    check_capsules(*f, np.abs(floats(n, rng)), np.abs(floats(n, rng)))
    check_capsules(*f, floats(n, rng), floats(n, rng))


# --- the binding's refusals ----------------------------------------------------------------------------


def test_the_binding_refuses_what_numba_would_read_out_of_bounds():
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
    with pytest.raises(ValueError, match="zero-size"):  # numba's error for no bodies
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
