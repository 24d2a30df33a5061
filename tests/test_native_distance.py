"""The C++ distance/ folder's drop-in kernels (issue 46): signed_distances and derivatives.

signed_distances and derivatives (the kernels under signed_distance) on every sample set, on the deep, thin,
spheroid, concentric and UNPROVEN pairs of the Python module's own tests, with every max_iter, on hypothesis's
hard and random pairs: statuses in range, the same bits twice, and the sign of every proven distance the exact
relation's (ext.resolve: separated pairs never below 0, overlapping ones never above); every path reached on the
special pairs (GLOBAL and UNPROVEN; SMOOTH, BRANCH, FLAT, UNPROVEN), UNPROVEN rows NaN; arbitrary finite floats
do not fail.  The per-pair functions pair_signed_distance(_from), contact_at and sigma_lower_bound (testing
submodule) against the batch kernel and at the warm start's scale limits.  Broadcasting, ranges, threads and
refusals; the status codes against the public enums.  (The stages against references: tests/test_distance.py,
test_global_max.py, test_inner_sum.py, test_spheroids.py, test_sphere_newton.py.)
"""

import threading

import leaves_poses
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_checks import assert_same_bits, finite, positive
from scipy.spatial.transform import Rotation as Rot
from strategies import hard_pair, random_pair
from test_native import arrays

import ellipsim.native as native
from ellipsim import ContactFeature, DerivativeStatus, DistanceStatus, Ellipsoids
from ellipsim.core import samples, threads
from ellipsim.core.relation import OVERLAPPING, SEPARATED, UNDECIDED
from ellipsim.core.samples import random_ellipsoids
from ellipsim.core.tolerances import NEWTON_MAX_ITER, WARM_SCALE_MAX, WARM_SCALE_MIN

ext = native.ext
T = ext.testing
GLOBAL, UNPROVEN = int(DistanceStatus.GLOBAL), int(DistanceStatus.UNPROVEN)


SETS = [
    ("generic", lambda: samples.generic_pairs(3000, seed=3)),
    ("near contact", lambda: samples.near_contact_pairs(3000, seed=4)),
]
SETS += [(c, lambda c=c: samples.stress_pairs(c, 600 if c != "aspect 1e4" else 100, seed=5)) for c in samples.STRESS]

any_pair = (
    st.lists(finite, min_size=6, max_size=6),
    st.lists(st.one_of(finite, st.floats(-1, 1)), min_size=18, max_size=18),
    st.lists(st.one_of(positive, st.floats(0.01, 10)), min_size=6, max_size=6),
)


def one_pair(c, R, r):
    C, M, S = np.array(c).reshape(2, 1, 3), np.array(R).reshape(2, 1, 3, 3), np.array(r).reshape(2, 1, 3)
    return C[0], M[0], S[0], C[1], M[1], S[1]


# --- the drop-in kernels: signed_distances and derivatives -----------------------------------------------------


def distances(kernel, args, n, max_iter=NEWTON_MAX_ITER, lo=0, hi=None):
    out = (np.full(n, 7.0), np.full((n, 3), 7.0), np.full((n, 3), 7.0), np.full(n, 7, np.int8))
    kernel(*args, max_iter, *out, lo, n if hi is None else hi)
    return out


def derivatives(kernel, args, normal, status, n, lo=0, hi=None):
    out = (np.full((n, 18), 7.0), np.full((n, 3, 18), 7.0), np.full((n, 3, 18), 7.0), np.full(n, 7, np.int8))
    kernel(*args, normal, status, *out, lo, n if hi is None else hi)
    return out


def check_kernels(args, n, max_iter=NEWTON_MAX_ITER, lo=0, hi=None, exact=True):
    """signed_distances and derivatives (at its normals and statuses) in [lo, hi): statuses in range, the same
    bits twice, the rest of their outputs left alone; with `exact`, every GLOBAL distance on the exact
    relation's side of 0.  Returns signed_distances' (dist, normal, pos, status)."""
    hi = n if hi is None else hi
    with np.errstate(all="ignore"):
        got = distances(ext.signed_distances, args, n, max_iter, lo, hi)
        again = distances(ext.signed_distances, args, n, max_iter, lo, hi)
    for g, w, name in zip(got, again, ("dist", "normal", "pos", "status")):
        assert_same_bits(g, w, f"signed_distances {name} twice")
        fill = np.full_like(g, 7)
        assert_same_bits(g[:lo], fill[:lo], name)
        assert_same_bits(g[hi:], fill[hi:], name)
    dist, normal, pos, status = got
    assert set(status[lo:hi].tolist()) <= {GLOBAL, UNPROVEN}
    if exact:
        rel = np.full(n, UNDECIDED, np.int8)
        ext.resolve(*args, rel, lo, hi)
        proven = status == GLOBAL
        assert not np.any(proven & (rel == SEPARATED) & (dist < 0)), "a separated pair below 0"
        assert not np.any(proven & (rel == OVERLAPPING) & (dist > 0)), "an overlapping pair above 0"
    if lo == 0 and hi == n:  # derivatives read every row of normal and status
        with np.errstate(all="ignore"):
            d = derivatives(ext.derivatives, args, normal, status, n)
            d2 = derivatives(ext.derivatives, args, normal, status, n)
        for g, w, name in zip(d, d2, ("grad", "jn", "jp", "status")):
            assert_same_bits(g, w, f"derivatives {name} twice")
        assert set(d[3].tolist()) <= {int(s) for s in DerivativeStatus}
        assert np.isnan(d[0][status != GLOBAL]).all() and (d[3][status != GLOBAL] == DerivativeStatus.UNPROVEN).all()
    return got


@pytest.mark.parametrize("label, make", SETS, ids=[s[0] for s in SETS])
def test_signed_distances_take_the_exact_relations_side(label, make):
    a, b = make()
    check_kernels(arrays(a, b), len(a))


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
def test_deep_and_special_pairs(label, make):
    """The pairs that reach inner_sum, spheroids and branch_and_bound (most of them deep), and the special cases
    of the Python module's tests: every path taken (GLOBAL and UNPROVEN, SMOOTH, BRANCH, FLAT)."""
    a, b = make()
    dist, normal, pos, status = check_kernels(arrays(a, b), len(a))
    if label == "special":
        assert (status == UNPROVEN).any() and (status == GLOBAL).any()
        out = derivatives(ext.derivatives, arrays(a, b), normal, status, len(a))
        S = DerivativeStatus
        assert {S.SMOOTH, S.BRANCH, S.FLAT, S.UNPROVEN} <= set(out[3].tolist())


@pytest.mark.parametrize("max_iter", [1, 2, 3, 5, 9, 10, 11, 40, 1000, 1_000_000])
def test_every_max_iter(max_iter):
    a, b = samples.generic_pairs(400, seed=7)
    c, d = deep_elongated(100, 8)
    a, b = Ellipsoids.concatenate([a, c]), Ellipsoids.concatenate([b, d])
    check_kernels(arrays(a, b), len(a), max_iter)


def test_derivatives_of_unproven_pairs_and_any_status():
    """dist_status as the caller gives it (test_derivatives: UNPROVEN rows are NaN, any nonzero code is)."""
    a, b = samples.generic_pairs(40, seed=2)
    dist, normal, pos, status = distances(ext.signed_distances, arrays(a, b), 40)
    status = np.array([0, 1, 0, 2, -1, 0, 127, 0] * 5, dtype=np.int8)
    got = derivatives(ext.derivatives, arrays(a, b), normal, status, 40)
    assert np.isnan(got[0][status != 0]).all() and (got[3][status != 0] == DerivativeStatus.UNPROVEN).all()
    assert np.isfinite(got[0][status == 0]).all() and not (got[3][status == 0] == DerivativeStatus.UNPROVEN).any()


def test_derivatives_at_any_normal_give_statuses_in_range():
    """Any direction (unit or not, zero included) as the normal: the polish and the status follow it."""
    a, b = samples.generic_pairs(300, seed=12)
    rng = np.random.default_rng(3)
    normal = rng.normal(size=(300, 3)) * 10.0 ** rng.integers(-3, 3, (300, 1))
    normal[:10] = 0.0
    status = np.zeros(300, np.int8)
    with np.errstate(all="ignore"):
        got = derivatives(ext.derivatives, arrays(a, b), normal, status, 300)
        again = derivatives(ext.derivatives, arrays(a, b), normal, status, 300)
    for g, w in zip(got, again):
        assert_same_bits(g, w, "derivatives twice")
    assert set(got[3].tolist()) <= {int(s) for s in DerivativeStatus}


def test_a_batch_of_one_broadcasts_and_a_range_writes_only_its_slice():
    a, b = samples.near_contact_pairs(300, seed=8)
    c, d = deep_elongated(20, 3)
    a, b = Ellipsoids.concatenate([a, c]), Ellipsoids.concatenate([b, d])
    n = len(a)
    for once, tiled in ((arrays(a[0], b), arrays(a[[0] * n], b)), (arrays(a, b[n - 1]), arrays(a, b[[n - 1] * n]))):
        got, want = check_kernels(once, n), check_kernels(tiled, n)
        for g, w in zip(got, want):
            assert_same_bits(g, w, "broadcast")
        got = derivatives(ext.derivatives, once, want[1], want[3], n)
        for g, w in zip(got, derivatives(ext.derivatives, tiled, want[1], want[3], n)):
            assert_same_bits(g, w, "broadcast derivatives")
    full = check_kernels(arrays(a, b), n)
    part = check_kernels(arrays(a, b), n, NEWTON_MAX_ITER, 17, 311)  # the rest keeps its fill (checked there)
    for g, w in zip(part, full):
        assert_same_bits(g[17:311], w[17:311], "range")
    dist, normal, pos, status = full
    got = derivatives(ext.derivatives, arrays(a, b), normal, status, n, 17, 311)
    want = derivatives(ext.derivatives, arrays(a, b), normal, status, n)
    for g, w in zip(got, want):
        assert_same_bits(g[17:311], w[17:311], "derivatives range")
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
def test_hard_pairs_take_the_exact_relations_side(pair):
    check_kernels(arrays(*pair), 1)


@settings(max_examples=150, deadline=None)
@given(*any_pair)
def test_arbitrary_finite_floats_give_statuses_in_range(c, R, r):
    """Any finite float the kernels may meet (the Python layer validates; the kernels must not fail):
    extreme exponents, subnormal radii, rotations that are not rotations."""
    check_kernels(one_pair(c, R, r), 1, exact=False)


def test_the_status_codes_are_status_py():
    codes = T.DISTANCE_CODES
    for enum in (DistanceStatus, DerivativeStatus, ContactFeature):
        for m in enum:
            assert codes[f"{enum.__name__}.{m.name}"] == int(m)
    assert len([k for k in codes if "." in k and k.split(".")[0] in ("DistanceStatus", "DerivativeStatus",
                                                                     "ContactFeature")]) == 14  # fmt: skip
    assert (codes["ellipsoid_pair.GLOBAL"], codes["ellipsoid_pair.UNPROVEN"]) == (GLOBAL, UNPROVEN)
    for k in ("SMOOTH", "BRANCH", "FLAT", "UNPROVEN"):
        assert codes[f"derivatives.{k}"] == DerivativeStatus[k]


# --- the per-pair functions: pair_signed_distance(_from), contact_at, sigma_lower_bound ---------------------------


def pair_stages(args, x, max_iter=NEWTON_MAX_ITER):
    """Per pair: pair_signed_distance (max_iter), pair_signed_distance_from (x), contact_at (x) and
    sigma_lower_bound (x): 9 + 9 + 7 + 1 columns; the same bits twice."""
    n = len(x)
    x = np.ascontiguousarray(x, dtype=np.float64)
    runs = []
    for _ in range(2):
        parts = (np.full((n, 9), 7.0), np.full((n, 9), 7.0), np.full((n, 7), 7.0), np.full((n, 1), 7.0))
        with np.errstate(all="ignore"):
            T.pair_signed_distance(*args, max_iter, parts[0], 0, n)
            T.pair_signed_distance_from(*args, x, parts[1], 0, n)
            T.contact_at(*args, x, parts[2], 0, n)
            T.sigma_lower_bound(*args, x, parts[3], 0, n)
        runs.append(np.concatenate(parts, axis=1))
    assert_same_bits(runs[0], runs[1], "pair stages twice")
    assert set(runs[0][:, 0].tolist()) <= {GLOBAL, UNPROVEN} and set(runs[0][:, 9].tolist()) <= {GLOBAL, UNPROVEN}
    return runs[0]


@pytest.mark.parametrize("label, make", SETS[:2] + DEEP, ids=[s[0] for s in SETS[:2] + DEEP])
def test_pair_signed_distance_is_a_row_of_the_batch_kernel(label, make):
    """pair_signed_distance's (status, dist, normal, pos) are signed_distances' row; from x (the previous
    step's normal, perturbed, random, zero, NaN) the status is in range."""
    a, b = make()
    a, b = a[:300], b[:300]
    n = len(a)
    rng = np.random.default_rng(7)
    max_iter = 3 if label == "generic" else NEWTON_MAX_ITER
    dist, normal, pos, status = distances(ext.signed_distances, arrays(a, b), n, max_iter)
    out = pair_stages(arrays(a, b), normal, max_iter)
    assert_same_bits(out[:, 0].astype(np.int8), status, "status")
    assert_same_bits(out[:, 1], dist, "dist")
    assert_same_bits(out[:, 2:5], normal, "normal")
    assert_same_bits(out[:, 5:8], pos, "pos")
    x = seeds(rng, n, normal)
    pair_stages(arrays(Ellipsoids.concatenate([a] * 3), Ellipsoids.concatenate([b] * 3)), x)


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


def test_sigma_lower_bound_at_the_scale_limits():
    """Semi-axes and offsets around WARM_SCALE_MIN and WARM_SCALE_MAX: -inf exactly where the smallest semi-axis
    is below WARM_SCALE_MIN or |d|_1 + max r_A + max r_B above WARM_SCALE_MAX, finite elsewhere."""
    a, b = samples.generic_pairs(60, seed=13)
    rng = np.random.default_rng(8)
    seen = set()
    for s in (2.0**-401, 2.0**-400, 2.0**-399, 2.0**380, 2.0**398, 2.0**399, 2.0**400):
        A = Ellipsoids(a.centers * s, a.rotations, a.radii * s)
        B = Ellipsoids(b.centers * s, b.rotations, b.radii * s)
        bound = pair_stages(arrays(A, B), rng.normal(size=(60, 3)))[:, 25]
        lo = np.minimum(A.radii.min(1), B.radii.min(1))
        S = np.abs(B.centers - A.centers).sum(1) + A.radii.max(1) + B.radii.max(1)
        beyond = ~((lo >= WARM_SCALE_MIN) & (S <= WARM_SCALE_MAX))
        assert np.array_equal(np.isneginf(bound), beyond) and np.isfinite(bound[~beyond]).all(), s
        seen |= set(beyond.tolist())
    assert seen == {False, True}


@settings(max_examples=120, deadline=None)
@given(*any_pair, st.tuples(*[st.one_of(finite, st.floats(-1, 1))] * 3), st.integers(1, 50))
def test_pair_stages_on_any_floats_give_statuses_in_range(c, R, r, x, max_iter):
    pair_stages(one_pair(c, R, r), np.array([x]), max_iter)
