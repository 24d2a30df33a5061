"""Contacts between frames (mujoco.between): pairs separated at two consecutive frames that touch in
between, against time_of_impact called directly, a dense sampling of the same motion with exact
classify, and a brute force without the prefilter; then replay, run and compare on the command line,
the JSON and the recording's markers."""

import dataclasses
import json
import math
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

from ellipsim import Ellipsoids, Impact, Relation, classify, time_of_impact
from ellipsim.app import capture, record, scenario, simulate
from ellipsim.app import replay as rp
from ellipsim.core import threads
from ellipsim.core.motion import broad_phase as broadphase
from ellipsim.core.motion.interpolation import poses_at
from ellipsim.mujoco import validate
from ellipsim.mujoco.between import BetweenFrames, Events, swept_pairs
from ellipsim.mujoco.geoms import ellipsoid_geoms
from ellipsim.native import ext

# A thin plate and a small pellet, both free: the pellet's motion is set per frame (replay) or shot
# at 50 m/s through the plate with a 10 ms step (compare): 0.5 m a step through a plate 1 cm thick.
PLATE_XML = """<mujoco model="plate">
  <option timestep="0.01" gravity="0 0 0"/>
  <worldbody>
    <body name="board"><freejoint/><geom name="plate" type="ellipsoid" size=".3 .3 .005"/></body>
    <body name="bullet" pos="0 0 .26"><freejoint/><geom name="pellet" type="ellipsoid" size=".02 .015 .01"/></body>
  </worldbody>
  <keyframe><key name="shot" qpos="0 0 0 1 0 0 0 0 0 .26 1 0 0 0" qvel="0 0 0 0 0 0 0 0 -50 0 0 0"/></keyframe>
</mujoco>"""
FPS = 10.0
SAMPLES = 2001  # instants of the dense check per step


@pytest.fixture(scope="module")
def plate():
    return mujoco.MjModel.from_xml_string(PLATE_XML)


def pellet_motion(zs, tilt=None):
    """qpos (F, 14): the plate at the origin, the pellet at heights zs (a quaternion per frame optional)."""
    q = np.zeros((len(zs), 14))
    q[:, 3] = 1.0
    q[:, 9] = zs
    q[:, 10] = 1.0
    if tilt is not None:
        q[:, 10:14] = tilt
    return q


def poses(model, motion):
    """centres (F, g, 3), rotations (F, g, 3, 3) of the ellipsoid geoms, and the checker's inputs."""
    data = mujoco.MjData(model)
    ids, radii, rules = ellipsoid_geoms(model)
    C, R = [], []
    for q in motion:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        C.append(data.geom_xpos[ids].copy())
        R.append(data.geom_xmat[ids].reshape(-1, 3, 3).copy())
    return np.array(C), np.array(R), radii, rules


def dense(a0, a1, b0, b1, n=SAMPLES):
    """Instants t in [0, 1] (n of them) and exact classify of the float poses there."""
    t = np.linspace(0.0, 1.0, n)
    rep = lambda x: x[np.zeros(n, dtype=np.int64)]  # noqa: E731
    return t, classify(poses_at(rep(a0), rep(a1), t), poses_at(rep(b0), rep(b1), t))


def check_event(C, R, radii, events, e, times):
    """Event e: separated at both frames, time_of_impact's toi directly, the dense samples agree."""
    k, (i, j) = int(events.frame[e]), events.pair[e]
    at = lambda f, g: Ellipsoids(C[f, g], R[f, g], radii[g])  # noqa: E731
    a0, a1, b0, b1 = at(k, i), at(k + 1, i), at(k, j), at(k + 1, j)
    assert classify(a0, b0)[0] == Relation.SEPARATED and classify(a1, b1)[0] == Relation.SEPARATED
    toi, status = time_of_impact(a0, a1, b0, b1, return_status=True)
    assert events.toi[e] == toi[0] and events.status[e] == status[0] and status[0] != Impact.NO_CONTACT
    back = time_of_impact(a1, a0, b1, b0)[0]
    dt = times[k + 1] - times[k]
    assert events.begin[e] == pytest.approx(times[k] + toi[0] * dt, abs=1e-12)
    assert events.end[e] == pytest.approx(times[k] + (1 - back) * dt, abs=1e-12)
    assert times[k] < events.begin[e] <= events.end[e] < times[k + 1]
    t, rel = dense(a0, a1, b0, b1)
    touching = t[rel != Relation.SEPARATED]
    # every instant before toi - TOI_TOL is proven separated, and so is every one after the end
    assert touching.min() >= toi[0] - 1e-9 and touching.max() <= 1 - back + 1e-9
    # the contact lasts more than a sample here: the samples see it, within a sample of toi and the end
    assert touching.min() - toi[0] <= 1 / (SAMPLES - 1) and (1 - back) - touching.max() <= 1 / (SAMPLES - 1)


# --- the checker ---------------------------------------------------------------------------------


def test_a_pellet_through_the_plate_between_two_frames(plate):
    motion = pellet_motion([0.5, 0.26, -0.24, -0.5])  # through the plate between frames 1 and 2
    C, R, radii, rules = poses(plate, motion)
    times = np.arange(len(motion)) / FPS
    events = BetweenFrames(radii, rules).check(np.arange(len(motion)), times, C, R)
    assert len(events) == 1 and events.frame.tolist() == [1] and events.pair.tolist() == [[0, 1]]
    assert events.status[0] == Impact.CONTACT and not events.half_turn[0]
    # first contact when the pellet's bottom (z - 0.01) meets the plate's top (0.005): z = 0.015
    assert events.toi[0] == pytest.approx((0.26 - 0.015) / 0.5, abs=1e-9)
    assert events.begin[0] == pytest.approx(0.1 + 0.49 * 0.1, abs=1e-9)
    assert events.end[0] == pytest.approx(0.1 + (0.26 + 0.015) / 0.5 * 0.1, abs=1e-9)
    np.testing.assert_allclose(events.point[0], [0, 0, 0.005], atol=1e-6)  # where they meet
    check_event(C, R, radii, events, 0, times)


def test_a_turning_limb_sweeps_through_a_ball():
    """Centres at rest, a long ellipsoid turning 80 degrees about z between two frames: a ball at 40
    degrees, clear of it at both frames, is hit in between."""
    radii = np.array([[1.0, 0.02, 0.02], [0.05, 0.05, 0.05]])
    rules = ellipsoid_geoms(
        mujoco.MjModel.from_xml_string(
            "<mujoco><worldbody><body><freejoint/><geom type='ellipsoid' size='1 .02 .02'/></body>"
            "<body><freejoint/><geom type='sphere' size='.05'/></body></worldbody></mujoco>"
        )
    )[2]
    rz = lambda deg: np.array(
        [
            [math.cos(math.radians(deg)), -math.sin(math.radians(deg)), 0],  # noqa: E731
            [math.sin(math.radians(deg)), math.cos(math.radians(deg)), 0],
            [0, 0, 1],
        ]
    )
    ball = 0.5 * np.array([math.cos(math.radians(40)), math.sin(math.radians(40)), 0])
    C = np.array([[[0, 0, 0], ball]] * 3, dtype=float)
    R = np.array([[rz(a), np.eye(3)] for a in (0, 80, 160)])
    times = np.array([0.0, 0.02, 0.04])
    events = BetweenFrames(radii, rules).check(np.arange(3), times, C, R)
    assert events.frame.tolist() == [0] and events.pair.tolist() == [[0, 1]]
    # the limb's axis reaches the ball's edge at 40 - asin(0.07 / 0.5) degrees or so: well inside
    assert 0.3 < events.toi[0] < 0.5
    check_event(C, R, radii, events, 0, times)


def test_no_contact_and_contacts_at_frames_are_not_between_frames(plate):
    C, R, radii, rules = poses(plate, pellet_motion([0.5, 0.4, 0.3, 0.02]))  # approaching, never touching
    assert len(BetweenFrames(radii, rules).check(np.arange(4), np.arange(4) / FPS, C, R)) == 0
    # overlapping at frame 1 (z = 0), then through and out: the frames see it, so no event between
    motion = pellet_motion([0.2, 0.0, -0.2, 0.01, 0.2])  # through, then back into it from below
    C, R, radii, rules = poses(plate, motion)
    rel = classify(
        Ellipsoids(C[:, 0], R[:, 0], np.broadcast_to(radii[0], (5, 3))),
        Ellipsoids(C[:, 1], R[:, 1], np.broadcast_to(radii[1], (5, 3))),
    )
    assert rel.tolist() == [0, 2, 0, 2, 0]  # 0.01 overlaps too: the plate's top is 0.005, the pellet 0.01 tall
    for contacts in (None, np.array([[f, 0, 1] for f in np.flatnonzero(rel)])):  # known or found by toi
        events = BetweenFrames(radii, rules).check(np.arange(5), np.arange(5) / FPS, C, R, contacts)
        assert len(events) == 0


def test_chunks_join_and_a_half_turn_is_unresolved(plate):
    motion = pellet_motion([0.5, 0.26, -0.24, -0.5, -0.26, 0.24, 0.5])  # through and back
    C, R, radii, rules = poses(plate, motion)
    times = np.arange(len(motion)) / FPS
    whole = BetweenFrames(radii, rules).check(np.arange(7), times, C, R)
    assert whole.frame.tolist() == [1, 4]
    checker = BetweenFrames(radii, rules)
    parts = [checker.check(np.arange(a, b), times[a:b], C[a:b], R[a:b]) for a, b in ((0, 2), (2, 3), (3, 7))]
    joined = Events.concatenate(parts)
    for name in ("frame", "pair", "toi", "begin", "end", "status", "point"):
        np.testing.assert_array_equal(getattr(joined, name), getattr(whole, name))
    with pytest.raises(ValueError, match="frames must continue at frame 7, got frame 8"):
        checker.check([8], [0.8], C[:1], R[:1])
    with pytest.raises(
        ValueError,
        match=r"must have shapes \(1, 2, 3\), \(1, 2, 3, 3\) and \(1,\) for 1 frames of 2 geoms, got \(2, 2, 3\)",
    ):
        checker.check([7], [0.7], C[:2], R[:1])
    bad = C.copy()
    bad[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="must be finite, got a non-finite pose of geom 1 at frame 2"):
        BetweenFrames(radii, rules).check(np.arange(7), times, bad, R)
    bad = R.copy()
    bad[2, 1] *= 1.01
    with pytest.raises(
        ValueError, match=r"rotations of geom 1 at frame 2 must be orthonormal: max \|R\^T R - I\| = 0.0201"
    ):
        BetweenFrames(radii, rules).check(np.arange(7), times, C, bad)
    # the pellet turns by exactly pi about x between frames 1 and 2 (while passing the plate): no
    # interpolated motion, reported as a possible contact over the whole step, no error
    flip = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0]], dtype=float)
    motion = pellet_motion([0.5, 0.26, -0.24, -0.5], tilt=flip)
    C, R, radii, rules = poses(plate, motion)
    events = BetweenFrames(radii, rules).check(np.arange(4), np.arange(4) / FPS, C, R)
    assert events.frame.tolist() == [1] and events.half_turn.tolist() == [True]
    assert (
        events.status[0] == Impact.UNRESOLVED and events.status_name(0) == "unresolved (half turn between the frames)"
    )
    assert (events.begin[0], events.end[0]) == (0.1, 0.2)


def test_the_prefilter_drops_no_contact():
    """Random motions of 12 ellipsoids over 30 frames: the events equal those of time_of_impact on
    every pair of every step (no prefilter), separated at both frames by classify."""
    rng = np.random.default_rng(5)
    g, F = 12, 30
    radii = rng.uniform(0.05, 0.3, (g, 3))
    radii[np.arange(g), rng.integers(0, 3, g)] = 0.01  # thin: easy to pass through within a frame
    xml = (
        "<mujoco><worldbody>"
        + "".join(f"<body><freejoint/><geom type='ellipsoid' size='{r[0]} {r[1]} {r[2]}'/></body>" for r in radii)
        + "</worldbody></mujoco>"
    )
    rules = ellipsoid_geoms(mujoco.MjModel.from_xml_string(xml))[2]
    start, amplitude, phase = rng.uniform(-0.4, 0.4, (g, 3)), rng.uniform(0.1, 0.4, (g, 3)), rng.uniform(0, 6, (g, 3))
    C = start[None] + amplitude[None] * np.sin(0.8 * np.arange(F)[:, None, None] + phase[None])  # up to 0.3 m a frame
    q = rng.normal(size=(g, 4)) / 2
    axis, speed = rng.normal(size=(g, 3)), rng.uniform(0, 1.5, g)
    R = np.empty((F, g, 3, 3))
    for f in range(F):
        for k in range(g):
            w = axis[k] / np.linalg.norm(axis[k]) * speed[k] * f
            W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
            th = np.linalg.norm(w)
            E = np.eye(3) + math.sin(th) / th * W + (1 - math.cos(th)) / th**2 * W @ W if th else np.eye(3)
            R[f, k] = Ellipsoids.from_quaternions(np.zeros(3), q[k], np.ones(3)).rotations[0] @ E
    times = np.arange(F) * 0.01
    got = BetweenFrames(radii, rules).check(np.arange(F), times, C, R)
    i, j = np.triu_indices(g, 1)
    s = np.repeat(np.arange(F - 1), len(i))
    i, j = np.tile(i, F - 1), np.tile(j, F - 1)
    at = lambda f, k: Ellipsoids(C[f, k], R[f, k], radii[k])  # noqa: E731
    a0, a1, b0, b1 = at(s, i), at(s + 1, i), at(s, j), at(s + 1, j)
    apart = (classify(a0, b0) == Relation.SEPARATED) & (classify(a1, b1) == Relation.SEPARATED)
    toi = time_of_impact(a0, a1, b0, b1)
    want = np.flatnonzero(apart & np.isfinite(toi))
    assert len(want) >= 5, "the motion should have some contacts between frames"
    assert sorted(zip(got.frame.tolist(), got.pair[:, 0].tolist(), got.pair[:, 1].tolist())) == sorted(
        zip(s[want].tolist(), i[want].tolist(), j[want].tolist())
    )
    # the prefilter does drop most pairs: fewer candidates than pairs; the rules as a matrix or not
    kept = swept_pairs(C, R, radii, rules)
    assert len(kept) < len(s) / 2 and np.array_equal(swept_pairs(C, R, radii, rules, rules.matrix()), kept)


def random_rotations(rng, n):
    return Ellipsoids.from_quaternions(np.zeros((n, 3)), rng.normal(size=(n, 4)), np.ones((n, 3))).rotations


def test_capsules_enclose_their_ellipsoids():
    """Points on the ellipsoids' surfaces (the worst places) lie within the capsule's radius of its
    segment, up to rounding; the long end's tip touches the capsule's end."""
    rng = np.random.default_rng(2)
    radii = np.r_[rng.uniform(0.01, 1.0, (200, 3)), [[1.0, 1.0, 1.0], [1.0, 0.2, 0.2], [0.3, 0.3, 2.0]]]
    axis, half, cap = broadphase.capsules(radii)
    u = rng.normal(size=(len(radii), 500, 3))
    x = radii[:, None] * u / np.linalg.norm(u, axis=2, keepdims=True)  # surface points, body frame
    along = np.take_along_axis(x, axis[:, None, None], axis=2)[..., 0]
    foot = np.clip(along, -half[:, None], half[:, None])
    off = x.copy()
    np.put_along_axis(off, axis[:, None, None], (along - foot)[..., None], axis=2)
    assert (np.linalg.norm(off, axis=2) <= cap[:, None] * (1 + 1e-12)).all()
    assert half[-3:].tolist() == [0.0, 0.8, 1.7] and cap[-3:].tolist() == [1.0, 0.2, 0.3]


def segment_distance(*args):
    """The broad phase's _segment_distance(p0, p1, p2, q0, q1, q2, d10, d11, d12, d20, d21, d22) (broad_phase.hpp)."""
    out = np.empty(1)
    ext.testing.segment_distance(np.array([args], dtype=float), out)
    return float(out[0])


def test_segment_distance_against_dense_sampling():
    rng = np.random.default_rng(4)
    cases = [rng.normal(size=(4, 3)) for _ in range(300)]
    p, d = rng.normal(size=3), rng.normal(size=3)
    cases += [
        np.array([p, p + d, p + [0, 0, 0.1], p + [0, 0, 0.1] + 0.5 * d]),  # parallel
        np.array([p, p + d, p + 1e-9 * rng.normal(size=3), p + d + [1e-8, 0, 0]]),  # nearly parallel
        np.array([p, p, p + d, p + 2 * d]),
        np.array([p, p, p + d, p + d]),
    ]  # a point
    u = np.linspace(0, 1, 401)
    for a0, a1, b0, b1 in cases:
        got = segment_distance(*a0, *b0, *(a1 - a0), *(b1 - b0))
        A = a0 + u[:, None] * (a1 - a0)
        B = b0 + u[:, None] * (b1 - b0)
        dense = np.linalg.norm(A[:, None] - B[None], axis=2).min()
        assert got <= dense + 1e-12  # never above the true distance (a lower bound is what is used)
        assert got >= dense - 0.01 * max(np.linalg.norm(a1 - a0), np.linalg.norm(b1 - b0))  # the grid's spacing


@pytest.mark.parametrize("seed", range(6))
def test_swept_pairs_keep_every_pair_time_of_impact_finds(seed, monkeypatch):
    """Fast thin limbs (turning up to ~110 degrees a step, some more than 120: sphere tests only, and
    spheres, and a few still): every pair that touches at some t of a step by time_of_impact (toi
    finite, touching at the frames included) is kept, and the capsule test drops most of the rest."""
    rng = np.random.default_rng(seed)
    g, F = 24, 8
    radii = rng.uniform(0.02, 0.4, (g, 3))
    radii[:4] = radii[:4, :1]  # spheres
    radii[4:12, 1:] = rng.uniform(0.005, 0.03, (8, 2))  # rods
    C = rng.uniform(-0.5, 0.5, (g, 3))[None] + np.cumsum(rng.normal(scale=0.08, size=(F, g, 3)), axis=0)
    R = np.empty((F, g, 3, 3))
    R[0] = random_rotations(rng, g)
    for f in range(1, F):
        turn = rng.uniform(0, 1.9, g)  # radians
        turn[:3] = rng.choice([0.0, 2.2], 3)  # still, or beyond PLAIN_COS
        w = rng.normal(size=(g, 3))
        w *= (turn / np.linalg.norm(w, axis=1))[:, None]
        R[f] = np.array(
            [
                r
                @ Ellipsoids.from_quaternions(
                    np.zeros(3), np.r_[math.cos(t / 2), math.sin(t / 2) * v / max(t, 1e-300)], np.ones(3)
                ).rotations[0]
                for r, v, t in zip(R[f - 1], w, turn)
            ]
        )
    rho = radii.max(axis=1) * 1.0000153
    got = broadphase.swept_pairs(C, R, radii, rho)
    assert np.all(np.diff(got[:, 0]) >= 0) and np.all(got[:, 1] < got[:, 2])
    i, j = np.triu_indices(g, 1)
    s = np.repeat(np.arange(F - 1), len(i))
    i, j = np.tile(i, F - 1), np.tile(j, F - 1)
    at = lambda f, k: Ellipsoids(C[f, k], R[f, k], radii[k])  # noqa: E731
    toi = time_of_impact(at(s, i), at(s + 1, i), at(s, j), at(s + 1, j))
    want = set(zip(s[np.isfinite(toi)].tolist(), i[np.isfinite(toi)].tolist(), j[np.isfinite(toi)].tolist()))
    have = set(map(tuple, got.tolist()))
    assert len(have) == len(got) and want <= have and len(want) >= 10
    monkeypatch.setattr(broadphase, "BLOCK_ROOM", 1)  # crowded blocks: swept again with room for all
    assert np.array_equal(broadphase.swept_pairs(C, R, radii, rho), got)
    spheres = broadphase.swept_pairs(C, R, np.repeat(rho[:, None], 3, axis=1), rho)  # capsules = the spheres
    assert have <= set(map(tuple, spheres.tolist())) and len(have) < 0.8 * len(spheres)


def test_crossed_rods_turning_are_kept_and_apart_ones_dropped():
    """A rod turning from -10 to +10 degrees about z over a still one crossing it (1 m long, 2 cm
    thick): touching at every t when their axes are 1.9 cm apart in z, kept; 6 cm apart, dropped
    (more than the thickness, the bend 0.49 m tan(10 deg)^2 / 2 = 7.6 mm and the slack, by enough for
    CAPSULE_STEPS advancements at the tips' 17 cm a step), though the bounding spheres overlap."""
    radii = np.array([[0.5, 0.01, 0.01], [0.5, 0.01, 0.01]])
    rz = lambda deg: np.array(
        [
            [math.cos(math.radians(deg)), -math.sin(math.radians(deg)), 0],  # noqa: E731
            [math.sin(math.radians(deg)), math.cos(math.radians(deg)), 0],
            [0, 0, 1],
        ]
    )
    rho = radii.max(axis=1) * 1.0000153
    R = np.array([[rz(-10), rz(90)], [rz(10), rz(90)]])
    for gap, kept in ((0.019, True), (0.06, False)):
        C = np.array([[[0, 0, 0], [0, 0, gap]]] * 2, dtype=float)
        assert len(broadphase.swept_pairs(C, R, radii, rho)) == kept
        assert len(broadphase.swept_pairs(C, R, np.full((2, 3), 0.5), rho)) == 1  # spheres: always
        assert (
            np.isfinite(
                time_of_impact(
                    Ellipsoids(C[0, 0], R[0, 0], radii[0]),
                    Ellipsoids(C[1, 0], R[1, 0], radii[0]),
                    Ellipsoids(C[0, 1], R[0, 1], radii[1]),
                    Ellipsoids(C[1, 1], R[1, 1], radii[1]),
                )
            )[0]
            == kept
        )


# --- replay, run, compare ------------------------------------------------------------------------


def test_replay_reports_and_records_the_contact_between_frames(plate, tmp_path):
    motion = pellet_motion([0.5, 0.26, -0.24, -0.5, -0.4])
    path = tmp_path / "shot.rrd"
    with record.Recorder(path) as recorder:
        result = rp.replay(plate, motion, fps=FPS, recorder=recorder, name="shot", between=True)
    (event,) = result.between_events()
    assert event["geoms"] == ["plate", "pellet"] and event["bodies"] == ["board", "bullet"] and event["frame"] == 1
    assert event["status"] == "contact" and 0.1 < event["t_begin"] < event["t_end"] < 0.2
    assert result.in_contact.sum() == 0  # no frame sees it
    assert rp.replay(plate, motion, fps=FPS).between is None  # not looked for by default
    points, texts = {}, []
    for c in RrdReader(path).stream().to_chunks():
        if c.is_static:
            continue
        batch = c.to_record_batch()
        if c.entity_path == "/world/between_frames":
            for t, pos, label in zip(
                batch.column("time").cast("int64").to_pylist(),
                batch.column("Points3D:positions").to_pylist(),
                batch.column("Points3D:labels").to_pylist(),
            ):
                points[t] = (pos, label)
        if c.entity_path == "/events/between_frames":
            texts += batch.column("TextLog:text").to_pylist()
    begin = round(event["t_begin"] * 1e9)
    assert sorted(points) == [begin, round(0.2 * 1e9)]  # the marker at the first contact, cleared at frame 2
    (pos,), (label,) = points[begin]
    np.testing.assert_allclose(pos, event["point"], atol=1e-6)  # float32 in the file
    assert label == "plate / pellet" and points[round(0.2 * 1e9)] == ([], [])
    assert len(texts) == 1 and "plate / pellet" in texts[0][0] and "frames 1-2" in texts[0][0]


def test_background_checks_equal_the_inline_ones(plate, monkeypatch):
    """FrameBuffer(background=True): the same events as the inline check, which is given the touching
    pairs at the frames (the background one classifies the ends itself), in chunks of 3 frames
    handed over 2 at a time (the step from one hand-over into the next is checked too)."""
    monkeypatch.setattr(capture, "MAX_CHUNK_FRAMES", 3)
    monkeypatch.setattr(capture, "BETWEEN_STRIDE", 2)
    motion = pellet_motion([0.5, 0.26, -0.24, -0.5, -0.26, 0.24, 0.5, 0.01, 0.3])  # through, back, into it at a frame
    data = mujoco.MjData(plate)
    found, workers = {}, []
    check = capture.FrameBuffer._check
    monkeypatch.setattr(
        capture.FrameBuffer, "_check", lambda self, *args: workers.append(threads.workers()) or check(self, *args)
    )
    for background in (False, True):
        buffer = capture.FrameBuffer(plate, between=True, background=background)
        chunks = []
        with threads.limit(1):  # the caller's limit holds on the buffer's thread too
            for f, q in enumerate(motion):
                data.qpos[:] = q
                mujoco.mj_fwdPosition(plate, data)
                if buffer.add(data, f / FPS):
                    chunks.append(buffer.flush())
            chunks = [c for c in chunks + [buffer.flush()] if c is not None]
        found[background] = Events.concatenate(
            [c.events for c in chunks] if not background else buffer.collect(wait=True)
        )
        assert all((c.events is None) == background for c in chunks)
        buffer.close()
    assert found[False].frame.tolist() == [1, 4] and workers and set(workers) == {1}
    for f in dataclasses.fields(Events):
        np.testing.assert_array_equal(getattr(found[True], f.name), getattr(found[False], f.name))


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "ellipsim", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.slow
def test_replay_and_compare_on_the_command_line(tmp_path):
    xml = tmp_path / "plate.xml"
    xml.write_text(PLATE_XML)
    np.save(tmp_path / "m.npy", pellet_motion([0.5, 0.26, -0.24, -0.5]))
    proc = cli(
        "replay",
        str(xml),
        str(tmp_path / "m.npy"),
        "--fps",
        str(FPS),
        "--json",
        str(tmp_path / "r.json"),
        "--between-frames",
    )
    assert proc.returncode == 0, proc.stderr
    assert (
        "contacts between frames (separated at two consecutive frames, touching in between on the interpolated motion): 1"
        in proc.stdout
    )
    assert (
        "frames 1-2: geoms plate / pellet (bodies board / bullet) touch from 0.149 s to 0.155 s (contact)"
        in proc.stdout
    )
    (event,) = json.loads((tmp_path / "r.json").read_text())["between_frames"]
    assert event["geoms"] == ["plate", "pellet"] and event["frame"] == 1 and event["status"] == "contact"
    assert event["t_begin"] == pytest.approx(0.149) and event["t_end"] == pytest.approx(0.155)
    proc = cli("replay", str(xml), str(tmp_path / "m.npy"), "--json", str(tmp_path / "n.json"), "--no-between-frames")
    assert proc.returncode == 0 and "between two frames: not looked for (--between-frames)" in proc.stdout
    assert json.loads((tmp_path / "n.json").read_text())["between_frames"] is None
    proc = cli("replay", str(xml), str(tmp_path / "m.npy"), "--fps", str(FPS), "--json", str(tmp_path / "d.json"))
    assert (
        proc.returncode == 0 and len(json.loads((tmp_path / "d.json").read_text())["between_frames"]) == 1
    )  # on by default
    proc = cli(
        "compare", str(xml), "--key", "shot", "--steps", "4", "--json", str(tmp_path / "c.json"), "--between-frames"
    )
    assert proc.returncode == 0, proc.stderr
    assert (
        "steps 0-1: geoms plate / pellet (bodies board / bullet) touch from 0.0049 s to 0.0055 s (contact)"
        in proc.stdout
    )
    (event,) = json.loads((tmp_path / "c.json").read_text())["passed_through"]
    assert event["step"] == 0 and event["bodies"] == ["board", "bullet"]
    proc = cli(
        "compare", str(xml), "--key", "shot", "--steps", "4", "--json", str(tmp_path / "d.json"), "--no-between-frames"
    )
    assert proc.returncode == 0 and json.loads((tmp_path / "d.json").read_text())["passed_through"] is None


def test_compare_finds_the_pellet_shot_through_the_plate(plate):
    """A simulation: separated at both steps by classify, in contact in between by time_of_impact."""
    data = mujoco.MjData(plate)
    mujoco.mj_resetDataKeyframe(plate, data, 0)
    v = validate(plate, data, 6, between=True)
    assert v.counts[:, 0].sum() == 0  # MuJoCo never sees a contact: the pellet tunnels
    events = v.passed_through
    assert events.frame.tolist() == [0] and v.ellipsoid_ids[events.pair[0]].tolist() == [
        plate.geom("plate").id,
        plate.geom("pellet").id,
    ]
    mujoco.mj_resetDataKeyframe(plate, data, 0)  # the same steps again, for the poses
    frames = []
    for _ in range(6):
        mujoco.mj_forward(plate, data)
        frames.append(data.qpos.copy())
        mujoco.mj_step(plate, data)
    C, R, radii, _ = poses(plate, np.array(frames))
    check_event(C, R, radii, events, 0, np.arange(6) * plate.opt.timestep)
    assert validate(plate, data, 2).passed_through is None  # not looked for by default


@pytest.mark.slow
def test_a_kinematic_scenario_run_looks_between_its_frames():
    s = scenario.load("replay")
    run = simulate.run(s, steps=60, between=True)
    assert isinstance(run.between, list) and run.between_candidates > 0
    for d in run.between:
        assert d["frame"] * s.timestep < d["t_begin"] <= d["t_end"] < (d["frame"] + 1) * s.timestep + 1e-12
    assert simulate.run(s, steps=5).between is None
