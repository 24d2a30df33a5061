"""shape_distance: an ellipsoid against a capsule, box or cylinder, and its derivatives (issue 24).

The derivatives against 40-digit central differences (h = 1e-15) of the distance on the contact's feature
(reference.shape_contact_mp: Newton on the Lagrange system of sigma restricted to the feature, in 60
digits), on every feature of every type, separated (SMOOTH) and penetrating (BRANCH); that reference is
checked against the body itself first (its witness lies on the surface of K, reference.sd_point_shape_mp;
its multipliers inside their bounds: the feature is the right one).  Bound: the issue's 1e-8 relative per
3-column block (a block that is zero by symmetry, as a capsule side's normal against the radius: relative
to 1e-6 of the quantity's largest entry).
"""

import types

import mpmath as mp
import numpy as np
import pytest
from reference import mp_body, perturbed, relative_errors, sd_point_shape_mp, shape_contact_mp, shape_feature_mp

import ellipsim as es
from ellipsim.core.samples import random_ellipsoids
from ellipsim.native import ext

H = mp.mpf("1e-15")
BOUND = 1e-8
KINDS = {"box": ("face", "edge", "vertex"), "capsule": ("side", "end"), "cylinder": ("side", "cap", "rim")}
FEATURE = {name: getattr(es.ContactFeature, name.upper()) for names in KINDS.values() for name in names}
CODES = ext.testing.PAIR_DERIVATIVE_CODES  # the C++ kernel's codes (pairs/derivatives.hpp)


def _poses(kind, n, seed, spread=1.5):
    """n random ellipsoids about the origin's neighbourhood and n bodies of `kind` at the origin."""
    rng = np.random.default_rng(seed)
    e = random_ellipsoids(rng, n, box=spread, radii=(0.2, 1.0))
    k = random_ellipsoids(rng, n, box=0.0, radii=(0.2, 1.0))
    sizes = k.radii.copy()
    if kind != "box":
        sizes[:, 2] = 0.0
    return e, k.centers.copy(), k.rotations.copy(), sizes


def _reference(kind, feature, E, K, i, n0):
    """(d dist (18,), d normal (3, 18), d pos (3, 18)) of pair i by 40-digit central differences."""
    with mp.workdps(40):
        A, B = mp_body(E, i), mp_body(K, i)
        g, jn, jp = np.zeros(18), np.zeros((3, 18)), np.zeros((3, 18))
        for j in range(18):
            body, part, axis = j // 9, (j % 9) // 3, j % 3
            if body == 1 and part == 2 and kind != "box" and axis == 2:
                continue  # a capsule's or cylinder's third size is not used
            out = []
            for h in (H, -H):
                Ap, Bp = (perturbed(A, part, axis, h), B) if body == 0 else (A, perturbed(B, part, axis, h))
                out.append(shape_contact_mp(kind, feature, *Ap, *Bp, n0)[:3])
            (sp, np_, pp), (sm, nm, pm) = out
            g[j] = float((sp - sm) / (2 * H))
            jn[:, j] = [float((np_[k] - nm[k]) / (2 * H)) for k in range(3)]
            jp[:, j] = [float((pp[k] - pm[k]) / (2 * H)) for k in range(3)]
    return g, jn, jp


def _check_reference(kind, feature, E, K, i, n0, dist):
    """The reference at the pair itself is the library's distance, its witness on the surface of K and its
    multipliers inside their bounds (the feature carries a stationary point of the whole problem)."""
    with mp.workdps(40):
        A, B = mp_body(E, i), mp_body(K, i)
        sigma, n, _, mu, pK = shape_contact_mp(kind, feature, *A, *B, n0)
        assert abs(float(sigma) - dist) <= 1e-12 * (1 + abs(dist))
        assert abs(sd_point_shape_mp(kind, *B, pK)) < mp.mpf(10) ** -30
        bounds = shape_feature_mp(kind, feature, *B, n0)[4]
        if feature == "cap":
            assert mp.sqrt(mu[0] ** 2 + mu[1] ** 2) < bounds[0]
        else:
            assert all(abs(m) < b for m, b in zip(mu, bounds))


@pytest.mark.parametrize("kind, feature", [(k, f) for k, names in KINDS.items() for f in names])
def test_against_mpmath_central_differences(kind, feature):
    """Two separated pairs (SMOOTH) and one penetrating (BRANCH) per feature."""
    E, c, R, s = _poses(kind, 400, seed=sum(map(ord, kind + feature)))
    dist, normal, pos, status, der = es.shape_distance(E, kind, c, R, s, derivatives=True)
    assert (status == es.DistanceStatus.GLOBAL).sum() >= 390
    K = types.SimpleNamespace(centers=c, rotations=R, radii=s)
    on = der.feature == FEATURE[feature]
    smooth = np.flatnonzero(on & (der.status == es.DerivativeStatus.SMOOTH))
    branch = np.flatnonzero(on & (der.status == es.DerivativeStatus.BRANCH))
    assert len(smooth) >= 2 and len(branch) >= 1, (len(smooth), len(branch))
    for i in [*smooth[:2], branch[0]]:
        assert (dist[i] > 0) == (der.status[i] == es.DerivativeStatus.SMOOTH)
        _check_reference(kind, feature, E, K, i, normal[i], dist[i])
        g, jn, jp = _reference(kind, feature, E, K, i, normal[i])
        for got, ref, name in ((der.dist[i], g, "dist"), (der.normal[i], jn, "normal"), (der.pos[i], jp, "pos")):
            err = relative_errors(got, ref, floor=1e-6 * np.abs(ref).max())
            assert err.max() <= BOUND, (kind, feature, i, name, err)


def _box_pair(x):
    """A ball of radius 0.5 at (x, 0, 2) above the unit cube [-1, 1]^3: at x = 1 its nearest point is on the
    edge between the top face and the face x = 1."""
    e = es.Ellipsoids([x, 0.0, 2.0], np.eye(3), [0.5, 0.5, 0.5])
    return e, "box", np.zeros(3), np.eye(3), np.ones(3)


def test_a_contact_where_two_features_meet_is_one_sided():
    """At the cube's edge: the top face's derivatives, flagged ONE_SIDED; they are the one-sided derivative
    from the face's side (moving the ball back over the face keeps the normal), not from the other (over
    the edge the normal turns at 1 / 0.5 per metre)."""
    dist, normal, _, _, der = es.shape_distance(*_box_pair(1.0), derivatives=True)
    assert der.status[0] == es.DerivativeStatus.ONE_SIDED and der.feature[0] == es.ContactFeature.FACE
    np.testing.assert_allclose(normal[0], [0, 0, -1], atol=1e-15)
    h = 1e-7
    back, ahead = es.shape_distance(*_box_pair(1.0 - h)), es.shape_distance(*_box_pair(1.0 + h))
    from_face = (normal[0] - back[1][0]) / h
    from_edge = (ahead[1][0] - normal[0]) / h
    np.testing.assert_allclose(der.normal[0, :, 0], from_face, atol=1e-8)
    assert np.abs(der.normal[0, :, 0] - from_edge).max() > 1.0
    inside = es.shape_distance(*_box_pair(0.5), derivatives=True)[4]
    assert inside.status[0] == es.DerivativeStatus.SMOOTH and inside.feature[0] == es.ContactFeature.FACE


def test_a_circle_of_maxima_is_flat():
    """A flat spheroid coaxial with a thin cylinder, crossing it: the deepest direction is any direction of
    the side's circle; no derivative (NaN), FLAT."""
    e = es.Ellipsoids([0.0, 0.0, 0.0], np.eye(3), [1.0, 1.0, 0.3])
    dist, _, _, status, der = es.shape_distance(
        e, "cylinder", np.zeros(3), np.eye(3), [0.2, 1.0, 0.0], derivatives=True
    )
    assert status[0] == es.DistanceStatus.GLOBAL
    np.testing.assert_allclose(dist[0], -1.2, rtol=1e-12)
    assert der.status[0] == es.DerivativeStatus.FLAT and der.feature[0] == es.ContactFeature.SIDE
    assert np.isnan(der.dist[0]).all() and np.isnan(der.normal[0]).all() and np.isnan(der.pos[0]).all()


def test_an_unproven_maximum_gives_nan():
    E, c, R, s = _poses("cylinder", 3, seed=2)
    _, normal, _, _ = es.shape_distance(E, "cylinder", c, R, s)
    out = (np.empty((3, 18)), np.empty((3, 3, 18)), np.empty((3, 3, 18)), np.empty(3, np.int8), np.empty(3, np.int8))
    proven = np.array([True, False, True])
    arrays = (E.centers, E.rotations, E.radii, c, R, s, CODES["CYLINDER"])
    ext.shape_derivatives(*arrays, normal, proven, *out, 0, 3)
    assert out[3][1] == es.DerivativeStatus.UNPROVEN and np.isnan(out[0][1]).all() and np.isnan(out[2][1]).all()
    assert np.isfinite(out[0][[0, 2]]).all()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_threads_and_broadcast_give_the_same_bits(kind):
    E, c, R, s = _poses(kind, 3000, seed=7)
    serial = es.shape_distance(E, kind, c, R, s, derivatives=True, parallel=False)
    threaded = es.shape_distance(E, kind, c, R, s, derivatives=True, parallel=True)
    for x, y in zip(serial[:4] + tuple(serial[4]), threaded[:4] + tuple(threaded[4])):
        np.testing.assert_array_equal(x, y)
    one = es.shape_distance(E[0], kind, c[:5], R[:5], s[:5], derivatives=True)
    many = es.shape_distance(es.Ellipsoids.concatenate([E[0]] * 5), kind, c[:5], R[:5], s[:5], derivatives=True)
    for x, y in zip(one[:4] + tuple(one[4]), many[:4] + tuple(many[4])):
        np.testing.assert_array_equal(x, y)


def test_agrees_with_the_narrow_phase_of_the_mujoco_glue():
    """The box's distance, normal and point are the narrow phase's (box.hpp's box_ellipsoid, through
    ext.testing) to the bit."""
    E, c, R, s = _poses("box", 20, seed=3)
    dist, normal, pos, _ = es.shape_distance(E, "box", c, R, s)
    out = np.empty((20, 9))  # status, dist, normal, pos, ub per pair
    ext.testing.box_ellipsoid(E.centers, E.rotations, E.radii, c, R, s, out, 0, 20)
    for i in range(20):
        d, n, p = out[i, 1], tuple(out[i, 2:5]), tuple(out[i, 5:8])
        assert (d, n, p) == (dist[i], tuple(normal[i]), tuple(pos[i]))


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda E, c, R, s: es.shape_distance(E, "sphere", c, R, s), "kind must be one of"),
        (lambda E, c, R, s: es.shape_distance(E, "box", c, R, -s), r"sizes\[0, 0\] \(a half-size of a box\)"),
        (lambda E, c, R, s: es.shape_distance(E, "capsule", c, R, s * [1, 0, 1]), r"sizes\[0, 1\] \(the half-length"),
        (lambda E, c, R, s: es.shape_distance(E, "box", c, 2 * R, s), r"rotations\[0\] must be orthonormal"),
        (lambda E, c, R, s: es.shape_distance(E, "box", c[:2], R[:2], s[:2]), "same length or one of them length 1"),
        (lambda E, c, R, s: es.shape_distance(E, "box", c, R, s[:2]), "centers, rotations and sizes"),
        (lambda E, c, R, s: es.shape_distance(E, "box", c, R, s, derivatives="yes"), "derivatives must be"),
        (lambda E, c, R, s: es.shape_distance(E.centers, "box", c, R, s), "ellipsoids must be an ellipsim.Ellipsoids"),
    ],
)
def test_bad_input_is_named(call, message):
    E, c, R, s = _poses("box", 3, seed=1)
    with pytest.raises(ValueError, match=message):
        call(E, c, R, s)


def test_codes_are_the_kernels():
    assert es.DerivativeStatus.ONE_SIDED == CODES["ONE_SIDED"]
    names = ("FACE", "EDGE", "VERTEX", "SIDE", "END", "CAP", "RIM")
    assert [f.value for f in es.ContactFeature] == [CODES[name] for name in names]
    assert es.core.pairs.shape_distance.KINDS.index("box") == CODES["BOX"]


@pytest.mark.parametrize("kind", ["capsule", "cylinder"])
def test_the_third_size_of_a_capsule_or_cylinder_is_ignored(kind):
    """MuJoCo leaves it 0; whatever a caller puts there changes no bit (it once scaled the flatness test)."""
    E, c, R, s = _poses(kind, 500, seed=4)
    big = s.copy()
    big[:, 2] = 1e12
    one, other = (
        es.shape_distance(E, kind, c, R, s, derivatives=True),
        es.shape_distance(E, kind, c, R, big, derivatives=True),
    )
    for x, y in zip(one[:4] + tuple(one[4]), other[:4] + tuple(other[4])):
        np.testing.assert_array_equal(x, y)
