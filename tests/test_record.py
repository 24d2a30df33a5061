"""record.save writes what the Trajectory says: read the .rrd back with rerun's own reader and compare.

rerun stores positions, sizes and quaternions as float32, so values are compared with the
trajectory's values rounded to float32, exactly.  Colours come back packed as 0xRRGGBBAA.
"""

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from ellipsim.app import record
from ellipsim.app.trajectory import Trajectory

F = 7
# Two figures of 4 geoms and 3 free ellipsoids, interleaved so that selecting by figure matters.
GEOM_FIGURE = np.array([0, 1, -1, 0, 1, 1, -1, 0, 1, 0, -1])
G = len(GEOM_FIGURE)
CONTACTS_PER_FRAME = [2, 0, 3, 1, 4, 0, 2]  # frames 1 and 5 have none


def make_trajectory(scenario="two figures and a pile"):
    rng = np.random.default_rng(7)
    q = rng.normal(size=(F, G, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    contact_frame = np.repeat(np.arange(F), CONTACTS_PER_FRAME)
    contact_frame = contact_frame[rng.permutation(len(contact_frame))]  # not sorted by frame
    K = len(contact_frame)
    normal = rng.normal(size=(K, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    state = np.zeros((F, G), dtype=np.int8)
    state[1, 0] = 1
    state[2, [0, 3]] = 2
    state[3, :] = 1
    state[4, 2] = 2  # a free ellipsoid
    state[6, :] = rng.integers(0, 3, G)
    return Trajectory(
        times=np.arange(F) / 60.0,  # rerun's own float -> ns conversion would truncate 1/60 s to 16666666 ns
        geom_names=[f"geom{g}" for g in range(G)],
        geom_figure=GEOM_FIGURE.copy(),
        half_sizes=rng.uniform(0.01, 0.2, (G, 3)),
        centers=rng.normal(size=(F, G, 3)),
        quaternions=q,
        state=state,
        contact_frame=contact_frame,
        contact_pos=rng.normal(size=(K, 3)),
        contact_normal=normal,
        builtin_counts=np.array(CONTACTS_PER_FRAME, dtype=np.int64),
        ellipsim_counts=np.array([1, 0, 2, 0, 5, 1, 3], dtype=np.int64),
        scenario=scenario,
    )


def packed(rgba):
    r, g, b, a = (int(v) for v in rgba)
    return (r << 24) | (g << 16) | (b << 8) | a


def f32(x):
    return np.asarray(x, dtype=np.float64).astype(np.float32)


class Recording:
    """The chunks of an .rrd, with row-level access per entity and component."""

    def __init__(self, path):
        reader = RrdReader(path)
        self.reader = reader
        self.chunks = reader.stream().to_chunks()

    def entities(self):
        return {c.entity_path for c in self.chunks}

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


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    t = make_trajectory()
    path = tmp_path_factory.mktemp("record") / "run.rrd"
    record.save(path, t)
    return t, path, Recording(path)


def figure_entities(t):
    out = {}
    for fig in np.unique(t.geom_figure):
        entity = "/world/ellipsoids" if fig == -1 else f"/world/figures/f{fig}"
        out[entity] = np.flatnonzero(t.geom_figure == fig)
    return out


def test_entities_exist(saved):
    t, path, rec = saved
    expected = {"/world", "/world/figures/f0", "/world/figures/f1", "/world/ellipsoids", "/world/contacts",
                "/world/contact_normals", "/counts/builtin", "/counts/ellipsim"}  # fmt: skip
    assert expected <= rec.entities()
    assert not any(e.startswith("/world/figures/f") and e not in expected for e in rec.entities())
    assert rec.reader.recordings()[0].recording_id == record.recording_id(t.scenario)
    assert record.recording_id(t.scenario) == record.recording_id("two figures and a pile")
    assert record.recording_id("a") != record.recording_id("b")


def test_rrd_verify(saved):
    _, path, _ = saved
    beside = pathlib.Path(sys.executable).with_name("rerun")
    command = [str(beside)] if beside.is_file() else [sys.executable, "-m", "rerun"]
    # `rrd verify` exists in 0.41 (`rerun rrd --help` lists it); exit 0 means the file loads.
    done = subprocess.run([*command, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "verified without error" in done.stderr + done.stdout


def test_static_geometry_once_per_entity(saved):
    t, _, rec = saved
    for entity, geoms in figure_entities(t).items():
        half_sizes = rec.static(entity, "Ellipsoids3D:half_sizes")
        assert len(half_sizes) == 1, entity
        np.testing.assert_array_equal(np.array(half_sizes[0], dtype=np.float32), f32(t.half_sizes[geoms]))
        assert rec.static(entity, "Ellipsoids3D:labels") == [[t.geom_names[g] for g in geoms]]
        assert rec.static(entity, "Ellipsoids3D:fill_mode") == [[3]]  # rr.components.FillMode.Solid
        # nothing static leaks into the per-frame rows and vice versa
        assert rec.temporal(entity, "Ellipsoids3D:half_sizes")[0] == []
        assert rec.static(entity, "Ellipsoids3D:centers") == []


def test_centers_and_quaternions_per_frame(saved):
    t, _, rec = saved
    for entity, geoms in figure_entities(t).items():
        frames, times, centers = rec.temporal(entity, "Ellipsoids3D:centers")
        assert frames == list(range(F)), entity
        assert times == [round(s * 1e9) for s in t.times]  # 1/60 s -> 16666667 ns, not 16666666
        for f in range(F):
            np.testing.assert_array_equal(np.array(centers[f], dtype=np.float32), f32(t.centers[f, geoms]))
        frames, _, quats = rec.temporal(entity, "Ellipsoids3D:quaternions")
        assert frames == list(range(F))
        for f in range(F):
            wxyz = t.quaternions[f, geoms]
            xyzw = np.column_stack([wxyz[:, 1], wxyz[:, 2], wxyz[:, 3], wxyz[:, 0]])
            np.testing.assert_array_equal(np.array(quats[f], dtype=np.float32), f32(xyzw))


def test_colors_follow_states(saved):
    t, _, rec = saved
    palette = [packed(c) for c in (record.FREE_COLOR, record.TOUCHING_COLOR, record.OVERLAPPING_COLOR)]
    assert len(set(palette)) == 3
    seen = set()
    for entity, geoms in figure_entities(t).items():
        frames, _, colors = rec.temporal(entity, "Ellipsoids3D:colors")
        assert frames == list(range(F))
        for f in range(F):
            assert colors[f] == [palette[s] for s in t.state[f, geoms]], (entity, f)
            seen |= set(colors[f])
    assert seen == set(palette)  # the fixture exercises all three states


def test_contacts_per_frame(saved):
    t, _, rec = saved
    frames, _, positions = rec.temporal("/world/contacts", "Points3D:positions")
    assert frames == list(range(F))
    assert [len(p) for p in positions] == CONTACTS_PER_FRAME
    assert positions[1] == [] and positions[5] == []
    _, _, origins = rec.temporal("/world/contact_normals", "Arrows3D:origins")
    _, _, vectors = rec.temporal("/world/contact_normals", "Arrows3D:vectors")
    for f in range(F):
        mine = np.flatnonzero(t.contact_frame == f)  # contacts keep their order within a frame
        np.testing.assert_array_equal(np.array(positions[f], dtype=np.float32).reshape(-1, 3), f32(t.contact_pos[mine]))
        np.testing.assert_array_equal(np.array(origins[f], dtype=np.float32).reshape(-1, 3), f32(t.contact_pos[mine]))
        expected = f32(record.NORMAL_LENGTH * t.contact_normal[mine])
        np.testing.assert_array_equal(np.array(vectors[f], dtype=np.float32).reshape(-1, 3), expected)
    lengths = np.linalg.norm(np.concatenate([np.reshape(v, (-1, 3)) for v in vectors]), axis=1)
    np.testing.assert_allclose(lengths, record.NORMAL_LENGTH, rtol=1e-6)  # unit normals, float32
    assert len(rec.static("/world/contacts", "Points3D:radii")) == 1


def test_count_series(saved):
    t, _, rec = saved
    for entity, counts in (("/counts/builtin", t.builtin_counts), ("/counts/ellipsim", t.ellipsim_counts)):
        frames, times, scalars = rec.temporal(entity, "Scalars:scalars")
        assert frames == list(range(F))
        assert times == [round(s * 1e9) for s in t.times]
        assert scalars == [[float(c)] for c in counts]
        assert len(rec.static(entity, "SeriesLines:names")) == 1
    assert rec.static("/counts/builtin", "SeriesLines:names") != rec.static("/counts/ellipsim", "SeriesLines:names")


def test_blueprint(saved):
    _, _, rec = saved
    (store,) = rec.reader.blueprints()
    views, kinds = {}, []
    for c in rec.reader.stream(store=store).to_chunks():
        batch = c.to_record_batch()
        if "ViewBlueprint:class_identifier" in batch.schema.names:
            (kind,) = batch.column("ViewBlueprint:class_identifier").to_pylist()
            (origin,) = batch.column("ViewBlueprint:space_origin").to_pylist()
            views[kind[0]] = origin[0]
        if "ContainerBlueprint:container_kind" in batch.schema.names:
            kinds += batch.column("ContainerBlueprint:container_kind").to_pylist()
    assert views == {"3D": "world", "TimeSeries": "counts"}
    assert kinds == [[rrb.components.ContainerKind.Horizontal.value]]


def test_free_ellipsoids_only_when_present(tmp_path):
    t = make_trajectory("figures only")
    keep = t.geom_figure >= 0
    t = Trajectory(
        times=t.times, geom_names=[n for n, k in zip(t.geom_names, keep) if k], geom_figure=t.geom_figure[keep],
        half_sizes=t.half_sizes[keep], centers=t.centers[:, keep], quaternions=t.quaternions[:, keep],
        state=t.state[:, keep], contact_frame=t.contact_frame[:0], contact_pos=t.contact_pos[:0],
        contact_normal=t.contact_normal[:0], builtin_counts=0 * t.builtin_counts,
        ellipsim_counts=t.ellipsim_counts, scenario=t.scenario,
    )  # fmt: skip
    path = tmp_path / "figures.rrd"
    record.save(str(path), t)
    rec = Recording(path)
    assert "/world/ellipsoids" not in rec.entities()
    frames, _, centers = rec.temporal("/world/figures/f1", "Ellipsoids3D:centers")
    assert frames == list(range(F)) and all(len(c) == 4 for c in centers)
    frames, _, positions = rec.temporal("/world/contacts", "Points3D:positions")
    assert frames == list(range(F)) and positions == [[]] * F  # no contacts at all: empty partitions


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
        record.save(bad, make_trajectory())
    assert str(bad) in str(info.value)
    assert not bad.exists()


def test_bad_path_directory(tmp_path):
    (tmp_path / "dir.rrd").mkdir()
    with pytest.raises(ValueError, match="path must be a file"):
        record.save(tmp_path / "dir.rrd", make_trajectory())


def test_bad_trajectory(tmp_path):
    with pytest.raises(ValueError, match="trajectory must be an ellipsim.app.trajectory.Trajectory, got dict"):
        record.save(tmp_path / "x.rrd", {"times": np.zeros(3)})
    t = make_trajectory()
    t.state[4, 6] = 3
    with pytest.raises(ValueError, match=r"trajectory.state\[4, 6\] must be 0, 1 or 2, got 3"):
        record.save(tmp_path / "x.rrd", t)
    t = make_trajectory()
    t.geom_figure[5] = -2
    with pytest.raises(ValueError, match=r"trajectory.geom_figure\[5\] must be >= -1, got -2"):
        record.save(tmp_path / "x.rrd", t)
    t = make_trajectory()
    t.centers[2, 3, 1] = np.nan
    with pytest.raises(ValueError, match=r"trajectory.centers\[2, 3, 1\] must be finite, got nan"):
        record.save(tmp_path / "x.rrd", t)
    assert not (tmp_path / "x.rrd").exists()


def test_view_missing_file(tmp_path):
    missing = tmp_path / "missing.rrd"
    with pytest.raises(ValueError, match="path must be an existing .rrd file") as info:
        record.view(missing)
    assert str(missing) in str(info.value)


def test_view_without_display(saved, monkeypatch, capsys):
    _, path, _ = saved
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("started a viewer without a display"))
    assert record.view(path) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    assert f"rerun {path}" in out and "app.rerun.io" in out


def test_view_with_display_runs_the_rerun_executable(saved, monkeypatch):
    _, path, _ = saved
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
