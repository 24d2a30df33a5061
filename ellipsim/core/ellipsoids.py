"""A validated, immutable batch of ellipsoids.

Convention (the same as MuJoCo's ``geom_xpos``, ``geom_xmat`` reshaped to 3x3 and ``geom_size``):

    E = { x : |diag(1/r) R^T (x - c)| <= 1 }

with centre ``c`` (3,), rotation ``R`` (3, 3) whose columns are the principal axes, and semi-axes
``r`` (3,) > 0.  The exact tests read this formula literally on the stored float64 numbers, so a
rotation that is orthonormal only to rounding still defines one precise ellipsoid.
"""

import numpy as np

from .rotations import quaternions_to_rotations
from .tolerances import ORTHONORMAL_TOL, PARALLEL_MIN_PAIRS, SMALL_BATCH_PAIRS


def _is_single(centers):
    """True for one unbatched centre (3,); a ragged value is left for _as_real_array to name."""
    try:
        return np.ndim(centers) == 1
    except Exception:
        return False


def _as_real_array(name, value, tail, single=False):
    """`value` (with a leading axis added when `single`) as a C-contiguous float64 array of shape
    (n, *tail); ValueError naming `name`."""
    try:
        arr = np.asarray(value)
    except Exception as exc:  # ragged nested lists and the like
        raise ValueError(f"{name} must be an array of shape (n, {', '.join(map(str, tail))}): {exc}") from None
    if single and arr.ndim == len(tail):
        arr = arr[None]
    if arr.dtype == bool or arr.dtype.kind not in "iuf":
        raise ValueError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 1 + len(tail) or arr.shape[1:] != tail:
        want = ", ".join(["n"] + [str(t) for t in tail])
        raise ValueError(f"{name} must have shape ({want}), got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name}[{', '.join(map(str, idx))}] must be finite, got {arr[idx]}")
    return arr


def orthonormality_defect(rotations):
    """max_ij |(R^T R - I)_ij| per rotation.  rotations : (n, 3, 3) -> (n,)

    The six distinct entries of R^T R as dot products of columns: 7-20x faster than one einsum
    over the 3x3 products (400 000 rotations: 15-18 ms against 120-340 ms), bit-identical."""
    c0, c1, c2 = rotations[:, :, 0], rotations[:, :, 1], rotations[:, :, 2]
    out = np.abs(np.einsum("nk,nk->n", c0, c0) - 1.0)
    for x, y, diagonal in ((c1, c1, 1.0), (c2, c2, 1.0), (c0, c1, 0.0), (c0, c2, 0.0), (c1, c2, 0.0)):
        np.maximum(out, np.abs(np.einsum("nk,nk->n", x, y) - diagonal), out=out)
    return out


def as_poses(centers, rotations, sizes, sizes_name):
    """(centres (n, 3), rotations (n, 3, 3), sizes (n, 3)) as C-contiguous float64 arrays of one length (one
    body may come unbatched); ValueError naming the argument otherwise."""
    single = _is_single(centers)
    c = _as_real_array("centers", centers, (3,), single)
    rot = _as_real_array("rotations", rotations, (3, 3), single)
    s = _as_real_array(sizes_name, sizes, (3,), single)
    if not len(c) == len(rot) == len(s):
        raise ValueError(
            f"centers, rotations and {sizes_name} must have the same length, got {len(c)}, {len(rot)} and {len(s)}"
        )
    return c, rot, s


def as_shape_poses(ellipsoids, centers, rotations, what):
    """(centres (k, 3), rotations (k, 3, 3), n pairs) of one shape posed per pair against `ellipsoids` (one pose
    may come unbatched; a batch of 1 on either side broadcasts): shapes checked, rotations orthonormal, lengths
    matching; ValueError naming the argument otherwise.  `what` names the shape in the messages."""
    single = _is_single(centers)
    c = _as_real_array("centers", centers, (3,), single)
    rot = _as_real_array("rotations", rotations, (3, 3), single)
    if len(c) != len(rot):
        raise ValueError(f"centers and rotations must have the same length, got {len(c)} and {len(rot)}")
    check_rotations(rot)
    ne, nk = len(ellipsoids.centers), len(c)
    if ne != nk and ne != 1 and nk != 1:
        raise ValueError(
            f"ellipsoids and the {what} poses must have the same length or one of them length 1, got {ne} and {nk}"
        )
    return c, rot, 0 if ne == 0 or nk == 0 else max(ne, nk)


def check_rotations(rot):
    """ValueError naming the first of rotations (n, 3, 3) that is not orthonormal to ORTHONORMAL_TOL."""
    defect = orthonormality_defect(rot)
    bad = np.flatnonzero(defect > ORTHONORMAL_TOL)
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"rotations[{i}] must be orthonormal: max |R^T R - I| = {defect[i]:.3g} "
            f"exceeds the tolerance {ORTHONORMAL_TOL:g}; got {rot[i].tolist()}"
        )


class Ellipsoids:
    """An immutable batch of n ellipsoids.

    centers : (n, 3) float64, metres
    rotations : (n, 3, 3) float64, orthonormal to ``ORTHONORMAL_TOL`` (columns = principal axes)
    radii : (n, 3) float64 > 0, metres (semi-axes along the columns of the rotation)

    A single ellipsoid may be given unbatched: centers (3,), rotations (3, 3), radii (3,).
    Integer indexing returns a batch of length 1, so ``batch[i]`` can be passed to any query.
    """

    __slots__ = ("centers", "rotations", "radii")

    def __init__(self, centers, rotations, radii):
        c, rot, r = as_poses(centers, rotations, radii, "radii")
        nonpos = r <= 0
        if nonpos.any():
            i, j = (int(k) for k in np.argwhere(nonpos)[0])
            raise ValueError(f"radii[{i}, {j}] must be positive, got {r[i, j]}")
        check_rotations(rot)
        for arr in (c, rot, r):
            arr.flags.writeable = False
        object.__setattr__(self, "centers", c)
        object.__setattr__(self, "rotations", rot)
        object.__setattr__(self, "radii", r)

    @classmethod
    def from_quaternions(cls, centers, quaternions_wxyz, radii):
        """Build from unit quaternions (n, 4) in MuJoCo's (w, x, y, z) order; they are normalised."""
        single = _is_single(centers)
        q = _as_real_array("quaternions_wxyz", quaternions_wxyz, (4,), single)
        norm = np.linalg.norm(q, axis=1)
        zero = np.flatnonzero(norm == 0)
        if len(zero):
            raise ValueError(f"quaternions_wxyz[{int(zero[0])}] must be non-zero, got {q[zero[0]].tolist()}")
        rot = quaternions_to_rotations(q / norm[:, None])
        if single:
            return cls(centers, rot[0], radii)
        return cls(centers, rot, radii)

    @classmethod
    def concatenate(cls, batches):
        """One batch holding the ellipsoids of `batches` in order (validated already, so not again)."""
        batches = list(batches)
        if not all(isinstance(b, Ellipsoids) for b in batches):
            raise ValueError("batches must all be ellipsim.Ellipsoids")
        new = object.__new__(cls)
        for name in cls.__slots__:
            parts = [getattr(b, name) for b in batches]
            arr = np.concatenate(parts) if parts else np.zeros((0,) + getattr(_EMPTY, name).shape[1:])
            arr.flags.writeable = False
            object.__setattr__(new, name, arr)
        return new

    def __setattr__(self, name, value):
        raise AttributeError("Ellipsoids is immutable")

    def __len__(self):
        return len(self.centers)

    def __getitem__(self, index):
        if isinstance(index, (int, np.integer)):
            n = len(self)
            if not -n <= index < n:
                raise IndexError(f"index {index} is out of range for {n} ellipsoids")
            index = slice(index, index + 1 if index != -1 else None)
        new = object.__new__(Ellipsoids)
        for name in self.__slots__:
            arr = np.ascontiguousarray(getattr(self, name)[index])
            arr.flags.writeable = False
            object.__setattr__(new, name, arr)
        return new

    def __repr__(self):
        if len(self) > 2:
            return f"Ellipsoids(n={len(self)})"
        with np.printoptions(precision=17):
            return (
                f"Ellipsoids(centers={self.centers.tolist()}, rotations={self.rotations.tolist()}, "
                f"radii={self.radii.tolist()})"
            )


_EMPTY = Ellipsoids(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)))


def check_pair(a, b):
    """Validate two batches for a pairwise query; return the broadcast length."""
    if not (isinstance(a, Ellipsoids) and isinstance(b, Ellipsoids)):
        for name, value in (("a", a), ("b", b)):
            if not isinstance(value, Ellipsoids):
                raise ValueError(f"{name} must be an ellipsim.Ellipsoids batch, got {type(value).__name__}")
    na, nb = len(a.centers), len(b.centers)  # not len(a): its __len__ is a Python call
    if na != nb and na != 1 and nb != 1:
        raise ValueError(f"a and b must have the same length or one of them length 1, got {na} and {nb}")
    return 0 if na == 0 or nb == 0 else max(na, nb)


def check_choice(name, value, options):
    """`value` must be one of the strings `options`; ValueError naming `name` otherwise."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {options}, got {value!r}")


def check_parallel(parallel, n):
    """Whether a query on n pairs runs on all cores: `parallel` if True or False, and for None
    (the default) from PARALLEL_MIN_PAIRS pairs on, where threading starts to pay on 2 cores."""
    if parallel is None:
        return n >= PARALLEL_MIN_PAIRS
    if not isinstance(parallel, (bool, np.bool_)):
        raise ValueError(f"parallel must be True, False or None, got {parallel!r}")
    return bool(parallel)


def indices_of(codes, value):
    """The indices i with codes[i] == value (1-D), ascending: np.flatnonzero, or for a batch of up to
    SMALL_BATCH_PAIRS a Python scan of its list (~0.1 us against numpy's ~1.3 us, issue 20)."""
    if len(codes) <= SMALL_BATCH_PAIRS:
        return [i for i, c in enumerate(codes.tolist()) if c == value]
    return np.flatnonzero(codes == value)
