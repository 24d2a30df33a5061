"""The installed package, run from outside the checkout: its data folders and its command line.

`python -m pytest` in the repository imports the checkout's ellipsim/ (the current directory comes
first on sys.path), where models/ and scenarios/ are plain folders next to the package.  These
tests start a fresh interpreter in an empty directory instead, so they import what pip installed:
a wheel that misses models/ or scenarios/ fails here.
"""

import os
import pathlib
import subprocess
import sys

import pytest


def installed(*args, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)


def test_shipped_data_is_installed_with_the_package(tmp_path):
    code = (
        "import importlib.resources as r, ellipsim\n"
        "models = sorted(p.name for p in r.files('ellipsim.models').iterdir() if p.name.endswith('.xml'))\n"
        "scenarios = sorted(p.name for p in r.files('ellipsim.scenarios').iterdir() if p.name.endswith('.toml'))\n"
        "import ellipsim.native\n"  # the compiled core loads, built from the sources installed beside it
        "print(ellipsim.__file__); print(','.join(models)); print(','.join(scenarios))\n"
        "print(ellipsim.native.ext.__file__)\n"
    )
    proc = installed("-c", code, tmp_path=tmp_path)
    assert proc.returncode == 0, proc.stderr
    where, models, scenarios, module = proc.stdout.splitlines()
    assert not where.startswith(str(tmp_path)) and not module.startswith(str(tmp_path))
    assert pathlib.Path(module).name.startswith("_ellipsim.")
    assert "figure.xml" in models.split(",")
    assert {"crowd.toml", "handshake.toml", "pile.toml", "replay.toml", "tumble.toml"} <= set(scenarios.split(","))


@pytest.mark.slow
def test_command_line_from_outside_the_checkout(tmp_path):
    proc = installed("-m", "ellipsim", "list", tmp_path=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert {line.split()[0] for line in proc.stdout.splitlines()} >= {"crowd", "handshake", "pile", "replay", "tumble"}
    proc = installed("-m", "ellipsim", "run", "handshake", "--steps", "20", "--record", "h.rrd", tmp_path=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "narrow phase:" in proc.stdout and (tmp_path / "h.rrd").stat().st_size > 1000


def test_the_warp_kernels_compile_the_installed_core_headers(tmp_path):
    """ellipsim.warp's kernels include the core's headers from the installed package (ellipsim/native/include and
    native/warp ship in the wheel): one pair's distance through Warp's CPU device, outside the checkout, is the
    CPU API's."""
    code = (
        "import numpy as np, warp as wp, ellipsim\n"
        "wp.config.quiet = True\n"
        "from ellipsim.warp import kernels\n"
        "x = [np.zeros((1, 3)), np.eye(3)[None], np.array([[0.3, 0.2, 0.1]]),\n"
        "     np.array([[0.4, 0.1, 0.0]]), np.eye(3)[None], np.array([[0.2, 0.2, 0.3]])]\n"
        "x = [v.astype(np.float32).astype(float) for v in x]  # (the kernel reads float32 poses)\n"
        "d = kernels.pair_distances(*x, device='cpu')[0][0]\n"
        "c = ellipsim.signed_distance(ellipsim.Ellipsoids(*x[:3]), ellipsim.Ellipsoids(*x[3:]))[0][0]\n"
        "print(kernels.NATIVE); print(d == c, d)\n"
    )
    proc = installed("-c", code, tmp_path=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    native, same = proc.stdout.splitlines()[-2:]
    assert not native.startswith(str(tmp_path)) and (pathlib.Path(native) / "warp" / "narrowphase.hpp").is_file()
    assert same.startswith("True"), same
