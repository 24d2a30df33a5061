"""Rotation matrices and unit quaternions, in MuJoCo's (w, x, y, z) order: the package's one copy."""

import numpy as np


def quaternions_to_rotations(quaternions_wxyz):
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) in MuJoCo's w, x, y, z order."""
    w, x, y, z = np.moveaxis(np.asarray(quaternions_wxyz, dtype=np.float64), -1, 0)
    rot = np.empty(np.shape(w) + (3, 3))
    rot[..., 0, 0] = 1 - 2 * (y * y + z * z)
    rot[..., 0, 1] = 2 * (x * y - w * z)
    rot[..., 0, 2] = 2 * (x * z + w * y)
    rot[..., 1, 0] = 2 * (x * y + w * z)
    rot[..., 1, 1] = 1 - 2 * (x * x + z * z)
    rot[..., 1, 2] = 2 * (y * z - w * x)
    rot[..., 2, 0] = 2 * (x * z - w * y)
    rot[..., 2, 1] = 2 * (y * z + w * x)
    rot[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return rot


def rotations_to_quaternions(rotations):
    """Unit quaternions (..., 4) w x y z, w >= 0, of rotation matrices (..., 3, 3) (scipy's
    Rotation.from_matrix: the nearest rotation of a matrix orthonormal only to rounding)."""
    from scipy.spatial.transform import Rotation  # scipy's import costs ~0.1 s: only when used

    rotations = np.asarray(rotations, dtype=np.float64)
    if rotations.size == 0:
        return np.zeros(rotations.shape[:-2] + (4,))
    xyzw = Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_quat()
    wxyz = np.roll(xyzw, 1, axis=-1)
    wxyz *= np.where(wxyz[:, :1] < 0, -1.0, 1.0)  # one sign per rotation: w >= 0
    return wxyz.reshape(rotations.shape[:-2] + (4,))


def quaternion_product(p, q):
    """Hamilton product p q of quaternions (..., 4) in w x y z order."""
    pw, px, py, pz = np.moveaxis(np.asarray(p, dtype=np.float64), -1, 0)
    qw, qx, qy, qz = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )
