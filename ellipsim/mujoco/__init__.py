"""The MuJoCo glue: ellipsim inside mj_step, and MuJoCo's contacts checked against the exact test.

    with ellipsim.mujoco.attach(model, data, mode="narrowphase"):   # or mode="filter"
        mujoco.mj_step(model, data)
    ellipsim.mujoco.validate(model, data, 100)             # MuJoCo's contacts vs exact verdicts
    ellipsim.mujoco.compare_narrowphase(model, data, 100)  # contact by contact, refereed

Modules: context (what the compiled callbacks read per process; geom type codes and PAIR_TYPES, the
pair types ellipsim handles), publish (filling the context, handing it to the callbacks: C++, compiled
with the package, ellipsim/native/mujoco/), attachment (installing them for one data), geoms (ellipsoid geoms and candidate pairs), between (contacts that
begin and end between two frames or steps), validate, compare, jacobian (d dist / d qpos of ellipsoid
pairs).  The scene builders live in
ellipsim.app.scenes: they import nothing of this glue.

`attach` is imported with the package; the rest on first use (PEP 562), so that attaching imports
the compiled callbacks and not the geometry core's Python layer.
"""

import importlib
import sys
import types

from ..native import check_mujoco
from .attachment import MODES, Attachment, attach

check_mujoco()  # the compiled glue reads MuJoCo's structs: only under the mujoco it was built against

_LAZY = {
    "candidate_pairs": "geoms",
    "validate": "validate",
    "Validation": "validate",
    "Disagreement": "validate",
    "compare_narrowphase": "compare",
    "NarrowphaseComparison": "compare",
    "ContactDifference": "compare",
    "distance_jacobian": "jacobian",
    "DistanceJacobian": "jacobian",
}

__all__ = ["MODES", "Attachment", "attach", *_LAZY]


def __getattr__(name):
    """The public names of geoms, validate and compare, imported on first use."""
    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


class _Package(types.ModuleType):
    """This package, whose attribute `validate` stays the function: importing the submodule
    ellipsim.mujoco.validate (anyone may, any time) would otherwise set the attribute to the module,
    as the import system does for every submodule (docs.python.org/3/reference/import.html#submodules)."""

    def __setattr__(self, name, value):
        if name == "validate" and isinstance(value, types.ModuleType):
            value = value.validate
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package  # the data model's way to customise a module (3.5+)
