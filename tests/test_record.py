"""Recordings: read every .rrd back with rerun's own reader and compare with what was recorded.

rerun stores positions, sizes and quaternions as float32, so values are compared with the recorded
values rounded to float32, exactly.  Colours come back packed as 0xRRGGBBAA.
"""

import colorsys
import os
import pathlib
import subprocess
import sys

import mujoco
import numpy as np
import pytest
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from ellipsim.app import capture, record, scenario, simulate, trajectory
from ellipsim.app.trajectory import GEOM_KINDS, Frames, SceneGeometry
from ellipsim.core.rotations import quaternion_product, quaternions_to_rotations

ZOO = pathlib.Path(__file__).parent / "models" / "zoo.xml"
K = {name: k for k, name in enumerate(GEOM_KINDS)}


def packed(rgba):
    r, g, b, a = (int(v) for v in rgba)
    return (r << 24) | (g << 16) | (b << 8) | a


def f32(x):
    return np.asarray(x, dtype=np.float64).astype(np.float32)


class Recording:
    """The chunks of an .rrd, with row-level access per entity and component."""

    def __init__(self, path):
        self.reader = RrdReader(path)
        self.chunks = self.reader.stream().to_chunks()

    def entities(self):
        return {c.entity_path for c in self.chunks}

    def timelines(self):
        """The timelines of every temporal row (the index columns of the recording's chunks)."""
        names = set()
        for c in self.chunks:
            if not c.is_static:
                names |= {n for n in c.to_record_batch().schema.names if ":" not in n and not n.startswith("rerun.")}
        return names

    def static(self, entity, component):
        """Every static row of `component` on `entity`: a list of per-row values."""
        rows = []
        for c in self.chunks:
            if c.entity_path == entity and c.is_static:
                batch = c.to_record_batch()
                if component in batch.schema.names:
                    rows += batch.column(component).to_pylist()
        return rows

    def temporal(self, entity, component):
        """(frames, times in ns, values) of every temporal row of `component` on `entity`, by frame."""
        frames, times, values = [], [], []
        for c in self.chunks:
            if c.entity_path == entity and not c.is_static:
                batch = c.to_record_batch()
                if component in batch.schema.names:
                    frames += batch.column("frame").to_pylist()
                    times += batch.column("time").cast("int64").to_pylist()
                    values += batch.column(component).to_pylist()
        order = np.argsort(frames, kind="stable")
        return [frames[i] for i in order], [times[i] for i in order], [values[i] for i in order]


# --- a synthetic model: every geom kind, a static body under a moving one, two chunks of frames ----

BODIES = ["world", "base", "arm", "hand", "free ball"]  # "free ball": a name that needs escaping
PARENT = [0, 0, 1, 2, 0]
MOVING = [2, 4]
GEOMS = [  # (name, body, kind)
    ("floor", 0, "plane"), ("plinth", 1, "box"), ("upper", 2, "ellipsoid"), ("knob", 2, "sphere"),
    ("rod", 2, "capsule"), ("drum", 3, "cylinder"), ("gem", 3, "mesh"), ("ball", 4, "ellipsoid"),
    ("ground", 0, "hfield"),
]  # fmt: skip
ELLIPSOIDS = [2, 3, 7]
F, SPLIT = 7, 4
BOX_LO, BOX_HI = [-1.0, -0.5, 0.0], [2.0, 0.5, 1.5]  # the bodies' bounding box in frame 0 (it grows by the frame)
STATE = [[0, 0, 0], [1, 0, 0], [1, 0, 0], [2, 2, 0], [2, 2, 0], [0, 0, 2], [0, 0, 2]]
CONTACTS_PER_FRAME = [2, 0, 3, 1, 4, 0, 2]  # frames 1 and 5 have none
TETRA = (
    np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]),
    np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]),
)
QUAD = (np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))


def unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def make_geometry(rng):
    G = len(GEOMS)
    return SceneGeometry(
        name="synthetic",
        body_names=list(BODIES),
        body_parent=np.array(PARENT),
        body_pos=rng.normal(size=(5, 3)),
        body_quat=unit(rng.normal(size=(5, 4))),
        moving=np.array(MOVING),
        geom_names=[g[0] for g in GEOMS],
        geom_body=np.array([g[1] for g in GEOMS]),
        geom_kind=np.array([K[g[2]] for g in GEOMS]),
        geom_size=rng.uniform(0.02, 0.2, (G, 3)),
        geom_pos=rng.normal(size=(G, 3)),
        geom_quat=unit(rng.normal(size=(G, 4))),
        geom_rgba=rng.uniform(0, 1, (G, 4)),
        meshes={0: QUAD, 6: TETRA, 8: QUAD},
        ellipsoids=np.array(ELLIPSOIDS),
    )


def make_frames(rng, first, last):
    f = last - first
    frame = np.arange(first, last)
    counts = CONTACTS_PER_FRAME[first:last]
    contact_frame = np.repeat(frame, counts)
    k = len(contact_frame)
    return Frames(
        frame=frame,
        times=frame / 60.0,
        body_pos=rng.normal(size=(f, 2, 3)),
        body_quat=unit(rng.normal(size=(f, 2, 4))),
        state=np.array(STATE[first:last], dtype=np.int8),
        contact_frame=contact_frame,
        contact_pos=rng.normal(size=(k, 3)),
        contact_normal=unit(rng.normal(size=(k, 3))),
        contact_ellipsoids=np.arange(k) % 2 == 0,
        contact_geoms=rng.integers(0, len(GEOMS), (k, 2)),
        contact_dist=rng.normal(scale=1e-3, size=k),
        builtin_counts=np.array([1, 0, 2, 0, 5, 1, 3][first:last]),
        ellipsim_counts=np.array([1, 0, 2, 1, 5, 0, 3][first:last]),
        touching_counts=np.array([0, 1, 1, 0, 0, 0, 0][first:last]),
        contact_counts=np.array(counts) + 1,
        bounds=np.stack([np.array(BOX_LO) - 0.1 * frame[:, None], np.array(BOX_HI) + 0.05 * frame[:, None]], axis=1),
        builtin_by_type=np.column_stack([np.array([1, 0, 2, 0, 5, 1, 3][first:last]), np.zeros(f, dtype=int)]),
        ellipsim_by_type=np.column_stack([np.array([1, 0, 2, 1, 5, 0, 3][first:last]), np.zeros(f, dtype=int)]),
    )


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    rng = np.random.default_rng(7)
    g = make_geometry(rng)
    chunks = [make_frames(rng, 0, SPLIT), make_frames(rng, SPLIT, F)]
    path = tmp_path_factory.mktemp("record") / "run.rrd"
    rid = record.save(path, g, chunks)
    return g, chunks, path, Recording(path), rid


BODY_PATH = {
    1: "/world/model/base",
    2: "/world/model/base/arm",
    3: "/world/model/base/arm/hand",
    4: "/world/model/free\\ ball",
}


def test_entity_tree_follows_the_bodies(saved):
    g, _, path, rec, rid = saved
    expected = {
        "/world",
        "/world/model/geoms/floor",
        "/world/model/geoms/ground",
        *BODY_PATH.values(),
        "/world/model/base/geoms/boxes",
        "/world/model/base/arm/geoms/ellipsoids",
        "/world/model/base/arm/geoms/capsules",
        "/world/model/base/arm/hand/geoms/cylinders",
        "/world/model/base/arm/hand/geoms/gem",
        "/world/model/free\\ ball/geoms/ellipsoids",
        "/world/contacts",
        "/world/contact_normals",
        "/counts/pairs/builtin",
        "/counts/pairs/ellipsim",
        "/counts/contacts/all",
    }
    assert expected <= rec.entities()
    assert not {e for e in rec.entities() if e.startswith("/world/model")} - expected
    assert rec.reader.recordings()[0].recording_id == rid


def test_rrd_verify(saved):
    path = saved[2]
    beside = pathlib.Path(sys.executable).with_name("rerun")
    command = [str(beside)] if beside.is_file() else [sys.executable, "-m", "rerun"]
    # `rrd verify` exists in 0.41 (`rerun rrd --help` lists it); exit 0 means the file loads.
    done = subprocess.run([*command, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "verified without error" in done.stderr + done.stdout


def test_static_bodies_once_moving_bodies_per_frame(saved):
    g, chunks, _, rec, _ = saved
    for b in (1, 3):  # not moving relative to their parents (3 hangs from the moving arm)
        (t,) = rec.static(BODY_PATH[b], "Transform3D:translation")
        np.testing.assert_array_equal(np.array(t, dtype=np.float32).ravel(), f32(g.body_pos[b]))
        (q,) = rec.static(BODY_PATH[b], "Transform3D:quaternion")
        np.testing.assert_array_equal(np.array(q, dtype=np.float32).ravel(), f32(np.roll(g.body_quat[b], -1)))
        assert rec.temporal(BODY_PATH[b], "Transform3D:translation")[0] == []
    pos = np.concatenate([c.body_pos for c in chunks])
    quat = np.concatenate([c.body_quat for c in chunks])
    for m, b in enumerate(MOVING):
        assert rec.static(BODY_PATH[b], "Transform3D:translation") == []
        frames, times, t = rec.temporal(BODY_PATH[b], "Transform3D:translation")
        assert frames == list(range(F)) and times == [round(f / 60 * 1e9) for f in range(F)]  # 1/60 s rounds up
        np.testing.assert_array_equal(np.array(t, dtype=np.float32).reshape(F, 3), f32(pos[:, m]))
        _, _, q = rec.temporal(BODY_PATH[b], "Transform3D:quaternion")
        np.testing.assert_array_equal(np.array(q, dtype=np.float32).reshape(F, 4), f32(np.roll(quat[:, m], -1, axis=1)))


def test_every_geom_kind_is_drawn_once_in_its_body_frame(saved):
    g, _, _, rec, _ = saved
    colors = record.figure_colors(g)
    base = "/world/model/base"
    (half,) = rec.static(f"{base}/geoms/boxes", "Boxes3D:half_sizes")
    np.testing.assert_array_equal(np.array(half, dtype=np.float32), f32(g.geom_size[[1]]))
    assert rec.static(f"{base}/geoms/boxes", "Boxes3D:colors") == [[packed(colors[1])]]
    arm = f"{base}/arm/geoms"
    (half,) = rec.static(f"{arm}/ellipsoids", "Ellipsoids3D:half_sizes")
    r = g.geom_size[3, 0]
    np.testing.assert_array_equal(np.array(half, dtype=np.float32), f32([g.geom_size[2], [r, r, r]]))  # sphere: r, r, r
    assert rec.static(f"{arm}/ellipsoids", "Ellipsoids3D:labels") == [["upper", "knob"]]
    (centers,) = rec.static(f"{arm}/ellipsoids", "Ellipsoids3D:centers")
    np.testing.assert_array_equal(np.array(centers, dtype=np.float32), f32(g.geom_pos[[2, 3]]))
    assert rec.temporal(f"{arm}/ellipsoids", "Ellipsoids3D:half_sizes")[0] == []  # static only
    # capsule: MuJoCo's is centred (half-length size[1] along z), rerun's starts at its translation
    (length,) = rec.static(f"{arm}/capsules", "Capsules3D:lengths")
    (start,) = rec.static(f"{arm}/capsules", "Capsules3D:translations")
    z = quaternions_to_rotations(g.geom_quat[4])[:, 2]
    np.testing.assert_array_equal(np.array(length, dtype=np.float32), f32([2 * g.geom_size[4, 1]]))
    np.testing.assert_allclose(np.array(start).ravel(), g.geom_pos[4] - g.geom_size[4, 1] * z, atol=1e-6)
    (length,) = rec.static(f"{base}/arm/hand/geoms/cylinders", "Cylinders3D:lengths")
    np.testing.assert_array_equal(np.array(length, dtype=np.float32), f32([2 * g.geom_size[5, 1]]))
    for entity, geom in (
        (f"{base}/arm/hand/geoms/gem", 6),
        ("/world/model/geoms/floor", 0),
        ("/world/model/geoms/ground", 8),
    ):
        (vertices,) = rec.static(entity, "Mesh3D:vertex_positions")
        np.testing.assert_array_equal(np.array(vertices, dtype=np.float32), f32(g.meshes[geom][0]))
        (triangles,) = rec.static(entity, "Mesh3D:triangle_indices")
        np.testing.assert_array_equal(np.array(triangles), g.meshes[geom][1])
        (t,) = rec.static(entity, "Transform3D:translation")
        np.testing.assert_array_equal(np.array(t, dtype=np.float32).ravel(), f32(g.geom_pos[geom]))
        assert rec.static(entity, "Mesh3D:albedo_factor") == [[packed(colors[geom])]]
        (normals,) = rec.static(entity, "Mesh3D:vertex_normals")
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, rtol=1e-6)


def test_ellipsoid_colours_where_the_state_changes(saved):
    g, _, _, rec, _ = saved
    colors = record.figure_colors(g)

    def palette(geom, s):
        return packed(colors[geom] if s == 0 else record.TOUCHING_COLOR if s == 1 else record.OVERLAPPING_COLOR)

    for entity, geoms, cols in (
        ("/world/model/base/arm/geoms/ellipsoids", [2, 3], [0, 1]),
        ("/world/model/free\\ ball/geoms/ellipsoids", [7], [2]),
    ):
        frames, _, got = rec.temporal(entity, "Ellipsoids3D:colors")
        state = np.array(STATE)[:, cols]
        changed = [0] + [f for f in range(1, F) if (state[f] != state[f - 1]).any()]
        assert frames == changed  # arm: 0, 1, 3, 5 (not 2, nor 4 across the chunk boundary); ball: 0, 5
        assert got == [[palette(geom, s) for geom, s in zip(geoms, state[f])] for f in changed]
        assert rec.static(entity, "Ellipsoids3D:colors") == []  # a static colour would hide the temporal ones


def test_contacts_of_every_kind_per_frame(saved):
    _, chunks, _, rec, _ = saved
    frames, _, positions = rec.temporal("/world/contacts", "Points3D:positions")
    assert frames == list(range(F))
    assert [len(p) for p in positions] == CONTACTS_PER_FRAME
    _, _, colors = rec.temporal("/world/contacts", "Points3D:colors")
    _, _, vectors = rec.temporal("/world/contact_normals", "Arrows3D:vectors")
    _, _, labels = rec.temporal("/world/contacts", "Points3D:labels")
    both = {True: packed(record.CONTACT_COLOR), False: packed(record.OTHER_CONTACT_COLOR)}
    for c in chunks:
        for f in c.frame:
            mine = np.flatnonzero(c.contact_frame == f)
            np.testing.assert_array_equal(
                np.array(positions[f], dtype=np.float32).reshape(-1, 3), f32(c.contact_pos[mine])
            )
            expected = f32(record.NORMAL_LENGTH * record.scene_scale(saved[0]) * c.contact_normal[mine])
            np.testing.assert_array_equal(np.array(vectors[f], dtype=np.float32).reshape(-1, 3), expected)
            assert colors[f] == [both[bool(e)] for e in c.contact_ellipsoids[mine]]
            names = [GEOMS[i][0] for i in range(len(GEOMS))]
            assert labels[f] == [
                f"{names[g1]} / {names[g2]}: " + (f"depth {-d:.3g} m" if d < 0 else f"apart {d:.3g} m")
                for (g1, g2), d in zip(c.contact_geoms[mine], c.contact_dist[mine])
            ]
    assert set(colors[0] + colors[2]) == set(both.values())
    # sized to the scene: a contact's sphere a fifth of the typical geom, hidden labels (shown on hover)
    (radius,) = rec.static("/world/contacts", "Points3D:radii")
    assert radius == [pytest.approx(record.CONTACT_RADIUS * record.scene_scale(saved[0]), rel=1e-6)]
    assert rec.static("/world/contacts", "Points3D:show_labels") == [[False]]


def test_count_series_stay_distinguishable(saved):
    _, chunks, _, rec, _ = saved
    for entity, field in (
        ("/counts/pairs/builtin", "builtin_counts"),
        ("/counts/pairs/ellipsim", "ellipsim_counts"),
        ("/counts/contacts/all", "contact_counts"),
    ):
        frames, _, scalars = rec.temporal(entity, "Scalars:scalars")
        assert frames == list(range(F))
        assert scalars == [[float(v)] for c in chunks for v in getattr(c, field)]
    style = {
        e: (rec.static(e, "SeriesLines:colors"), rec.static(e, "SeriesLines:widths")[0][0])
        for e in ("/counts/pairs/builtin", "/counts/pairs/ellipsim")
    }
    (builtin_color, builtin_width), (ours_color, ours_width) = style.values()
    assert builtin_color != ours_color
    assert builtin_width >= 3 * ours_width  # the thin line runs inside the wide one where they agree


def blueprint_of(rec):
    """The views (kind: [origin]), container kinds and the 3D view's eye controls of a recording's one blueprint."""
    return blueprint_parts(rec)[:3]


def blueprint_parts(rec):
    """blueprint_of's views, container kinds and eye controls, and {panel: state} of the viewer's side panels,
    [(container kind, name, column shares)] of the containers."""
    (store,) = rec.reader.blueprints()
    views, kinds, eye, panels, containers = {}, [], {}, {}, []
    for c in rec.reader.stream(store=store).to_chunks():
        batch = c.to_record_batch()
        names = batch.schema.names
        if "ViewBlueprint:class_identifier" in names:
            (kind,) = batch.column("ViewBlueprint:class_identifier").to_pylist()
            (origin,) = batch.column("ViewBlueprint:space_origin").to_pylist()
            views.setdefault(kind[0], []).append(origin[0])
        if "ContainerBlueprint:container_kind" in names:
            kind = batch.column("ContainerBlueprint:container_kind").to_pylist()
            kinds += kind
            name = (
                batch.column("ContainerBlueprint:display_name").to_pylist()
                if "ContainerBlueprint:display_name" in names
                else [None]
            )
            shares = (
                batch.column("ContainerBlueprint:col_shares").to_pylist()
                if "ContainerBlueprint:col_shares" in names
                else [None]
            )
            containers.append((kind[0][0], (name[0] or [None])[0], shares[0]))
        if "PanelBlueprint:state" in names:
            panels[c.entity_path] = batch.column("PanelBlueprint:state").to_pylist()[0][0]
        for name in ("position", "look_target", "eye_up"):
            if f"EyeControls3D:{name}" in names:
                eye[name] = np.array(batch.column(f"EyeControls3D:{name}").to_pylist()[0][0])
    return views, kinds, eye, panels, containers


def test_blueprint(saved):
    assert saved[3].timelines() == {"frame", "time"}  # columns only: no log_time or log_tick
    views, kinds, eye, panels, containers = blueprint_parts(saved[3])
    assert views["3D"] == ["world"]
    assert sorted(views["TimeSeries"]) == ["counts/contacts", "counts/pairs", "depth"]  # contacts deeper than 0
    assert views["TextDocument"] == ["legend"]
    assert set(views) == {"3D", "TimeSeries", "TextDocument"}  # no contacts between frames: no log tab
    assert sorted(k[0] for k in kinds) == sorted(
        [rrb.components.ContainerKind.Horizontal.value, rrb.components.ContainerKind.Vertical.value]
    )
    # the side panels collapsed, the 3D view SCENE_SHARE of the width
    assert panels == {"/blueprint_panel": rrb.components.PanelState.Collapsed.value} | {
        "/selection_panel": rrb.components.PanelState.Collapsed.value
    }  # (the time panel keeps its playback bar)
    (scene,) = [c for c in containers if c[1] == "scene"]
    assert scene[2] == [record.SCENE_SHARE, 100 - record.SCENE_SHARE] and record.SCENE_SHARE >= 60


def test_the_camera_frames_where_the_contacts_are(saved):
    """The camera looks at the box of MuJoCo's contacts over the run (framing: their percentiles, grown by
    FRAMING_PAD scene scales and to FRAMING_MIN across), from above, z up, as close as keeps it in view."""
    g, chunks, _, rec, _ = saved
    _, _, eye = blueprint_of(rec)
    points = np.concatenate([c.contact_pos for c in chunks])
    scale = record.scene_scale(g)
    lo, hi = np.percentile(points, record.FRAMING_PERCENTILES, axis=0)
    lo, hi = lo - record.FRAMING_PAD * scale, hi + record.FRAMING_PAD * scale
    grow = np.maximum(record.FRAMING_MIN * scale - (hi - lo), 0) / 2
    lo, hi = lo - grow, hi + grow
    np.testing.assert_allclose(eye["look_target"], (lo + hi) / 2, rtol=1e-6, atol=1e-9)
    distance = np.linalg.norm(eye["position"] - eye["look_target"])
    radius = np.linalg.norm(hi - lo) / 2
    assert radius < distance < 3 * radius  # outside the box, close enough that it fills the view
    assert eye["position"][2] > eye["look_target"][2] and list(eye["eye_up"]) == [0, 0, 1]  # from above, z up


def test_framing_leaves_out_a_far_contact_and_falls_back_to_the_last_frame():
    scale = 0.1
    heap = np.random.default_rng(0).uniform(-0.5, 0.5, (500, 3))
    flung = np.vstack([heap, [[30.0, 0.0, 0.0]]])  # one contact far off: not framed
    lo, hi = record.framing(flung, np.zeros(3), np.ones(3), scale)
    assert hi[0] < 1.0 and lo[0] > -1.0
    lo, hi = record.framing(np.zeros((0, 3)), -np.ones(3), 2 * np.ones(3), scale)  # no contact: the bodies
    np.testing.assert_array_equal(lo, -np.ones(3)) and np.testing.assert_array_equal(hi, 2 * np.ones(3))
    lo, hi = record.framing(np.zeros((3, 3)), np.zeros(3), np.ones(3), scale)  # one point: FRAMING_MIN across
    np.testing.assert_allclose(hi - lo, record.FRAMING_MIN * scale)


def test_the_deepest_pairs_have_a_depth_series(saved):
    """depth/<geom1> ~ <geom2>: the DEPTH_PAIRS deepest judged pairs (contact_ellipsoids), each MuJoCo's depth
    at the frames it penetrates, 0 around them."""
    g, chunks, _, rec, _ = saved
    frames = trajectory.concatenate(chunks)
    deep = np.flatnonzero(frames.contact_ellipsoids & (frames.contact_dist < 0))
    assert len(deep)
    names = g.geom_names
    best = {}
    for k in deep:
        g1, g2 = sorted(int(x) for x in frames.contact_geoms[k])
        key = (names[g1], names[g2])
        best[key] = max(best.get(key, 0.0), -frames.contact_dist[k])
    top = sorted(best, key=lambda k: -best[k])[: record.DEPTH_PAIRS]
    drawn = sorted(e for e in rec.entities() if e.startswith("/depth/"))
    assert drawn == sorted("/depth/" + rr.escape_entity_path_part(f"{a} ~ {b}") for a, b in top)
    for a, b in top:
        _, _, values = rec.temporal("/depth/" + rr.escape_entity_path_part(f"{a} ~ {b}"), "Scalars:scalars")
        assert max(v[0] for v in values) == pytest.approx(best[(a, b)])


def test_the_legend_says_what_the_colours_mean(saved):
    text = saved[3].static("/legend", "TextDocument:text")[-1]  # the last: logged again at close
    for words in ("red", "amber", "green", "black", "a hue per figure", "model's own colours", "not looked for"):
        assert words in text[0]


def test_figures_get_a_hue_each_clear_of_the_state_colours(saved):
    g = saved[0]
    colors = record.figure_colors(g).astype(float) / 255
    hue = lambda c: colorsys.rgb_to_hls(*c[:3])[0] * 360  # noqa: E731
    trees = {
        1: 1,
        2: 1,
        3: 1,
        4: 1,
        5: 1,
        6: 1,
        7: 4,
    }  # geom: tree (base 1 holds the moving arm; the free ball its own)
    lo, hi = record.FIGURE_HUES
    for geom in trees:
        assert lo - 1e-6 <= hue(colors[geom]) <= hi + 1e-6
    assert abs(hue(colors[2]) - hue(colors[5])) < 1e-6 and abs(hue(colors[2]) - hue(colors[7])) > 20  # one per tree
    np.testing.assert_array_equal(record.figure_colors(g)[[0, 8]], record.rgba8(g.geom_rgba[[0, 8]]))  # the world's
    for state in (record.TOUCHING_COLOR, record.OVERLAPPING_COLOR):
        assert not lo <= hue(np.array(state) / 255) <= hi


def test_labels_are_hidden_unless_asked_and_capsules_are_solid(tmp_path, saved):
    g, chunks, _, rec, _ = saved
    arm = "/world/model/base/arm/geoms"
    assert rec.static(f"{arm}/ellipsoids", "Ellipsoids3D:show_labels") == [[False]]
    assert rec.static(f"{arm}/capsules", "Capsules3D:show_labels") == [[False]]
    solid = rr.components.FillMode.Solid.value
    for entity, archetype in (
        (f"{arm}/ellipsoids", "Ellipsoids3D"),
        (f"{arm}/capsules", "Capsules3D"),
        ("/world/model/base/arm/hand/geoms/cylinders", "Cylinders3D"),
        ("/world/model/base/geoms/boxes", "Boxes3D"),
    ):
        assert rec.static(entity, f"{archetype}:fill_mode") == [[solid]], entity
    with record.Recorder(tmp_path / "labels.rrd", labels=True, colors="mjcf") as recorder:
        recorder.begin(g)
        for c in chunks:
            recorder.write(c)
    labelled = Recording(tmp_path / "labels.rrd")
    assert labelled.static(f"{arm}/ellipsoids", "Ellipsoids3D:show_labels") == [[True]]
    assert labelled.static(f"{arm}/capsules", "Capsules3D:colors") == [[packed(record.rgba8(g.geom_rgba[4]))]]
    with pytest.raises(ValueError, match="colors must be one of"):
        record.Recorder(tmp_path / "x.rrd", colors="rainbow")


def test_an_infinite_floor_is_sized_to_the_bodies(tmp_path, saved):
    g, chunks, _, _, _ = saved
    size = g.geom_size.copy()
    size[0] = [0, 0, 1]  # the floor plane, infinite
    pos, quat = g.geom_pos.copy(), g.geom_quat.copy()
    pos[0], quat[0] = [0.5, 0, 0], [1, 0, 0, 0]
    g = SceneGeometry(**{**g.__dict__, "geom_size": size, "geom_pos": pos, "geom_quat": quat})
    with record.Recorder(tmp_path / "floor.rrd") as recorder:
        recorder.begin(g)
        for c in chunks:
            recorder.write(c)
    rows = Recording(tmp_path / "floor.rrd").static("/world/model/geoms/floor", "Mesh3D:vertex_positions")
    vertices = np.array(rows[-1])  # the last static row: logged again at close
    bounds = np.concatenate([c.bounds for c in chunks])
    lo, hi = bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)
    reach = np.maximum(np.abs(lo[:2] - pos[0, :2]), np.abs(hi[:2] - pos[0, :2]))  # from the plane's centre
    half = np.abs(vertices[:, :2]).max(axis=0)
    assert (half > reach).all() and (half < 3 * reach).all()  # covers the bodies, not a field around them


def test_contacts_between_frames_are_markers_until_the_next_frame(tmp_path):
    """Two contacts in the step 2-3 and one in 5-6: from each one's time the step's contacts so far,
    cleared at the next frame; a log line each, at its time."""
    rng = np.random.default_rng(3)
    path = tmp_path / "between.rrd"
    frame = [2, 5, 2]
    time = [2.5 / 60, 5.2 / 60, 2.25 / 60]  # the step's second contact is given first
    point = rng.normal(size=(3, 3))
    with record.Recorder(path) as recorder:
        recorder.begin(make_geometry(rng))
        recorder.write(make_frames(rng, 0, F))
        recorder.write_events(
            frame, time, [3 / 60, 6 / 60, 3 / 60], point, ["a / b", "c / d", "e / f"], ["line a", "line c", "line e"]
        )
        with pytest.raises(ValueError, match=r"time\[0\] must be <= until\[0\], got 0.5 and 0.25"):
            recorder.write_events([1], [0.5], [0.25], [[0, 0, 0]], ["x"], ["x"])
        with pytest.raises(ValueError, match="one row per event, got 1, 1, 1, 1, 2 and 1"):
            recorder.write_events([1], [0.5], [0.5], [[0, 0, 0]], ["x", "y"], ["x"])
    rec = Recording(path)
    frames, times, positions = rec.temporal("/world/between_frames", "Points3D:positions")
    _, _, labels = rec.temporal("/world/between_frames", "Points3D:labels")
    rows = sorted(zip(times, frames, positions, labels))
    ns = lambda t: round(t * 1e9)  # noqa: E731
    assert [(t, f) for t, f, _, _ in rows] == [
        (ns(2.25 / 60), 2),
        (ns(2.5 / 60), 2),
        (ns(3 / 60), 3),
        (ns(5.2 / 60), 5),
        (ns(6 / 60), 6),
    ]
    assert [lab for *_, lab in rows] == [["e / f"], ["e / f", "a / b"], [], ["c / d"], []]
    np.testing.assert_array_equal(rows[1][2], f32(point[[2, 0]]))
    views, _, _ = blueprint_of(rec)
    assert views["TextLog"] == ["events"]  # with contacts between frames, their log gets a panel
    text = rec.static("/legend", "TextDocument:text")[-1]
    assert "one of the 3 contacts between frames" in text[0]
    _, times, texts = rec.temporal("/events/between_frames", "TextLog:text")
    assert sorted(zip(times, texts)) == [
        (ns(2.25 / 60), ["line e"]),
        (ns(2.5 / 60), ["line a"]),
        (ns(5.2 / 60), ["line c"]),
    ]


def test_every_run_gets_its_own_recording_id(tmp_path):
    rng = np.random.default_rng(1)
    g = make_geometry(rng)
    ids = [record.save(tmp_path / f"{k}.rrd", g, make_frames(rng, 0, F)) for k in range(2)]
    got = [Recording(tmp_path / f"{k}.rrd").reader.recordings()[0].recording_id for k in range(2)]
    assert got == ids and ids[0] != ids[1]


def test_an_interrupted_recording_leaves_nothing_behind(tmp_path):
    rng = np.random.default_rng(2)
    g = make_geometry(rng)
    path = tmp_path / "run.rrd"
    path.write_bytes(b"an older recording")
    with pytest.raises(KeyboardInterrupt):
        with record.Recorder(path) as recorder:
            recorder.begin(g)
            recorder.write(make_frames(rng, 0, SPLIT))
            assert os.path.getsize(recorder.partial) > 0 and os.path.dirname(recorder.partial) == str(tmp_path)
            raise KeyboardInterrupt
    assert path.read_bytes() == b"an older recording"
    assert sorted(os.listdir(tmp_path)) == ["run.rrd"]


def test_frames_must_fit_the_geometry_and_continue(tmp_path):
    rng = np.random.default_rng(3)
    g = make_geometry(rng)
    with record.Recorder(tmp_path / "x.rrd") as recorder:
        recorder.begin(g)
        bad = make_frames(rng, 0, SPLIT)
        bad.state = bad.state[:, :2]
        with pytest.raises(ValueError, match=r"Frames\.state must have shape \(4, 3\), got \(4, 2\)"):
            recorder.write(bad)
        bad = make_frames(rng, 0, SPLIT)
        bad.body_pos[1, 0, 2] = np.nan
        with pytest.raises(ValueError, match=r"Frames\.body_pos\[1, 0, 2\] must be finite, got nan"):
            recorder.write(bad)
        with pytest.raises(ValueError, match="frames must continue at frame 0, got frame 4"):
            recorder.write(make_frames(rng, SPLIT, F))
        recorder.write(make_frames(rng, 0, SPLIT))
    assert Recording(tmp_path / "x.rrd").temporal("/counts/pairs/builtin", "Scalars:scalars")[0] == list(range(SPLIT))


def test_bad_geometry_is_named():
    rng = np.random.default_rng(4)
    g = make_geometry(rng)
    with pytest.raises(ValueError, match=r"SceneGeometry.geom_body\[2\] must be in \[0, 5\), got 9"):
        SceneGeometry(**{**g.__dict__, "geom_body": np.array([0, 1, 9, 2, 2, 3, 3, 4, 0])})
    with pytest.raises(ValueError, match=r"SceneGeometry.body_quat must have shape \(5, 4\), got \(5, 3\)"):
        SceneGeometry(**{**g.__dict__, "body_quat": np.zeros((5, 3))})


@pytest.mark.parametrize(
    "path, message",
    [
        ("no/such/directory/run.rrd", "path must be in an existing directory"),
        ("run.txt", "path must end in .rrd"),
        ("run", "path must end in .rrd"),
    ],
)
def test_bad_path(tmp_path, path, message):
    bad = tmp_path / path
    with pytest.raises(ValueError, match=message) as info:
        record.Recorder(bad)
    assert str(bad) in str(info.value)
    assert not bad.exists()


def test_bad_path_directory(tmp_path):
    (tmp_path / "dir.rrd").mkdir()
    with pytest.raises(ValueError, match="path must be a file"):
        record.Recorder(tmp_path / "dir.rrd")


# --- a real model: every geom kind, includes, a material ------------------------------------------


@pytest.fixture(scope="module")
def zoo_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("zoo") / "zoo.rrd"
    s = scenario.load(str(ZOO))
    with record.Recorder(path, colors="mjcf") as recorder:  # the model's own colours, to check them
        result = simulate.run(s, steps=200, recorder=recorder, keep=True)
    model = mujoco.MjModel.from_xml_path(str(ZOO))
    return s, result, model, Recording(path)


def _world_pose(rec, entity, frame):
    """World position and (w x y z) quaternion of an entity at a frame, composing every Transform3D
    on its path (static, or the temporal row of that frame)."""
    parts = entity.strip("/").split("/")
    pos, quat = np.zeros(3), np.array([1.0, 0, 0, 0])
    for k in range(1, len(parts) + 1):
        path = "/" + "/".join(parts[:k])
        t = rec.static(path, "Transform3D:translation")
        q = rec.static(path, "Transform3D:quaternion")
        if not t:
            frames, _, ts = rec.temporal(path, "Transform3D:translation")
            if not frames:
                continue
            _, _, qs = rec.temporal(path, "Transform3D:quaternion")
            t, q = [ts[frames.index(frame)]], [qs[frames.index(frame)]]
        t = np.array(t[0], dtype=np.float64).ravel()
        x, y, z, w = np.array(q[0], dtype=np.float64).ravel()
        pos = pos + quaternions_to_rotations(quat) @ t
        quat = quaternion_product(quat, [w, x, y, z])
    return pos, quat


@pytest.mark.slow
def test_a_real_model_is_drawn_where_mujoco_puts_it(zoo_run):
    """Composing the recorded transforms puts every ellipsoid where MuJoCo had it in that frame."""
    _, result, model, rec = zoo_run
    kept = result.kept
    names = kept.geom_names
    for frame in (0, 17, len(kept.centers) - 1):
        for g, name in enumerate(names):
            body = model.geom_bodyid[model.geom(name).id]
            entity = next(e for e in rec.entities() if e.endswith(f"/{model.body(body).name}/geoms/ellipsoids"))
            (labels,) = rec.static(entity, "Ellipsoids3D:labels")
            (centers,) = rec.static(entity, "Ellipsoids3D:centers")
            pos, quat = _world_pose(rec, entity, frame)
            local = np.array(centers[labels.index(name)], dtype=np.float64)
            world = pos + quaternions_to_rotations(quat) @ local
            np.testing.assert_allclose(world, kept.centers[frame, g], atol=2e-6)  # float32 transforms, ~1 m


@pytest.mark.slow
def test_a_real_model_keeps_its_colours_and_floor_contacts(zoo_run):
    _, result, model, rec = zoo_run
    base = "/world/model/torso/arm_r/forearm_r/geoms"
    steel = record.rgba8(model.mat_rgba[model.material("steel").id])
    assert rec.static(f"{base}/cylinders", "Cylinders3D:colors") == [[packed(steel)]]  # the material's colour
    skin = record.rgba8(model.geom_rgba[model.geom("forearm_l").id])
    assert rec.static("/world/model/torso/arm_l/forearm_l/geoms/capsules", "Capsules3D:colors") == [[packed(skin)]]
    frames, _, colors = rec.temporal("/world/contacts", "Points3D:colors")
    # the figure drops onto the floor: contacts that are not between two ellipsoids are recorded too
    assert any(packed(record.OTHER_CONTACT_COLOR) in c for c in colors)
    assert sum(len(c) for c in colors) == int(result.frames.contact_counts.sum())
    assert (
        "/world/model/geoms/terrain" in rec.entities()
        and "/world/model/torso/arm_r/forearm_r/geoms/hand_r" in rec.entities()
    )


@pytest.mark.slow
def test_a_real_run_is_framed_on_its_bodies_not_its_floor(zoo_run):
    """The camera looks into the box of the ellipsoids over the run (MuJoCo's stat.center averages the
    floor in), and the infinite floor is a square about the bodies, not 2 x stat.extent."""
    _, result, model, rec = zoo_run
    _, _, eye = blueprint_of(rec)
    centers = result.kept.centers.reshape(-1, 3)
    reach = model.geom_rbound.max()
    lo, hi = centers.min(axis=0) - reach, centers.max(axis=0) + reach
    assert ((lo <= eye["look_target"]) & (eye["look_target"] <= hi)).all(), (lo, hi, eye)
    assert np.linalg.norm(eye["position"] - eye["look_target"]) < 4 * np.linalg.norm(hi - lo)
    labels = rec.static("/world/model/torso/geoms/ellipsoids", "Ellipsoids3D:show_labels")
    assert labels == [[False]]


def test_geometry_of_a_model_reads_meshes_and_height_fields():
    model = mujoco.MjModel.from_xml_path(str(ZOO))
    g = capture.geometry(model, "zoo")
    kinds = {GEOM_KINDS[k] for k in g.geom_kind}
    assert kinds == set(GEOM_KINDS)
    hand = model.geom("hand_r").id
    vertices, triangles = g.meshes[hand]
    assert vertices.shape == (6, 3) and triangles.shape == (8, 3)
    np.testing.assert_allclose(np.abs(vertices).max(), 0.05, rtol=1e-6)  # the octahedron, about its centre
    terrain = model.geom("terrain").id
    vertices, triangles = g.meshes[terrain]
    assert vertices.shape == (20, 3) and triangles.shape == (2 * 3 * 4, 3)
    np.testing.assert_allclose([vertices[:, 0].min(), vertices[:, 0].max(), vertices[:, 1].max()], [-0.5, 0.5, 0.4])
    np.testing.assert_allclose(vertices[:, 2].max(), 0.1)  # elevation 1 x size[2]
    assert g.body_names[0] == "world" and set(g.moving) == {
        model.body("torso").id,
        model.body("ball").id,
        model.body("arm_l").id,
        model.body("forearm_l").id,
        model.body("arm_r").id,
        model.body("forearm_r").id,
        model.body("leg").id,
    }


def test_view_missing_file(tmp_path):
    missing = tmp_path / "missing.rrd"
    with pytest.raises(ValueError, match="path must be an existing .rrd file") as info:
        record.view(missing)
    assert str(missing) in str(info.value)


def test_view_refuses_a_file_that_is_not_a_recording(tmp_path, monkeypatch):
    fake = tmp_path / "notes.rrd"
    fake.write_text("not a recording")
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("started a viewer on a non-recording"))
    with pytest.raises(ValueError, match=r"notes\.rrd' is not a rerun recording"):
        record.view(fake)


def test_view_without_display(saved, monkeypatch, capsys):
    path = saved[2]
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("started a viewer without a display"))
    assert record.view(path) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    assert f"rerun {path}" in out and "app.rerun.io" in out


def test_view_with_display_runs_the_rerun_executable(saved, monkeypatch):
    path = saved[2]
    calls = []

    def fake_run(command, **kwargs):
        calls.append(command)
        return subprocess.CompletedProcess(command, 0)

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(subprocess, "run", fake_run)  # no GUI in tests
    assert record.view(path) == 0
    (command,) = calls
    assert command[-1] == os.fspath(path)
    assert command[0].endswith("rerun") or command[-2:-1] == ["rerun"]


def test_a_chunk_with_more_contacts_than_the_sample_keeps_a_uniform_sample(tmp_path, monkeypatch):
    """The camera's contact sample (CONTACT_SAMPLES at most) takes a first chunk with many more contacts than
    it holds (a long run's first chunk once made sampling without replacement fail), and later chunks too."""
    monkeypatch.setattr(record, "CONTACT_SAMPLES", 5)
    rng = np.random.default_rng(7)
    g = make_geometry(rng)
    recorder = record.Recorder(tmp_path / "r.rrd")
    recorder.begin(g)
    chunk = make_frames(rng, 0, SPLIT)
    chunk.contact_pos = np.repeat(chunk.contact_pos, 7, axis=0)[: len(chunk.contact_pos)]  # as recorded
    recorder._keep_contacts(chunk)
    bigger = type("F", (), {})()
    bigger.contact_pos = rng.normal(size=(40, 3))
    bigger.contact_ellipsoids = np.zeros(40, dtype=bool)
    bigger.contact_dist = np.ones(40)
    bigger.contact_geoms = np.zeros((40, 2), dtype=np.int64)
    bigger.contact_frame = np.zeros(40, dtype=np.int64)
    for _ in range(3):
        recorder._keep_contacts(bigger)
    assert len(recorder._contact_sample) == 5 and recorder._contacts_seen == len(chunk.contact_pos) + 120
    recorder.abort()
