"""Contacts of ellipsoids with a height field, as MuJoCo makes them (mjc_ConvexHField; pairs/height_field.hpp):
every prism of the field (a cell's triangle extruded to the base) within the margin of the ellipsoid gives one
contact, its proven signed distance, normal and point (polytope.hpp), in MuJoCo's order, at most `maxcon`.

    field = HeightField(elevation, size)     # elevation (nrow, ncol) in [0, 1]; size (x, y, z, base) as MuJoCo's
    c = hfield_contacts(ellipsoids, centers, rotations, field, margin=0.0)
    c.count[i], c.dist[i, :c.count[i]], c.normal[i, :c.count[i]], c.pos[i, :c.count[i]]

A field's geometry is MuJoCo's hfield: x in [-size[0], size[0]] over ncol columns, y in [-size[1], size[1]] over
nrow rows (row r at y = -size[1] + 2 size[1] r / (nrow - 1)), height elevation[r, c] * size[2], the solid down
to z = -size[3], in the field's frame posed at (centre, rotation).  A MuJoCo model's is
ellipsim.mujoco.hull.model_height_field.
"""

from typing import NamedTuple

import numpy as np

from ...native import ext
from .. import threads
from ..ellipsoids import Ellipsoids, as_shape_poses, check_parallel

#: MuJoCo's mjMAXCONPAIR: its height-field function's most contacts per pair
MAX_CONTACTS = 50


class HeightField(NamedTuple):
    """elevation (nrow, ncol) float32 in [0, 1], size (4,) float64: half-extents x and y, height scale, base depth."""

    elevation: np.ndarray
    size: np.ndarray


class Contacts(NamedTuple):
    """count (n,) int32; dist (n, maxcon) metres, normal (n, maxcon, 3) unit from the field to the ellipsoid, pos
    (n, maxcon, 3): the first count[i] rows of pair i (the rest unset)."""

    count: np.ndarray
    dist: np.ndarray
    normal: np.ndarray
    pos: np.ndarray


def check_field(field):
    """The HeightField's arrays as the kernel reads them (float32 elevation, float64 size), checked; ValueError
    naming the field otherwise."""
    if not isinstance(field, HeightField):
        raise ValueError(f"field must be an ellipsim HeightField, got {type(field).__name__}")
    e = np.ascontiguousarray(field.elevation, np.float32)
    s = np.ascontiguousarray(field.size, np.float64)
    if e.ndim != 2 or min(e.shape) < 2:
        raise ValueError(f"field.elevation must be (nrow, ncol) with nrow, ncol >= 2, got shape {e.shape}")
    if not np.all(np.isfinite(e)) or e.min() < 0.0 or e.max() > 1.0:
        raise ValueError("field.elevation must lie in [0, 1] (MuJoCo's normalised elevations)")
    if s.shape != (4,) or not np.all(np.isfinite(s)) or not np.all(s > 0):
        raise ValueError(f"field.size must be 4 positive numbers (x, y, height, base), got {field.size!r}")
    return HeightField(e, s)


def hfield_contacts(ellipsoids, centers, rotations, field, margin=0.0, *, maxcon=MAX_CONTACTS, parallel=None):
    """The contacts of each ellipsoid with the field posed at (centers[i], rotations[i]) (one pose may be given
    unbatched; a batch of 1 broadcasts): every prism whose signed distance from the ellipsoid is below
    margin (a number, or (n,)), at most maxcon per pair.  Returns Contacts; count[i] is -1 where a distance is
    not finite (non-finite input)."""
    if not isinstance(ellipsoids, Ellipsoids):
        raise ValueError(f"ellipsoids must be an ellipsim.Ellipsoids batch, got {type(ellipsoids).__name__}")
    f = check_field(field)
    c, rot, n = as_shape_poses(ellipsoids, centers, rotations, "field")
    if isinstance(maxcon, bool) or not isinstance(maxcon, (int, np.integer)) or maxcon < 1:
        raise ValueError(f"maxcon must be a positive integer, got {maxcon!r}")
    m = np.asarray(margin, dtype=np.float64)
    if m.ndim > 1 or (m.ndim == 1 and len(m) != n) or not np.all(np.isfinite(m)):
        raise ValueError(f"margin must be a finite number or (n,) = ({n},) of them, got {margin!r}")
    m = np.ascontiguousarray(np.broadcast_to(m, (n,)))
    k = int(maxcon)
    out = Contacts(
        np.empty(n, np.int32), np.full((n, k), np.nan), np.full((n, k, 3), np.nan), np.full((n, k, 3), np.nan)
    )
    e = ellipsoids
    threads.run(
        ext.hfield_contacts, n, check_parallel(parallel, n), e.centers, e.rotations, e.radii, c, rot, *f, m, k, *out
    )
    return out
