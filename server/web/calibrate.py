"""Measuring for commissioning: a robot's TCP now, and MotionPlus's axis calibrations.

``POST /api/calibrate`` is ``calibrate_rotary_axis`` / ``calibrate_linear_axis``
of Universal Robots' MotionPlus Axis Group API over HTTP: poses as MotionPlus
writes them (metres and a rotation vector, in the measuring robot's base
frame), the fitted frame back in the same form. It computes and changes
nothing, so it needs no ``--allow-edits``; as every POST, it is JSON from this
server's own page or a script (``guards``).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Request
from pydantic import BaseModel, ConfigDict, Field, RootModel

from ..commissioning import CommissioningError, tcp_now
from ..kinematics import calibrate_linear_axis, calibrate_rotary_axis
from .routes import runtime_of
from .transformation import Finite, parse_body

router = APIRouter(prefix="/api")

PoseVector = Annotated[list[Finite], Field(min_length=3, max_length=6)]
"""``[x, y, z, rx, ry, rz]`` (m, rotation vector in rad); only the position is used."""
MAX_SAMPLES = 1000


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class Rotary(_Body):
    """``calibrate_rotary_axis(headstock, tailstock=[])``."""

    kind: Literal["rotary"]
    headstock: Annotated[list[PoseVector], Field(max_length=MAX_SAMPLES)]
    tailstock: Annotated[list[PoseVector], Field(max_length=MAX_SAMPLES)] = []


class Linear(_Body):
    """``calibrate_linear_axis(origin, z_points, x_dir, is_mounted=False)``."""

    kind: Literal["linear"]
    origin: PoseVector
    z_points: Annotated[list[PoseVector], Field(max_length=MAX_SAMPLES)]
    x_dir: PoseVector
    is_mounted: bool = False


class Calibration(RootModel[Annotated[Rotary | Linear, Field(discriminator="kind")]]):
    """Either kind, told apart by ``kind``."""


@router.post("/calibrate")
async def calibrate(request: Request) -> dict[str, Any]:
    """The frame of a rotary or linear axis from sampled poses (``Rotary``, ``Linear``)."""
    body = parse_body(Calibration, await request.body()).root
    try:
        if isinstance(body, Rotary):
            rotary = calibrate_rotary_axis(body.headstock, body.tailstock or None)
            return {
                "pose": rotary.pose.tolist(),
                "radius": rotary.radius,
                "max_error": rotary.max_error,
                "mean_error": rotary.mean_error,
            }
        linear = calibrate_linear_axis(body.origin, body.z_points, body.x_dir, body.is_mounted)
    except ValueError as exc:  # too few samples, degenerate ones: MotionPlus's reasons
        raise HTTPException(422, str(exc)) from None
    return {
        "pose": linear.pose.tolist(),
        "max_error": linear.max_error,
        "mean_error": linear.mean_error,
    }


@router.get("/robots/{name}/tcp")
async def tcp(name: str, request: Request) -> dict[str, Any]:
    """A sample: ``name``'s TCP now, in its base frame (``tcp``, as MotionPlus samples it) and in
    the cell (``world``), UR pose vectors; and its joints now (SI)."""
    runtime = runtime_of(request)
    robot = runtime.robot(name)
    if robot is None:
        raise HTTPException(404, f"no robot named {name!r} in the cell")
    values = runtime.newest_values().get(name)
    if values is None:
        raise HTTPException(409, f"{name} has no joint values now: is its source connected?")
    q = robot.to_si(values)
    try:
        in_base, in_world = tcp_now(robot, q)
    except CommissioningError as exc:
        raise HTTPException(exc.status, str(exc)) from None
    return {"robot": name, "tcp": in_base, "world": in_world, "joints": q.tolist()}
