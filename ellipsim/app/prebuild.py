"""Shipped kernels: every numba kernel that a README command or a public function uses, compiled for
the platform's baseline CPU into the package's kernels/ folder (core/kernel_cache.py loads them).

    python -m ellipsim.app.prebuild            # the callbacks (mujoco/prebuild.py), then the kernels

A child process with NUMBA_CPU_NAME=generic (SSE2 on x86-64, as the shipped callbacks) and the
kernel cache writing into the emptied kernels/ folder runs WORKLOAD: the README's commands on short
settings and every public function on one pair and on a batch large enough for the thread pool.
Run from a checkout, the test suite's fast part follows (_test_kernels).  Whatever they compile is what a
fresh install loads instead of compiling; a kernel a later change
adds and the workload misses compiles on first use, announced (tests/test_startup.py checks that
the README's commands compile nothing on a fresh install).
"""

import contextlib
import io
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from ..core import kernel_cache


def _public_functions():
    """Every public function of the core on one pair and on a threaded batch, every method."""
    import ellipsim as es
    from ellipsim.core.samples import generic_pairs, near_contact_pairs

    for n in (1, 2, 20_000):
        a, b = generic_pairs(n, seed=1)
        for parallel in (False, True):
            es.classify(a, b, parallel=parallel)
            for method in ("sturm", "descartes"):
                for setup in ("rearranged", "cofactor"):
                    for dtype in ("float64", "float32"):
                        es.classify(a, b, method=method, setup=setup, dtype=dtype, parallel=parallel)
                    es.characteristic_polynomial(a, b, setup=setup, parallel=parallel)
            es.classify_pairs(es.Ellipsoids.concatenate([a, b]), np.arange(n), np.arange(n, 2 * n), parallel=parallel)
            es.contact_scale(a, b, parallel=parallel)
            es.signed_distance(a, b, parallel=parallel)
            es.signed_distance(a, b, parallel=parallel, derivatives=True)
            es.contains(a, b, parallel=parallel)
            moved = es.Ellipsoids(b.centers + 0.1, b.rotations, b.radii)
            es.time_of_impact(a, a, b, moved, parallel=parallel, return_status=True)
            es.time_of_impact(a, a, b, moved, parallel=parallel, derivatives=True)
            for kind in ("capsule", "box", "cylinder"):
                es.shape_distance(a, kind, b.centers, b.rotations, b.radii, parallel=parallel, derivatives=True)
    a, b = near_contact_pairs(200, seed=2)
    es.signed_distance(a, b)
    es.classify(a, b)


def _glue():
    """The MuJoCo glue's public functions on a pile (their kernels: candidate pairs, the exact verdicts)."""
    import itertools
    import re

    import mujoco

    import ellipsim.mujoco as em

    from . import scenes

    k = itertools.count()

    def swap(m):  # every pair type: ellipsoids, capsules and cylinders heaped in a bin of box walls
        kind = ("ellipsoid", "capsule", "cylinder")[next(k) % 3]
        return m[0] if kind == "ellipsoid" else f'type="{kind}" size="{m[1]} {m[2]}"'

    xml = re.sub(r'type="ellipsoid" size="(\S+) (\S+) \S+"', swap, scenes.pile_xml(18, seed=1, bin_half_width=0.3))
    model = mujoco.MjModel.from_xml_string(xml)
    for steps in (1, 200):  # the pile settled: deep and shallow contacts of every pair type
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data, steps)
        pairs = em.candidate_pairs(model, data)
        em.distance_jacobian(model, data, pairs)
        e = int(np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID)[0])
        other = np.isin(
            model.geom_type, [mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_BOX]
        )
        em.distance_jacobian(model, data, [(e, int(g)) for g in np.flatnonzero(other)])  # capsule, cylinder, box walls
        em.validate(model, data, 5, between=True)
        em.compare_narrowphase(model, data, 5)


def _commands(tmp):
    """The README's commands on short settings (the README's own paths under tmp)."""
    from . import bench, cli, scenes

    model = tmp / "figure.xml"
    model.write_text(scenes.scene_xml(2))
    import mujoco

    m = mujoco.MjModel.from_xml_string(model.read_text())
    rng = np.random.default_rng(0)
    motion = np.repeat(m.qpos0[None], 30, 0) + 0.05 * rng.standard_normal((30, m.nq)) * (np.arange(m.nq) >= 7)
    np.save(tmp / "walk.npy", motion)
    runs = [
        ["run", "handshake", "--steps", "60", "--record", str(tmp / "handshake.rrd")],
        ["run", "replay", "--steps", "30", "--record", str(tmp / "dance.rrd")],
        ["run", "pile", "--steps", "30", "--mode", "filter"],
        ["run", "tumble", "--steps", "30", "--mode", "narrowphase"],
        ["compare", "pile", "--steps", "20", "--json", str(tmp / "pile.json")],
        ["compare", str(model), "--steps", "20"],
        [
            "replay",
            str(model),
            str(tmp / "walk.npy"),
            "--record",
            str(tmp / "walk.rrd"),
            "--json",
            str(tmp / "walk.json"),
        ],
        ["fix", str(model), str(tmp / "walk.npy"), "--clearance", "0.005", "--out", str(tmp / "fixed.npy")],
        ["demo", "--pairs", "2000"],
        # the bench's own kernels (not the start-up section, which compiles in children of its own, nor the warp
        # section, whose kernels are Warp's)
        [
            "bench",
            "--quick",
            "--out",
            str(tmp / "bench"),
            "--only",
            *(s for s in bench.SECTIONS if s not in ("startup", "warp")),
        ],
    ]
    for argv in runs:
        with contextlib.redirect_stdout(io.StringIO()):
            status = cli.main(argv)
        if status != 0 and not (argv[0] == "fix" and status == 1):  # (fix: 1 when a pair is left; not an error here)
            raise RuntimeError(f"prebuild: `ellipsim {' '.join(argv)}` exited {status}")


def _workload():
    with tempfile.TemporaryDirectory() as tmp:
        _public_functions()
        _glue()
        _commands(pathlib.Path(tmp))


def _test_kernels(env, out):
    """From a checkout: the kernels that the test suite's `-m "not slow"` part compiles beyond the
    workload (internal kernels the tests call with their own signatures, ~1 min of compiling on a fresh
    machine), into `out` as well.  Its verdicts are not looked at here (tests that check the shipped
    folder itself fail while it is being written; CI runs the suite); kernels defined in test files
    (keyed by their folder, other/) are dropped."""
    tests = pathlib.Path(__file__).resolve().parents[2] / "tests"
    if not tests.is_dir():
        return
    print("prebuild: the test suite's own kernels (pytest -m 'not slow', its verdicts ignored) ...", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        cmd = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-p", "no:cacheprovider", str(tests)]
        subprocess.call(cmd, env=dict(env, TMPDIR=scratch), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    shutil.rmtree(out / "other", ignore_errors=True)


def main(argv):
    if argv:
        print("usage: python -m ellipsim.app.prebuild", file=sys.stderr)
        return 2
    out = kernel_cache.SHIPPED
    if os.environ.get(kernel_cache.BUILD_ENV):  # the child
        _workload()
        return 0
    from ..mujoco import prebuild as callbacks

    if callbacks.main([]):  # first: the README's commands then load the callbacks, current
        return 1
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    with tempfile.TemporaryDirectory() as cache:
        env = dict(
            os.environ,
            NUMBA_CPU_NAME="generic",
            NUMBA_CPU_FEATURES="",
            NUMBA_CACHE_DIR=cache,
            ELLIPSIM_CACHE_DIR=cache,
            **{kernel_cache.BUILD_ENV: str(out)},
        )
        status = subprocess.call([sys.executable, "-m", "ellipsim.app.prebuild"], env=env)
        if status:
            return status
        _test_kernels(env, out)
    # out/mujoco: the callbacks' own kernels, which a compile of the callbacks loads (a platform
    # with these kernels but other sources than the prebuilt callbacks')
    size = kernel_cache.compress_shipped(out)
    print(f"wrote {len(list(out.rglob('*.nbc')))} kernels, {size / 1e6:.1f} MB compressed, into {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
