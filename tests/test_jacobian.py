"""ellipsim.mujoco.distance_jacobian against central differences of the exact distance over qpos.

qpos is moved along each dof by mj_integratePos(qpos, +-h e_k, 1) (for hinges and slides qpos itself,
for free joints the tangent space of the quaternion), the geoms posed by mj_kinematics, and the proven
signed distance recomputed; h = 1e-6 m or rad.  float64 central differences err by ~h^2 |d^3 dist| plus
~u |dist| / h: 1e-9 of the row's largest entry here, so the bound 1e-7 has a hundredfold margin and still
catches a wrong frame, sign or column (those are O(1) errors).
"""

import mujoco
import numpy as np
import pytest

import ellipsim as es
import ellipsim.mujoco as em
from ellipsim.app import scenes

H = 1e-6
BOUND = 1e-7


def _settled(xml, steps):
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, steps)
    return model, data


def _distances(model, qpos, pairs):
    """The proven signed distance of each pair at qpos: ellipsim's own distance for two ellipsoids (or a
    sphere), distance_jacobian's (core.pairs) for a capsule, box or cylinder."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    if not np.isin(model.geom_type[pairs], [mujoco.mjtGeom.mjGEOM_ELLIPSOID, mujoco.mjtGeom.mjGEOM_SPHERE]).all():
        return em.distance_jacobian(model, data, pairs).dist

    def body(g):
        size = model.geom_size[g].copy()
        sphere = model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE
        size[sphere] = size[sphere, :1]
        return es.Ellipsoids(data.geom_xpos[g], data.geom_xmat[g].reshape(-1, 3, 3), size)

    return es.signed_distance(body(pairs[:, 0]), body(pairs[:, 1]))[0]


def _finite_differences(model, qpos, pairs):
    out = np.empty((len(pairs), model.nv))
    for k in range(model.nv):
        v = np.zeros(model.nv)
        v[k] = H
        plus, minus = qpos.copy(), qpos.copy()
        mujoco.mj_integratePos(model, plus, v, 1.0)
        mujoco.mj_integratePos(model, minus, -v, 1.0)
        out[:, k] = (_distances(model, plus, pairs) - _distances(model, minus, pairs)) / (2 * H)
    return out


def _mixed_pile():
    """A pile whose geoms are ellipsoids, capsules, boxes and cylinders in turn, in a bin of box walls."""
    import itertools
    import re

    k = itertools.count()

    def swap(m):
        kind = ("ellipsoid", "capsule", "box", "ellipsoid", "cylinder")[next(k) % 5]
        return (
            m[0]
            if kind == "ellipsoid"
            else f'type="{kind}" size="{m[1]} {m[2]}' + (f' {m[2]}"' if kind == "box" else '"')
        )

    return re.sub(r'type="ellipsoid" size="(\S+) (\S+) \S+"', swap, scenes.pile_xml(20, seed=4, bin_half_width=0.25))


def _mixed_pairs(model, data):
    """Every pair of an ellipsoid with another geom of the model whose bounding spheres come within 2 cm."""
    ell = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    other = np.flatnonzero(model.geom_bodyid > 0)
    out = []
    for e in ell:
        for g in other:
            if g != e and model.geom_bodyid[g] != model.geom_bodyid[e]:
                gap = (
                    np.linalg.norm(data.geom_xpos[e] - data.geom_xpos[g]) - model.geom_rbound[e] - model.geom_rbound[g]
                )
                if gap < 0.02 and (g > e or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_ELLIPSOID):
                    out.append((e, g) if len(out) % 2 else (g, e))  # both orders
    return np.array(out)


@pytest.mark.parametrize(
    "xml, steps",
    [
        (scenes.scene_xml(3, layout="pile", seed=3, drop_height=0.3), 400),  # figures: hinges and a free root each
        (scenes.pile_xml(12, seed=2, bin_half_width=0.2), 300),  # free ellipsoids, shallow and deep contacts
        (_mixed_pile(), 300),  # ellipsoids against capsules, boxes and cylinders (the witness-point gradient)
    ],
    ids=["figures", "pile", "capsules, boxes, cylinders"],
)
def test_against_finite_differences_of_qpos(xml, steps):
    model, data = _settled(xml, steps)
    mixed = (model.geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE).any()
    pairs = _mixed_pairs(model, data) if mixed else em.candidate_pairs(model, data)
    if mixed:
        kinds = set(model.geom_type[pairs].ravel().tolist())
        assert {
            int(mujoco.mjtGeom.mjGEOM_CAPSULE),
            int(mujoco.mjtGeom.mjGEOM_BOX),
            int(mujoco.mjtGeom.mjGEOM_CYLINDER),
        } <= kinds
    assert len(pairs) >= 5
    qpos = data.qpos.copy()
    jac = em.distance_jacobian(model, data, pairs)
    np.testing.assert_array_equal(data.qpos, qpos)  # qpos untouched
    defined = (jac.status == es.DerivativeStatus.SMOOTH) | (jac.status == es.DerivativeStatus.BRANCH)
    assert defined.sum() >= 5
    assert np.isnan(jac.jacobian[~defined]).all()
    fd = _finite_differences(model, qpos, pairs)
    np.testing.assert_array_equal(jac.dist, _distances(model, qpos, pairs))
    smooth = jac.status == es.DerivativeStatus.SMOOTH
    scale = np.abs(fd[smooth]).max(axis=1, keepdims=True)
    err = np.abs(jac.jacobian[smooth] - fd[smooth]) / scale
    assert err.max() <= BOUND, err.max()
    assert np.isin(jac.status, [0, 1, 2, 3]).all()


def test_a_free_body_moved_along_the_normal():
    """Two free ellipsoids: translating B along the normal changes the distance one for one, so the free
    joint's linear columns of B are the normal (MuJoCo's free-joint qvel is the world-frame velocity)."""
    xml = """<mujoco><worldbody>
      <body pos="0 0 0"><freejoint/><geom type="ellipsoid" size="0.3 0.2 0.1"/></body>
      <body pos="0.5 0.1 0.05" quat="0.9 0.2 0.3 0.1"><freejoint/><geom type="ellipsoid" size="0.25 0.15 0.1"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    jac = em.distance_jacobian(model, data, [[0, 1]])
    assert jac.status[0] == es.DerivativeStatus.SMOOTH
    np.testing.assert_allclose(jac.jacobian[0, 6:9], jac.normal[0], atol=1e-15)
    np.testing.assert_allclose(jac.jacobian[0, 0:3], -jac.normal[0], atol=1e-15)


@pytest.mark.parametrize(
    "pairs, message",
    [
        ([[1, 5]], r"pairs\[0, 1\] = 5 is not a geom id of the model \(ngeom 3\)"),
        ([[1, 1]], "pairs\\[0\\] names geom 1 twice"),
        ([[1, 2, 0]], r"must be a \(k, 2\) array"),
        ([[1.0, 2.0]], "integer geom ids"),
        ([[1, 0]], r"pairs\[0\] = \(1, 0\) is #1 \(ellipsoid\) x floor \(plane\)"),
    ],
)
def test_bad_pairs_are_named(pairs, message):
    xml = """<mujoco><worldbody><geom name="floor" type="plane" size="1 1 1"/>
      <body><freejoint/><geom type="ellipsoid" size="0.3 0.2 0.1"/></body>
      <body pos="1 0 0"><freejoint/><geom type="ellipsoid" size="0.3 0.2 0.1"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.raises(ValueError, match=message):
        em.distance_jacobian(model, mujoco.MjData(model), np.array(pairs))


def test_no_pairs():
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>"
    )
    jac = em.distance_jacobian(model, mujoco.MjData(model), np.zeros((0, 2), int))
    assert jac.jacobian.shape == (0, 6)


def test_interpolated_distance_jacobian_against_finite_differences():
    """The distance at t = 0.3 of the interpolated motion between two states of a pile, differentiated with
    respect to each state's qpos, against central differences through mj_integratePos (h = 1e-6)."""
    from ellipsim.core.motion.interpolation import poses_at

    model, data0 = _settled(scenes.pile_xml(12, seed=2, bin_half_width=0.2), 300)
    data1 = mujoco.MjData(model)
    data1.qpos[:] = data0.qpos
    v = np.random.default_rng(1).normal(size=model.nv) * 0.05
    mujoco.mj_integratePos(model, data1.qpos, v, 1.0)
    pairs = em.candidate_pairs(model, data0)
    pairs = pairs[(model.geom_type[pairs] == mujoco.mjtGeom.mjGEOM_ELLIPSOID).all(axis=1)][:8]  # not the box walls
    t = 0.3
    q0, q1 = data0.qpos.copy(), data1.qpos.copy()
    dist, J0, J1, status = em.jacobian.interpolated_distance_jacobian(model, data0, data1, pairs, t)
    smooth = status == es.DerivativeStatus.SMOOTH
    assert smooth.sum() >= 4

    def at(qa, qb):
        da, db = mujoco.MjData(model), mujoco.MjData(model)
        da.qpos[:], db.qpos[:] = qa, qb
        for d in (da, db):
            mujoco.mj_kinematics(model, d)

        def body(d, g):
            return es.Ellipsoids(d.geom_xpos[g], d.geom_xmat[g].reshape(-1, 3, 3), model.geom_size[g])

        out = []
        for col in (0, 1):
            g = pairs[:, col]
            out.append(poses_at(body(da, g), body(db, g), t))
        return es.signed_distance(*out)[0]

    np.testing.assert_array_equal(dist, at(q0, q1))
    for which, J in ((0, J0), (1, J1)):
        fd = np.empty_like(J)
        for k in range(model.nv):
            step = np.zeros(model.nv)
            step[k] = H
            plus, minus = (q0.copy(), q1.copy()), (q0.copy(), q1.copy())
            mujoco.mj_integratePos(model, plus[which], step, 1.0)
            mujoco.mj_integratePos(model, minus[which], -step, 1.0)
            fd[:, k] = (at(*plus) - at(*minus)) / (2 * H)
        scale = np.abs(fd[smooth]).max(axis=1, keepdims=True)
        assert (np.abs(J[smooth] - fd[smooth]) / scale).max() <= BOUND
