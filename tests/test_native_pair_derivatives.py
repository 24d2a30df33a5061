"""The C++ pairs/derivatives.hpp (issue 46): shape_derivatives' behaviour, broadcasting, ranges and refusals.

shape_derivatives (ext.shape_derivatives, the kernel under shape_distance(..., derivatives=True)) at the normals
and statuses of the narrow phase (the public shape_distance) on capsules, boxes and cylinders: on the capsule,
box and cylinder tests' poses, coaxial spheroids and test_shape_derivatives' random poses every feature (face,
edge, vertex, side, end, cap, rim) is reached; the hand-picked cases of test_shape_derivatives (a ball over a
cube's edge: ONE_SIDED on a face; a circle of maxima: FLAT; a ball at a cylinder's cap edge: ONE_SIDED;
unproven maxima: UNPROVEN and NaN) give their statuses; every sample set, normals on the kinks and anywhere,
hypothesis's random poses and arbitrary finite floats give statuses and features in range (the same bits
twice).  A batch of one broadcasts, a range writes only its slice, chunks on threads give the serial bits; the
refusals; the codes against the public enums.  (Against references: tests/test_shape_derivatives.py.)
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import as_shapes, assert_same_bits, finite, pose_args, positive, quaternion, rotation, size
from scipy.spatial.transform import Rotation as Rot

import ellipsim.native as native
from ellipsim import ContactFeature, DerivativeStatus, Ellipsoids
from ellipsim.core import samples, threads
from ellipsim.core.pairs import shape_distance as sd
from ellipsim.core.samples import random_ellipsoids

ext = native.ext
T = ext.testing
KINDS = ("capsule", "box", "cylinder")
FEATURES = {"capsule": ("SIDE", "END"), "box": ("FACE", "EDGE", "VERTEX"), "cylinder": ("SIDE", "CAP", "RIM")}


def narrow_phase(args, kind):
    """The narrow phase's normals and proven flags (the public shape_distance)."""
    with np.errstate(all="ignore"):
        dist, normal, pos, status = sd.shape_distance(Ellipsoids(*args[:3]), kind, *args[3:])
    return np.ascontiguousarray(normal), status == 0


def derivatives(kernel, args, code, normal, proven, lo=0, hi=None):
    n = len(normal)
    out = (
        np.full((n, 18), 7.0),
        np.full((n, 3, 18), 7.0),
        np.full((n, 3, 18), 7.0),
        np.full(n, 7, np.int8),
        np.full(n, 7, np.int8),
    )
    with np.errstate(all="ignore"):
        kernel(*args, code, normal, proven, *out, lo, n if hi is None else hi)
    return out


NAMES = ("grad", "jn", "jp", "status", "feature")


def shape_derivatives(args, kind, normal=None, proven=None, lo=0, hi=None):
    """ext.shape_derivatives at the narrow phase's normals (or those given) in [lo, hi): statuses and features in
    range there, the same bits twice, the rest of the outputs left alone; returns the outputs."""
    if normal is None:
        normal, p = narrow_phase(args, kind)
        proven = p if proven is None else proven
    code = KINDS.index(kind)
    got = derivatives(ext.shape_derivatives, args, code, normal, proven, lo, hi)
    for g, w, name in zip(got, derivatives(ext.shape_derivatives, args, code, normal, proven, lo, hi), NAMES):
        assert_same_bits(g, w, f"{kind} {name} twice")
    hi = len(normal) if hi is None else hi
    assert set(got[3][lo:hi].tolist()) <= {int(s) for s in DerivativeStatus}, kind
    assert set(got[4][lo:hi].tolist()) <= {int(ContactFeature[f]) for f in FEATURES[kind]}, kind
    for x, fill in zip(got, derivatives(lambda *a: None, args, code, normal, proven)):
        assert_same_bits(x[:lo], fill[:lo], "before lo")
        assert_same_bits(x[hi:], fill[hi:], "after hi")
    return got


def reached(outs, kind):
    """The features and statuses the outputs hold, by name."""
    feature = np.concatenate([o[4] for o in outs])
    status = np.concatenate([o[3] for o in outs])
    return {ContactFeature(f).name for f in np.unique(feature)}, {DerivativeStatus(s).name for s in np.unique(status)}


# --- the narrow phase's own test poses ---------------------------------------------------------------------


def shape_poses(kind, n, seed, spread=1.5):
    """test_shape_derivatives' poses: random ellipsoids near the origin and bodies of `kind` at it."""
    rng = np.random.default_rng(seed)
    e = random_ellipsoids(rng, n, box=spread, radii=(0.2, 1.0))
    k = random_ellipsoids(rng, n, box=0.0, radii=(0.2, 1.0))
    sizes = k.radii.copy()
    if kind != "box":
        sizes[:, 2] = 0.0
    return dict(cE=e.centers, RE=e.rotations, rE=e.radii, cK=k.centers, RK=k.rotations, sK=sizes)


def kind_poses(kind):
    """The kind's test poses (test_capsule, test_box, test_cylinder: every category), coaxial spheroids (capsule,
    cylinder: circles of maxima), test_shape_derivatives' random poses, and for boxes float32 rotations."""
    from pair_types import coaxial_poses

    module = {"capsule": "test_capsule", "box": "test_box", "cylinder": "test_cylinder"}[kind]
    make_poses = __import__(module).make_poses
    P = make_poses(seed=0, per=40)[0]
    sets = [P, shape_poses(kind, 600, seed=sum(map(ord, kind)))]
    if kind == "box":
        sets.append({k: (v.astype(np.float32).astype(float) if k in ("RE", "RK") else v) for k, v in P.items()})
    else:
        sets += [coaxial_poses(0, 100), coaxial_poses(1, 100)]
    return sets


@pytest.mark.parametrize("kind", KINDS)
def test_the_narrow_phase_test_poses_reach_every_feature(kind):
    outs = [shape_derivatives(pose_args(P), kind) for P in kind_poses(kind)]
    features, statuses = reached(outs, kind)
    assert features == set(FEATURES[kind]), features
    assert {"SMOOTH", "BRANCH"} <= statuses, statuses


SETS = [
    ("generic", lambda: samples.generic_pairs(300, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(300, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 60, seed=5)) for c in samples.STRESS]


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_every_sample_set_as_capsules_boxes_and_cylinders(label, make):
    """Near tangency to 1e-15, spheres and coaxial spheroids, identical and contained bodies, aspects to 1e4,
    offsets to 1e7 and scales from 1e-6 to 1e6 (unit_scale's powers of two)."""
    P = as_shapes(*make())
    for kind in KINDS:
        shape_derivatives(pose_args(P), kind)


# --- hand-picked cases: every status ---------------------------------------------------------------------


I3 = np.eye(3)


def one(cE, rE, cK, sK, RE=I3, RK=I3):
    return dict(cE=[cE], RE=[RE], rE=[rE], cK=[cK], RK=[RK], sK=[sK])


def stack(*poses):
    return {k: np.concatenate([np.asarray(p[k], float) for p in poses]) for k in poses[0]}


def hand_picked():
    """(kind, poses): test_shape_derivatives' ball over a cube's edge (ONE_SIDED on a face) and inside its top face
    (SMOOTH), over a vertex and a hair off it; its circle of maxima (FLAT, a cylinder's side); test_capsule's and
    test_cylinder's hand-picked ends, caps and sides; a ball centred on a cylinder's rim and its cap's edge; concentric
    bodies; the degenerate poses of test_native_pairs."""
    from test_native_pairs import _degenerate_poses

    R = Rot.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()
    Ry = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    ball = [0.5, 0.5, 0.5]
    box = [one([x, 0.0, 2.0], ball, [0, 0, 0], [1, 1, 1]) for x in (1.0, 1.0 - 1e-12, 1.0 + 1e-12, 0.5, 0.0, 2.0)]
    box += [one([x, x, 2.0], ball, [0, 0, 0], [1, 1, 1]) for x in (1.0, 1.5, 2.0)]
    box += [one([2.0, 2.0, 2.0], ball, [0, 0, 0], [1, 1, 1]), one([0, 0, 0], [0.3, 0.2, 0.1], [0, 0, 0], [1, 1, 1])]
    box += [one([0.1, 0.2, 0.3], [0.3, 0.2, 0.1], [0.0, 0.0, 0.0], [1, 2, 3], R, R.T)]
    capsule = [
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.0, 0.0, 0.5], [0.05, 0.15, 0.0]),
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.0, 0.0, 0.0], [0.05, 0.2, 0.0], RK=Ry),
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.3, 0.4, 0.2], [0.05, 0.2, 0.0], RK=Ry),
        one([0, 0, 0], [0.2, 0.2, 0.2], [0.0, 0.0, 0.0], [0.05, 0.2, 0.0]),
    ]
    cylinder = [
        one([0, 0, 0], [1.0, 1.0, 0.3], [0, 0, 0], [0.2, 1.0, 0.0]),
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.0, 0.0, 0.5], [0.05, 0.15, 0.0]),
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.0, 0.0, 0.4], [0.05, 0.2, 0.0], RK=Ry),
        one([0, 0, 0], [0.3, 0.2, 0.1], [0.3, 0.4, 0.2], [0.05, 0.2, 0.0], RK=Ry),
        one([1.0, 0.0, 2.0], ball, [0, 0, 0], [1.0, 1.0, 0.0]),
        one([1.0 - 1e-12, 0.0, 2.0], ball, [0, 0, 0], [1.0, 1.0, 0.0]),
        one([0.5, 0.0, 2.0], ball, [0, 0, 0], [1.0, 1.0, 0.0]),
        one([2.0, 0.0, 2.0], ball, [0, 0, 0], [1.0, 1.0, 0.0]),
        one([0, 0, 0], [0.2, 0.2, 0.2], [0.0, 0.0, 0.0], [0.05, 0.2, 0.0]),
    ]
    d = _degenerate_poses()
    return [("box", stack(*box, d)), ("capsule", stack(*capsule, d)), ("cylinder", stack(*cylinder, d))]


def test_hand_picked_cases_give_every_status():
    S, F = DerivativeStatus, ContactFeature
    outs = {kind: shape_derivatives(pose_args(P), kind) for kind, P in hand_picked()}
    box, cylinder = outs["box"], outs["cylinder"]
    assert box[3][0] == S.ONE_SIDED and box[4][0] == F.FACE  # test_shape_derivatives' ball at the edge
    assert cylinder[3][0] == S.FLAT and cylinder[4][0] == F.SIDE  # its circle of maxima
    statuses = set(np.concatenate([o[3] for o in outs.values()]).tolist())
    assert {S.SMOOTH, S.BRANCH, S.ONE_SIDED, S.FLAT} <= statuses, statuses
    assert (cylinder[3] == S.ONE_SIDED).any()  # a ball at the cap's edge
    for kind, P in hand_picked():  # UNPROVEN: the narrow phase's proven flag, false on every other pair
        args = pose_args(P)
        normal, proven = narrow_phase(args, kind)
        proven[::2] = False
        out = shape_derivatives(args, kind, normal, proven)
        assert (out[3][::2] == S.UNPROVEN).all() and np.isnan(out[0][::2]).all()
        assert not (out[3][1::2] == S.UNPROVEN).any()


def test_normals_on_the_kinks_and_anywhere_give_statuses_in_range():
    """Not maximisers: the stratum of any direction, on the kinks themselves (K's axes and their bisectors, exactly
    and within DERIV_KINK_COS), zero, unnormalised and random normals, proven or not."""
    rng = np.random.default_rng(11)
    for kind in KINDS:
        P = shape_poses(kind, 400, seed=3)
        args = pose_args(P)
        V = P["RK"].transpose(0, 2, 1)  # each row an axis
        picks = []
        for k in range(3):
            for s in (1.0, -1.0):
                picks.append(s * V[:, k])
                picks.append(s * V[:, k] + 1e-11 * V[:, (k + 1) % 3])
                picks.append(s * V[:, k] + 1e-9 * V[:, (k + 1) % 3])
                picks.append(s * (V[:, k] + V[:, (k + 1) % 3]) / np.sqrt(2.0))
            picks.append((V[:, 0] + V[:, 1] + V[:, 2]) / np.sqrt(3.0))
        picks += [np.zeros((400, 3)), 3.0 * rng.normal(size=(400, 3)), rng.normal(size=(400, 3))]
        for normal in picks:
            normal = np.ascontiguousarray(normal)
            proven = rng.random(400) < 0.9
            shape_derivatives(args, kind, normal, proven)


# --- random poses and arbitrary floats ----------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(
    st.tuples(*[st.floats(-1, 1)] * 3),
    quaternion,
    st.tuples(*[size] * 3),
    st.tuples(*[st.floats(-1, 1)] * 3),
    quaternion,
    st.tuples(*[size] * 3),
    st.sampled_from(KINDS),
)
def test_random_poses_give_statuses_in_range(cE, qE, rE, cK, qK, sK, kind):
    P = dict(cE=[cE], RE=[rotation(qE)], rE=[rE], cK=[cK], RK=[rotation(qK)], sK=[sK])
    shape_derivatives(pose_args(P), kind)


@settings(max_examples=400, deadline=None)
@given(
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=3, max_size=3),
    st.booleans(),
    st.sampled_from(KINDS),
)
def test_arbitrary_finite_floats_give_statuses_in_range(c, R, r, normal, proven, kind):
    """Any finite float (the Python layer validates; the kernel must not fail): extreme exponents, subnormal
    sizes, rotations that are not rotations, normals that are not unit."""
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    args = (C[0], M[0], S[0], C[1], M[1], S[1])
    shape_derivatives(args, kind, np.array([normal], float), np.array([proven]))


# --- broadcasting, ranges, threads, refusals, codes ---------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice(kind):
    P = pose_args(shape_poses(kind, 120, seed=8))
    normal, proven = narrow_phase(P, kind)
    full = shape_derivatives(P, kind, normal, proven)
    for once, tiled in (
        (tuple(x[:1].copy() for x in P[:3]) + P[3:], tuple(x[[0] * 120] for x in P[:3]) + P[3:]),
        (P[:3] + tuple(x[5:6].copy() for x in P[3:]), P[:3] + tuple(x[[5] * 120] for x in P[3:])),
    ):
        for g, w, name in zip(
            shape_derivatives(once, kind, normal, proven), shape_derivatives(tiled, kind, normal, proven), NAMES
        ):
            assert_same_bits(g, w, f"broadcast {name}")
    out = shape_derivatives(P, kind, normal, proven, 17, 101)  # the rest keeps its fill (checked there)
    assert not np.any(out[3][17:101] == 7)
    for g, w, name in zip(out, full, NAMES):
        assert_same_bits(g[17:101], w[17:101], f"range {name}")


@pytest.mark.parametrize("kind", KINDS)
def test_chunks_on_threads_get_the_serial_bits(kind):
    P = pose_args(shape_poses(kind, 3000, seed=10))
    normal, proven = narrow_phase(P, kind)
    code = KINDS.index(kind)
    serial = derivatives(ext.shape_derivatives, P, code, normal, proven)
    chunked = tuple(np.empty_like(x) for x in serial)
    with threads.limit(2):
        threads.run(ext.shape_derivatives, len(normal), True, *P, code, normal, proven, *chunked)
    for x, y, name in zip(chunked, serial, NAMES):
        assert_same_bits(x, y, f"chunked {name}")


def test_the_kernel_refuses_bad_ranges_kinds_and_arrays():
    P = pose_args(shape_poses("box", 10, seed=1))
    normal, proven = narrow_phase(P, "box")
    out = (
        np.empty((10, 18)),
        np.empty((10, 3, 18)),
        np.empty((10, 3, 18)),
        np.empty(10, np.int8),
        np.empty(10, np.int8),
    )
    f = ext.shape_derivatives
    with pytest.raises(IndexError, match="pair range outside the output"):
        f(*P, 1, normal, proven, *out, 0, 11)
    with pytest.raises(IndexError, match="pair range outside the output"):
        f(*P, 1, normal, proven, *out, 5, 4)
    with pytest.raises(IndexError, match="pair range outside the batches"):
        f(*(x[:5].copy() for x in P), 1, normal, proven, *out, 0, 10)
    with pytest.raises(ValueError, match="same length"):
        f(*P, 1, normal, proven[:9], *out, 0, 9)
    with pytest.raises(ValueError, match="same length"):
        f(*P, 1, normal, proven, *out[:4], np.empty(9, np.int8), 0, 9)
    with pytest.raises(ValueError, match="same length"):
        f(*P[:5], P[5][:9].copy(), 1, normal, proven, *out, 0, 9)
    with pytest.raises(ValueError, match="kind must be"):
        f(*P, 3, normal, proven, *out, 0, 10)
    with pytest.raises(ValueError, match="kind must be"):
        f(*P, -1, normal, proven, *out, 0, 10)
    with pytest.raises(TypeError):  # a strided output is refused, never copied
        f(*P, 1, normal, proven, np.empty((10, 36))[:, ::2], *out[1:], 0, 10)
    with pytest.raises(TypeError):  # proven must be bool, status and feature int8
        f(*P, 1, normal, proven.astype(np.int8), *out, 0, 10)
    with pytest.raises(TypeError):
        f(*P, 1, normal, proven, *out[:3], np.empty(10, np.int32), out[4], 0, 10)
    with pytest.raises(TypeError):
        f(*P, 1, normal, proven, np.empty((10, 17)), *out[1:], 0, 10)
    with pytest.raises(TypeError):
        f(*P, 1, normal, proven, out[0], np.empty((10, 18, 3)), *out[2:], 0, 10)
    f(*P, 1, normal, proven, *out, 3, 3)  # an empty range is no error


def test_the_codes_are_the_public_ones():
    codes = T.PAIR_DERIVATIVE_CODES
    assert codes["ONE_SIDED"] == DerivativeStatus.ONE_SIDED
    assert [codes[f.name] for f in ContactFeature] == [f.value for f in ContactFeature]
    assert [codes[k.upper()] for k in KINDS] == list(range(3)) == [sd.KINDS.index(k) for k in KINDS]


def test_the_stages_refuse_bad_ranges():
    x = np.zeros((4, 33))
    with pytest.raises(IndexError, match="range"):
        T.pair_derivative_stages(x, np.empty((4, 69)), 0, 5)
    with pytest.raises(IndexError, match="range"):
        T.pair_derivative_stages(x[:3].copy(), np.empty((4, 69)), 0, 4)
    with pytest.raises(TypeError):
        T.pair_derivative_stages(x, np.empty((4, 70)), 0, 4)
