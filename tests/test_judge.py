"""Every pair type judged, one margin rule everywhere: validate, compare, run and replay count the same
contacts of each pair type as MuJoCo makes them, and MuJoCo's normals far from the exact ones are flagged."""

import json

import mujoco
import numpy as np
import pytest

import ellipsim.mujoco as em
from ellipsim.app import replay as rp
from ellipsim.app import scenario, simulate
from ellipsim.app.bench.validation import mixed_pile_xml
from ellipsim.app.cli import main
from ellipsim.mujoco.judge import KEYS, NORMAL_OFF_DEG, judged, pair_type, sigma, verdicts
from tests.test_margins_pairs import ABOVE, BELOW, ELLIPSOID_A, ELLIPSOID_B, MARGIN, SPHERE_A, rows_xml

CAPSULE_B, BOX_B, CYLINDER_B = ("capsule", (0.08, 0.2)), ("box", (0.1, 0.12, 0.14)), ("cylinder", (0.09, 0.15))
#: One pair of each type (geom a an ellipsoid, b of the type), in judge.KEYS' order, but mesh and height field
#: (tests/test_meshes.py)
EVERY_TYPE = (ELLIPSOID_B, SPHERE_A, CAPSULE_B, BOX_B, CYLINDER_B)


def test_pair_types_are_the_tables_rows_in_either_order():
    model = mujoco.MjModel.from_xml_string(rows_xml([(ELLIPSOID_A, b, 0.1, "", "") for b in EVERY_TYPE]))
    pairs = np.arange(2 * len(EVERY_TYPE)).reshape(-1, 2)
    assert pair_type(model, pairs[:, 0], pairs[:, 1]).tolist() == list(range(len(EVERY_TYPE)))
    assert pair_type(model, pairs[:, 1], pairs[:, 0]).tolist() == list(range(len(EVERY_TYPE)))
    assert not judged(model, [3, 5], [5, 7]).any()  # sphere x capsule, capsule x box: not ellipsim's


def test_validate_counts_every_type_as_mujoco_makes_its_contacts():
    """Over 400 steps of the mixed pile, validate's MuJoCo contacts per pair type are the pairs of each
    type on which MuJoCo made a contact with dist < margin (read from data.contact independently); the
    exact side disagrees only within MuJoCo's tolerance, and every type has contacts."""
    model = mujoco.MjModel.from_xml_string(mixed_pile_xml(per_type=3))
    data = mujoco.MjData(model)
    seen = []

    def observer(m, d, step, found):
        per_type = np.zeros(len(KEYS), dtype=np.int64)
        pairs = set()
        for c in d.contact[: d.ncon]:
            g1, g2 = sorted(int(g) for g in c.geom)
            margin = m.geom_margin[g1] + m.geom_margin[g2]
            if judged(m, [g1], [g2])[0] and c.dist < margin and (g1, g2) not in pairs:
                pairs.add((g1, g2))
                per_type[pair_type(m, [g1], [g2])[0]] += 1
        seen.append(per_type)

    v = em.validate(model, data, 400, observer=observer)
    theirs = v.by_type[:, :, 0] + v.by_type[:, :, 2]
    np.testing.assert_array_equal(theirs, np.array(seen))
    assert (theirs.sum(axis=0) > 0).all(), theirs.sum(axis=0)
    np.testing.assert_array_equal(v.counts, v.by_type.sum(axis=1))
    assert {d.kind for d in v.disagreements} <= {"near_tangent", "normal_off"}
    for d in v.disagreements:
        assert d.pair_type in KEYS and d.bodies and d.right in ("ellipsim", "undetermined")
        if d.kind == "near_tangent":
            assert abs(d.signed_distance - d.margin) < 2e-6


@pytest.mark.parametrize("sd, contact", [(BELOW, True), (ABOVE, False)])
def test_one_margin_rule_in_validate_compare_run_and_replay(tmp_path, capsys, sd, contact):
    """A pair of each type with a 1 mm margin, 40 um inside or outside it (no gravity, at rest): every
    command counts it as a contact on both sides, or on neither, the same per type."""
    rows = [(ELLIPSOID_A, b, sd, f'margin="{MARGIN}"', "") for b in EVERY_TYPE]
    path = tmp_path / "margins.xml"
    path.write_text(rows_xml(rows))
    model = mujoco.MjModel.from_xml_string(path.read_text())
    want = [int(contact)] * len(EVERY_TYPE) + [0] * (len(KEYS) - len(EVERY_TYPE))  # no mesh, no field
    v = em.validate(model, mujoco.MjData(model), 1)
    assert (v.by_type[0, :, 0] + v.by_type[0, :, 2]).tolist() == want  # MuJoCo's contacts
    assert (v.by_type[0, :, 0] + v.by_type[0, :, 3]).tolist() == want  # the exact test's
    assert v.disagreements == []
    report = tmp_path / "c.json"
    assert main(["compare", str(path), "--steps", "1", "--json", str(report)]) == 0
    by_type = json.loads(report.read_text())["by_pair_type"]
    assert [by_type[k]["ellipsim_contacts"] for k in KEYS] == want == [by_type[k]["mujoco_contacts"] for k in KEYS]
    run = simulate.run(scenario.load(str(path)), steps=1, mode="builtin")
    assert run.frames.ellipsim_by_type.tolist() == [want] == run.frames.builtin_by_type.tolist()
    played = rp.replay(model, model.qpos0[None], fps=30)
    assert played.in_contact_by_type.tolist() == [want] == played.mujoco_by_type.tolist()
    capsys.readouterr()
    assert main(["run", str(path), "--steps", "1", "--mode", "builtin"]) == 0
    out = capsys.readouterr().out
    for key, w in zip(KEYS, want):  # one line per type in contact
        assert (f"    {key}: MuJoCo mean {float(contact):.2f}" in out) == bool(w), key


def test_normal_off_flags_mujocos_wrong_normal_and_not_a_tight_one():
    """Two ellipsoids 1 mm deep: MuJoCo's EPA at its default 35 iterations stops with its normal 4.9 deg off
    (sigma there 0.63 mm below the exact -1 mm); at 1000 iterations it is within its tolerance."""
    xml = rows_xml([(ELLIPSOID_A, ELLIPSOID_B, -0.001, "", "")])
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    n = data.contact.frame[0, :3]
    exact = verdicts(model, data, [[0, 1]], [0.0], measure=[True])
    angle = np.degrees(np.arccos(np.clip(n @ exact.normal[0], -1, 1)))
    assert angle > NORMAL_OFF_DEG and sigma(model, data, [0], [1], n[None])[0] < exact.dist[0] - 1e-4
    v = em.validate(model, mujoco.MjData(model), 1)
    (d,) = v.disagreements
    assert (d.kind, d.right, d.pair_type, d.names) == ("normal_off", "ellipsim", "ellipsoid-ellipsoid", ("a0", "b0"))
    assert d.angle == pytest.approx(angle) and d.sigma_mujoco < d.signed_distance - 1e-4
    assert v.normal_off.tolist() == [[1] + [0] * (len(KEYS) - 1)] and v.counts.tolist() == [
        [1, 0, 0, 0]
    ]  # agree on contact
    model.opt.ccd_iterations = 1000
    assert em.validate(model, mujoco.MjData(model), 1).disagreements == []


def test_no_candidate_pairs_says_why(tmp_path, capsys):
    """A model with no pair ellipsim judges, and one whose geoms never come near: no `0/0`, a reason."""
    far = tmp_path / "far.xml"
    far.write_text(rows_xml([(ELLIPSOID_A, ELLIPSOID_B, 1.0, "", "")]))
    boxes = tmp_path / "boxes.xml"
    boxes.write_text(rows_xml([(BOX_B, CAPSULE_B, -0.01, "", "")]))
    for path, why in ((far, "brought no pair ellipsim judges within reach"), (boxes, "has no pair ellipsim judges")):
        assert main(["compare", str(path), "--steps", "3"]) == 0
        out = capsys.readouterr().out
        assert "no candidate pairs in 3 steps: " in out and why in out and "0/0" not in out and "agreement" not in out
