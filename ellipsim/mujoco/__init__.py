"""The MuJoCo glue: ellipsim inside mj_step, and MuJoCo's contacts checked against the exact test.

    with ellipsim.mujoco.attach(model, data, mode="narrowphase"):   # or mode="filter"
        mujoco.mj_step(model, data)
    ellipsim.mujoco.validate(model, data, 100)             # MuJoCo's contacts vs exact verdicts
    ellipsim.mujoco.compare_narrowphase(model, data, 100)  # contact by contact, refereed

Modules: structs (mjModel/mjData field access from compiled code), callbacks (the cfuncs), attachment
(installing them for one data), geoms (ellipsoid geoms and candidate pairs), validate, compare,
scenes (MJCF builders: figures, piles, chains).
"""

from .attachment import MODES, Attachment, attach
from .compare import ContactDifference, NarrowphaseComparison, compare_narrowphase
from .geoms import candidate_pairs
from .validate import Disagreement, Validation, validate

__all__ = [
    "MODES", "Attachment", "attach", "candidate_pairs", "validate", "Validation", "Disagreement",
    "compare_narrowphase", "NarrowphaseComparison", "ContactDifference",
]  # fmt: skip
