"""`ellipsim bench`: the one place that times things.

    ellipsim bench [--quick] [--only SECTION ...] [--out DIR]

Writes DIR/report.md and PNG plots (matplotlib, Agg; the 'bench' extra).  Sections, one module
each:

1. accuracy: time against error for every method (classify, contact_scale, the narrow phase,
   MuJoCo's mj_geomDistance at several tolerances, coal with the 'peers' extra)
2. stress: misclassified pairs per numerically hard category and method
3. scaling: classify against batch size; the kinematic replay against the number of figures
4. table1: the thesis's Table 1 re-run
5. inside_mujoco: mj_step per mode, cost per pair, contacts against MuJoCo's, long runs
6. startup: `import ellipsim` to the first narrow-phase mj_step in fresh interpreters, against MuJoCo
   alone; the README's commands run twice on a fresh install, first against second
7. motion: time_of_impact against checking sampled instants with the exact classify, the samples a
   sampling checker needs to find the same contacts; contains
8. speculative: MuJoCo 4.0's speculative contacts against time_of_impact on fast ellipsoids: missed
   impacts, where the body ends after the step, cost
9. warp: ellipsim on MuJoCo Warp (the warp extra) against Warp's GJK/EPA: accuracy per distance category,
   cost per pair, collision and mjw.step per world-step on the heap and the pile
10. gradients: signed_distance and time_of_impact with their exact derivatives against without;
   `ellipsim fix` on the replay dance (4 and 64 figures): frames/s, change, pairs freed, verification
11. pairs: section 5's table of the other pair types against MuJoCo's function, measured again and
   again: each cell's speed-up as median, lowest and highest over the runs
12. validation: MuJoCo's contacts judged against the exact test on the shipped scenes and a scene of
   every pair type: disagreements by kind, MuJoCo's normals against the exact ones, the cost per step
13. baseline: this build against another install (--baseline PYTHON): every public function per pair and
   mj_step per scene and mode, side by side in alternating processes
14. meshes: ellipsoid x convex mesh (hulls of 8 to 500 points) and x height field against MuJoCo's functions
   per category; mj_step on the terrain scene, plain and narrowphase

Every number compared in a table is measured in the same run, in interleaved rounds (common.py).
"""

import datetime
import os
import time

from . import (
    accuracy,
    baseline,
    gradients,
    inside_mujoco,
    meshes,
    motion,
    on_warp,
    pair_spread,
    scaling,
    speculative,
    startup,
    stress,
    table1,
    validation,
)
from .common import SIZES, machine_description, plt

SECTIONS = {
    "accuracy": accuracy,
    "stress": stress,
    "scaling": scaling,
    "table1": table1,
    "mujoco": inside_mujoco,
    "startup": startup,
    "motion": motion,
    "speculative": speculative,
    "warp": on_warp,
    "gradients": gradients,
    "pairs": pair_spread,
    "validation": validation,
    "baseline": baseline,
    "meshes": meshes,
}


def run(out_dir, *, quick=False, only=None, baseline=None):
    """Run the suite (or the sections named in `only`) and write out_dir/report.md and its plots.

    baseline: the interpreter of another install for section 13 (None: $ELLIPSIM_BASELINE_PYTHON, else skipped).
    Returns (path of the report, seconds).
    """
    pyplot = plt()
    __import__("mpmath")
    names = list(SECTIONS) if not only else [n for n in SECTIONS if n in only]
    unknown = sorted(set(only or ()) - set(SECTIONS))
    if unknown:
        raise ValueError(f"only must name sections of {tuple(SECTIONS)}, got {unknown[0]!r}")
    os.makedirs(out_dir, exist_ok=True)
    size = dict(SIZES["quick" if quick else "full"], baseline=baseline)
    t_start = time.perf_counter()
    body = []
    for name in names:
        module = SECTIONS[name]
        body += module.write(module.measure(size), size, out_dir, pyplot)
    seconds = time.perf_counter() - t_start
    command = "ellipsim bench" + (" --quick" if quick else "") + (f" --only {' '.join(names)}" if only else "")
    head = [f"# {command}", "", f"{datetime.date.today()}, {machine_description()}; {seconds:.0f} s.", ""]
    path = os.path.join(out_dir, "report.md")
    with open(path, "w") as f:
        f.write("\n".join(head + body + [f"Run time {seconds:.0f} s."]) + "\n")
    return path, seconds
