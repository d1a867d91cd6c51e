"""Calibration of external axes from sampled robot poses (MotionPlus Axis Group API).

Inputs are UR pose vectors ``[x, y, z, rx, ry, rz]`` (or bare positions
``[x, y, z]``) in the robot's base frame, in metres; only their positions are
used. Results are frames in the same base frame, as UR pose vectors, with
distances (radius, errors) in metres. Fits are least squares: a plane by SVD
then a geometric circle in it, or a line by SVD.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._pose_vector import pose_vector_from_matrix

Array = npt.NDArray[np.float64]

# Relative size below which a spread of points counts as degenerate.
_DEGENERATE = 1e-9
_CIRCLE_ITERATIONS = 20


@dataclass(frozen=True, eq=False)
class RotaryCalibration:
    """Result of :func:`calibrate_rotary_axis` (as MotionPlus returns it).

    ``pose``: frame of the rotary axis in the base frame (UR pose vector),
    origin at the headstock circle's centre, +Z the axis of rotation, +X towards
    the first headstock sample. ``radius``: of the headstock circle (m).
    ``max_error``, ``mean_error``: distances (m) of the headstock samples to
    the fitted circle.
    """

    pose: Array
    radius: float
    max_error: float
    mean_error: float


@dataclass(frozen=True, eq=False)
class LinearCalibration:
    """Result of :func:`calibrate_linear_axis` (as MotionPlus returns it).

    ``pose``: frame of the linear axis in the base frame (UR pose vector),
    origin at the origin sample projected on the fitted line, +Z along the line
    towards the z points, +X towards ``x_dir``. ``max_error``, ``mean_error``:
    distances (m) of the origin and z points to the fitted line.
    """

    pose: Array
    max_error: float
    mean_error: float


def _positions(samples: npt.ArrayLike, what: str, at_least: int) -> Array:
    pts = np.array(samples, dtype=np.float64)
    if pts.size == 0:
        pts = pts.reshape(0, 3)
    if pts.ndim != 2 or pts.shape[1] not in (3, 6):
        raise ValueError(f"{what} must be an array of poses [x, y, z, rx, ry, rz], got {pts.shape}")
    if pts.shape[0] < at_least:
        raise ValueError(f"the size of {what} must be at least {at_least}, got {pts.shape[0]}")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{what} must be finite")
    return pts[:, :3]


def _unit(v: Array, what: str) -> Array:
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise ValueError(what)
    unit: Array = v / norm
    return unit


def _frame(origin: Array, x_axis: Array, z_axis: Array) -> Array:
    """UR pose vector of the frame at ``origin`` with unit axes ``x_axis`` normal to ``z_axis``."""
    matrix = np.eye(4)
    matrix[:3, 0] = x_axis
    matrix[:3, 1] = np.cross(z_axis, x_axis)
    matrix[:3, 2] = z_axis
    matrix[:3, 3] = origin
    return pose_vector_from_matrix(matrix)


def fit_circle(points: Array) -> tuple[Array, Array, float]:
    """Least-squares circle through ``(N, 3)`` points (m): ``(centre, unit normal, radius)``.

    The plane is the SVD best fit; in it an algebraic (Kasa) fit seeds a few
    Gauss-Newton steps on the geometric distances ``| |p - c| - r |``. The
    normal's sign is arbitrary. Raises ``ValueError`` for collinear points.
    """
    mean = points.mean(axis=0)
    centred = points - mean
    _, sing, vt = np.linalg.svd(centred)
    if sing[1] <= _DEGENERATE * max(float(sing[0]), 1e-300):
        raise ValueError("the samples are collinear, no circle fits them")
    basis = vt[:2]
    uv = centred @ basis.T
    design = np.column_stack([2.0 * uv, np.ones(len(uv))])
    sol = np.linalg.lstsq(design, np.sum(uv * uv, axis=1), rcond=None)[0]
    centre, radius = sol[:2], float(np.sqrt(sol[2] + sol[:2] @ sol[:2]))
    for _ in range(_CIRCLE_ITERATIONS):
        diff = uv - centre
        dist = np.linalg.norm(diff, axis=1)
        if np.any(dist == 0.0):
            break
        jac = np.column_stack([-diff / dist[:, None], -np.ones(len(uv))])
        step = np.linalg.lstsq(jac, -(dist - radius), rcond=None)[0]
        centre, radius = centre + step[:2], radius + float(step[2])
        if np.linalg.norm(step) <= 1e-15 * max(radius, 1.0):
            break
    return mean + centre @ basis, vt[2], radius


def calibrate_rotary_axis(
    headstock: npt.ArrayLike, tailstock: npt.ArrayLike | None = None
) -> RotaryCalibration:
    """Frame of a rotary axis from samples in a circle round its headstock (and tailstock).

    ``headstock``: more than 2 poses (base frame, m). The frame's origin is the
    fitted circle's centre and +X points to the first sample. +Z is the circle's
    normal, or with ``tailstock`` (more than 2 poses round the other end; empty
    means none) the line from the headstock centre to the tailstock centre;
    either way its sign makes the turn from the first headstock sample to the
    second positive by the right-hand rule. ``radius``: mean distance of the
    samples from the axis, the least-squares radius for that centre and axis.
    """
    head = _positions(headstock, "headstock", 3)
    centre, z_axis, _ = fit_circle(head)
    if tailstock is not None and np.size(tailstock) > 0:
        tail_centre, _, _ = fit_circle(_positions(tailstock, "tailstock", 3))
        z_axis = _unit(tail_centre - centre, "the headstock and tailstock centres coincide")
    turn = float(z_axis @ np.cross(head[0] - centre, head[1] - centre))
    if abs(turn) <= _DEGENERATE * float(np.sum((head[:2] - centre) ** 2)):
        raise ValueError("the first two headstock samples must not be opposite or coincide")
    if turn < 0.0:
        z_axis = -z_axis
    rel = head - centre
    height = rel @ z_axis
    radial = rel - height[:, None] * z_axis
    x_axis = _unit(radial[0], "the first headstock sample lies on the axis")
    spread = np.linalg.norm(radial, axis=1)
    radius = float(spread.mean())
    error = np.hypot(height, spread - radius)
    return RotaryCalibration(
        pose=_frame(centre, x_axis, z_axis),
        radius=radius,
        max_error=float(error.max()),
        mean_error=float(error.mean()),
    )


def calibrate_linear_axis(
    origin: npt.ArrayLike,
    z_points: npt.ArrayLike,
    x_dir: npt.ArrayLike,
    is_mounted: bool = False,
) -> LinearCalibration:
    """Frame of a linear axis from a sampled origin, points along it and a point towards +X.

    ``origin``, ``x_dir``: one pose each; ``z_points``: one or more poses along
    the axis (base frame, m). +Z is the SVD line through the origin and z
    points, pointing from the origin towards the z points. ``is_mounted``: the
    robot rides on the axis, so the samples of a fixed point move opposite to
    the carriage and +Z is reversed (an assumption: the API does not say).
    """
    start = _positions(np.reshape(np.asarray(origin, dtype=np.float64), (1, -1)), "origin", 1)[0]
    along = _positions(z_points, "z_points", 1)
    towards_x = _positions(np.reshape(np.asarray(x_dir, dtype=np.float64), (1, -1)), "x_dir", 1)[0]
    points = np.vstack([start, along])
    mean = points.mean(axis=0)
    _, sing, vt = np.linalg.svd(points - mean)
    if sing[0] == 0.0:
        raise ValueError("the origin and z_points coincide, no line fits them")
    z_axis = vt[0]
    if float((along.mean(axis=0) - start) @ z_axis) < 0.0:
        z_axis = -z_axis
    if is_mounted:
        z_axis = -z_axis
    frame_origin = mean + float((start - mean) @ z_axis) * z_axis
    to_x = towards_x - frame_origin
    x_axis = _unit(to_x - float(to_x @ z_axis) * z_axis, "x_dir lies on the fitted z axis")
    rel = points - mean
    error = np.linalg.norm(rel - np.outer(rel @ z_axis, z_axis), axis=1)
    return LinearCalibration(
        pose=_frame(frame_origin, x_axis, z_axis),
        max_error=float(error.max()),
        mean_error=float(error.mean()),
    )
