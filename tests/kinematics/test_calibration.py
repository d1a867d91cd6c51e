"""Rotary and linear axis calibration (seed 003): worked examples and synthetic recoveries."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from server.kinematics import (
    calibrate_linear_axis,
    calibrate_rotary_axis,
    matrix_from_pose_vector,
)

HEADSTOCK = [[0.1, 0.0, 0.001, 0, 0, 0], [0.0, 0.1, 0.001, 0, 0, 0], [-0.1, 0.0, 0.001, 0, 0, 0]]


def _circle_samples(frame: np.ndarray, radius: float, angles: np.ndarray, z: float = 0.0):
    """Poses on a circle about the frame's +Z, at ``angles`` from its +X (no orientation)."""
    local = np.stack(
        [
            radius * np.cos(angles),
            radius * np.sin(angles),
            np.full_like(angles, z),
            np.ones_like(angles),
        ],
        -1,
    )
    points = local @ frame.T
    return np.concatenate([points[:, :3], np.zeros((len(angles), 3))], axis=1)


def _random_frame(rng: np.random.Generator) -> np.ndarray:
    frame = np.eye(4)
    frame[:3, :3] = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()
    frame[:3, 3] = rng.uniform(-1.0, 1.0, 3)
    return frame


def test_seed_example_headstock_only() -> None:
    result = calibrate_rotary_axis(HEADSTOCK)
    np.testing.assert_allclose(result.pose, [0, 0, 0.001, 0, 0, 0], atol=1e-12)
    assert result.radius == pytest.approx(0.1, abs=1e-12)
    assert result.max_error == pytest.approx(0.0, abs=1e-12)
    assert result.mean_error == pytest.approx(0.0, abs=1e-12)


def test_seed_example_with_tailstock() -> None:
    # The seed says "centered at p[0, 0, 1, ...]" but its samples lie at z = 0.1; the
    # samples decide. The axis is +Z either way, so the result is the same pose.
    tailstock = [[0.0, 0.2, 0.1, 0, 0, 0], [-0.2, 0.0, 0.1, 0, 0, 0], [0.0, -0.2, 0.1, 0, 0, 0]]
    result = calibrate_rotary_axis(HEADSTOCK, tailstock)
    np.testing.assert_allclose(result.pose, [0, 0, 0.001, 0, 0, 0], atol=1e-12)
    assert result.radius == pytest.approx(0.1, abs=1e-12)
    assert result.max_error == pytest.approx(0.0, abs=1e-12)
    assert result.mean_error == pytest.approx(0.0, abs=1e-12)


def test_seed_example_linear_axis() -> None:
    # The seed lists x_dir = p[0.1, 0.1, 0, ...] and calls with p[0.1, 0, 0.1, ...]; only the
    # listed one gives its stated result (+X of the base), so the call is taken as a typo.
    result = calibrate_linear_axis(
        [0, 0.1, 0, 0, 0, 0], [[0, 0.2, 0, 0, 0, 0], [0, 0.3, 0, 0, 0, 0]], [0.1, 0.1, 0, 0, 0, 0]
    )
    np.testing.assert_allclose(result.pose, [0, 0.1, 0, -math.pi / 2, 0, 0], atol=1e-12)
    assert result.pose[3] == pytest.approx(-1.5708, abs=1e-4)
    assert result.max_error == pytest.approx(0.0, abs=1e-12)
    assert result.mean_error == pytest.approx(0.0, abs=1e-12)


def test_reversed_sample_order_flips_the_axis() -> None:
    result = calibrate_rotary_axis([HEADSTOCK[0], [0.0, -0.1, 0.001, 0, 0, 0], HEADSTOCK[2]])
    frame = matrix_from_pose_vector(result.pose)
    np.testing.assert_allclose(frame[:3, 2], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(frame[:3, 0], [1, 0, 0], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.02, 1.0), st.integers(3, 12))
def test_exact_circle_recovers_the_frame(seed: int, radius: float, count: int) -> None:
    rng = np.random.default_rng(seed)
    frame = _random_frame(rng)
    # The first sample on +X, the second a positive turn away (less than half a turn).
    angles = np.concatenate([[0.0, rng.uniform(0.3, 2.5)], rng.uniform(0.0, 2 * np.pi, count - 2)])
    result = calibrate_rotary_axis(_circle_samples(frame, radius, angles))
    np.testing.assert_allclose(matrix_from_pose_vector(result.pose), frame, atol=1e-9)
    assert result.radius == pytest.approx(radius, rel=1e-9)
    assert result.max_error < 1e-10 and result.mean_error <= result.max_error


def test_noisy_circle_recovers_pose_and_radius() -> None:
    rng = np.random.default_rng(7)
    sigma = 1e-4
    for _ in range(20):
        frame = _random_frame(rng)
        angles = np.concatenate([[0.0, 0.5], rng.uniform(0.0, 2 * np.pi, 30)])
        samples = _circle_samples(frame, 0.25, angles)
        samples[:, :3] += rng.normal(0.0, sigma, (len(angles), 3))
        result = calibrate_rotary_axis(samples)
        fitted = matrix_from_pose_vector(result.pose)
        assert np.linalg.norm(fitted[:3, 3] - frame[:3, 3]) < 6 * sigma
        assert abs(result.radius - 0.25) < 6 * sigma
        assert np.degrees(np.arccos(min(1.0, fitted[:3, 2] @ frame[:3, 2]))) < 0.1
        # +X points at the (noisy) first sample, so compare loosely.
        assert fitted[:3, 0] @ frame[:3, 0] > math.cos(math.radians(0.5))
        # Errors are distances of noisy samples to the circle: of the order of the noise.
        assert sigma * 0.3 < result.mean_error < 3 * sigma
        assert result.mean_error <= result.max_error < 6 * sigma


def test_tailstock_sets_the_axis_through_both_centres() -> None:
    rng = np.random.default_rng(11)
    frame = _random_frame(rng)
    angles = np.array([0.0, 1.0, 2.5, 4.0])
    head = _circle_samples(frame, 0.1, angles)
    tail = _circle_samples(frame, 0.3, angles + 0.2, z=0.8)
    # A slight tilt of the headstock samples moves the plane normal but not the centres much.
    result = calibrate_rotary_axis(head, tail)
    np.testing.assert_allclose(matrix_from_pose_vector(result.pose), frame, atol=1e-9)
    tilted = head.copy()
    tilted[:, :3] += 1e-3 * np.outer(np.cos(angles), frame[:3, 2])
    with_tail = matrix_from_pose_vector(calibrate_rotary_axis(tilted, tail).pose)
    alone = matrix_from_pose_vector(calibrate_rotary_axis(tilted).pose)
    assert with_tail[:3, 2] @ frame[:3, 2] > alone[:3, 2] @ frame[:3, 2]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 8))
def test_exact_line_recovers_the_frame(seed: int, count: int) -> None:
    rng = np.random.default_rng(seed)
    frame = _random_frame(rng)
    origin = frame[:3, 3]
    along = origin + np.outer(np.sort(rng.uniform(0.05, 1.0, count)), frame[:3, 2])
    towards_x = origin + 0.2 * frame[:3, 0] + rng.uniform(-0.5, 0.5) * frame[:3, 2]
    result = calibrate_linear_axis(origin, along, towards_x)
    np.testing.assert_allclose(matrix_from_pose_vector(result.pose), frame, atol=1e-9)
    assert result.max_error < 1e-10
    mounted = matrix_from_pose_vector(calibrate_linear_axis(origin, along, towards_x, True).pose)
    np.testing.assert_allclose(mounted[:3, 2], -frame[:3, 2], atol=1e-9)
    np.testing.assert_allclose(mounted[:3, 0], frame[:3, 0], atol=1e-9)


def test_noisy_line_recovers_the_axis() -> None:
    rng = np.random.default_rng(5)
    sigma = 1e-4
    for _ in range(20):
        frame = _random_frame(rng)
        origin = frame[:3, 3] + rng.normal(0, sigma, 3)
        along = frame[:3, 3] + np.outer(np.linspace(0.1, 1.0, 10), frame[:3, 2])
        along += rng.normal(0, sigma, along.shape)
        result = calibrate_linear_axis(origin, along, frame[:3, 3] + 0.3 * frame[:3, 0])
        fitted = matrix_from_pose_vector(result.pose)
        assert np.degrees(np.arccos(min(1.0, fitted[:3, 2] @ frame[:3, 2]))) < 0.05
        assert np.linalg.norm(fitted[:3, 3] - frame[:3, 3]) < 6 * sigma
        assert sigma * 0.3 < result.mean_error <= result.max_error < 6 * sigma
        # The frame origin lies on the fitted line, at the origin sample's foot.
        assert abs((origin - fitted[:3, 3]) @ fitted[:3, 0]) < 6 * sigma


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: calibrate_rotary_axis(HEADSTOCK[:2]), "size of headstock must be at least 3"),
        (lambda: calibrate_rotary_axis(HEADSTOCK, HEADSTOCK[:2]), "size of tailstock"),
        (lambda: calibrate_rotary_axis([[0, 0, 0], [1, 0, 0], [2, 0, 0]]), "collinear"),
        (lambda: calibrate_rotary_axis(HEADSTOCK, HEADSTOCK), "centres coincide"),
        (
            lambda: calibrate_rotary_axis([HEADSTOCK[0], HEADSTOCK[2], HEADSTOCK[1]]),
            "opposite",
        ),
        (lambda: calibrate_linear_axis([0, 0, 0], [], [1, 0, 0]), "size of z_points must be"),
        (lambda: calibrate_linear_axis([0, 0, 0], [[0, 0, 0]], [1, 0, 0]), "coincide"),
        (lambda: calibrate_linear_axis([0, 0, 0], [[0, 0, 1]], [0, 0, 2]), "x_dir lies on"),
        (lambda: calibrate_rotary_axis([[0, 0, math.nan]] * 3), "finite"),
    ],
)
def test_calibration_refuses_degenerate_samples(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()
