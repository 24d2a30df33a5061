"""Where ellipsim keeps what it builds on the user's machine (compiled kernels, MuJoCo callbacks).

Standard library only: the MuJoCo glue's loader reads it without importing numba.
"""

import os
import pathlib

CACHE_ENV = "ELLIPSIM_CACHE_DIR"


def cache_root():
    """$ELLIPSIM_CACHE_DIR, else $NUMBA_CACHE_DIR/ellipsim, else $XDG_CACHE_HOME/ellipsim or ~/.cache/ellipsim."""
    if os.environ.get(CACHE_ENV):
        return pathlib.Path(os.environ[CACHE_ENV])
    if os.environ.get("NUMBA_CACHE_DIR"):
        return pathlib.Path(os.environ["NUMBA_CACHE_DIR"]) / "ellipsim"
    return pathlib.Path(os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache") / "ellipsim"
