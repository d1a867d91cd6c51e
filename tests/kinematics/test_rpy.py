"""Roll, pitch, yaw (seed 004, [8] and [9]): composition, round trips, pitch = +-90 deg."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from server.kinematics import matrix_from_rpy, rpy_from_matrix

roll_or_yaw = st.floats(-math.pi + 1e-9, math.pi - 1e-9)
# Away from the gimbal lock, so the three angles are unique.
pitch = st.floats(-math.pi / 2 + 1e-3, math.pi / 2 - 1e-3)
quaternion = arrays(np.float64, (4,), elements=st.floats(-1, 1)).filter(
    lambda v: np.linalg.norm(v) > 1e-3
)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rotation_from_quaternion(v: np.ndarray) -> np.ndarray:
    w, x, y, z = v / np.linalg.norm(v)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@given(roll_or_yaw, st.floats(-math.pi, math.pi), roll_or_yaw)
def test_matrix_is_yaw_after_pitch_after_roll_about_fixed_axes(roll, pitch_, yaw) -> None:
    expected = rot_z(yaw) @ rot_y(pitch_) @ rot_x(roll)
    np.testing.assert_allclose(matrix_from_rpy([roll, pitch_, yaw]), expected, atol=1e-15)


@given(roll_or_yaw, pitch, roll_or_yaw)
def test_angles_round_trip_away_from_the_gimbal_lock(roll, pitch_, yaw) -> None:
    back = rpy_from_matrix(matrix_from_rpy([roll, pitch_, yaw]))
    np.testing.assert_allclose(back, [roll, pitch_, yaw], atol=1e-12)


@settings(max_examples=300)
@given(quaternion)
def test_any_rotation_is_reproduced_by_its_angles(v) -> None:
    rot = rotation_from_quaternion(v)
    rpy = rpy_from_matrix(rot)
    assert -math.pi / 2 <= rpy[1] <= math.pi / 2
    assert np.all(np.abs(rpy) <= math.pi)
    # Near the lock the seed's formulas lose digits; see GIMBAL_LOCK_COS.
    tolerance = 1e-12 if math.hypot(rot[0, 0], rot[1, 0]) > 1e-3 else 5e-8
    np.testing.assert_allclose(matrix_from_rpy(rpy), rot, atol=tolerance)


@given(roll_or_yaw, st.sampled_from([math.pi / 2, -math.pi / 2]), roll_or_yaw)
def test_gimbal_lock_puts_the_whole_turn_in_yaw(roll, pitch_, yaw) -> None:
    rot = matrix_from_rpy([roll, pitch_, yaw])
    back = rpy_from_matrix(rot)
    assert back[0] == 0.0 and back[1] == pitch_
    # Only yaw - roll (pitch +90) or yaw + roll (pitch -90) is defined there.
    combined = yaw - roll if pitch_ > 0 else yaw + roll
    assert abs(math.remainder(back[2] - combined, 2 * math.pi)) < 1e-12
    np.testing.assert_allclose(matrix_from_rpy(back), rot, atol=1e-15)


def test_seed_formula_for_pitch_minus_90_degrees() -> None:
    # Seed [9]: at pitch -90 deg, roll = 0 and yaw = -atan2(r01, r11).
    rot = rot_z(0.7) @ rot_y(-math.pi / 2) @ rot_x(0.0)
    assert rpy_from_matrix(rot)[2] == -math.atan2(rot[0, 1], rot[1, 1])


def test_batches_keep_their_leading_axes() -> None:
    rpy = np.random.default_rng(0).uniform(-1.5, 1.5, (4, 5, 3))
    rot = matrix_from_rpy(rpy)
    assert rot.shape == (4, 5, 3, 3)
    np.testing.assert_allclose(
        rot @ np.swapaxes(rot, -1, -2), np.broadcast_to(np.eye(3), rot.shape), atol=1e-15
    )
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-14)
    np.testing.assert_allclose(rpy_from_matrix(rot), rpy, atol=1e-12)
