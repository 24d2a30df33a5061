"""`compare --record`: MuJoCo's contacts against the exact verdicts, frame by frame, read back with
rerun's own reader (test_record.Recording)."""

import json

import mujoco
import numpy as np
import pytest
import rerun.blueprint as rrb

from ellipsim.app import compare_record, record
from ellipsim.app.cli import main
from ellipsim.core.distance.ellipsoid_pair import signed_distance
from ellipsim.core.ellipsoids import Ellipsoids
from ellipsim.mujoco.validate import Disagreement
from tests.test_record import Recording, blueprint_parts, packed

TWO = """<mujoco><option gravity="0 0 -9.81"/><worldbody>
  <geom name="floor" type="plane" size="0 0 1"/>
  <body name="left" pos="0 0 0.3" quat="1 0.2 0.1 0"><freejoint/><geom name="a" type="ellipsoid" size=".1 .2 .3"/></body>
  <body name="right" pos="0.22 0.02 0.32"><freejoint/><geom name="b" type="ellipsoid" size=".15 .1 .2"/></body>
</worldbody></mujoco>"""
STEPS = 8


def fake(step, kind):
    """A disagreement between geoms a (1) and b (2) of kind mujoco_extra / mujoco_missed / near_tangent."""
    return Disagreement(
        step=step,
        geom1=1,
        geom2=2,
        names=("a", "b"),
        bodies=("left", "right"),
        pair_type="ellipsoid-ellipsoid",
        kind=kind,
        mujoco_contact=kind == "mujoco_extra",
        mujoco_dist=-1e-4 if kind == "mujoco_extra" else float("nan"),
        relation="separated" if kind == "mujoco_extra" else "overlapping",
        contact_scale=1.001,
        geom_distance=1e-9 if kind == "near_tangent" else 0.01 * (1 if kind == "mujoco_extra" else -1),
        right="ellipsim",
        reason=f"why {kind}",
        signed_distance=0.5,
        mujoco_pos=(0.1, 0.2, 0.3) if kind == "mujoco_extra" else None,
        mujoco_normal=(1.0, 0.0, 0.0) if kind == "mujoco_extra" else None,
        ellipsim_pos=(0.1 * step, 0.0, 0.3),
        ellipsim_normal=(0.0, 1.0, 0.0),
    )


INJECTED = {2: ["mujoco_extra", "mujoco_missed"], 3: ["near_tangent"], 6: ["mujoco_missed"]}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """STEPS steps of two ellipsoids falling onto each other and the floor, with made-up disagreements
    at steps 2, 3 and 6; MuJoCo's contacts of each step kept to check the differences against."""
    model = mujoco.MjModel.from_xml_string(TWO)
    data = mujoco.MjData(model)
    path = tmp_path_factory.mktemp("compare") / "compare.rrd"
    contacts = []
    with record.Recorder(path) as recorder:
        observer = compare_record.CompareRecording(recorder, model, "two")
        for step in range(STEPS):
            mujoco.mj_forward(model, data)
            mine = [k for k in range(data.ncon) if set(data.contact.geom[k]) == {1, 2}]
            contacts.append(
                [
                    (
                        data.contact.dist[k],
                        data.contact.frame[k, :3].copy(),
                        data.geom_xpos.copy(),
                        data.geom_xmat.copy(),
                    )
                    for k in mine
                ]
            )
            observer(model, data, step, [fake(step, kind) for kind in INJECTED.get(step, [])])
            mujoco.mj_step(model, data)
        observer.finish()
    return model, Recording(path), contacts


def test_disagreements_are_marked_at_their_step_and_cleared_after(recorded):
    """A ball on a pole at each disagreement's step, taken off at the next; the pole rises from ellipsim's
    contact point straight up to above the geoms stacked there (the ball's height), in the kind's colour."""
    model, rec, _ = recorded
    frames, _, positions = rec.temporal("/world/disagreements", "Points3D:positions")
    rows = dict(zip(frames, positions))
    assert sorted(rows) == [2, 3, 4, 6, 7]  # 4 and 7: the markers of steps 3 and 6 taken off
    assert [len(rows[f]) for f in (2, 3, 4, 6, 7)] == [2, 1, 0, 1, 0]
    head = np.array(rows[6], dtype=np.float64)
    np.testing.assert_allclose(head[0, :2], [0.6, 0.0], rtol=1e-6)  # above the contact point (0.6, 0, 0.3)
    scale = record.scene_scale(_geometry(model))
    assert head[0, 2] >= 0.3 + compare_record.POLE_ABOVE * scale - 1e-6
    _, _, strips = rec.temporal("/world/disagreements/poles", "LineStrips3D:strips")
    pole = np.array(dict(zip(frames, strips))[6][0], dtype=np.float64)
    np.testing.assert_allclose(pole, [[0.6, 0.0, 0.3], head[0]], rtol=1e-6)
    _, _, colors = rec.temporal("/world/disagreements", "Points3D:colors")
    by_kind = {k: packed(c) for k, (c, _) in compare_record.kinds("MuJoCo").items()}
    assert dict(zip(frames, colors))[2] == [by_kind["mujoco_extra"], by_kind["mujoco_missed"]]
    assert dict(zip(frames, colors))[3] == [by_kind["near_tangent"]]
    verdicts = {packed(c) for c in (record.OVERLAPPING_COLOR, record.TOUCHING_COLOR, record.CONTACT_COLOR)}
    assert not set(by_kind.values()) & verdicts  # the markers' colours are none of the verdict colours
    _, _, labels = rec.temporal("/world/disagreements", "Points3D:labels")
    assert dict(zip(frames, labels))[2] == ["mujoco_extra: a / b", "mujoco_missed: a / b"]
    assert rec.static("/world/disagreements", "Points3D:show_labels") == [[True]]  # few: their labels shown
    # both contacts: MuJoCo's where it made one (the mujoco_extra pair), ellipsim's at every disagreement
    frames, _, vectors = rec.temporal("/world/disagreements/mujoco", "Arrows3D:vectors")
    length = record.NORMAL_LENGTH * scale
    assert dict(zip(frames, vectors))[2] == [pytest.approx([length, 0, 0], rel=1e-6)]
    assert dict(zip(frames, vectors))[3] == []
    frames, _, vectors = rec.temporal("/world/disagreements/ellipsim", "Arrows3D:vectors")
    assert [len(dict(zip(frames, vectors))[f]) for f in (2, 3, 4, 6, 7)] == [2, 1, 0, 1, 0]


def _geometry(model):
    from ellipsim.app import capture

    return capture.geometry(model, "two")


def test_every_disagreement_has_a_log_line_at_its_step(recorded):
    _, rec, _ = recorded
    frames, _, texts = rec.temporal("/events/disagreements", "TextLog:text")
    lines = [(f, t[0]) for f, t in zip(frames, texts)]
    assert [f for f, _ in lines] == [2, 2, 3, 6]
    first = lines[0][1]
    assert first == (
        "step 2: mujoco_extra: ellipsoid-ellipsoid a / b (bodies left / right): MuJoCo -0.0001 m, exact 0.5 m; "
        "right: ellipsim, the exact distance is >= margin 0"
    )
    assert "MuJoCo no contact" in lines[1][1] and "the exact distance is < margin 0" in lines[1][1]
    _, _, levels = rec.temporal("/events/disagreements", "TextLog:level")
    assert [lv[0] for lv in levels] == ["WARN", "WARN", "INFO", "WARN"]
    assert set(rec.timelines()) == {"frame", "time"}  # columns only: no log_time or log_tick


def test_the_overview_counts_and_lists_every_disagreement(recorded):
    _, rec, _ = recorded
    (text,) = rec.static("/overview", "TextDocument:text")[-1]
    assert text.startswith("**4 disagreements in 8 steps**")
    assert "| ellipsoid-ellipsoid | 1 | 2 | 1 | 0 |" in text  # extra, missed, near_tangent, normal_off
    assert text.count("| a / b |") == 4


def test_the_difference_plots_peaks_are_named_in_the_log(recorded):
    _, rec, _ = recorded
    _, _, dist = rec.temporal("/differences/distance", "Scalars:scalars")
    frames, _, texts = rec.temporal("/events/differences", "TextLog:text")
    peaks = [t[0] for t in texts]
    top = next(x for x in peaks if "peak 1 of the run's |MuJoCo dist - exact|" in x)
    assert top.endswith("on a / b (bodies left / right)")
    assert float(top.split(": ")[2].split(" ")[0]) == pytest.approx(max(d[0] for d in dist), rel=1e-2)


def test_disagreement_counts_per_step(recorded):
    _, rec, _ = recorded
    for kind in ("mujoco_extra", "mujoco_missed", "near_tangent", "normal_off"):
        frames, _, scalars = rec.temporal(f"/counts/disagreements/{kind}", "Scalars:scalars")
        assert frames == list(range(STEPS))
        expected = [float(INJECTED.get(step, []).count(kind)) for step in range(STEPS)]
        assert [s[0] for s in scalars] == expected


def test_distance_and_normal_differences_on_mujocos_contacts(recorded):
    """Each step with a MuJoCo contact between the ellipsoids: the largest |dist - signed distance|
    and normal angle against ellipsim on the same poses."""
    model, rec, contacts = recorded
    frames, _, dist = rec.temporal("/differences/distance", "Scalars:scalars")
    _, _, angle = rec.temporal("/differences/normal_angle", "Scalars:scalars")
    with_contacts = [step for step, cs in enumerate(contacts) if cs]
    assert frames == with_contacts and with_contacts  # they touch
    radii = model.geom_size[[1, 2]]
    for f, got_dist, got_angle in zip(frames, dist, angle):
        worst = [0.0, 0.0]
        for mj_dist, normal, xpos, xmat in contacts[f]:
            a = Ellipsoids(xpos[[1]], xmat[[1]].reshape(1, 3, 3), radii[[0]])
            b = Ellipsoids(xpos[[2]], xmat[[2]].reshape(1, 3, 3), radii[[1]])
            d, n = signed_distance(a, b)[:2]
            worst[0] = max(worst[0], abs(mj_dist - d[0]))
            worst[1] = max(worst[1], np.degrees(np.arccos(np.clip(n[0] @ normal, -1, 1))))
        assert got_dist[0] == pytest.approx(worst[0], rel=1e-12, abs=1e-15)
        assert got_angle[0] == pytest.approx(worst[1], rel=1e-9, abs=1e-9)


def test_the_layout_shows_the_disagreements(recorded):
    _, rec, _ = recorded
    views, kinds, eye, panels, containers = blueprint_parts(rec)
    assert sorted(views["TimeSeries"]) == sorted(
        ["counts/pairs", "counts/disagreements", "differences/distance", "differences/normal_angle", "depth"]
    )
    assert views["TextLog"] == ["events"] and sorted(views["TextDocument"]) == ["legend", "overview"]
    assert views["3D"] == ["world"]
    assert [c[1] for c in containers if c[0] == rrb.components.ContainerKind.Tabs.value] == [None]
    assert {c[1] for c in containers} >= {"scene", "disagreements"}  # the log a tab of its own, the window wide
    text = rec.static("/legend", "TextDocument:text")[-1][0]
    assert "**pink**: mujoco_extra, MuJoCo made a contact the exact test separates" in text and "yellow" in text
    assert eye["look_target"][2] > 0  # inside the bodies, above the floor


def test_compare_record_on_the_command_line_logs_the_disagreements_the_json_lists(tmp_path, capsys):
    out, report = tmp_path / "rec" / "compare.rrd", tmp_path / "compare.json"
    assert main(["compare", "replay", "--steps", "40", "--record", str(out), "--json", str(report)]) == 0
    assert f"recording: {out} (40 steps" in capsys.readouterr().out
    rec = Recording(out)
    assert rec.temporal("/counts/pairs/builtin", "Scalars:scalars")[0] == list(range(40))
    listed = json.loads(report.read_text())["disagreements"]
    frames, _, texts = rec.temporal("/events/disagreements", "TextLog:text")
    assert [(f, t[0].split(":")[1].strip()) for f, t in zip(frames, texts)] == [(d["step"], d["kind"]) for d in listed]
    assert {"/world/contacts", "/world/disagreements", "/counts/disagreements/mujoco_missed"} <= rec.entities()
    text = rec.static("/legend", "TextDocument:text")[-1][0]
    (overview,) = rec.static("/overview", "TextDocument:text")[-1]
    assert overview.startswith(f"**{len(listed)} disagreements in 40 steps**")
    assert ("No disagreements in 40 steps." in text) == (not listed)
