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
    "native": {"native"},  # the compiled core (issue 46): the C++ and its module, below everything
    "core": {"core", "native"},
    "mujoco": {"core", "mujoco", "native", "shipped", "pair_table"},
    # the MuJoCo Warp layer (issue 21): beside mujoco, not on it; both read one pair table (pair_table.py, data)
    "warp": {"core", "warp", "native", "shipped", "pair_table"},
    "app": {"core", "mujoco", "warp", "app", "native", "shipped", "pair_table"},
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
    assert modules or layer == "warp"  # the warp layer's place is declared before it lands
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


def test_import_ellipsim_and_its_glue_load_only_what_attaching_needs():
    """`import ellipsim` + `ellipsim.mujoco.attach` import only the glue that attaching needs and the compiled
    module (its callbacks): no JIT compiler, no scipy, not the core's Python layer (tests/test_startup.py steps)."""
    code = (
        "import sys, ellipsim\n"
        "ellipsim.mujoco.attach\n"
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in ('ellipsim', 'numba', 'scipy', 'llvmlite'))))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.split() == [
        "ellipsim",
        "ellipsim.mujoco",
        "ellipsim.mujoco.attachment",
        "ellipsim.mujoco.context",
        "ellipsim.mujoco.publish",
        "ellipsim.native",
        "ellipsim.pair_table",  # the pair table both glues read: data only
    ]


def test_every_public_name_resolves_to_its_module():
    import ellipsim.core.distance.ellipsoid_pair
    import ellipsim.core.distance.status
    import ellipsim.core.ellipsoids
    import ellipsim.core.exact.characteristic
    import ellipsim.core.exact.classify
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
    assert ellipsim.DistanceStatus is ellipsim.core.distance.status.DistanceStatus
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


# --- the core's folders and the package's import graph ------------------------------------------------

#: The core's concept folders, each importing only the folders before it here and the core's foundation
#: (the modules directly in core/): exact relations, the ellipsoid pair's distance, the other pair
#: types, moving bodies.
CORE_FOLDERS = ("exact", "distance", "pairs", "motion")
CORE_FOUNDATION = {
    "ellipsoids",
    "relation",
    "rotations",
    "samples",
    "threads",
    "tolerances",
}


def _modules():
    """{dotted name: path} of every module of the package."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def _module_imports(path, modules):
    """The package's modules that the module at `path` imports, anywhere in it (module level or not)."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    package = list(parts[:-1])
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = base + (node.module.split(".") if node.module else [])
            dotted = ".".join(target)
            for alias in node.names:
                found.add(f"{dotted}.{alias.name}" if f"{dotted}.{alias.name}" in modules else dotted)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
    return {m for m in found if m in modules}


def _import_graph():
    modules = _modules()
    return {name: _module_imports(path, modules) - {name} for name, path in modules.items()}


def _cycle(edges):
    """A cycle [a, b, ..., a] in the directed graph {a: {b, ...}}, or None."""
    state = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == "open":
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state and (found := visit(nxt, path + [nxt])):
                return found
        state[node] = "done"
        return None

    for start in sorted(edges):
        if start not in state and (found := visit(start, [start])):
            return found
    return None


def test_no_import_cycle_anywhere_in_the_package():
    # every import counts, module level or inside a function: a cycle through a deferred import is
    # still two modules that each need the other
    graph = {m: {t for t in targets if t != "ellipsim"} for m, targets in _import_graph().items()}
    assert _cycle(graph) is None, f"import cycle {' -> '.join(_cycle(graph))}"
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_core_is_grouped_by_concept():
    core = PACKAGE / "core"
    assert {p.name for p in core.iterdir() if p.is_dir() and p.name != "__pycache__"} == set(CORE_FOLDERS)
    assert {p.stem for p in core.glob("*.py")} == CORE_FOUNDATION | {"__init__"}
    for folder in CORE_FOLDERS:  # a folder's __init__ imports nothing: importing one module loads one
        tree = ast.parse((core / folder / "__init__.py").read_text())
        assert not [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))], folder


def test_core_folders_import_only_the_foundation_and_the_folders_before_them():
    for module, targets in _import_graph().items():
        parts = module.split(".")
        if parts[:2] != ["ellipsim", "core"] or len(parts) < 4:
            continue
        rank = CORE_FOLDERS.index(parts[2])
        for target in targets:
            tparts = target.split(".")
            if tparts[:2] == ["ellipsim", "native"]:  # the compiled core, below every folder
                continue
            assert tparts[:2] == ["ellipsim", "core"], f"{module} imports {target}"
            if len(tparts) == 3:
                assert tparts[2] in CORE_FOUNDATION, f"{module} imports {target}"
            else:
                assert CORE_FOLDERS.index(tparts[2]) <= rank, f"{module} imports {target}, a later folder"


def test_the_foundation_imports_no_concept_folder_except_for_the_sample_sets():
    # samples.py builds pairs for tests and benchmarks with classify and contact_scale; the rest of
    # the foundation (tolerances, the batch, vectors, threads) is below every folder
    for module, targets in _import_graph().items():
        parts = module.split(".")
        if parts[:2] == ["ellipsim", "core"] and len(parts) == 3 and parts[2] != "samples":
            assert all(len(t.split(".")) == 3 for t in targets if t.startswith("ellipsim.core.")), module


def test_every_layer_folder_is_declared_and_the_warp_layer_may_import_only_the_core():
    # ellipsim.warp (issue 21) sits beside ellipsim.mujoco: it may use the core's kernels, never the
    # MuJoCo C glue (whose compiled callbacks and process context it must not load) nor the app
    layers = {p.name for p in PACKAGE.iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert layers <= set(ALLOWED), sorted(layers - set(ALLOWED))
    assert ALLOWED["warp"] == {"core", "warp", "native", "shipped", "pair_table"}
    assert "warp" not in ALLOWED["mujoco"] and "warp" in ALLOWED["app"]


def test_every_package_folder_is_installed():
    # the wheel takes the whole ellipsim/ folder (every file git does not ignore: modules, C++ sources,
    # shipped kernels) and maps models/ and scenarios/ into it; tests/test_installed.py imports the result
    import tomllib

    skbuild = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["tool"]["scikit-build"]
    assert skbuild["wheel"]["packages"] == {
        "ellipsim": "ellipsim",
        "ellipsim/models": "models",
        "ellipsim/scenarios": "scenarios",
    }
    assert skbuild["cmake"]["source-dir"] == "ellipsim/native"
    for folder in ("models", "scenarios"):
        assert (PACKAGE.parent / folder / "__init__.py").is_file(), folder
