"""ellipsim: exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.

Three layers, each importing only the ones above it in this list:

    ellipsim.core     the geometry (numpy and the compiled core, ellipsim/native): classify, contact_scale, signed_distance,
                      shape_distance, time_of_impact, contains
    ellipsim.mujoco   the MuJoCo glue: attach to mj_step, validate and compare, scene builders
    ellipsim.app      scenarios, recording, the command line, sweeps, mesh fitting, the benchmark suite

`import ellipsim` loads none of them: every public name is imported on first use (PEP 562), so that
attaching to MuJoCo loads the compiled module and the glue, not the core's Python layer.
"""

import importlib

__version__ = "0.2.0"

_LAZY = {
    "Ellipsoids": "core.ellipsoids",
    "Relation": "core.relation",
    "classify": "core.exact.classify",
    "classify_pairs": "core.exact.classify",
    "characteristic_polynomial": "core.exact.characteristic",
    "contact_scale": "core.exact.contact_scale",
    "signed_distance": "core.distance.ellipsoid_pair",
    "DistanceStatus": "core.distance.status",
    "DerivativeStatus": "core.distance.status",
    "shape_distance": "core.pairs.shape_distance",
    "ContactFeature": "core.distance.status",
    "time_of_impact": "core.motion.time_of_impact",
    "Impact": "core.motion.time_of_impact",
    "contains": "core.exact.containment",
    "sweep": "app.sweep",
}
_SUBPACKAGES = ("core", "mujoco", "app")

__all__ = [
    "Ellipsoids",
    "Relation",
    "classify",
    "classify_pairs",
    "characteristic_polynomial",
    "contact_scale",
    "signed_distance",
    "DistanceStatus",
    "DerivativeStatus",
    "shape_distance",
    "ContactFeature",
    "time_of_impact",
    "Impact",
    "contains",
    "sweep",
]


def __getattr__(name):
    """The public names of the core, and the layers `ellipsim.mujoco` / `ellipsim.app`, on first use."""
    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | set(_SUBPACKAGES))
