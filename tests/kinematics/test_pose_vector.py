"""UR pose vectors <-> 4x4 poses: round trips, agreement with scipy, angles near 0 and pi."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from server.kinematics import matrix_from_pose_vector, pose_vector_from_matrix

finite = st.floats(-2.0, 2.0, allow_nan=False)
unit_axis = st.tuples(finite, finite, finite).filter(lambda v: np.linalg.norm(v) > 1e-3)


def _rotvec(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64)
    return a / np.linalg.norm(a) * angle


@settings(max_examples=200)
@given(unit_axis, st.floats(0.0, math.pi - 1e-6), st.tuples(finite, finite, finite))
def test_round_trip_below_pi_returns_the_same_vector(axis, angle, xyz) -> None:
    pose = np.concatenate([xyz, _rotvec(axis, angle)])
    back = pose_vector_from_matrix(matrix_from_pose_vector(pose))
    np.testing.assert_allclose(back, pose, atol=1e-9)


@settings(max_examples=200)
@given(unit_axis, st.floats(0.0, 3.0 * math.pi))
def test_rotation_agrees_with_scipy(axis, angle) -> None:
    rv = _rotvec(axis, angle)
    expected = Rotation.from_rotvec(rv).as_matrix()
    rotation = matrix_from_pose_vector([0, 0, 0, *rv])[:3, :3]
    np.testing.assert_allclose(rotation, expected, atol=1e-12)


@pytest.mark.parametrize("angle", [0.0, 1e-300, 1e-12, 1e-8, 1e-6, 1e-5, 9.9e-5, 1e-4, 1e-3])
def test_tiny_angles_are_exact(angle: float) -> None:
    rv = _rotvec((0.3, -0.5, 0.8), angle)
    matrix = matrix_from_pose_vector([0, 0, 0, *rv])
    np.testing.assert_allclose(matrix[:3, :3], Rotation.from_rotvec(rv).as_matrix(), atol=1e-15)
    back = pose_vector_from_matrix(matrix)[3:]
    # Relative accuracy even far below the series threshold.
    np.testing.assert_allclose(back, rv, rtol=1e-9, atol=1e-300)


@pytest.mark.parametrize("gap", [0.0, 1e-12, 1e-9, 1e-6, 1e-3])
@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (-0.2, 0.9, -0.4)])
def test_near_pi_the_axis_survives_up_to_sign(axis: tuple[int, int, int], gap: float) -> None:
    rv = _rotvec(axis, math.pi - gap)
    matrix = matrix_from_pose_vector([0, 0, 0, *rv])
    back = pose_vector_from_matrix(matrix)[3:]
    assert np.linalg.norm(back) <= math.pi + 1e-12
    np.testing.assert_allclose(matrix_from_pose_vector([0, 0, 0, *back]), matrix, atol=1e-12)
    if gap >= 1e-6:
        np.testing.assert_allclose(back, rv, atol=1e-9)
    else:
        assert min(np.linalg.norm(back - rv), np.linalg.norm(back + rv)) < 1e-6


@settings(max_examples=100)
@given(st.tuples(finite, finite, finite, finite))
def test_matrices_from_random_quaternions_round_trip(quat) -> None:
    q = np.asarray(quat)
    if np.linalg.norm(q) < 1e-3:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(q).as_matrix()
    matrix[:3, 3] = [0.1, -0.2, 0.3]
    np.testing.assert_allclose(
        matrix_from_pose_vector(pose_vector_from_matrix(matrix)), matrix, atol=1e-12
    )


def test_matrix_is_a_proper_rigid_transform() -> None:
    rng = np.random.default_rng(3)
    poses = rng.normal(size=(50, 6)) * 2.0
    matrices = matrix_from_pose_vector(poses)
    rot = matrices[:, :3, :3]
    identity = np.broadcast_to(np.eye(3), rot.shape)
    np.testing.assert_allclose(rot @ np.swapaxes(rot, -1, -2), identity, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-12)
    np.testing.assert_array_equal(matrices[:, 3], np.broadcast_to([0, 0, 0, 1], (50, 4)))
    np.testing.assert_array_equal(matrices[:, :3, 3], poses[:, :3])


def test_batch_first_shapes_match_one_by_one() -> None:
    rng = np.random.default_rng(4)
    poses = rng.normal(size=(2, 3, 6))
    matrices = matrix_from_pose_vector(poses)
    assert matrices.shape == (2, 3, 4, 4)
    for i in range(2):
        for j in range(3):
            np.testing.assert_array_equal(matrices[i, j], matrix_from_pose_vector(poses[i, j]))
    assert pose_vector_from_matrix(matrices).shape == (2, 3, 6)


def test_ur_rotation_about_x() -> None:
    # Seed 003's linear calibration result p[0, 0.1, 0, -1.5708, 0, 0]: -90 deg about base X.
    matrix = matrix_from_pose_vector([0, 0.1, 0, -math.pi / 2, 0, 0])
    np.testing.assert_allclose(matrix[:3, :3], [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=1e-15)
    np.testing.assert_allclose(matrix[:3, 3], [0, 0.1, 0])


@pytest.mark.parametrize("bad", [[0.0] * 5, [0.0] * 7, 1.0])
def test_wrong_pose_vector_size_is_refused(bad: object) -> None:
    with pytest.raises(ValueError, match="6 elements"):
        matrix_from_pose_vector(bad)  # type: ignore[arg-type]


def test_wrong_matrix_shape_is_refused() -> None:
    with pytest.raises(ValueError, match="4, 4"):
        pose_vector_from_matrix(np.eye(3))
