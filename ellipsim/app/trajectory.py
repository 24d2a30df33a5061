"""What a run produces for recording and comparison: poses, ellipsim states and contacts per frame.

The simulation (scenario.py) fills a Trajectory; record.py turns it into rerun calls.  Nothing here
knows about MuJoCo or rerun.
"""

import dataclasses

import numpy as np


@dataclasses.dataclass
class Trajectory:
    """F frames of G ellipsoids (ellipsoid and sphere geoms), with K contacts in all.

    times : (F,) float64 seconds
    geom_names : list of G str
    geom_figure : (G,) int64, figure index of each geom, -1 for ellipsoids that belong to no figure
    half_sizes : (G, 3) float64 semi-axes, metres (a sphere: r, r, r)
    centers : (F, G, 3) float64, metres
    quaternions : (F, G, 4) float64, unit, MuJoCo's (w, x, y, z) order
    state : (F, G) int8, per ellipsim: 0 free, 1 touching, 2 overlapping (the worst over its pairs)
    contact_frame : (K,) int64, frame of each contact (MuJoCo's contacts between these geoms)
    contact_pos : (K, 3) float64, metres
    contact_normal : (K, 3) float64, unit
    builtin_counts : (F,) int64, MuJoCo's contacts between these geoms per frame
    ellipsim_counts : (F,) int64, pairs ellipsim classifies overlapping per frame
    scenario : name of the scenario
    """

    times: np.ndarray
    geom_names: list
    geom_figure: np.ndarray
    half_sizes: np.ndarray
    centers: np.ndarray
    quaternions: np.ndarray
    state: np.ndarray
    contact_frame: np.ndarray
    contact_pos: np.ndarray
    contact_normal: np.ndarray
    builtin_counts: np.ndarray
    ellipsim_counts: np.ndarray
    scenario: str = ""

    def __post_init__(self):
        F, G = len(self.times), len(self.geom_names)
        shapes = {
            "geom_figure": (G,), "half_sizes": (G, 3), "centers": (F, G, 3), "quaternions": (F, G, 4),
            "state": (F, G), "contact_pos": (len(self.contact_frame), 3),
            "contact_normal": (len(self.contact_frame), 3), "builtin_counts": (F,), "ellipsim_counts": (F,),
        }  # fmt: skip
        for name, shape in shapes.items():
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"{name} must have shape {shape}, got {got}")
        if len(self.contact_frame) and not (0 <= np.min(self.contact_frame) and np.max(self.contact_frame) < F):
            raise ValueError(f"contact_frame must index the {F} frames, got values in [{np.min(self.contact_frame)}, {np.max(self.contact_frame)}]")
