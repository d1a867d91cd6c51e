"""Synchronized trapezoidal movej and speedj profiles (seed 003): limits, timing, continuity."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from server.kinematics import plan_movej, plan_speedj

position = st.floats(-5.0, 5.0, allow_nan=False)
limit = st.floats(0.05, 5.0, allow_nan=False)


@st.composite
def moves(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(1, 6))
    q0 = np.array(draw(st.lists(position, min_size=n, max_size=n)))
    q1 = np.array(draw(st.lists(position, min_size=n, max_size=n)))
    # Some axes stay put, which the planner must allow.
    still = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    # Distances are zero or at least a micro-unit; sub-micro moves have their own test.
    q1 = np.where(still | (np.abs(q1 - q0) < 1e-6), q0, q1)
    v = np.array(draw(st.lists(limit, min_size=n, max_size=n)))
    a = np.array(draw(st.lists(limit, min_size=n, max_size=n)))
    return q0, q1, v, a


def _single_axis_time(distance: float, v: float, a: float) -> float:
    """Textbook minimum time of a rest-to-rest trapezoid on one axis."""
    if distance == 0.0:
        return 0.0
    if distance >= v * v / a:
        return distance / v + v / a
    return 2.0 * math.sqrt(distance / a)


@settings(max_examples=150, deadline=None)
@given(moves())
def test_movej_starts_and_ends_at_rest_at_the_given_positions(move) -> None:
    q0, q1, v, a = move
    plan = plan_movej(q0, q1, v, a)
    np.testing.assert_array_equal(plan.position(0.0), q0)
    np.testing.assert_array_equal(plan.position(plan.duration), q1)
    np.testing.assert_array_equal(plan.position(plan.duration + 10.0), q1)
    np.testing.assert_array_equal(plan.position(-1.0), q0)
    ends = plan.velocity(np.array([0.0, plan.duration]))
    np.testing.assert_array_equal(ends, np.zeros((2, q0.size)))


@settings(max_examples=150, deadline=None)
@given(moves())
def test_movej_is_as_slow_as_its_most_constraining_axis(move) -> None:
    q0, q1, v, a = move
    plan = plan_movej(q0, q1, v, a)
    # Every axis needs at least its own minimum time and sharing phases costs no more
    # than giving every axis the weakest normalised limits.
    own = [_single_axis_time(abs(d), vi, ai) for d, vi, ai in zip(q1 - q0, v, a, strict=True)]
    assert plan.duration >= max(own) - 1e-9
    moving = q1 != q0
    if moving.any():
        span = np.abs(q1 - q0)[moving]
        v_progress = float(np.min(v[moving] / span))
        shared = _single_axis_time(1.0, v_progress, float(np.min(a[moving] / span)))
        assert plan.duration == pytest.approx(shared, rel=1e-12)
    else:
        assert plan.duration == 0.0


@settings(max_examples=100, deadline=None)
@given(moves())
def test_movej_axes_move_in_step_and_finish_together(move) -> None:
    q0, q1, v, a = move
    plan = plan_movej(q0, q1, v, a)
    t = np.linspace(0.0, plan.duration, 401)
    pos = plan.position(t)
    assert pos.shape == (401, q0.size)
    moving = q1 != q0
    still = np.broadcast_to(q0, pos.shape)
    np.testing.assert_array_equal(pos[:, ~moving], still[:, ~moving])
    if not moving.any():
        return
    progress = (pos[:, moving] - q0[moving]) / (q1 - q0)[moving]
    # One shared progress from 0 to 1: all axes accelerate, cruise and stop together.
    np.testing.assert_allclose(progress, progress[:, :1] * np.ones(progress.shape[1]), atol=1e-9)
    assert np.all(np.diff(progress[:, 0]) >= -1e-12)
    assert np.all(progress[:-1, 0] < 1.0 - 1e-12)


@settings(max_examples=100, deadline=None)
@given(moves())
def test_movej_respects_velocity_and_acceleration_limits(move) -> None:
    q0, q1, v, a = move
    plan = plan_movej(q0, q1, v, a)
    if plan.duration == 0.0:
        return
    t = np.linspace(0.0, plan.duration, 2001)
    dt = t[1] - t[0]
    pos = plan.position(t)
    vel = plan.velocity(t)
    assert np.all(np.abs(vel) <= v * (1 + 1e-9))
    # Finite differences, independent of the profile's own velocity.
    fd_vel = np.diff(pos, axis=0) / dt
    assert np.all(np.abs(fd_vel) <= v * (1 + 1e-9) + 1e-12)
    fd_acc = np.diff(pos, 2, axis=0) / dt**2
    assert np.all(np.abs(fd_acc) <= a * (1 + 1e-6) + 1e-9)
    # Continuity: no step larger than the speed limit allows.
    assert np.all(np.abs(np.diff(pos, axis=0)) <= v * dt * (1 + 1e-9) + 1e-12)
    np.testing.assert_allclose(np.gradient(pos, dt, axis=0)[1:-1], vel[1:-1], atol=np.max(a) * dt)
    # Fastest: some axis reaches its velocity or its acceleration limit.
    reaches_v = np.any(np.isclose(plan.peak_velocity, v, rtol=1e-9))
    reaches_a = np.any(np.isclose(plan.peak_acceleration, a, rtol=1e-9))
    assert reaches_a and (reaches_v or plan.is_triangular)


def test_long_move_cruises_at_the_velocity_limit() -> None:
    plan = plan_movej([0.0], [3.0], 1.0, 2.0)
    assert not plan.is_triangular
    assert plan.accel_time == pytest.approx(0.5)
    assert plan.duration == pytest.approx(3.0 / 1.0 + 1.0 / 2.0)
    t = np.array([0.25, 1.0, 2.0, 3.25])
    np.testing.assert_allclose(plan.velocity(t), [[0.5], [1], [1], [0.5]])
    np.testing.assert_allclose(plan.acceleration(np.array([0.25, 1.0, 3.25])), [[2], [0], [-2]])
    np.testing.assert_allclose(plan.position(0.5), [0.25])


def test_short_move_is_triangular() -> None:
    plan = plan_movej([1.0], [1.5], 1.0, 1.0)
    assert plan.is_triangular
    assert plan.duration == pytest.approx(2.0 * math.sqrt(0.5))
    peak = plan.velocity(plan.duration / 2)
    assert peak[0] == pytest.approx(math.sqrt(0.5)) and peak[0] < 1.0
    np.testing.assert_allclose(plan.position(plan.duration / 2), [1.25])


def test_weak_axis_slows_the_strong_one() -> None:
    plan = plan_movej([0.0, 0.0], [1.0, -4.0], [10.0, 1.0], [10.0, 1.0])
    # Axis 1 alone needs 4 + 1 s; axis 0 is stretched to the same time and shape.
    assert plan.duration == pytest.approx(5.0)
    np.testing.assert_allclose(plan.peak_velocity, [0.25, 1.0])
    mid = plan.position(2.5)
    np.testing.assert_allclose(mid, [0.5, -2.0])


@pytest.mark.parametrize("distance", [5e-324, 1e-310, 1e-300, 1e-12])
def test_vanishing_distances_plan_without_overflow(distance: float) -> None:
    plan = plan_movej([0.0, 1.0], [distance, 1.0], 1.0, 1.0)
    assert 0.0 < plan.duration < 1e-5
    np.testing.assert_array_equal(plan.position(plan.duration), [distance, 1.0])
    assert np.all(np.isfinite(plan.velocity(np.linspace(0.0, plan.duration, 5))))


def test_zero_move_has_zero_duration() -> None:
    plan = plan_movej([0.3, -0.2], [0.3, -0.2], 1.0, 1.0)
    assert plan.duration == 0.0
    np.testing.assert_array_equal(plan.position(np.array([0.0, 1.0])), [[0.3, -0.2]] * 2)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([0.0], [1.0], 0.0, 1.0), "v_max must be positive"),
        (([0.0], [1.0], 1.0, -1.0), "a_max must be positive"),
        (([0.0], [1.0, 2.0], 1.0, 1.0), "same size"),
        (([0.0, 0.0], [1.0, 2.0], [1.0, 1.0, 1.0], 1.0), "one entry per axis"),
        (([0.0], [math.nan], 1.0, 1.0), "finite"),
    ],
)
def test_movej_refuses_bad_arguments(args: tuple[object, ...], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        plan_movej(*args)  # type: ignore[arg-type]


def test_speedj_ramps_synchronously_then_holds_forever() -> None:
    plan = plan_speedj([0.0, 1.0], [1.0, -0.5], 2.0)
    assert plan.ramp_time == pytest.approx(0.5)
    assert math.isinf(plan.duration) and math.isinf(plan.hold_until)
    t = np.array([0.0, 0.25, 0.5, 10.0])
    np.testing.assert_allclose(plan.velocity(t), [[0, 0], [0.5, -0.25], [1, -0.5], [1, -0.5]])
    # Ramp: v^2 / (2 a_axis); then constant velocity.
    ramp_dist = np.array([1.0 * 0.5 / 2, -0.5 * 0.5 / 2])
    np.testing.assert_allclose(plan.position(0.5), [0.0, 1.0] + ramp_dist)
    cruise = 9.5 * np.array([1.0, -0.5])
    np.testing.assert_allclose(plan.position(10.0), [0.0, 1.0] + ramp_dist + cruise)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.floats(-3, 3), min_size=1, max_size=6),
    st.floats(0.1, 5.0),
    st.floats(-1.0, 4.0),
    st.floats(-2, 2),
)
def test_speedj_velocity_is_continuous_and_acceleration_bounded(qd, a, t_hold, v0) -> None:
    target = np.array(qd)
    initial = np.full(target.size, v0)
    plan = plan_speedj(np.zeros(target.size), target, a, t=t_hold, qd0=initial)
    end = 12.0 if math.isinf(plan.duration) else plan.duration + 1.0
    t = np.linspace(0.0, end, 3001)
    dt = t[1] - t[0]
    vel = plan.velocity(t)
    pos = plan.position(t)
    np.testing.assert_allclose(vel[0], initial)
    assert np.all(np.abs(np.diff(vel, axis=0)) <= a * dt * (1 + 1e-9) + 1e-12)
    fd_acc = np.diff(pos, 2, axis=0) / dt**2
    assert np.all(np.abs(fd_acc) <= a * (1 + 1e-6) + 1e-9)
    if t_hold < 0:
        if plan.ramp_time < end:
            np.testing.assert_allclose(vel[-1], target, atol=1e-12)
    else:
        np.testing.assert_array_equal(vel[-1], np.zeros(target.size))
        assert plan.duration >= t_hold


def test_speedj_with_time_stops_after_it() -> None:
    plan = plan_speedj([0.0], [1.0], 1.0, t=3.0)
    # 1 s ramp up, hold to 3 s, 1 s ramp down.
    assert plan.duration == pytest.approx(4.0)
    t = np.array([1.0, 3.0, 4.0, 9.0])
    np.testing.assert_allclose(plan.position(t)[:, 0], [0.5, 2.5, 3.0, 3.0])


def test_speedj_to_zero_is_a_stop() -> None:
    plan = plan_speedj([2.0], [0.0], 1.0, qd0=[1.0])
    assert plan.duration == pytest.approx(1.0)
    np.testing.assert_allclose(plan.position(5.0), [2.5])


def test_speedj_refuses_non_positive_acceleration() -> None:
    with pytest.raises(ValueError, match="a must be positive"):
        plan_speedj([0.0], [1.0], 0.0)
