"""REST routes of the Transformation service: ``/api/robots/{name}/fk`` and ``/ik`` (SI units)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Request
from pydantic import BaseModel, ConfigDict, Field

from ..cell import Robot, transformation
from ..runtime import MoveError
from .routes import runtime_of

router = APIRouter(prefix="/api/robots")

Finite = Annotated[float, Field(allow_inf_nan=False)]
JointRow = Annotated[list[Finite], Field(min_length=1, max_length=16)]
MAX_ROWS = 10_000
"""Rows per /fk call: bounds the work one request can ask of the server."""
MAX_LINK_ROWS = 64
"""Rows per /fk call that also asks for every link's pose (a preview draws a few)."""


class ForwardRequest(BaseModel):
    """Joint rows, each in hello order (rad or m)."""

    model_config = ConfigDict(extra="forbid")
    joints: list[JointRow] = Field(min_length=1, max_length=MAX_ROWS)
    links: bool = False
    """Also return every link's pose per row (for drawing a configuration)."""


class InverseRequest(BaseModel):
    """A TCP pose [x, y, z, qx, qy, qz, qw] (m), a reference posture, and whether to list all."""

    model_config = ConfigDict(extra="forbid")
    tcp: Annotated[list[Finite], Field(min_length=7, max_length=7)]
    joints_ref: JointRow | None = None
    all: bool = False


class MoveRequest(BaseModel):
    """Target joints in hello order (rad or m)."""

    model_config = ConfigDict(extra="forbid")
    joints: JointRow


def _robot(request: Request, name: str) -> Robot:
    robot = runtime_of(request).robot(name)
    if robot is None:
        raise HTTPException(status_code=404, detail=f"no robot named {name!r} in the cell")
    return robot


def _run(call: Any, *args: Any) -> dict[str, Any]:
    try:
        result: dict[str, Any] = vars(call(*args))
    except transformation.TransformInputError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from exc
    return result


# Plain ``def`` routes run in FastAPI's threadpool: the numpy work stays off the
# event loop that streams to viewers.
@router.post("/{name}/fk")
def forward(name: str, body: ForwardRequest, request: Request) -> dict[str, Any]:
    """TCP pose and roll-pitch-yaw for each joint row."""
    if body.links and len(body.joints) > MAX_LINK_ROWS:
        raise HTTPException(422, f"with links, at most {MAX_LINK_ROWS} rows per call")
    return _run(transformation.forward, _robot(request, name), body.joints, body.links)


@router.post("/{name}/ik")
def inverse(name: str, body: InverseRequest, request: Request) -> dict[str, Any]:
    """Joint solutions for a TCP pose; ``best`` is nearest ``joints_ref``."""
    return _run(transformation.inverse, _robot(request, name), body.tcp, body.joints_ref, body.all)


@router.post("/{name}/move", status_code=202)
async def move(name: str, body: MoveRequest, request: Request) -> dict[str, Any]:
    """Command a synchronised move to ``joints``; 403 where moves are not allowed."""
    robot = _robot(request, name)
    try:
        await runtime_of(request).move(robot, body.joints)
    except MoveError as exc:
        raise HTTPException(status_code=exc.status, detail=str(exc)) from exc
    return {"ok": True, "robot": name, "joints": body.joints}
