"""The C++ core's distance/inner_sum.hpp (its stages through tests/distance_stages.py): the ellipsoid inside A + (-B) that touches it at a direction n bounds max
sigma from above whatever n is, and closes on the global maximum for most deep crossings.

The references are test_global_max's (sigma in A's frame written out in numpy and 40-digit mpmath,
reference_max: dense directions and gradient ascent polished in 40 digits, nothing of ellipsim)."""

import leaves_poses
import numpy as np
import pytest
from distance_stages import inner_sum_bound
from hypothesis import given, settings
from hypothesis import strategies as st
from test_global_max import Pair, deep_pair, local_maxima, reference_max, seeded_deep_pairs, thin_deep_pairs

from ellipsim import Ellipsoids, signed_distance

U64 = 2.0**-53


def bound(P, n):
    n = np.asarray(n, float) / np.linalg.norm(n)
    return inner_sum_bound(tuple(map(float, n)), P.e, P.a, P.U, P.b, float(P.sigma(n)[0]))


def maximiser(P):
    """The narrow phase's proven maximiser of the pair (A's frame: A at the identity)."""
    _, normal, _, status = signed_distance(*P.ellipsoids())
    assert status[0] == 0
    return normal[0]


def leaves_pairs():
    return [Pair(p["ca"], p["Ra"], p["ra"], p["cb"], p["Rb"], p["rb"]) for p in leaves_poses.POSES]


@settings(max_examples=40, deadline=None)
@given(deep_pair(), st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: sum(x * x for x in v) > 1e-2))
def test_bound_holds_from_any_direction(P, n):
    """Q lies inside A + (-B) for every n: the bound is never below the global maximum, from a random
    direction, from each local maximum, and from the best direction."""
    ref = reference_max(P)
    slack = 4 * U64 * P.S  # the reference's own rounding to float
    for m in [np.array(n)] + local_maxima(P, 3):
        assert bound(P, m) >= ref - slack, (P, m)


@pytest.mark.parametrize(
    "make, share",
    [
        (lambda: seeded_deep_pairs(6, 7), 0.6),
        (lambda: thin_deep_pairs(6, 8), 0.6),
        # the leaves.xml contacts where two maxima are nearly as deep (the first release took the wrong
        # one): no ellipsoid inside A + (-B) separates them, these go to the branch and bound
        (leaves_pairs, 0.0),
    ],
)
def test_bound_is_not_fooled_by_a_lower_local_maximum(make, share):
    """At a local maximum below the global one the bound stays above the global maximum (so the narrow
    phase goes on to the branch and bound), and at the global maximiser it is within the proof's
    tolerance on most random deep pairs."""
    tight = total = 0
    for P in make():
        ref = reference_max(P)
        for m in local_maxima(P, 3):
            assert bound(P, m) >= ref - 4 * U64 * P.S
        ub = bound(P, maximiser(P))
        assert ub >= ref - 4 * U64 * P.S
        if ref < 0:
            total += 1
            tight += ub <= ref + P.tol
    assert tight >= share * total, (tight, total)


def test_leaves_landing_contacts_are_proven_in_one_shot():
    """MuJoCo's leaves.xml (25 x 10 x 1 mm leaves) at its landing, 1000 steps from the drop, where leaves
    cross up to twice their thickness deep: the bound at the narrow phase's maximiser proves at least
    90 % of the deep ellipsoid pairs (depth beyond the rolling radii) within the proof's tolerance."""
    import mujoco

    from ellipsim.app.bench import inside_mujoco
    from ellipsim.mujoco import candidate_pairs

    xml = dict(inside_mujoco.SCENES)["MuJoCo's replicate/leaves.xml, landing"][0]()
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)
    pairs = candidate_pairs(model, data)
    pairs = pairs[(model.geom_type[pairs] == mujoco.mjtGeom.mjGEOM_ELLIPSOID).all(axis=1)]
    poses = [
        Pair(data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), model.geom_size[g],
             data.geom_xpos[h], data.geom_xmat[h].reshape(3, 3), model.geom_size[h])
        for g, h in pairs
    ]  # fmt: skip
    rho = 2 * 0.001**2 / 0.025
    deep = tight = 0
    for P in poses:
        a, b = P.ellipsoids()
        dist, normal, _, status = signed_distance(a, b)
        if dist[0] < -rho:
            deep += 1
            tight += bound(P, normal[0]) <= dist[0] + P.tol
    assert deep >= 40 and tight >= 0.9 * deep, (tight, deep)


def test_no_bound_for_a_separated_pair():
    """inf where sigma(n) >= 0: the bound is for penetrating maxima (separated ones are proven by
    concavity)."""
    P = Pair([0, 0, 0], np.eye(3), [0.1, 0.05, 0.02], [0.5, 0, 0], np.eye(3), [0.1, 0.05, 0.02])
    assert P.sigma([1, 0, 0])[0] > 0 and bound(P, [1, 0, 0]) == np.inf


def test_aligned_boxes_of_axes_give_the_exact_depth():
    """Two ellipsoids with the same axes: at a principal direction S = I makes Q = A + B exactly an
    ellipsoid (semi-axes summed), and the bound is the depth of the offset in it."""
    P = Pair([0, 0, 0], np.eye(3), [0.1, 0.05, 0.02], [0.0, 0.0, 0.01], np.eye(3), [0.1, 0.05, 0.02])
    assert abs(bound(P, [0, 0, 1]) - (0.01 - 0.04)) <= 1e-15


def test_signed_distance_of_deep_crossings_matches_the_reference():
    """Through the narrow phase (where the bound now proves most deep maxima): random deep crossings of
    leaves and of elongated ellipsoids within the proof's tolerance of the reference, status GLOBAL."""
    rng = np.random.default_rng(11)
    for ra, rb, spread in (
        ([0.025, 0.01, 0.001], [0.025, 0.01, 0.001], 0.01),
        ([0.3, 0.04, 0.03], [0.25, 0.05, 0.02], 0.03),
    ):
        for _ in range(12):
            q = rng.normal(size=(2, 4))
            a = Ellipsoids.from_quaternions([0, 0, 0], q[0], ra)
            b = Ellipsoids.from_quaternions(rng.normal(size=3) * spread, q[1], rb)
            dist, _, _, status = signed_distance(a, b)
            P = Pair.of(a, b)
            ref = reference_max(P)
            assert status[0] == 0
            assert abs(dist[0] - ref) <= P.tol + 4 * U64 * P.S, (P, dist[0], ref)
