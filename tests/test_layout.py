"""The three layers: core imports nothing of MuJoCo, rerun or trimesh; each layer only those below."""

import ast
import pathlib
import subprocess
import sys

import pytest

import ellipsim

PACKAGE = pathlib.Path(ellipsim.__file__).parent
# What each layer may import of ellipsim (besides itself); `shipped` only locates data folders.
ALLOWED = {
    "core": {"core"},
    "mujoco": {"core", "mujoco", "shipped"},
    "app": {"core", "mujoco", "app", "shipped"},
}
HEAVY = ("mujoco", "rerun", "trimesh")


def _ellipsim_imports(path):
    """The ellipsim layers (first component after `ellipsim.`) a module imports, absolute or relative."""
    tree = ast.parse(path.read_text())
    package = path.relative_to(PACKAGE.parent).with_suffix("").parts[:-1]  # ("ellipsim", "app", "bench")
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[: len(package) - node.level + 1])
                target = base + (node.module.split(".") if node.module else [])
                names = [target + [a.name] for a in node.names] if len(target) == 1 else [target]
            else:
                names = [(node.module or "").split(".")]
            for parts in names:
                if parts[0] == "ellipsim" and len(parts) > 1:
                    found.add(parts[1])
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "ellipsim" and len(parts) > 1:
                    found.add(parts[1])
    return found


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_each_layer_imports_only_the_layers_below(layer):
    modules = sorted((PACKAGE / layer).rglob("*.py"))
    assert modules
    for path in modules:
        used = _ellipsim_imports(path)
        assert used <= ALLOWED[layer], f"{path.relative_to(PACKAGE)} imports ellipsim.{sorted(used - ALLOWED[layer])}"


def test_core_modules_do_not_import_heavy_libraries():
    for path in sorted((PACKAGE / "core").rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                roots = [(node.module or "").split(".")[0]]
            else:
                continue
            assert not set(roots) & set(HEAVY), f"{path.name} imports {roots}"


def test_import_ellipsim_loads_no_mujoco_rerun_or_trimesh():
    code = (
        "import sys, ellipsim, ellipsim.core.samples, ellipsim.core.motion.broad_phase\n"
        f"heavy = sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})\n"
        "print(','.join(heavy))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == ""


def test_glue_and_application_are_reached_from_the_top_package():
    code = "import sys, ellipsim\nellipsim.mujoco.attach\nellipsim.app\nprint('mujoco' in sys.modules)\n"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "True"
    with pytest.raises(AttributeError, match="no attribute 'plugin'"):
        ellipsim.plugin  # noqa: B018


def test_import_ellipsim_and_its_glue_load_no_numba():
    """`import ellipsim` + `ellipsim.mujoco.attach` import only the glue that attaching needs: with the
    callbacks cached, a process attaches and steps without numba (tests/test_startup.py steps)."""
    code = (
        "import sys, ellipsim\n"
        "ellipsim.mujoco.attach\n"
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in ('ellipsim', 'numba', 'scipy', 'llvmlite'))))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.split() == [
        "ellipsim", "ellipsim.mujoco", "ellipsim.mujoco.attachment", "ellipsim.mujoco.context",
        "ellipsim.mujoco.nativecache", "ellipsim.mujoco.publish", "ellipsim.mujoco.structs",
    ]  # fmt: skip


def test_every_public_name_resolves_to_its_module():
    import ellipsim.core.exact.characteristic
    import ellipsim.core.exact.classify
    import ellipsim.core.distance.ellipsoid_pair
    import ellipsim.core.ellipsoids
    import ellipsim.core.exact.contact_scale
    import ellipsim.core.relation
    import ellipsim.mujoco.compare
    import ellipsim.mujoco.geoms

    assert set(ellipsim.__all__) <= set(dir(ellipsim)) and set(ellipsim.mujoco.__all__) <= set(dir(ellipsim.mujoco))
    assert ellipsim.classify is ellipsim.core.exact.classify.classify
    assert ellipsim.Ellipsoids is ellipsim.core.ellipsoids.Ellipsoids
    assert ellipsim.Relation is ellipsim.core.relation.Relation
    assert ellipsim.contact_scale is ellipsim.core.exact.contact_scale.contact_scale
    assert ellipsim.signed_distance is ellipsim.core.distance.ellipsoid_pair.signed_distance
    assert ellipsim.characteristic_polynomial is ellipsim.core.exact.characteristic.characteristic_polynomial
    assert ellipsim.mujoco.compare_narrowphase is ellipsim.mujoco.compare.compare_narrowphase
    assert ellipsim.mujoco.candidate_pairs is ellipsim.mujoco.geoms.candidate_pairs
    for name in set(ellipsim.mujoco.__all__) - {"MODES"}:
        assert getattr(ellipsim.mujoco, name).__name__ == name
    assert ellipsim.mujoco.MODES == ("filter", "narrowphase")
    with pytest.raises(AttributeError, match="no attribute 'classfy'"):
        ellipsim.classfy  # noqa: B018


def test_importing_the_validate_module_keeps_the_validate_function():
    code = (
        "import ellipsim.mujoco.validate\n"
        "import ellipsim.mujoco as em\n"
        "from ellipsim.mujoco.validate import Validation\n"
        "print(em.validate.__module__, em.validate.__name__, em.Validation is Validation)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.split() == ["ellipsim.mujoco.validate", "validate", "True"]
