"""The kernels' cache (core/kernel_cache.py): keyed on every source a kernel may inline, so a stale
object is never loaded; the shipped objects are current, and a fresh install compiles nothing."""

import os
import pathlib
import shutil
import subprocess
import sys
import textwrap

import pytest

from ellipsim.core import kernel_cache

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _python(code, env, cwd=None):
    proc = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True, cwd=cwd, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def _env(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "ELLIPSIM_"))}
    return {**env, "ELLIPSIM_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT), **extra}


def test_the_stamp_changes_with_any_core_source(tmp_path):
    core = pathlib.Path(kernel_cache.__file__).parent
    copy = tmp_path / "core"
    shutil.copytree(core, copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert kernel_cache.sources_digest(copy) == kernel_cache.sources_digest(core) == kernel_cache.core_digest()
    stage = copy / "pairs" / "point_ellipsoid.py"  # a module whose stages other modules inline
    stage.write_text(stage.read_text() + "\n# edited\n")
    assert kernel_cache.sources_digest(copy) != kernel_cache.core_digest()
    (copy / "pairs" / "new.py").write_text("x = 1\n")  # a new module counts too
    assert len({kernel_cache.sources_digest(copy), kernel_cache.core_digest()}) == 2


KERNEL = """
from ellipsim.core._jit import jit

SCALE = {scale}


@jit
def kernel(x):
    return SCALE * x
"""


def test_a_kernel_compiles_once_announced_then_loads_and_recompiles_when_its_source_changes(tmp_path):
    module = tmp_path / "mod" / "toy_kernel.py"
    module.parent.mkdir()
    module.write_text(KERNEL.format(scale=2.0))
    env = _env(tmp_path, PYTHONPATH=f"{ROOT}{os.pathsep}{module.parent}")
    code = """
        import toy_kernel
        print(toy_kernel.kernel(3.0), sum(toy_kernel.kernel.stats.cache_hits.values()))
    """
    first = _python(code, env)
    assert first.stdout.split() == ["6.0", "0"]
    assert first.stderr.count("ellipsim: compiling kernels") == 1  # one line, before the compile
    second = _python(code, env)
    assert second.stdout.split() == ["6.0", "1"] and "compiling" not in second.stderr
    module.write_text(KERNEL.format(scale=5.0))  # same bytecode, another global: numba's own key misses it
    third = _python(code, env)
    assert third.stdout.split() == ["15.0", "0"] and third.stderr.count("ellipsim: compiling kernels") == 1


def test_an_unreadable_shipped_object_is_a_miss_not_an_error(tmp_path):
    # a truncated or half-rewritten file (a checkout during a prebuild) compiles the kernel instead
    shipped = object.__new__(kernel_cache._ShippedFile)
    shipped._cache_path = str(tmp_path)
    (tmp_path / "torn.nbc").write_bytes(b"not zlib at all")
    (tmp_path / "short.nbc").write_bytes(__import__("zlib").compress(b"\x80\x04\x95"))
    assert shipped._load_data("torn.nbc") is None
    assert shipped._load_data("short.nbc") is None
    assert shipped._load_data("absent.nbc") is None


@pytest.mark.skipif(not kernel_cache.platform_matches(), reason="the shipped kernels are for x86-64 Linux")
def test_a_fresh_install_loads_the_shipped_kernels_of_the_public_functions(tmp_path):
    # fails when a change to the core is committed without `python -m ellipsim.app.prebuild`
    proc = _python(
        """
        import ellipsim as es, numpy as np
        from ellipsim.core.samples import generic_pairs
        a, b = generic_pairs(50, seed=4)
        es.classify(a, b); es.signed_distance(a, b); es.contact_scale(a, b); es.contains(a, b)
        moved = es.Ellipsoids(b.centers + 0.1, b.rotations, b.radii)
        es.time_of_impact(a, a, b, moved)
        es.classify(a, b, method="sturm", setup="cofactor")
        """,
        _env(tmp_path),
    )
    assert "compiling" not in proc.stderr, proc.stderr
    assert not (tmp_path / "cache" / "kernels").exists() or not any((tmp_path / "cache" / "kernels").rglob("*.nbc"))


@pytest.mark.slow
@pytest.mark.skipif(not kernel_cache.platform_matches(), reason="the shipped kernels are for x86-64 Linux")
def test_a_fresh_install_runs_the_readme_commands_without_compiling(tmp_path):
    env = _env(tmp_path)
    for argv in (
        ["run", "handshake", "--steps", "30", "--record", str(tmp_path / "h.rrd")],
        ["compare", "pile", "--steps", "10"],
        ["demo", "--pairs", "500"],
    ):
        proc = subprocess.run(
            [sys.executable, "-m", "ellipsim", *argv], env=env, capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert "compiling" not in proc.stderr, (argv, proc.stderr)
