"""core/motion/broad_phase.py on its own: sweep_and_prune (bounding spheres per frame) and swept_pairs
(between consecutive frames), each against an O(n^2) numpy brute force written here.

sweep_and_prune: the pairs (f, i, j), i < j, with |c_i - c_j| <= rho_i + rho_j, found by testing every pair
(pairs within 1e-12 of the boundary may go either way; exactly tangent dyadic spheres must be found), on random
scenes and degenerate ones: coincident centres, every body in one spot (more pairs than the first buffer),
bodies in a line along each axis, huge and tiny scales, frames with 0 or 1 bodies.

swept_pairs (a necessary condition: no pair that touches during a step may be missed):
* spheres (radii = rho): the pair touches during the step iff the centres' straight paths come within
  rho_i + rho_j, the closest approach written out here; the output must be that set, up to rounding room;
* ellipsoids turning (scipy's Rotation for R0 exp(t log(R0^T R1))): a pair with a sampled point inside both at
  a sampled t must be kept; every kept pair passes the swept-sphere brute force;
* zero-length motion, coincident centres, tunnelling through each other within one step, power-of-two
  scalings (exact in floats: the same output), `allowed` as a matrix and as a callable, F or g below 2.
"""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation as Rot

from ellipsim.core.motion import broad_phase as bp
from ellipsim.native import ext

BOUNDARY = 1e-12  # relative room around |d| = rho_i + rho_j where rounding may decide either way


# --- references ------------------------------------------------------------------------------------


def sphere_pairs(centers, rho):
    """(sure, maybe): the sets of (f, i, j) whose spheres overlap by more than the rounding room, and those
    within it of overlapping (sure is a subset of maybe), by testing every pair."""
    sure, maybe = set(), set()
    g = centers.shape[1]
    i, j = np.triu_indices(g, 1)
    r = rho[i] + rho[j]
    for f in range(centers.shape[0]):
        d = np.linalg.norm(centers[f, i] - centers[f, j], axis=1)
        sure |= {(f, int(a), int(b)) for a, b in zip(i[d <= r * (1 - BOUNDARY)], j[d <= r * (1 - BOUNDARY)])}
        maybe |= {(f, int(a), int(b)) for a, b in zip(i[d <= r * (1 + BOUNDARY)], j[d <= r * (1 + BOUNDARY)])}
    return sure, maybe


def closest_approach(centers):
    """(F - 1, g, g): min over t in [0, 1] of |(c_j - c_i)(t)| with both centres moving linearly over each step."""
    d0 = centers[:-1, None, :, :] - centers[:-1, :, None, :]
    d1 = centers[1:, None, :, :] - centers[1:, :, None, :]
    e = d1 - d0
    ee = np.einsum("...k,...k", e, e)
    t = np.clip(-np.einsum("...k,...k", d0, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    return np.linalg.norm(d0 + t[..., None] * e, axis=-1)


def swept_sphere_pairs(centers, rho, slack):
    """The set of (step, i, j), i < j, whose centres come within (rho_i + rho_j)(1 + slack) during the step."""
    ca = closest_approach(centers)
    g = centers.shape[1]
    i, j = np.triu_indices(g, 1)
    r = (rho[i] + rho[j]) * (1 + slack)
    out = set()
    for s in range(centers.shape[0] - 1):
        hit = ca[s, i, j] <= r
        out |= {(s, int(a), int(b)) for a, b in zip(i[hit], j[hit])}
    return out


def as_set(pairs):
    got = {tuple(int(x) for x in p) for p in pairs}
    assert len(got) == len(pairs)  # each pair once
    return got


def check_layout(pairs):
    assert pairs.dtype == np.int64 and pairs.ndim == 2 and pairs.shape[1] == 3
    assert np.all(np.diff(pairs[:, 0]) >= 0) and np.all(pairs[:, 1] < pairs[:, 2])


def random_rotations(rng, n):
    return Rot.random(n, random_state=rng).as_matrix()


# --- sweep_and_prune -------------------------------------------------------------------------------


def check_sweep(centers, rho):
    pairs = bp.sweep_and_prune(np.ascontiguousarray(centers, dtype=np.float64), np.asarray(rho, dtype=np.float64))
    check_layout(pairs)
    got = as_set(pairs)
    sure, maybe = sphere_pairs(centers, rho)
    assert sure <= got <= maybe, (sorted(sure - got)[:5], sorted(got - maybe)[:5])
    return got


@pytest.mark.parametrize("seed", range(8))
def test_sweep_and_prune_is_the_brute_force_on_random_scenes(seed):
    rng = np.random.default_rng(seed)
    F, g = 4, int(rng.integers(2, 80))
    centers = rng.uniform(-1, 1, (F, g, 3)) * rng.permutation([0.1, 1.0, 4.0])
    rho = rng.uniform(0.01, 0.5, g) * rng.choice([1.0, 3.0], g)  # mixed sizes: long intervals in the sweep
    got = check_sweep(centers, rho)
    assert len(got) > 0


@pytest.mark.parametrize("axis", range(3))
def test_sweep_and_prune_bodies_in_a_line(axis):
    """Bodies along one axis, touching neighbours exactly (dyadic centres and radii): every touching pair kept,
    whatever the sweep axis."""
    g = 33
    centers = np.zeros((2, g, 3))
    centers[0, :, axis] = np.arange(g) * 0.5  # neighbours 0.5 apart, radii 0.25: tangent
    centers[1, :, axis] = np.arange(g) * 0.75  # 0.75 apart: separated by 0.25
    rho = np.full(g, 0.25)
    got = check_sweep(centers, rho)
    assert got == {(0, k, k + 1) for k in range(g - 1)}


def test_sweep_and_prune_exactly_tangent_spheres_off_axis():
    """Centres (3, 4, 12) / 8 apart (13 / 8 exactly), radii 1 and 5/8: tangent in exact arithmetic and in floats."""
    d = np.array([3.0, 4.0, 12.0]) / 8
    centers = np.array([[[0.0, 0.0, 0.0], d], [[0.0, 0.0, 0.0], d * (1 + 2.0**-40)]])
    got = bp.sweep_and_prune(centers, np.array([1.0, 0.625]))
    assert as_set(got) == {(0, 0, 1)}


def test_sweep_and_prune_all_in_one_spot_and_coincident_centres():
    """Every body at one point: all g (g - 1) / 2 pairs of every frame, more than the first buffer of 1024."""
    g, F = 50, 3
    centers = np.zeros((F, g, 3)) + np.array([0.3, -2.0, 7.0])
    rho = np.random.default_rng(3).uniform(1e-9, 1.0, g)
    got = check_sweep(centers, rho)
    assert len(got) == F * g * (g - 1) // 2
    centers = np.random.default_rng(4).uniform(-3, 3, (F, g, 3))
    centers[:, 1::2] = centers[:, ::2]  # coincident in pairs, far from the rest
    got = check_sweep(centers, np.full(g, 1e-3))
    assert {(f, k, k + 1) for f in range(F) for k in range(0, g, 2)} <= got


@pytest.mark.parametrize("scale", [2.0**-400, 2.0**-60, 2.0**60, 2.0**450])
def test_sweep_and_prune_huge_and_tiny_scenes(scale):
    """A power-of-two scaling is exact: the same pairs, and the brute force's."""
    rng = np.random.default_rng(5)
    centers = rng.uniform(-1, 1, (3, 40, 3))
    rho = rng.uniform(0.05, 0.4, 40)
    base = bp.sweep_and_prune(centers, rho)
    scaled = bp.sweep_and_prune(centers * scale, rho * scale)
    np.testing.assert_array_equal(scaled, base)
    assert as_set(base) == check_sweep(centers, rho)


def test_sweep_and_prune_empty_and_single_body_frames():
    for F, g in ((0, 0), (0, 5), (3, 0), (3, 1)):
        pairs = bp.sweep_and_prune(np.zeros((F, g, 3)), np.ones(g))
        assert pairs.shape == (0, 3) and pairs.dtype == np.int64
    centers = np.zeros((2, 2, 3))
    centers[1, 1] = [0.0, 0.0, 3.0]
    assert as_set(bp.sweep_and_prune(centers, np.ones(2))) == {(0, 0, 1)}  # frame 1: apart


# --- swept_pairs -----------------------------------------------------------------------------------


def random_walk(rng, F, g, box=1.0, step=0.1):
    return rng.uniform(-box, box, (g, 3))[None] + np.cumsum(rng.normal(scale=step, size=(F, g, 3)), axis=0)


def still_rotations(F, g):
    return np.broadcast_to(np.eye(3), (F, g, 3, 3)).copy()


@pytest.mark.parametrize("seed", range(4))
def test_swept_pairs_of_spheres_are_the_closest_approach_brute_force(seed):
    """Spheres: the capsules are the spheres, so the kept pairs are those whose centres come within rho_i + rho_j
    during the step, no more (up to rounding room), no fewer; turning spheres are the same spheres."""
    rng = np.random.default_rng(seed)
    F, g = 9, 30
    C = random_walk(rng, F, g, step=0.15)
    rho = rng.uniform(0.03, 0.3, g)
    radii = np.repeat(rho[:, None], 3, axis=1)
    R = np.stack([random_rotations(rng, g) for _ in range(F)])  # any turn: a sphere is a sphere
    got = bp.swept_pairs(C, R, radii, rho)
    check_layout(got)
    have = as_set(got)
    want = swept_sphere_pairs(C, rho, -BOUNDARY)
    assert want <= have <= swept_sphere_pairs(C, rho, BOUNDARY)
    assert len(want) >= 20


def test_swept_pairs_keep_tunnelling_spheres():
    """Two small spheres swapping places within one step (far apart at both frames) touch in between."""
    C = np.array([[[-5.0, 0.0, 0.0], [5.0, 0.1, 0.0]], [[5.0, 0.0, 0.0], [-5.0, 0.1, 0.0]]])
    rho = np.array([0.1, 0.1])
    got = bp.swept_pairs(C, still_rotations(2, 2), np.repeat(rho[:, None], 3, axis=1), rho)
    assert as_set(got) == {(0, 0, 1)}
    C[:, 1, 1] = 0.3  # passing 0.3 apart: never within 0.2
    assert len(bp.swept_pairs(C, still_rotations(2, 2), np.repeat(rho[:, None], 3, axis=1), rho)) == 0


def motion_at(C, R, t):
    """Centres (g, 3) and rotations (g, 3, 3) at t of each body's step: c0 + t (c1 - c0), R0 exp(t log(R0^T R1))."""
    w = Rot.from_matrix(np.einsum("gji,gjk->gik", R[0], R[1])).as_rotvec()
    return C[0] + t * (C[1] - C[0]), (Rot.from_matrix(R[0]) * Rot.from_rotvec(t * w)).as_matrix()


def touching_by_sampling(C, R, radii, ts, m, rng):
    """(step, i, j) with a point inside both found among m points sampled in A at some t of ts: they overlap."""
    F, g = C.shape[0], C.shape[1]
    u = rng.normal(size=(m, 3))
    u *= (rng.uniform(0, 1, m) ** (1 / 3) / np.linalg.norm(u, axis=1))[:, None]  # uniform in the unit ball
    out = set()
    i, j = np.triu_indices(g, 1)
    for s in range(F - 1):
        for t in ts:
            c, Rt = motion_at(C[s : s + 2], R[s : s + 2], t)
            near = np.linalg.norm(c[i] - c[j], axis=1) < radii[i].max(axis=1) + radii[j].max(axis=1)
            for a, b in zip(i[near], j[near]):
                if (s, a, b) in out:
                    continue
                x = c[a] + (u * radii[a]) @ Rt[a].T  # points of A
                y = ((x - c[b]) @ Rt[b]) / radii[b]
                if np.any(np.einsum("mk,mk->m", y, y) < 1.0):
                    out.add((s, int(a), int(b)))
    return out


@pytest.mark.parametrize("seed", range(3))
def test_swept_pairs_keep_every_pair_found_overlapping_in_between(seed):
    """Turning ellipsoids (rods, plates, spheres; up to ~110 degrees a step): every pair with a sampled point
    inside both at a sampled instant is kept, and every kept pair passes the swept-sphere brute force."""
    rng = np.random.default_rng(100 + seed)
    F, g = 6, 14
    radii = rng.uniform(0.05, 0.45, (g, 3))
    radii[:3] = radii[:3, :1]
    radii[3:8, 1:] = rng.uniform(0.01, 0.04, (5, 2))
    C = random_walk(rng, F, g, box=0.7, step=0.12)
    R = np.empty((F, g, 3, 3))
    R[0] = random_rotations(rng, g)
    for f in range(1, F):
        v = rng.normal(size=(g, 3))
        v *= (rng.uniform(0, 1.9, g) / np.linalg.norm(v, axis=1))[:, None]
        R[f] = (Rot.from_matrix(R[f - 1]) * Rot.from_rotvec(v)).as_matrix()
    rho = radii.max(axis=1)
    got = bp.swept_pairs(C, R, radii, rho)
    check_layout(got)
    have = as_set(got)
    must = touching_by_sampling(C, R, radii, np.linspace(0, 1, 17), 3000, rng)
    assert must <= have, sorted(must - have)[:5]
    assert have <= swept_sphere_pairs(C, rho, BOUNDARY)
    assert len(must) >= 8


def test_swept_pairs_zero_length_motion_is_the_per_frame_sweep():
    """Bodies that do not move: the kept sphere pairs of each step are the overlapping pairs of its frame."""
    rng = np.random.default_rng(7)
    g, F = 40, 6
    C = np.broadcast_to(rng.uniform(-1, 1, (g, 3)), (F, g, 3)).copy()
    rho = rng.uniform(0.05, 0.3, g)
    got = bp.swept_pairs(C, still_rotations(F, g), np.repeat(rho[:, None], 3, axis=1), rho)
    sure, maybe = sphere_pairs(C[:-1], rho)
    assert sure <= as_set(got) <= maybe and len(sure) > 0


def test_swept_pairs_all_in_one_spot():
    """Every body at one point at every frame, more pairs than each block's first room: all pairs, every step."""
    g, F = 40, 7
    C = np.zeros((F, g, 3)) + np.array([1.0, 2.0, 3.0])
    rng = np.random.default_rng(8)
    radii = rng.uniform(0.01, 0.5, (g, 3))
    R = np.stack([random_rotations(rng, g) for _ in range(F)])
    got = bp.swept_pairs(C, R, radii, radii.max(axis=1))
    i, j = np.triu_indices(g, 1)
    assert as_set(got) == {(s, int(a), int(b)) for s in range(F - 1) for a, b in zip(i, j)}
    assert g * (g - 1) // 2 > bp.BLOCK_ROOM * g / 2  # the crowded-block rerun was needed


def point_segment(x, q, d):
    t = np.clip(np.dot(x - q, d) / max(np.dot(d, d), 1e-300), 0.0, 1.0)
    return np.linalg.norm(x - q - t * d)


def segment_distance_reference(p, d1, q, d2):
    """min over s of the point-segment distance (convex in s): a dense grid, then a bounded scalar minimisation."""
    h = lambda s: point_segment(p + s * d1, q, d2)  # noqa: E731
    grid = np.linspace(0, 1, 201)
    k = int(np.argmin([h(s) for s in grid]))
    res = minimize_scalar(h, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, 200)]), method="bounded",
                          options={"xatol": 1e-13})  # fmt: skip
    return min(res.fun, h(grid[k]), point_segment(q, p, d1), point_segment(q + d2, p, d1))


def random_segments(rng, n):
    out = []
    for k in range(n):
        p, d1, q, d2 = rng.normal(size=(4, 3))
        if k % 5 == 1:
            d2 = d1 * rng.uniform(-2, 2)  # parallel
        elif k % 5 == 2:
            d1 = np.zeros(3)  # a point
        elif k % 5 == 3:
            d1, d2 = np.zeros(3), np.zeros(3)
        out.append((p, d1, q, d2))
    return out


def segment_distance(*args):
    """The broad phase's _segment_distance(p0, p1, p2, q0, q1, q2, d10, d11, d12, d20, d21, d22) (broad_phase.hpp)."""
    out = np.empty(1)
    ext.testing.segment_distance(np.array([args], dtype=float), out)
    return float(out[0])


def seg(p, d1, q, d2, scale=1.0):
    return segment_distance(*(p * scale), *(q * scale), *(d1 * scale), *(d2 * scale)) / scale


def test_segment_distance_against_a_minimisation():
    for p, d1, q, d2 in random_segments(np.random.default_rng(11), 200):
        ref = segment_distance_reference(p, d1, q, d2)
        assert abs(seg(p, d1, q, d2) - ref) <= 1e-7 * (1 + ref), (p, d1, q, d2)
        for scale in (2.0**-200, 2.0**200):
            assert seg(p, d1, q, d2, scale) == seg(p, d1, q, d2)  # exact power-of-two scaling


@pytest.mark.parametrize("scale", [2.0**-300, 2.0**300])
def test_segment_distance_of_extreme_segments(scale):
    """Crossing segments 0.1 apart, scaled by 2^-+300: still 0.1 apart (the float path's range is 2^-+500)."""
    p, d1, q, d2 = np.array([-1.0, 0, 0]), np.array([2.0, 0, 0]), np.array([0.5, -1, 0.1]), np.array([0, 2.0, 0])
    assert seg(p, d1, q, d2) == pytest.approx(0.1, rel=1e-15)
    assert seg(p, d1, q, d2, scale) == pytest.approx(0.1, rel=1e-15)


def scaled_scene():
    """Sixteen ellipsoids wandering and turning (0.4 rad a step from frame 3 on)."""
    rng = np.random.default_rng(9)
    F, g = 6, 16
    radii = rng.uniform(0.05, 0.4, (g, 3))
    C = random_walk(rng, F, g, box=0.6, step=0.1)
    R = np.stack([random_rotations(rng, g)] * F)
    R[3:] = (Rot.from_matrix(R[2]) * Rot.from_rotvec(rng.normal(scale=0.4, size=(g, 3)))).as_matrix()
    return C, R, radii, radii.max(axis=1)


@pytest.mark.parametrize("scale", [2.0**-200, 2.0**-30, 2.0**30, 2.0**200])
def test_swept_pairs_scale_exactly(scale):
    """A power-of-two scaling is exact in floats: the same pairs."""
    C, R, radii, rho = scaled_scene()
    base = bp.swept_pairs(C, R, radii, rho)
    np.testing.assert_array_equal(bp.swept_pairs(C * scale, R, radii * scale, rho * scale), base)
    assert len(base) > 0


@pytest.mark.parametrize("scale", [2.0**-300, 2.0**300])
def test_swept_pairs_keep_touching_pairs_of_extreme_scenes(scale):
    """Scenes scaled by 2^-+300 (inside classify's 2^-+500 range): every pair found overlapping in between is kept."""
    C, R, radii, rho = scaled_scene()
    must = touching_by_sampling(C, R, radii, np.linspace(0, 1, 33), 20000, np.random.default_rng(1))
    assert len(must) > 0
    have = as_set(bp.swept_pairs(C * scale, R, radii * scale, rho * scale))
    assert must <= have, sorted(must - have)


def test_swept_pairs_allowed_matrix_and_callable_filter():
    rng = np.random.default_rng(10)
    F, g = 7, 20
    C = random_walk(rng, F, g, box=0.5)
    rho = rng.uniform(0.1, 0.3, g)
    radii = np.repeat(rho[:, None], 3, axis=1)
    R = still_rotations(F, g)
    allowed = rng.uniform(size=(g, g)) < 0.5
    allowed = allowed | allowed.T
    every = bp.swept_pairs(C, R, radii, rho)
    want = every[allowed[every[:, 1], every[:, 2]]]
    assert 0 < len(want) < len(every)
    np.testing.assert_array_equal(bp.swept_pairs(C, R, radii, rho, allowed), want)
    np.testing.assert_array_equal(bp.swept_pairs(C, R, radii, rho, lambda i, j: allowed[i, j]), want)
    with pytest.raises(ValueError, match=r"allowed must be a \(20, 20\) matrix or a callable, got shape \(3, 3\)"):
        bp.swept_pairs(C, R, radii, rho, np.ones((3, 3), dtype=bool))


def test_swept_pairs_fewer_than_two_frames_or_bodies():
    for F, g in ((0, 4), (1, 4), (5, 0), (5, 1)):
        out = bp.swept_pairs(np.zeros((F, g, 3)), still_rotations(F, g), np.ones((g, 3)), np.ones(g))
        assert out.shape == (0, 3) and out.dtype == np.int64
