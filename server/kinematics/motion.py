"""Joint-space motion profiles for external axes (MotionPlus ``axis_group_movej``, ``speedj``).

Positions are in rad (rotary) or m (linear), velocities per second and
accelerations per second squared; time ``t`` is in seconds from the start of
the move. Every profile has a piecewise-linear velocity, so its position is
piecewise quadratic. ``position``, ``velocity`` and ``acceleration`` take
any array of times and return ``t.shape + (n_axes,)``, without Python loops
over samples. Times before 0 read as 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class _VelocityRamps:
    """Velocity linear between ``knots`` (strictly increasing, first 0), constant after.

    ``knot_position`` and ``knot_velocity`` are ``(k, n)``; ``slope`` is each
    segment's acceleration ``(k, n)``, the last row zero.
    """

    knots: Array
    knot_position: Array
    knot_velocity: Array
    slope: Array

    def _segment(self, t: npt.ArrayLike) -> tuple[npt.NDArray[np.intp], Array]:
        tt = np.maximum(np.asarray(t, dtype=np.float64), 0.0)
        seg = np.searchsorted(self.knots, tt, side="right") - 1
        return seg, (tt - self.knots[seg])[..., None]

    def position(self, t: npt.ArrayLike) -> Array:
        """Axis positions ``t.shape + (n,)`` (rad or m) at times ``t`` (s)."""
        seg, dt = self._segment(t)
        pos: Array = (
            self.knot_position[seg] + self.knot_velocity[seg] * dt + 0.5 * self.slope[seg] * dt * dt
        )
        return pos

    def velocity(self, t: npt.ArrayLike) -> Array:
        """Axis velocities ``t.shape + (n,)`` (rad/s or m/s) at times ``t`` (s)."""
        seg, dt = self._segment(t)
        vel: Array = self.knot_velocity[seg] + self.slope[seg] * dt
        return vel

    def acceleration(self, t: npt.ArrayLike) -> Array:
        """Axis accelerations ``t.shape + (n,)`` (rad/s^2 or m/s^2); right-continuous at knots."""
        seg, _ = self._segment(t)
        acc: Array = self.slope[seg]
        return acc


def _ramps(start: Array, knots: list[float], velocities: list[Array]) -> _VelocityRamps:
    """Integrate a piecewise-linear velocity, dropping zero-length segments."""
    times, vels = [knots[0]], [velocities[0]]
    for time, vel in zip(knots[1:], velocities[1:], strict=True):
        if time > times[-1]:
            times.append(time)
            vels.append(vel)
        else:
            # A segment too short to resolve in time: its end velocity wins.
            vels[-1] = vel
    t = np.asarray(times, dtype=np.float64)
    v = np.stack(vels)
    dt = np.diff(t)[:, None]
    slope = np.zeros_like(v)
    slope[:-1] = np.diff(v, axis=0) / dt
    steps = 0.5 * (v[:-1] + v[1:]) * dt
    pos = np.concatenate([start[None, :], start + np.cumsum(steps, axis=0)])
    return _VelocityRamps(t, pos, v, slope)


def _axis_vector(value: npt.ArrayLike, n: int, what: str, positive: bool) -> Array:
    """``value`` broadcast to ``(n,)``; finite, and > 0 if ``positive``."""
    arr = np.asarray(value, dtype=np.float64)
    try:
        out = np.broadcast_to(arr, (n,)).astype(np.float64)
    except ValueError:
        raise ValueError(f"{what} must be a scalar or have one entry per axis ({n})") from None
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{what} must be finite")
    if positive and not np.all(out > 0.0):
        raise ValueError(f"{what} must be positive")
    return out


def _positions(value: npt.ArrayLike, what: str) -> Array:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{what} must be a 1-D array of axis values, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite")
    return arr


@dataclass(frozen=True, eq=False)
class TrapezoidMove(_VelocityRamps):
    """Synchronized trapezoidal move from ``start`` to ``end`` (MotionPlus ``axis_group_movej``).

    All axes accelerate for ``accel_time``, cruise for ``cruise_time`` and
    decelerate for ``accel_time``, together, so they arrive at the same time
    ``duration``. ``cruise_time`` is 0 for a triangular profile. Axis ``i``
    follows ``start_i + (end_i - start_i) * s(t)`` with one shared progress
    ``s`` from 0 to 1, so ``peak_velocity`` and ``peak_acceleration`` are
    proportional to each axis's distance.
    """

    start: Array
    end: Array
    accel_time: float
    cruise_time: float
    peak_velocity: Array
    peak_acceleration: Array

    @property
    def duration(self) -> float:
        """Time (s) at which every axis is at ``end`` and at rest."""
        return 2.0 * self.accel_time + self.cruise_time

    @property
    def is_triangular(self) -> bool:
        """True when the distance is too short to reach cruise speed."""
        return self.cruise_time == 0.0


def plan_movej(
    q0: npt.ArrayLike, q1: npt.ArrayLike, v_max: npt.ArrayLike, a_max: npt.ArrayLike
) -> TrapezoidMove:
    """Plan the fastest synchronized trapezoidal move from rest at ``q0`` to rest at ``q1``.

    ``q0``, ``q1``: ``(n,)`` positions (rad or m). ``v_max``, ``a_max``: per-axis
    (or scalar) velocity and acceleration limits of this move, positive.

    In progress units (``s`` from 0 to 1) axis ``i`` allows velocity
    ``v_max_i / |d_i|`` and acceleration ``a_max_i / |d_i|``; the smallest of
    each (the most constraining axis) is used by all, so no axis exceeds its
    limits and all finish together. With ``V`` and ``A`` those smallest
    values, the duration is ``1 / V + V / A``, or ``2 / sqrt(A)`` when
    ``V^2 >= A`` (triangular: cruise speed is never reached). Axes with zero
    distance stand still; if every distance is zero the move has zero duration.
    """
    start = _positions(q0, "q0")
    end = _positions(q1, "q1")
    if start.shape != end.shape:
        raise ValueError(f"q0 and q1 must have the same size, got {start.size} and {end.size}")
    n = start.size
    v_lim = _axis_vector(v_max, n, "v_max", positive=True)
    a_lim = _axis_vector(a_max, n, "a_max", positive=True)
    dist = end - start
    span = np.abs(dist)
    moving = span > 0.0
    if not np.any(moving):
        zero = np.zeros(n)
        return TrapezoidMove(
            np.zeros(1),
            end[None, :].copy(),
            zero[None, :],
            zero[None, :],
            start,
            end,
            0.0,
            0.0,
            zero,
            zero,
        )
    # Seconds (and seconds squared) the slowest axis needs per unit of progress;
    # written as span / limit so tiny distances cannot overflow.
    tiny = float(np.finfo(np.float64).smallest_subnormal)
    tau_v = max(float(np.max(span / v_lim)), tiny)
    tau_a = max(float(np.max(span / a_lim)), tiny)
    if tau_a >= tau_v * tau_v:
        # Half the distance is covered accelerating before cruise speed is reached.
        accel_time = math.sqrt(tau_a)
        cruise_time = 0.0
        rate = 1.0 / accel_time
    else:
        accel_time = tau_a / tau_v
        cruise_time = tau_v - accel_time
        rate = 1.0 / tau_v
    peak_v = dist * rate
    zero = np.zeros(n)
    ramps = _ramps(
        start,
        [0.0, accel_time, accel_time + cruise_time, 2.0 * accel_time + cruise_time],
        [zero, peak_v, peak_v, zero],
    )
    # Land exactly on the target rather than on the rounded sum of the phases.
    knot_position = ramps.knot_position.copy()
    knot_position[-1] = end
    return TrapezoidMove(
        ramps.knots,
        knot_position,
        ramps.knot_velocity,
        ramps.slope,
        start,
        end,
        accel_time,
        cruise_time,
        np.abs(peak_v),
        span / tau_a,
    )


@dataclass(frozen=True, eq=False)
class SpeedMove(_VelocityRamps):
    """Velocity ramp and hold (MotionPlus ``axis_group_speedj``).

    Velocities go linearly from ``initial_velocity`` to ``target_velocity`` in
    ``ramp_time``; all axes reach it together, the axis needing the longest
    ramp at its full acceleration. The velocity is then held until
    ``hold_until`` (``inf``: forever), after which the axes ramp to rest with
    the same accelerations, together again. ``duration`` is the time they are
    at rest (``inf`` while they hold a nonzero velocity forever).
    """

    start: Array
    initial_velocity: Array
    target_velocity: Array
    ramp_time: float
    hold_until: float
    duration: float


def _ramp_time(dv: Array, accel: Array) -> float:
    return float(np.max(np.abs(dv) / accel, initial=0.0))


def plan_speedj(
    q0: npt.ArrayLike,
    qd: npt.ArrayLike,
    a: npt.ArrayLike,
    t: float = -1.0,
    qd0: npt.ArrayLike | None = None,
) -> SpeedMove:
    """Plan a speedj from ``q0`` (rad or m) and velocity ``qd0`` (default rest) to velocity ``qd``.

    ``a``: per-axis (or scalar) acceleration, positive (rad/s^2 or m/s^2).
    ``t``: seconds after which the axes stop (ramping to rest with ``a``); if
    ``t < 0`` the velocity is held forever. If ``t`` is shorter than the ramp,
    the ramp is cut off there. Commanding ``qd = 0`` with ``t < 0`` is a stop.
    """
    start = _positions(q0, "q0")
    n = start.size
    target = _axis_vector(qd, n, "qd", positive=False)
    initial = np.zeros(n) if qd0 is None else _axis_vector(qd0, n, "qd0", positive=False)
    accel = _axis_vector(a, n, "a", positive=True)
    if math.isnan(t):
        raise ValueError("t must be a number of seconds (t < 0: hold forever)")
    ramp_time = _ramp_time(target - initial, accel)
    if t < 0.0 or math.isinf(t):
        hold_until = math.inf
        knots, vels = [0.0, ramp_time], [initial, target]
        duration = ramp_time if not np.any(target) else math.inf
    else:
        hold_until = float(t)
        if hold_until < ramp_time:
            reached = initial + (target - initial) * (hold_until / ramp_time)
            knots, vels = [0.0, hold_until], [initial, reached]
        else:
            reached = target
            knots, vels = [0.0, ramp_time, hold_until], [initial, target, target]
        duration = hold_until + _ramp_time(reached, accel)
        knots.append(duration)
        vels.append(np.zeros(n))
    ramps = _ramps(start, knots, vels)
    return SpeedMove(
        ramps.knots,
        ramps.knot_position,
        ramps.knot_velocity,
        ramps.slope,
        start,
        initial,
        target,
        ramp_time,
        hold_until,
        duration,
    )
