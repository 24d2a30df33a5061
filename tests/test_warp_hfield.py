"""ellipsim.warp's ellipsoid x height-field row on Warp's CPU device: the core's pairs/height_field.hpp (the function
MuJoCo C's narrow phase runs) against the CPU API's hfield_contacts on the same float32 poses widened, bit for bit;
an attached terrain run writes those contacts, in MuJoCo's order, and drops none."""

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp
from native_checks import assert_same_bits
from scipy.spatial.transform import Rotation as Rot
from test_meshes import terrain_xml

import ellipsim
import ellipsim.warp as ew
from ellipsim.core.pairs.height_field import HeightField, hfield_contacts
from ellipsim.pair_table import ELLIPSOID, HFIELD
from ellipsim.warp import kernels

SLOW = pytest.mark.slow


@pytest.fixture(autouse=True)
def cpu():
    with wp.ScopedDevice("cpu"):
        yield


def _wide(x):
    return np.asarray(x, np.float32).astype(np.float64)


def _poses(seed, n, lift, scale=(0.03, 0.1)):
    """n ellipsoids over a 2 m field posed off the origin, their centres `lift` (a range) above its top, and the
    field's pose, all float32."""
    rng = np.random.default_rng(seed)
    Rf = Rot.from_euler("xyz", rng.uniform(-0.2, 0.2, 3)).as_matrix()
    cf = np.array([0.3, -0.2, 0.1])
    local = np.c_[rng.uniform(-1.1, 1.1, (n, 2)), 0.1 + rng.uniform(*lift, n)]
    ce = cf + local @ Rf.T
    return [
        np.asarray(x, np.float32)
        for x in (ce, Rot.random(n, random_state=rng).as_matrix(), rng.uniform(*scale, (n, 3)), np.tile(cf, (n, 1)),
                  np.tile(Rf, (n, 1, 1)))
    ]  # fmt: skip


def _field(seed, nrow=30, ncol=30):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, (nrow, ncol)).astype(np.float32), np.float32([1.0, 1.0, 0.1, 0.05])


def _same_as_cpu(ce, Re, re, cf, Rf, elevation, size, margin):
    """The kernel's row and the CPU API on the same widened numbers: the same contacts, bit for bit; the counts."""
    cw, dw, nw, pw = kernels.hfield_pair_contacts(ce, Re, re, cf, Rf, elevation, size, margin)
    E = ellipsim.Ellipsoids(_wide(ce), _wide(Re), _wide(re))
    c = hfield_contacts(E, _wide(cf), _wide(Rf), HeightField(elevation, _wide(size)), margin)
    np.testing.assert_array_equal(cw, c.count)
    assert_same_bits(dw, c.dist, "dist")  # NaN past each count on both sides
    assert_same_bits(nw, c.normal, "normal")
    assert_same_bits(pw, c.pos, "pos")
    return cw


@pytest.mark.parametrize("margin", [0.0, 0.005])
def test_the_hfield_row_is_the_cpus_hfield_contacts_bit_for_bit(margin):
    """Ellipsoids from 5 cm into the field to 5 cm above its top over a tilted, moved field: the same count,
    distances, normals and points as core.pairs.height_field.hfield_contacts on the float32 poses widened."""
    elevation, size = _field(1)
    count = _same_as_cpu(*_poses(2, 300, (-0.05, 0.05)), elevation, size, margin)
    assert (count == 0).sum() > 30 and (count > 0).sum() > 100 and count.sum() > 1000
    assert count.min() >= 0


def test_the_hfield_row_stops_at_mujocos_50_as_the_cpu():
    """A large ellipsoid sunk into a fine field has over 50 prisms within the margin: 50 contacts, MuJoCo's
    mjMAXCONPAIR, the first 50 in MuJoCo's order as on the CPU."""
    elevation, size = _field(3, 60, 60)
    ce, Re, re, cf, Rf = _poses(4, 20, (-0.1, 0.0), scale=(0.2, 0.3))
    count = _same_as_cpu(ce, Re, re, cf, Rf, elevation, size, 0.0)
    assert (count == kernels.HFIELD_MAXCON).sum() > 10


def _terrain(nworld=2, naconmax=4000):
    mjm = mujoco.MjModel.from_xml_string(terrain_xml(0, n=8, nrow=20, ncol=20, meshes=1))
    m = mjw.put_model(mjm)
    d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=nworld, naconmax=naconmax)
    return mjm, m, d


def _cpu_field_contacts(mjm, m, d, world, field, ell):
    """hfield_contacts of geom `ell` with geom `field` on d's float32 poses widened, Warp's float32 model field."""
    hid = mjm.geom_dataid[field]
    nrow, ncol, adr = (int(a.numpy()[hid]) for a in (m.hfield_nrow, m.hfield_ncol, m.hfield_adr))
    F = HeightField(
        m.hfield_data.numpy()[adr : adr + nrow * ncol].reshape(nrow, ncol), _wide(m.hfield_size.numpy()[hid])
    )
    xpos, xmat = d.geom_xpos.numpy()[world], d.geom_xmat.numpy()[world]
    E = ellipsim.Ellipsoids(_wide(xpos[ell][None]), _wide(xmat[ell][None]), _wide(m.geom_size.numpy()[0, ell][None]))
    c = hfield_contacts(E, _wide(xpos[field]), _wide(xmat[field]), F, 0.0)
    k = c.count[0]
    return c.dist[0, :k], c.normal[0, :k], c.pos[0, :k]


@SLOW
def test_an_attached_terrain_run_writes_the_cpus_field_contacts_in_mujocos_order_and_drops_none():
    """8 ellipsoids dropped on a 20 x 20 field, 2 worlds, 150 steps on Warp with ellipsim attached: the field
    pairs are ellipsim's, and at the last step each (world, ellipsoid)'s field contacts are the CPU's on the same
    float32 poses, in the same order, rounded to float32 as Warp's write_contact stores them (the frame's normal
    within make_frame's renormalisation); no overflow, no failed pair.  Then a small naconmax: the contacts past
    it are counted as overflow, none written."""
    mjm, m, d = _terrain()
    field = int(np.flatnonzero(mjm.geom_type == HFIELD)[0])
    ells = np.flatnonzero(mjm.geom_type == ELLIPSOID)
    candidates = ew.candidate_pairs(m)
    with ew.attach(m) as att:
        np.testing.assert_array_equal(att.pairs, candidates)
        assert {(field, int(e)) for e in ells} <= {(int(a), int(b)) for a, b in att.pairs}
        for _ in range(150):
            mjw.step(m, d)
        counters = att.counters
        n = int(d.nacon.numpy()[0])
        c = d.contact
        world, geom, dist = c.worldid.numpy()[:n], c.geom.numpy()[:n], c.dist.numpy()[:n]
        pos, normal = c.pos.numpy()[:n], c.frame.numpy()[:n, 0]
        made = 0
        for w in range(d.nworld):
            for e in ells:
                at = np.flatnonzero((world == w) & (geom[:, 0] == field) & (geom[:, 1] == e))  # in cid order
                want = _cpu_field_contacts(mjm, m, d, w, field, e)
                assert len(at) == len(want[0]), (w, e)
                np.testing.assert_array_equal(dist[at], want[0].astype(np.float32))
                np.testing.assert_array_equal(pos[at], want[2].astype(np.float32))
                np.testing.assert_allclose(normal[at], want[1], atol=1e-6)
                made += len(at)
        assert made > 20, made  # 36 measured
        assert counters["contacts"] > 1000 and counters["overflow"] == 0 and counters["failed"] == 0, counters

        small = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=2, naconmax=8)
        small.qpos.assign(d.qpos.numpy())
        att.reset_counters()
        mjw.forward(m, small)
        k = att.counters
        assert int(small.nacon.numpy()[0]) > 8 and k["overflow"] > 0
        assert k["contacts"] - k["overflow"] <= 8


@SLOW
def test_an_attached_field_pair_at_the_cap_is_counted_as_on_the_cpu():
    """A flat ellipsoid sunk into a 40 x 40 field (254 prisms within the margin) makes 50 contacts a world on
    Warp, and each world's call is counted as capped, as MuJoCo C's narrow phase counts it; one resting on the
    tops (6 prisms) is not."""
    xml = terrain_xml(0, n=0, nrow=40, ncol=40, meshes=0).replace(
        "</worldbody>",
        '<body pos="0 0 {z}"><freejoint/><geom type="ellipsoid" size="0.3 0.3 0.05"/></body></worldbody>',
    )
    for z, made, capped in ((0.05, kernels.HFIELD_MAXCON, 2), (0.14, 6, 0)):
        mjm = mujoco.MjModel.from_xml_string(xml.format(z=z))
        m = mjw.put_model(mjm)
        d = mjw.put_data(mjm, mujoco.MjData(mjm), nworld=2, naconmax=400)
        with ew.attach(m) as att:
            mjw.forward(m, d)
            counters = att.counters
        assert int(d.nacon.numpy()[0]) == 2 * made and counters["capped"] == capped, counters
        assert counters["overflow"] == 0 and counters["failed"] == 0


@SLOW
def test_compare_engine_warp_judges_warps_own_field_contacts(tmp_path, capsys):
    """`ellipsim compare --engine warp` on a terrain model (ellipsoids started 15 cm up, on the 10 cm field): the
    field pairs are candidates now (candidate_pairs reads the same rows) and Warp's own contacts on them are
    judged exactly, under their pair type."""
    import json
    import re

    from ellipsim.app import cli

    xml = re.sub(
        r'<body pos="(\S+) (\S+) \S+"><freejoint/><geom type="ellipsoid"',
        r'<body pos="\1 \2 0.15"><freejoint/><geom type="ellipsoid"',
        terrain_xml(0, n=6, nrow=20, ncol=20, meshes=1),
    )
    path, report = tmp_path / "terrain.xml", tmp_path / "warp.json"
    path.write_text(xml)
    argv = ["compare", str(path), "--engine", "warp", "--worlds", "2", "--steps", "4", "--json", str(report)]
    assert cli.main(argv) == 0
    assert "ellipsoid-hfield:" in capsys.readouterr().out
    field = json.loads(report.read_text())["by_pair_type"]["ellipsoid-hfield"]
    assert field["pairs"] == 2 * 4 * 6 and field["mujoco_contacts"] > 0 and field["ellipsim_contacts"] > 0, field


def test_warps_own_field_overflow_is_explained_not_called_another_buffer():
    """Warp's height-field collider past 50 prisms on a pair it keeps (a mesh rock on the terrain): run's line says
    which collider and why, and d.overflow is cleared."""
    import types

    from ellipsim.app import warp_run

    with wp.ScopedDevice("cpu"):
        d = types.SimpleNamespace(overflow=wp.array([int(mjw.OverflowType.HFIELD), 0], dtype=int))
        line = warp_run.overflow(d, types.SimpleNamespace(naconmax=10, nconmax=5, njmax=8))
        assert "height-field collider met more than 50 prisms" in line and "another" not in line
        assert not d.overflow.numpy().any() and warp_run.overflow(d, None) == ""
