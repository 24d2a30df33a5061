"""The C++ motion/time_of_impact.hpp (issue 46): the batch kernel, its exact fallback and its drop-ins.

The batch kernel (ext.toi) on the scenes and hard cases of test_toi.py (spheres on straight paths, random and
small-step pairs, tunnelling plates, grazing and near misses, a spinning needle, identical, concentric and
touching at t = 0 or 1, at rest, reversed, elongated, tiny, huge, far off and far apart, rotations orthonormal
to 1e-7, slow approaches, half turns, tiny motions), hypothesis and arbitrary floats: statuses in range, chunked
[lo, hi) calls, scattered indices and threads give the serial call's bits, a batch of one broadcasts, power-of-two
scales scale the times exactly.  The C++ exact fallback (ext.resolve_exact) against the same search run with
rational_fallback.py's Fraction relation (the loop time_of_impact ran before the C++ one), and the C++ exact
relation against rational.relation at the float poses.  toi_small and toi_pair (the single-pair search) give
ext.toi's results; the pipeline (time_of_impact) is ext.toi + ext.resolve_exact; the binding's refusals.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import finite, positive
from scipy.spatial.transform import Rotation as Rot
from test_native_motion import assert_same, floats
from test_toi import I, one, random_motion, smallstep_motion

import ellipsim.native as native
from ellipsim import Ellipsoids
from ellipsim.core import threads
from ellipsim.core.exact import rational_fallback as rational
from ellipsim.core.motion import time_of_impact as T
from ellipsim.core.tolerances import TOI_MAX_ORACLE

ext = native.ext
X = ext.testing
STATUSES = {T.NO_CONTACT, T.CONTACT, T.CONTACT_AT_FLOAT_POSE, T.UNRESOLVED, T.NEED_EXACT}
NAMES = ("toi", "status", "t_exact", "steps")


def oracle(n, width=TOI_MAX_ORACLE):
    return np.zeros((n, width)), np.zeros((n, width), np.int8), np.zeros(n, np.int64)


def outputs(n):
    """out, status, t_exact, steps filled with sentinels (a row the kernel skips stays as it was)."""
    return np.full(n, 7.0), np.full(n, 9, np.int8), np.full(n, 7.0), np.full(n, -5, np.int64)


def check_kernel(arrays, n, idx=None, chunks=(), OT=None, OR=None, OC=None):
    """ext.toi on pairs idx (all): statuses in range, rows outside idx untouched, and the same bits again in
    the chunks given; returns the outputs."""
    idx = np.arange(n) if idx is None else np.asarray(idx, np.int64)
    if OT is None:
        OT, OR, OC = oracle(n)
    want = outputs(n)
    with np.errstate(all="ignore"):
        ext.toi(*arrays, idx, OT, OR, OC, *want, 0, len(idx))
    assert set(want[1][idx].tolist()) <= STATUSES
    rest = np.setdiff1d(np.arange(n), idx)
    for x, fill in zip(want, outputs(n)):
        assert_same(x[rest], fill[rest], "rows outside idx")
    bounds = [0, *chunks, len(idx)]
    got = outputs(n)
    with np.errstate(all="ignore"):
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            ext.toi(*arrays, idx, OT, OR, OC, *got, lo, hi)
    for name, g, w in zip(NAMES, got, want):
        assert_same(g, w, f"chunked {name}")
    return want


def resolve_with_rationals(arrays, OT, OR, OC, out, status, t_exact, steps):
    """The exact fallback in rationals: pairs whose search asked for the exact relation at an instant get
    rational.relation at the float pose there in their oracle, and the search reruns, until none asks (a full
    oracle: UNRESOLVED, out the proven end)."""
    while True:
        idx = np.flatnonzero(status == T.NEED_EXACT)
        full = idx[OC[idx] >= TOI_MAX_ORACLE]
        status[full] = T.UNRESOLVED
        idx = idx[OC[idx] < TOI_MAX_ORACLE]
        if not len(idx):
            return
        ca, Ra, ra, cb, Rb, rb = T.float_poses(arrays, idx, t_exact[idx])
        for k, i in enumerate(idx):
            OT[i, OC[i]] = t_exact[i]
            OR[i, OC[i]] = rational.relation(ca[k], Ra[k], ra[k], cb[k], Rb[k], rb[k])
            OC[i] += 1
        with np.errstate(all="ignore"):
            ext.toi(*arrays, idx, OT, OR, OC, out, status, t_exact, steps, 0, len(idx))


def check_resolved(arrays, n):
    """The whole search with the exact fallback: ext.toi + ext.resolve_exact (the C++ exact fallback) against
    ext.toi + resolve_with_rationals, every output and the oracles bit for bit."""
    runs = []
    for rationals in (True, False):
        OT, OR, OC = oracle(n)
        out = outputs(n)
        with np.errstate(all="ignore"):
            ext.toi(*arrays, np.arange(n), OT, OR, OC, *out, 0, n)
            if rationals:
                resolve_with_rationals(arrays, OT, OR, OC, *out)
            else:
                ext.resolve_exact(*arrays, OT, OR, OC, *out, 0, n)
        runs.append((*out, OT, OR, OC))
    for name, w, g in zip((*NAMES, "OT", "OR", "OC"), *runs):
        assert_same(g, w, f"resolved {name}")
    assert T.NEED_EXACT not in runs[1][1]
    return runs[1]


def check(a0, a1, b0, b1, label=""):
    """Kernel and resolved search on a validated scene (time_of_impact's _check)."""
    arrays, n = T._check(a0, a1, b0, b1)
    want = check_kernel(arrays, n, chunks=(n // 3, n // 2) if n > 2 else ())
    resolved = check_resolved(arrays, n)
    return want, resolved


def motion(c0, R0, c1, R1, r):
    """A body's two validated batches."""
    return Ellipsoids(np.asarray(c0, float), np.asarray(R0, float), np.asarray(r, float)), Ellipsoids(
        np.asarray(c1, float), np.asarray(R1, float), np.asarray(r, float)
    )


# --- the scenes of test_toi.py ----------------------------------------------------------------------------


def test_spheres_on_straight_paths():
    rng = np.random.default_rng(11)
    n = 2000
    ca0, ca1, cb0, cb1 = (rng.uniform(-2, 2, (n, 3)) for _ in range(4))
    sa, sb = np.repeat(rng.uniform(0.1, 1, n)[:, None], 3, 1), np.repeat(rng.uniform(0.1, 1, n)[:, None], 3, 1)
    R = [Rot.random(n, random_state=rng).as_matrix() for _ in range(2)]
    want, _ = check(
        Ellipsoids(ca0, R[0], sa), Ellipsoids(ca1, R[1], sa), Ellipsoids(cb0, R[1], sb), Ellipsoids(cb1, R[0], sb)
    )
    assert np.count_nonzero(want[1] == T.CONTACT) > 300 and np.count_nonzero(want[3] > 3) > 30


def test_random_pairs_and_small_steps():
    rng = np.random.default_rng(12)
    a0, a1 = random_motion(rng, 400)
    b0, b1 = random_motion(rng, 400)
    check(a0, a1, b0, b1)
    a0, a1 = random_motion(rng, 300, box=1.0)
    b0, b1 = random_motion(rng, 300, box=1.0)
    check(a0, a1, b0, b1)
    want, _ = check(*smallstep_motion(np.random.default_rng(21), 1000))
    assert np.count_nonzero(want[1] == T.NO_CONTACT) > 100 and np.count_nonzero(want[1] == T.CONTACT) > 100


def approaching(rng, n, gap=(0.01, 1.0), radii=(0.1, 1.0), turn=1.0):
    """Pairs separated at t = 0 that close in, each body turning by up to `turn`: the sweep runs its steps."""
    a0, a1 = random_motion(rng, n, box=0.2, turn=turn, radii=radii)
    b, b1 = random_motion(rng, n, box=0.2, turn=turn, radii=radii)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    reach = a0.radii.max(axis=1) + b.radii.max(axis=1) + rng.uniform(*gap, n)
    start = a0.centers + u * reach[:, None]
    end = a0.centers + u * rng.uniform(-0.5, 1.0, n)[:, None] * reach[:, None]
    return a0, a1, Ellipsoids(start, b.rotations, b.radii), Ellipsoids(end, b1.rotations, b.radii)


def test_approaching_pairs():
    rng = np.random.default_rng(31)
    want, _ = check(*approaching(rng, 1500))
    assert np.mean(want[3]) > 3 and np.count_nonzero(want[1] == T.CONTACT) > 300
    check(*approaching(rng, 500, radii=(0.001, 1.0), turn=3.0))  # elongated, fast turns


def test_tunnelling_plates():
    rng = np.random.default_rng(14)
    n = 200
    R = Rot.random(n, random_state=rng).as_matrix()
    normal = R[:, :, 2]
    plate = np.tile([1.0, 1.0, 0.002], (n, 1))
    a0, a1 = Ellipsoids(-3 * normal, R, plate), Ellipsoids(3 * normal, R, plate)
    b = Ellipsoids(rng.uniform(-0.3, 0.3, (n, 3)), Rot.random(n, random_state=rng).as_matrix(), np.full((n, 3), 0.005))
    want, _ = check(a0, a1, b, b)
    assert np.all(want[1] == T.CONTACT)


def test_grazing_near_misses_and_slow_approaches():
    A = one([0, 0, 0], I, [1, 1, 1])
    ends = []
    for g in (1e-3, 1e-6, 1e-9, 1e-12, 1e-14, 0.0):
        for sign in (1, -1):
            y = 2 + sign * g
            ends.append(([3, y, 0], [-3, y, 0]))
    for speed in (1e-3, 1e-4, 1e-5, 1e-7, 1e-9):
        ends.append(([2 + 0.5 * speed, 0, 0], [2 - 0.5 * speed, 0, 0]))
    c0, c1 = np.array([e[0] for e in ends], float), np.array([e[1] for e in ends], float)
    n = len(ends)
    Rs = np.broadcast_to(I, (n, 3, 3)).copy()
    b0, b1 = motion(c0, Rs, c1, Rs, np.ones((n, 3)))
    want, resolved = check(A, A, b0, b1)
    assert {int(s) for s in resolved[1]} >= {T.NO_CONTACT, T.CONTACT, T.UNRESOLVED}


def test_spinning_needles():
    rng = np.random.default_rng(15)
    n = 300
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    R0 = Rot.random(n, random_state=rng)
    R1 = Rot.from_rotvec(axis * rng.uniform(0.5, 3.0, n)[:, None]) * R0
    a0, a1 = motion(
        np.zeros((n, 3)), R0.as_matrix(), np.zeros((n, 3)), R1.as_matrix(), np.tile([2.0, 0.1, 0.15], (n, 1))
    )
    t_c = rng.uniform(0.1, 1.0, n)
    axis_at = (R0 * Rot.from_rotvec(t_c[:, None] * (R0.inv() * R1).as_rotvec())).as_matrix()[:, :, 0]
    centre = axis_at * rng.uniform(0.8, 1.9, n)[:, None] + rng.uniform(-0.2, 0.2, (n, 3))
    b = Ellipsoids(centre, np.broadcast_to(I, (n, 3, 3)).copy(), np.full((n, 3), 0.3))
    want, _ = check(a0, a1, b, b)
    assert np.count_nonzero(want[1] == T.CONTACT) > 100


def test_touching_concentric_at_rest_and_reversed():
    rng = np.random.default_rng(16)
    a0, a1 = random_motion(rng, 20)
    check(a0, a1, a0, a1)  # identical
    b0 = Ellipsoids(a0.centers, Rot.random(20, random_state=rng).as_matrix(), a0.radii * 0.3)
    check(a0, a1, b0, Ellipsoids(a1.centers, b0.rotations, b0.radii))  # concentric throughout
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1, C0 = one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3)
    spin = one([3, 0, 0], Rot.from_rotvec([0, 0, 3.0]).as_matrix(), [0.5] * 3)
    far = one([5, 0, 0], I, [0.5] * 3)
    cases = [(B0, B1), (C0, B0), (C0, C0), (C0, spin), (far, far)]
    b0 = Ellipsoids.concatenate([c[0] for c in cases])
    b1 = Ellipsoids.concatenate([c[1] for c in cases])
    want, resolved = check(A, A, b0, b1)
    assert want[1][0] == T.NEED_EXACT and resolved[1][0] == T.CONTACT  # touching at t = 0: decided exactly
    assert resolved[0][0] == 0.0 and 1 - 1e-9 <= resolved[0][1] <= 1 and np.all(np.isinf(resolved[0][2:]))
    check(A, A, b1, b0)  # reversed
    c0, c1 = one([3, 0.5, 0], I, [0.5] * 3), one([-3, 0.5, 0], I, [0.5] * 3)
    check(A, A, c0, c1)
    check(A, A, c1, c0)


def test_elongated_tiny_huge_far_off_and_noisy_rotations():
    rng = np.random.default_rng(22)
    n = 300
    a0, a1 = random_motion(rng, n, radii=(0.001, 1.0))
    b0, b1 = random_motion(rng, n, radii=(0.001, 1.0))
    base, _ = check(a0, a1, b0, b1)
    for f in (2.0**-20, 2.0**20, 2.0**-200, 2.0**200, 2.0**-600, 2.0**600):
        sc = lambda x: Ellipsoids(x.centers * f, x.rotations, x.radii * f)  # noqa: E731
        want, _ = check(sc(a0), sc(a1), sc(b0), sc(b1))
        if abs(math.log2(f)) <= 200:
            assert_same(want[0], base[0], f"scaled by {f}")
    shift = np.array([1e7, -3e6, 5e6])
    sh = lambda x: Ellipsoids(x.centers + shift, x.rotations, x.radii)  # noqa: E731
    check(sh(a0), sh(a1), sh(b0), sh(b1))
    noisy = lambda x: Ellipsoids(x.centers, x.rotations + rng.uniform(-1e-7, 1e-7, x.rotations.shape), x.radii)  # noqa: E731
    check(noisy(a0), noisy(a1), noisy(b0), noisy(b1))
    far = lambda x: Ellipsoids(x.centers + [100.0, 0.0, 0.0], x.rotations, x.radii)  # noqa: E731
    want, _ = check(a0, a1, far(b0), far(b1))  # far apart throughout: the swept spheres decide
    assert np.all(want[1] == T.NO_CONTACT) and np.all(want[3] == 0)


def test_tiny_motions_and_turns():
    rng = np.random.default_rng(25)
    a0, _ = random_motion(rng, 400, box=0.6)
    b0, _ = random_motion(rng, 400, box=0.6)
    for move, turn in ((1e-12, 0.0), (0.0, 1e-9), (1e-9, 1e-12), (1e-15, 1e-15), (0.0, 0.0)):

        def step(x):
            rv = rng.normal(size=(len(x), 3)) * turn
            R1 = (Rot.from_matrix(x.rotations) * Rot.from_rotvec(rv)).as_matrix() if turn else x.rotations
            return Ellipsoids(x.centers + rng.normal(size=(len(x), 3)) * move, R1, x.radii)

        check(a0, step(a0), b0, step(b0))


def raw(c0, R0, r, c1, R1, w):
    return (np.ascontiguousarray(c0), np.ascontiguousarray(R0), np.ascontiguousarray(r)), (
        np.ascontiguousarray(c1),
        np.ascontiguousarray(R1),
        np.ascontiguousarray(w),
    )


def test_half_turns():
    """Turns within 2e-6 of a half turn (time_of_impact refuses them; the kernels take any w)."""
    rng = np.random.default_rng(26)
    n = 300
    arrays = []
    for _ in range(2):
        R0 = Rot.random(n, random_state=rng)
        v = rng.normal(size=(n, 3))
        v *= ((math.pi - rng.choice([1e-3, 1e-5, 2e-6], n)) / np.linalg.norm(v, axis=1))[:, None]
        R1 = (R0 * Rot.from_rotvec(v)).as_matrix()
        w, angle = np.empty((n, 3)), np.empty(n)
        ext.rotation_vectors(np.ascontiguousarray(R0.as_matrix()), R1, w, angle)
        c0 = rng.uniform(-1, 1, (n, 3))
        arrays.extend(raw(c0, R0.as_matrix(), rng.uniform(0.1, 1, (n, 3)), c0 + rng.normal(size=(n, 3)), R1, w))
    want = check_kernel(tuple(arrays), n, chunks=(100,))
    assert np.count_nonzero(want[3] > 3) > 20


def test_broadcasting_and_scattered_indices():
    """A body given once is the body repeated; a scattered idx gives the full call's rows and leaves the others."""
    rng = np.random.default_rng(24)
    b0, b1 = random_motion(rng, 30)
    A = one([0, 0, 0], I, [0.5, 0.4, 0.3])
    AA = A[[0] * 30]
    for scene, tiled in (((A, A, b0, b1), (AA, AA, b0, b1)), ((b0, b1, A, A), (b0, b1, AA, AA))):
        got, got_resolved = check(*scene)
        want, want_resolved = check(*tiled)
        for name, g, w in zip(NAMES, got + got_resolved[:4], want + want_resolved[:4]):
            assert_same(g, w, f"broadcast {name}")
    check(A, A, A, A)
    arrays, n = T._check(A, A, b0, b1)
    full = check_kernel(arrays, n)
    idx = rng.permutation(n)[:17]
    some = check_kernel(arrays, n, idx=idx, chunks=(5,))  # rows the kernel skips keep their sentinels
    for name, g, w in zip(NAMES, some, full):
        assert_same(g[idx], w[idx], f"scattered {name}")
    check_kernel(arrays, n, idx=np.zeros(0, np.int64))


def test_an_oracle_given_is_used_alike():
    """Oracle rows with relations at the times the search asks about (and at others), as the rerun sees them."""
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1 = one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3)
    arrays, n = T._check(A, A, Ellipsoids.concatenate([B0] * 4), Ellipsoids.concatenate([B1] * 4))
    OT, OR, OC = oracle(n)
    OT[:, :3] = [[0.25, 0.0, 0.5]] * n
    OR[:, :3] = [[0, 2, 0], [0, 1, 0], [0, 0, 0], [0, 2, 0]]
    OC[:] = [3, 3, 1, 2]
    want = check_kernel(arrays, n, OT=OT, OR=OR, OC=OC)
    assert want[1].tolist() == [T.CONTACT, T.CONTACT, T.NEED_EXACT, T.CONTACT]


# --- resolve_exact, the C++ exact relation and float_poses ---------------------------------------------------


def test_the_exact_fallback_gives_the_rational_relation_at_the_float_poses():
    """The poses the searches ask about (t_exact) and the poses at each toi: the C++ exact relation (ext.resolve,
    exact/rational_fallback.hpp) is rational.relation's."""
    rng = np.random.default_rng(27)
    a0, a1, b0, b1 = approaching(rng, 200)
    arrays, n = T._check(a0, a1, b0, b1)
    OT, OR, OC = oracle(n)
    out = outputs(n)
    ext.toi(*arrays, np.arange(n), OT, OR, OC, *out, 0, n)
    idx = np.flatnonzero(np.isfinite(out[0]))
    t = np.concatenate([out[0][idx], out[0][idx] - 1e-9, np.full(len(idx), 0.5)])
    idx = np.concatenate([idx] * 3)
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    touch, _ = T._check(A, A, one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3))
    poses = [T.float_poses(arrays, idx, t), T.float_poses(touch, [0, 0, 0], [0.0, 1.0, 0.25])]
    for ca, Ra, ra, cb, Rb, rb in poses:
        got = np.full(len(ca), -1, np.int8)
        ext.resolve(ca, Ra, ra, cb, Rb, rb, got, 0, len(ca))
        want = np.array([rational.relation(*(x[k] for x in (ca, Ra, ra, cb, Rb, rb))) for k in range(len(ca))], np.int8)
        assert_same(got, want, "exact relation")
    assert set(got.tolist()) == {0, 1}


def test_resolve_exact_runs_every_pair_to_the_end_as_the_rationals_do():
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    B0, B1 = one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3)
    far = one([5, 0, 0], I, [0.5] * 3)
    arrays, n = T._check(A, A, Ellipsoids.concatenate([B0, far, B0, B1]), Ellipsoids.concatenate([B1, far, B1, B0]))
    resolved = check_resolved(arrays, n)
    assert resolved[1].tolist() == [T.CONTACT, T.NO_CONTACT, T.CONTACT, T.CONTACT]
    # a full oracle: UNRESOLVED with the proven end, as in rationals
    OT, OR, OC = oracle(n)
    OC[:] = TOI_MAX_ORACLE
    got, want = outputs(n), outputs(n)
    for out in (got, want):
        ext.toi(*arrays, np.arange(n), OT, OR, OC, *out, 0, n)
    resolve_with_rationals(arrays, OT.copy(), OR.copy(), OC.copy(), *want)
    ext.resolve_exact(*arrays, OT, OR, OC, *got, 0, n)
    for g, w in zip(got, want):
        assert_same(g, w, "full oracle")
    assert want[1][0] == T.UNRESOLVED


def check_small(a0, a1, b0, b1):
    """ext.toi_small: done, and where done ext.toi's times and statuses (no exact relation asked)."""
    args = [a for x in (a0, a1, b0, b1) for a in (x.centers, x.rotations, x.radii)]
    with np.errstate(all="ignore"):
        done, toi, status = ext.toi_small(*args)
    if done:
        arrays, n = T._check(a0, a1, b0, b1)
        want = check_kernel(arrays, n)
        assert T.NEED_EXACT not in want[1]
        assert_same(toi, want[0], "toi_small toi")
        assert_same(status, want[1], "toi_small status")
    return done


def test_toi_small_is_the_batch_search():
    rng = np.random.default_rng(35)
    a0, a1, b0, b1 = approaching(rng, 64)
    done = [
        check_small(a0[k : k + m], a1[k : k + m], b0[k : k + m], b1[k : k + m]) for k, m in ((0, 16), (16, 5), (21, 1))
    ]
    done += [check_small(a0[:1], a1[:1], b0[30:46], b1[30:46]), check_small(b0[50:60], b1[50:60], a0[:1], a1[:1])]
    assert all(done)
    assert not check_small(a0[:17], a1[:17], b0[:17], b1[:17])  # too many pairs
    assert not check_small(a0[:3], a1[:3], b0[:2], b1[:2])  # lengths that do not broadcast
    assert not check_small(a0[:2], a1[:3], b0[:2], b1[:2])
    assert not check_small(a0[:0], a1[:0], b0[:2], b1[:2])
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    assert not check_small(A, A, one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3))  # needs rationals
    wide = one([0, 0, 0], I, [1, 0.5, 0.3])
    assert not check_small(A, wide, a0[:2], a1[:2])  # semi-axes that change
    half = one([0, 0, 0], np.diag([1.0, -1.0, -1.0]), [1, 0.5, 0.25])
    assert not check_small(a0[:2], a1[:2], A, half)  # a half turn
    near = one([0, 0, 0], Rot.from_rotvec([0, 0, math.pi - 2e-6]).as_matrix(), [1, 0.5, 0.25])
    check_small(a0[:2], a1[:2], A, near)
    for case in (approaching(rng, 16), smallstep_motion(rng, 16), (*random_motion(rng, 16), *random_motion(rng, 16))):
        check_small(*case)


# --- toi_pair ---------------------------------------------------------------------------------------------


def pair_args(arrays, i):
    (Ca0, Ra0, ra), (Ca1, Ra1, Wa), (Cb0, Rb0, rb), (Cb1, Rb1, Wb) = arrays
    sa, sb = int(len(Ca0) > 1), int(len(Cb0) > 1)
    ia, ib = i * sa, i * sb
    return [Ca0[ia], Ra0[ia], Ca1[ia], Ra1[ia], ra[ia], Wa[ia], Cb0[ib], Rb0[ib], Cb1[ib], Rb1[ib], rb[ib], Wb[ib]]


def test_toi_pair_is_a_row_of_the_batch_search():
    """The single-pair search with an oracle (empty, or relations at two times) gives ext.toi's row."""
    rng = np.random.default_rng(29)
    arrays, n = T._check(*approaching(rng, 40))
    A = one([0, 0, 0], I, [1, 0.5, 0.25])
    touch, _ = T._check(A, A, one([1.5, 0, 0], I, [0.5] * 3), one([3, 0, 0], I, [0.5] * 3))
    for arr, m in ((arrays, n), (touch, 1)):
        for ot, orel, oc in (
            (np.zeros(TOI_MAX_ORACLE), np.zeros(TOI_MAX_ORACLE, np.int8), 0),
            (
                np.r_[0.0, 0.3, np.zeros(TOI_MAX_ORACLE - 2)],
                np.r_[1, 0, np.zeros(TOI_MAX_ORACLE - 2)].astype(np.int8),
                2,
            ),
        ):
            OT, OR, OC = np.tile(ot, (m, 1)), np.tile(orel, (m, 1)), np.full(m, oc, np.int64)
            want = check_kernel(arr, m, OT=OT, OR=OR, OC=OC)
            for i in range(m):
                got = X.toi_pair(*pair_args(arr, i), ot, orel, oc)
                row = (float(want[0][i]), int(want[1][i]), float(want[2][i]), int(want[3][i]))
                assert got == row and math.copysign(1, got[0]) == math.copysign(1, row[0]), (i, got, row)


# --- arbitrary floats -------------------------------------------------------------------------------------


def test_arbitrary_floats():
    rng = np.random.default_rng(32)
    n = 500
    arrays = tuple(
        (floats(3 * n, rng).reshape(n, 3), floats(9 * n, rng).reshape(n, 3, 3), floats(3 * n, rng).reshape(n, 3))
        for _ in range(4)
    )
    check_kernel(arrays, n, chunks=(200,))
    # plausible poses with one field at a time arbitrary
    a0, a1 = random_motion(rng, n)
    b0, b1 = random_motion(rng, n)
    base, _ = T._check(a0, a1, b0, b1)
    for body in range(4):
        for field in range(3):
            arrays = [list(x) for x in base]
            x = arrays[body][field]
            arrays[body][field] = np.where(rng.uniform(size=x.shape) < 0.3, floats(x.size, rng).reshape(x.shape), x)
            check_kernel(tuple(tuple(x) for x in arrays), n)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.one_of(finite, st.floats(-2, 2), st.sampled_from([0.0, 0.5, 1.0])), min_size=60, max_size=60), st.data()
)
def test_any_floats(x, data):
    x = np.array(x)
    r = np.array(data.draw(st.lists(st.one_of(positive, st.floats(0.01, 1)), min_size=6, max_size=6)))
    bodies = []
    for k, rk in ((0, r[:3]), (30, r[3:])):
        bodies.append((x[k : k + 3].reshape(1, 3), x[k + 3 : k + 12].reshape(1, 3, 3), rk.reshape(1, 3)))
        bodies.append(
            (
                x[k + 12 : k + 15].reshape(1, 3),
                x[k + 15 : k + 24].reshape(1, 3, 3),
                x[k + 24 : k + 27].reshape(1, 3) * 0.1,
            )
        )
    check_kernel(tuple(tuple(np.ascontiguousarray(a) for a in b) for b in bodies), 1)


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.floats(-2, 2), min_size=12, max_size=12),
    st.lists(st.floats(0.01, 1), min_size=6, max_size=6),
    st.lists(st.floats(-3, 3), min_size=6, max_size=6),
    st.sampled_from([1.0, 2.0**-300, 2.0**300, 1e-9]),
)
def test_any_plausible_motion(c, r, rv, scale):
    """Hypothesis's centres, semi-axes and turns (rotations from rotation vectors) at several scales."""
    c, r, rv = np.array(c) * scale, np.array(r) * scale, np.array(rv).reshape(2, 3)
    R0 = Rot.from_rotvec(rv).as_matrix()
    R1 = (Rot.from_rotvec(rv) * Rot.from_rotvec(rv[::-1] * 0.3)).as_matrix()
    a0, a1 = motion(c[0:3][None], R0[:1], c[3:6][None], R1[:1], r[:3][None])
    b0, b1 = motion(c[6:9][None], R0[1:], c[9:12][None], R1[1:], r[3:][None])
    check(a0, a1, b0, b1)


# --- chunks, threads and the time_of_impact pipeline -------------------------------------------------------------


def test_threads_run_the_cpp_kernel_as_a_drop_in():
    rng = np.random.default_rng(33)
    a0, a1, b0, b1 = approaching(rng, 4500)
    arrays, n = T._check(a0, a1, b0, b1)
    OT, OR, OC = oracle(n)
    want = outputs(n)
    ext.toi(*arrays, np.arange(n), OT, OR, OC, *want, 0, n)
    got = outputs(n)
    with threads.limit(2):
        threads.run(ext.toi, n, True, *arrays, np.arange(n), OT, OR, OC, *got)
    for g, w in zip(got, want):
        assert_same(g, w, "threads")
    toi, status = T.time_of_impact(a0, a1, b0, b1, return_status=True)  # the whole pipeline, rationals included
    ext.resolve_exact(*arrays, OT, OR, OC, *got, 0, n)
    assert_same(got[0], toi, "time_of_impact")
    assert_same(got[1], status, "time_of_impact status")


# --- the binding's refusals --------------------------------------------------------------------------------


def test_the_binding_refuses_what_it_would_read_out_of_bounds():
    rng = np.random.default_rng(34)
    a0, a1 = random_motion(rng, 4)
    b0, b1 = random_motion(rng, 4)
    arrays, n = T._check(a0, a1, b0, b1)
    OT, OR, OC = oracle(n)
    idx = np.arange(n)
    ext.toi(*arrays, idx, OT, OR, OC, *outputs(n), 0, n)
    with pytest.raises(IndexError, match="outside the outputs"):
        ext.toi(*arrays, np.array([0, 4]), OT, OR, OC, *outputs(n), 0, 2)
    with pytest.raises(IndexError, match="outside the outputs"):
        ext.toi(*arrays, np.array([-1]), OT, OR, OC, *outputs(n), 0, 1)  # no wrap-around
    with pytest.raises(IndexError, match="outside the batches"):
        short, _ = T._check(a0[:3], a1[:3], b0[:3], b1[:3])
        ext.toi(*short, idx, OT, OR, OC, *outputs(n), 0, n)
    with pytest.raises(IndexError, match="range outside idx"):
        ext.toi(*arrays, idx, OT, OR, OC, *outputs(n), 0, 5)
    with pytest.raises(ValueError, match="one row per pair"):
        ext.toi(*arrays, idx, OT, OR, OC, *outputs(n)[:3], np.zeros(3, np.int64), 0, n)
    with pytest.raises(ValueError, match="same width"):
        ext.toi(*arrays, idx, OT, OR[:, :4].copy(), OC, *outputs(n), 0, n)
    with pytest.raises(IndexError, match="oracle count"):
        ext.toi(*arrays, idx, OT, OR, np.full(n, 17, np.int64), *outputs(n), 0, n)
    with pytest.raises(ValueError, match="same length"):
        (C0, R0, r), rest = arrays[0], arrays[1:]
        ext.toi((C0, R0, r[:3].copy()), *rest, idx, OT, OR, OC, *outputs(n), 0, n)
    with pytest.raises(TypeError):  # no silent copy: a strided or wrongly typed array is not taken
        ext.toi(*arrays, idx, OT, OR, OC, np.zeros(2 * n)[::2], *outputs(n)[1:], 0, n)
    with pytest.raises(TypeError):
        ext.toi(*arrays, idx.astype(np.int32), OT, OR, OC, *outputs(n), 0, n)
    with pytest.raises(ValueError, match="TOI_MAX_ORACLE"):
        ext.resolve_exact(*arrays, *oracle(n, 8), *outputs(n), 0, n)
    with pytest.raises(ValueError, match="a row per index"):
        ext.float_poses(*arrays, idx, np.zeros(2), *T.float_poses(arrays, idx, np.zeros(n)))
    with pytest.raises(IndexError, match="ocount"):
        X.toi_pair(*pair_args(arrays, 0), np.zeros(2), np.zeros(2, np.int8), 3)
    args = [a for x in (a0, a1, b0, b1) for a in (x.centers, x.rotations, x.radii)]
    args[2] = args[2][:3].copy()
    with pytest.raises(ValueError, match="same length"):  # the kernel would read past ra0
        ext.toi_small(*args)
