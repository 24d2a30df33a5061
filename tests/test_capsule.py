"""Ellipsoid x capsule: the kernel (the C++ core's pairs/capsule.hpp, through ext.testing) against an
independent reference, and the narrow phase inside MuJoCo against MuJoCo's own GJK/EPA run tight.  That a
data not attached stays plain MuJoCo to the bit on a capsule pile is tested with the other scope tests
(test_scope.py)."""

import itertools
import re

import mujoco
import numpy as np
import pytest
from pair_types import (
    check_against_reference,
    coaxial_poses,
    entry_installed_and_restored,
    far_poses,
    kernel_result,
    pair_row,
    pile_agrees_with_tight_mujoco,
    place_gaps,
)
from reference import dense_maximum

import ellipsim.mujoco as em
from ellipsim.app import scenes
from ellipsim.native import ext

CAP, ELL = int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
CERTIFIED, ENUMERATED = ext.testing.CAPSULE_CONSTANTS["CERTIFIED"], ext.testing.CAPSULE_CONSTANTS["ENUMERATED"]


def capsule_ellipsoid(E, K):
    """The kernel (ext.testing.capsule_ellipsoid) on one pair: (status, dist, normal, pos, ub)."""
    return kernel_result(ext.testing.capsule_ellipsoid, E, K)


def centre_line_bound(E, K):
    """capsule.hpp's centre_line_bound (a column of ext.testing.capsule_stages)."""
    return pair_row(ext.testing.capsule_stages, E, K, 24)[23]


# --- an independent reference (reference.dense_maximum) ------------------------------------------
# sigma(n) = n.(cK - cE) - |rE (RE^T n)| - L |n.z| - r written out in world coordinates with numpy,
# nothing of ellipsim; its kink is the great circle n.z = 0.


def ref_sigma(P, n):
    """sigma of the poses P at the directions n (m, k, 3), normalised here."""
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    v = np.einsum("mkj,mj->mk", n, P["cK"] - P["cE"])
    loc = np.einsum("mkj,mji->mki", n, P["RE"]) * P["rE"][:, None, :]
    a = np.einsum("mkj,mj->mk", n, P["RK"][:, :, 2])
    return v - np.sqrt(np.sum(loc * loc, -1)) - P["sK"][:, None, 1] * np.abs(a) - P["sK"][:, None, 0]


def reference(P):
    return dense_maximum(ref_sigma, P, P["RK"][:, None, :, 2])


# --- poses ------------------------------------------------------------------------------------


def _kernel(P, i):
    E = (tuple(P["cE"][i]), tuple(P["RE"][i].ravel()), tuple(P["rE"][i]))
    K = (tuple(P["cK"][i]), tuple(P["RK"][i].ravel()), tuple(P["sK"][i]))
    return capsule_ellipsoid(E, K)


def make_poses(seed=0, per=60):
    """Categories of `per` poses: separated, touching (gap 0 and +-1e-9), shallow, deep, parallel axes
    (side or end against a tip of E), capsule inside the ellipsoid, ellipsoid around the segment."""
    rng = np.random.default_rng(seed)
    names = ("separated", "touching", "shallow", "deep", "parallel", "capsule inside", "around segment")
    m = per * len(names)
    cat = np.repeat(np.arange(len(names)), per)
    rE = rng.uniform(0.02, 0.3, (m, 3))
    sK = np.stack([rng.uniform(0.01, 0.1, m), rng.uniform(0.02, 0.3, m), np.zeros(m)], 1)
    P = far_poses(rng, rE, sK)
    cE, RE, cK, RK = P["cE"], P["RE"], P["cK"], P["RK"]
    small = np.minimum(sK[:, 0], rE.min(1))
    place_gaps(P, cat, _kernel, small, rng)
    deep = cat == 3
    cK[deep] = cE[deep] + rng.uniform(-0.3, 0.3, (int(deep.sum()), 3)) * rE[deep].min(1)[:, None]
    # parallel: the capsule's axis along E's axis k, its side (or end) against E's axis j (or k)
    par = np.flatnonzero(cat == 4)
    for i in par:
        k = rng.integers(3)
        j = (k + rng.integers(1, 3)) % 3
        z = RE[i][:, k]
        x = np.cross(z, rng.normal(size=3))
        x /= np.linalg.norm(x)
        RK[i] = np.stack([x, np.cross(z, x), z], 1)
        g = rng.choice([0.0, 1e-9, -1e-9, 1e-4, -1e-4, -0.3 * small[i]])
        side = rng.choice([-1.0, 1.0])
        if rng.random() < 0.5:
            cK[i] = cE[i] + side * RE[i][:, j] * (rE[i, j] + sK[i, 0] + g) + z * rng.uniform(-0.9, 0.9) * sK[i, 1]
        else:
            cK[i] = cE[i] + side * z * (rE[i, k] + sK[i, 1] + sK[i, 0] + g)
    inside = cat == 5  # a small capsule deep inside a large ellipsoid
    rE[inside] = rng.uniform(0.2, 0.3, (int(inside.sum()), 3))
    sK[inside, 0], sK[inside, 1] = (
        rng.uniform(0.01, 0.03, int(inside.sum())),
        rng.uniform(0.02, 0.06, int(inside.sum())),
    )
    cK[inside] = cE[inside] + rng.uniform(-0.05, 0.05, (int(inside.sum()), 3))
    around = np.flatnonzero(cat == 6)  # a small ellipsoid centred on a long capsule's segment
    rE[around] = rng.uniform(0.01, 0.05, (len(around), 3))
    sK[around, 0], sK[around, 1] = rng.uniform(0.04, 0.1, len(around)), rng.uniform(0.1, 0.3, len(around))
    cK[around] = cE[around] - RK[around][:, :, 2] * (rng.uniform(-0.9, 0.9, len(around)) * sK[around, 1])[:, None]
    return P, cat, names


@pytest.fixture(scope="module")
def poses():
    P, cat, names = make_poses()
    out = np.array([_kernel(P, i)[:2] + (_kernel(P, i)[4],) for i in range(len(cat))])
    normals = np.array([_kernel(P, i)[2] for i in range(len(cat))])
    value, _ = reference(P)
    return P, cat, names, out, normals, value


def test_kernel_matches_the_reference_within_1e12_of_the_smaller_half_size(poses):
    P, cat, names, out, normals, ref = poses
    dist = out[:, 1]
    s_min = np.minimum(P["rE"].min(1), P["sK"][:, 0])
    proofs = (CERTIFIED, ENUMERATED)
    check_against_reference(P, cat, names, out, normals, ref, ref_sigma, s_min, proofs, CERTIFIED)
    assert (dist[cat == 3] < 0).all() and (dist[cat == 5] < 0).all() and (dist[cat == 0] > 0).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_capsule_on_a_spheroids_axis_is_the_maximum(seed):
    """A capsule on (or a hair off) a spheroid's axis: E projected along the axis is a (near-)circle
    with the centre a hair off the capsule's, where the side circle's 2-D solve (foot2) put the normal
    on an axis whatever the offset was: ENUMERATED answers 5.5e-11 m (8e-10 of the smaller size) below
    the maximum on seed 0.  Every answer is now within the contract's 1e-12 of the dense reference."""
    P = coaxial_poses(seed)
    results = [_kernel(P, i) for i in range(len(P["cE"]))]
    dist = np.array([r[1] for r in results])
    assert (dist < -0.05).sum() > 50
    ref, _ = reference(P)
    scale = np.linalg.norm(P["cK"], axis=1) + np.maximum(P["rE"].max(1), P["sK"][:, :2].max(1))
    tol = 1e-12 * np.minimum(P["rE"].min(1), P["sK"][:, 0]) + 64 * 2.0**-53 * scale
    assert (ref - dist <= tol).all(), (ref - dist).max()


def test_kernel_hand_picked_cases():
    I = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    E = ((0.0, 0.0, 0.0), I, (0.3, 0.2, 0.1))
    # end on: the capsule along z above E's shortest axis, 0.25 m apart
    st, dist, normal, pos, _ = capsule_ellipsoid(E, ((0.0, 0.0, 0.5), I, (0.05, 0.15, 0.0)))
    assert dist == pytest.approx(0.5 - 0.15 - 0.05 - 0.1, abs=1e-15) and normal == pytest.approx((0, 0, 1), abs=1e-15)
    assert pos == pytest.approx((0.0, 0.0, 0.1 + 0.1), abs=1e-15)
    # side on, axis along y through E's centre: the shortest way out is along z
    Ry = (1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0)
    st, dist, normal, _, _ = capsule_ellipsoid(E, ((0.0, 0.0, 0.0), Ry, (0.05, 0.2, 0.0)))
    assert dist == pytest.approx(-0.15, abs=1e-15) and abs(normal[2]) == pytest.approx(1.0, abs=1e-15)
    # the centre-line bound never exceeds the distance
    K = ((0.3, 0.4, 0.2), Ry, (0.05, 0.2, 0.0))
    assert centre_line_bound(E, K) <= capsule_ellipsoid(E, K)[1]


# --- inside MuJoCo ------------------------------------------------------------------------------


def capsule_pile_xml(n=30, seed=1, margin=0.0):
    """scenes.pile_xml with every other ellipsoid a capsule (radius, half-length: its first two
    semi-axes), and `margin` on every third geom: capsules and ellipsoids heaped in a bin."""
    k = itertools.count()

    def swap(m):
        i = next(k)
        geom = f'type="capsule" size="{m[1]} {m[2]}"' if i % 2 else m[0]
        return geom + (f' margin="{margin}"' if margin and i % 3 == 0 else "")

    return re.sub(r'type="ellipsoid" size="(\S+) (\S+) \S+"', swap, scenes.pile_xml(n, seed=seed))


@pytest.mark.parametrize("margin", [0.0, 0.01])
def test_pile_agrees_with_tight_mujoco(margin):
    """The capsule x ellipsoid contacts of a capsule pile against MuJoCo run tight
    (pair_types.pile_agrees_with_tight_mujoco)."""
    compared, counts = pile_agrees_with_tight_mujoco(capsule_pile_xml(margin=margin), CAP, ELL)
    assert compared > 100 and counts["fallbacks"] == 0 and counts["contacts"] > 100
    assert counts["calls"] >= counts["separated"] + counts["contacts"]


def test_capsule_entry_is_installed_and_restored():
    xml = (
        '<mujoco><worldbody><body><freejoint/><geom type="capsule" size=".05 .1"/></body>'
        '<body pos="0 0 .3"><freejoint/><geom type="ellipsoid" size=".1 .1 .2"/></body></worldbody></mujoco>'
    )
    entry_installed_and_restored(xml, CAP, ELL)
    model = mujoco.MjModel.from_xml_string(xml)
    with em.attach(model, mujoco.MjData(model), mode="filter") as att:
        assert not att.installed  # the filter handles no capsule pair
