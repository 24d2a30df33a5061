"""ellipsim: exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.

Three layers, each importing only the ones above it in this list:

    ellipsim.core     the geometry (numpy and numba only): classify, contact_scale, signed_distance
    ellipsim.mujoco   the MuJoCo glue: attach to mj_step, validate and compare, scene builders
    ellipsim.app      scenarios, recording, the command line, mesh fitting, the benchmark suite

`import ellipsim` loads the core only; `ellipsim.mujoco` and `ellipsim.app` are imported on first use.
"""

import importlib

from .core.charpoly import characteristic_polynomial
from .core.classify import classify
from .core.distance import signed_distance
from .core.ellipsoids import Ellipsoids
from .core.perram_wertheim import contact_scale
from .core.relation import Relation

__all__ = ["Ellipsoids", "Relation", "classify", "characteristic_polynomial", "contact_scale", "signed_distance"]
__version__ = "0.2.0"

_LAZY = ("mujoco", "app")


def __getattr__(name):
    """`ellipsim.mujoco` and `ellipsim.app` without importing MuJoCo or rerun with the core."""
    if name in _LAZY:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
