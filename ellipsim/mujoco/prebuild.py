"""Build the CPU-generic callback objects shipped in ellipsim/mujoco/prebuilt/, so that a fresh
install starts without compiling (a release step, once per platform; rerun after any change to the
kernels the callbacks use -- tests/test_startup.py fails until then):

    python -m ellipsim.mujoco.prebuild [OUTDIR]        # default: the package's prebuilt/ folder

Compiles in a child process with NUMBA_CPU_NAME=generic and no CPU features (the platform's
baseline ISA: SSE2 on x86-64) and an empty numba cache, so that no callee compiled for this CPU is
linked in, and writes each callback under nativecache.portable_key, replacing this platform's
previous objects.  Generic code costs 2-3 % per call against code for the host CPU (337 against
329 ns per penetrating pair, measured in the start-up prototype) and gives bit-identical
trajectories (fastmath is off: no FMA contraction either way; tests/test_startup.py compares).
"""

import os
import sys
import tempfile

from ..core.cache_root import CACHE_ENV
from . import nativecache, publish


def build(outdir):
    """Compile every callback for the generic CPU into outdir; the paths written.  Run with
    NUMBA_CPU_NAME=generic before numba is imported (main() does)."""
    from . import callbacks

    if os.environ.get("NUMBA_CPU_NAME") != "generic" or os.environ.get("NUMBA_CPU_FEATURES") != "":
        raise RuntimeError("build() must run with NUMBA_CPU_NAME=generic and NUMBA_CPU_FEATURES='' (use main())")
    publish.fill_context()
    paths = []
    for kind in nativecache.KINDS:
        path = nativecache.prebuilt_path(kind, outdir)
        if not nativecache.write(path, nativecache.portable_key(kind), callbacks.compile_callback(kind)):
            raise OSError(f"could not write {path}")
        paths.append(path)
    return paths


def main(argv):
    if len(argv) > 1:
        print("usage: python -m ellipsim.mujoco.prebuild [OUTDIR]", file=sys.stderr)
        return 2
    outdir = argv[0] if argv else str(nativecache.prebuilt_dir())
    if os.environ.get("NUMBA_CPU_NAME") != "generic":
        import subprocess

        with tempfile.TemporaryDirectory() as numba_cache:
            # the callees come from the shipped kernels (generic too) or compile; never from a cache
            # of host-CPU code
            env = dict(
                os.environ,
                NUMBA_CPU_NAME="generic",
                NUMBA_CPU_FEATURES="",
                NUMBA_CACHE_DIR=numba_cache,
                **{CACHE_ENV: numba_cache},
            )
            return subprocess.call([sys.executable, "-m", "ellipsim.mujoco.prebuild", outdir], env=env)
    for path in build(outdir):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
