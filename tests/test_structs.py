"""Struct offsets from mujoco.introspect: equal to the first release's memory scan, verified against
the bindings, and refused for a MuJoCo outside the tested range."""

import ctypes
import pathlib
import re
import tomllib

import mujoco
import pytest

from ellipsim.app import scenes
from ellipsim.mujoco import context, structs


def test_introspection_equals_the_memory_scan():
    rows = structs.compare_with_scan()
    assert {(s, name) for s, name, _, _ in rows} == {("model", k) for k in context.MODEL_WORDS} | {
        ("data", k) for k in context.DATA_WORDS
    }
    assert [(s, name, a) for s, name, a, b in rows if a != b] == []


def test_every_exposed_field_verifies_on_the_probe_and_on_a_real_scene():
    assert structs.verify(*structs._probe()) >= structs._PROBE_MIN_FIELDS
    model = mujoco.MjModel.from_xml_string(scenes.scene_xml(2, layout="pile", seed=1))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    assert structs.verify(model, data) >= structs._PROBE_MIN_FIELDS
    assert structs.verify_fields(model, data) == len(context.MODEL_WORDS) + len(context.DATA_WORDS)


def test_a_wrong_offset_is_caught(monkeypatch):
    lay = structs.layout()
    model, data = structs._probe()
    for struct, name in (("model", "geom_size"), ("model", "opt.o_margin"), ("data", "geom_xmat")):
        wrong = {**lay, struct: {**lay[struct], name: lay[struct][name] + 8}}
        monkeypatch.setattr(structs, "layout", lambda wrong=wrong: wrong)
        with pytest.raises(structs.LayoutError, match=rf"{name} at offset {lay[struct][name] + 8} reads"):
            structs.verify_fields(model, data)


def test_layout_matches_what_the_narrow_phase_writes():
    lay = structs.layout()
    assert lay["sizeof"]["mjModel"] > lay["model"]["geom_gap"] and lay["sizeof"]["mjData"] > lay["data"]["geom_xmat"]
    offsets = structs._offsets(structs._struct("mjPreContact"))
    assert offsets == {k: 8 * w for k, w in context.PRECONTACT_WORDS.items()}
    assert lay["key"].startswith(f"mujoco-{mujoco.__version__}-")


@pytest.mark.parametrize("version", [3003007, 4001000, 5000000])
def test_a_mujoco_outside_the_tested_range_is_refused(monkeypatch, version):
    monkeypatch.setattr(mujoco, "mj_version", lambda: version)
    monkeypatch.delenv(structs.UNTESTED_ENV, raising=False)
    shown = f"{version // 1000000}.{version // 1000 % 1000}.{version % 1000}"
    message = (
        rf"tested with MuJoCo >= 4\.0\.0, < 4\.1\.0; this is MuJoCo {re.escape(shown)}\. "
        rf"Install a tested MuJoCo .*or set {structs.UNTESTED_ENV}=1"
    )
    with pytest.raises(structs.LayoutError, match=message):
        structs.check_version()
    monkeypatch.setenv(structs.UNTESTED_ENV, "1")
    assert structs.check_version() == version


def test_bindings_and_library_of_different_versions_are_refused(monkeypatch):
    monkeypatch.setattr(mujoco, "mj_versionString", lambda: "4.0.9")
    with pytest.raises(
        structs.LayoutError,
        match=rf"bindings \({re.escape(mujoco.__version__)}\) and the loaded libmujoco \(4\.0\.9\) differ",
    ):
        structs.check_version()


def test_pyproject_pins_the_tested_range():
    pyproject = pathlib.Path(__file__).resolve().parents[1] / "pyproject.toml"
    deps = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    (pin,) = [d for d in deps if re.match(r"mujoco\b", d)]
    low, high = (structs._version_string(v) for v in structs.TESTED)
    assert pin.replace(" ", "") == f"mujoco>={low.removesuffix('.0')},<{high.removesuffix('.0')}"


def test_collision_table_is_mujocos():
    table, n = structs.collision_table()
    assert n == int(mujoco.mjtGeom.mjNGEOMTYPES)
    ell = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    assert table[ell * n + ell] == ctypes.cast(structs.mujoco_library().mjc_Convex, ctypes.c_void_p).value
