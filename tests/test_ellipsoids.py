import mujoco
import numpy as np
import pytest

from ellipsim import Ellipsoids

I = np.eye(3)


def test_attributes_are_read_only_float64_and_the_batch_is_immutable():
    e = Ellipsoids([[0, 0, 0], [1, 2, 3]], [I, I], [[1, 1, 1], [1, 2, 3]])
    assert len(e) == 2
    assert e.centers.dtype == np.float64 and e.centers.shape == (2, 3)
    with pytest.raises(ValueError):
        e.radii[0, 0] = 5.0
    with pytest.raises(AttributeError):
        e.radii = np.ones((2, 3))


def test_single_ellipsoid_and_indexing():
    e = Ellipsoids([1, 2, 3], I, [1, 2, 3])
    assert len(e) == 1 and e.centers.tolist() == [[1, 2, 3]]
    batch = Ellipsoids(np.arange(15.0).reshape(5, 3), np.stack([I] * 5), np.ones((5, 3)))
    assert batch[2].centers.tolist() == [[6, 7, 8]]
    assert batch[-1].centers.tolist() == [[12, 13, 14]]
    assert batch[1:3].centers[:, 0].tolist() == [3, 6]
    assert len(batch[np.array([True, False, True, False, True])]) == 3
    with pytest.raises(IndexError, match="index 5 is out of range for 5"):
        batch[5]


def test_from_quaternions_matches_mujoco():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(20, 4))
    e = Ellipsoids.from_quaternions(rng.normal(size=(20, 3)), q, np.ones((20, 3)))
    for i in range(20):
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, q[i] / np.linalg.norm(q[i]))
        np.testing.assert_allclose(e.rotations[i], mat.reshape(3, 3), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(centers=[[0, np.nan, 0]]), r"centers\[0, 1\] must be finite, got nan"),
        (dict(centers=[[0, 0, 0], [0, 0, np.inf]]), r"centers\[1, 2\] must be finite, got inf"),
        (dict(radii=[[1, 0, 1]]), r"radii\[0, 1\] must be positive, got 0.0"),
        (dict(radii=[[1, 1, -0.2]]), r"radii\[0, 2\] must be positive, got -0.2"),
        (
            dict(rotations=[[[1, 0, 0], [0, 1, 0], [0, 0, 1.01]]]),
            r"rotations\[0\] must be orthonormal: max \|R\^T R - I\| = 0.0201",
        ),
        (dict(rotations=[[[1, 0, 0], [0, 1, 0]]]), r"rotations must have shape \(n, 3, 3\), got \(1, 2, 3\)"),
        (dict(centers=[[0, 0]]), r"centers must have shape \(n, 3\), got \(1, 2\)"),
        (dict(radii=[["a", "b", "c"]]), r"radii must hold real numbers, got dtype <U1"),
        (dict(centers=[[1j, 0, 0]]), r"centers must hold real numbers, got dtype complex128"),
        (dict(radii=[[True, True, True]]), r"radii must hold real numbers, got dtype bool"),
        (dict(centers=[[0, 0, 0], [1, 1, 1]]), r"same length, got 2, 1 and 1"),
    ],
)
def test_bad_input_names_the_argument_index_and_value(kwargs, message):
    args = dict(centers=[[0, 0, 0]], rotations=[I], radii=[[1, 1, 1]])
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        Ellipsoids(**args)


@pytest.mark.parametrize(
    "args, message",
    [
        (([0, 0, 0], [[1, 0, 0], [0, 1], [0, 0, 1]], [1, 1, 1]), r"rotations must be an array of shape \(n, 3, 3\)"),
        (([[0, 0, 0], [1]], [I, I], [[1, 1, 1]] * 2), r"centers must be an array of shape \(n, 3\)"),
        (([0, 0, 0], I, [1, 1]), r"radii must have shape \(n, 3\), got \(1, 2\)"),
    ],
)
def test_ragged_or_misshapen_single_ellipsoid_names_the_argument(args, message):
    with pytest.raises(ValueError, match=message):
        Ellipsoids(*args)
    with pytest.raises(ValueError, match=r"quaternions_wxyz must be an array of shape \(n, 4\)"):
        Ellipsoids.from_quaternions([0, 0, 0], [1, 0, [0], 0], [1, 1, 1])


def test_rotation_tolerance_is_1e_6():
    near = I + np.diag([4e-7, 0, 0])
    Ellipsoids([[0, 0, 0]], [near], [[1, 1, 1]])
    with pytest.raises(ValueError, match="rotations"):
        Ellipsoids([[0, 0, 0]], [I + np.diag([1e-6, 0, 0])], [[1, 1, 1]])


def test_zero_quaternion_is_rejected():
    with pytest.raises(ValueError, match=r"quaternions_wxyz\[1\] must be non-zero"):
        Ellipsoids.from_quaternions(np.zeros((2, 3)), [[1, 0, 0, 0], [0, 0, 0, 0]], np.ones((2, 3)))
