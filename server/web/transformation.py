"""REST routes of the Transformation service: ``/fk``, ``/ik`` and ``/move`` of a robot (SI units).

Bodies are read as bytes (at most 1 MiB, see ``guards``) and parsed and
validated in the threadpool with the kinematics: a large request costs its
sender time, never the event loop that streams to viewers. At most
``MAX_RUNNING`` of them run at once and ``MAX_WAITING`` wait for their turn;
past that they are answered 503 with ``Retry-After``, since each running one
competes with the stream for the interpreter. Models are strict: ``"0.1"``
or ``true`` where a number belongs is a 422, not a guess.
"""

from __future__ import annotations

import time
from typing import Annotated, Any, TypeVar

import orjson
from fastapi import APIRouter, HTTPException, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..cell import Robot, transformation
from ..runtime import MoveError
from ..sizes import MAX_JOINTS
from .routes import runtime_of
from .slots import Slots

router = APIRouter(prefix="/api/robots")

Finite = Annotated[float, Field(allow_inf_nan=False)]
JointRow = Annotated[list[Finite], Field(min_length=1, max_length=MAX_JOINTS)]
MAX_ROWS = 10_000
"""Rows per /fk call: bounds the work one request can ask of the server."""
MAX_LINK_ROWS = 64
"""Rows per /fk call that also asks for every link's pose (a preview draws a few)."""
CHUNK_ROWS = 500
"""Rows computed in one go; the thread yields to the event loop between chunks."""
MAX_RUNNING = 1
"""Transformation requests computed at once, per process: one core's worth of them, as
each holds the interpreter in turns with the event loop that streams to viewers."""
MAX_WAITING = 8
"""Requests that may wait for one of those; past that they are refused at once."""
WAIT_S = 2.0
RETRY_AFTER_S = 1


running = Slots(
    f"{MAX_RUNNING} transformation requests are being computed and {MAX_WAITING} wait",
    MAX_RUNNING,
    MAX_WAITING,
    WAIT_S,
    RETRY_AFTER_S,
)
"""This process's transformation requests."""


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class ForwardRequest(_Body):
    """Joint rows, each in hello order (rad or m)."""

    joints: list[JointRow] = Field(min_length=1, max_length=MAX_ROWS)
    links: bool = False
    """Also return every link's pose per row (for drawing a configuration)."""


class InverseRequest(_Body):
    """A TCP pose [x, y, z, qx, qy, qz, qw] (m), a reference posture, and whether to list all."""

    tcp: Annotated[list[Finite], Field(min_length=7, max_length=7)]
    joints_ref: JointRow | None = None
    all: bool = False


class MoveRequest(_Body):
    """Target joints in hello order (rad or m)."""

    joints: JointRow


Body = TypeVar("Body", bound=BaseModel)


def parse_body(model: type[Body], raw: bytes) -> Body:
    """``raw`` (a request's JSON body) as ``model``; a 422 naming each bad field otherwise."""
    try:
        return model.model_validate_json(raw)
    except ValidationError as exc:
        raise RequestValidationError(exc.errors(include_input=False)) from None


def _robot(request: Request, name: str) -> Robot:
    robot = runtime_of(request).robot(name)
    if robot is None:
        raise HTTPException(status_code=404, detail=f"no robot named {name!r} in the cell")
    return robot


def _forward(robot: Robot, raw: bytes) -> bytes:
    body = parse_body(ForwardRequest, raw)
    if body.links and len(body.joints) > MAX_LINK_ROWS:
        raise HTTPException(422, f"with links, at most {MAX_LINK_ROWS} rows per call")
    answer: dict[str, list[Any]] = {}
    for start in range(0, len(body.joints), CHUNK_ROWS):
        rows = body.joints[start : start + CHUNK_ROWS]
        try:
            part = transformation.forward(robot, rows, body.links)
        except transformation.TransformInputError as exc:
            raise HTTPException(status_code=422, detail=str(exc)) from exc
        for key, value in vars(part).items():
            if value is not None:
                answer.setdefault(key, []).extend(value)
        time.sleep(0)  # lets the event loop's thread take the interpreter between chunks
    # Encoded here, in the worker thread: FastAPI would encode a returned dict of 10 000
    # rows on the event loop, where it holds up every viewer's frames.
    return orjson.dumps(answer)


def _inverse(robot: Robot, raw: bytes) -> bytes:
    body = parse_body(InverseRequest, raw)
    try:
        result = transformation.inverse(robot, body.tcp, body.joints_ref, body.all)
    except transformation.TransformInputError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from exc
    return orjson.dumps(vars(result))


@router.post("/{name}/fk")
async def forward(name: str, request: Request) -> Response:
    """TCP pose and roll-pitch-yaw for each joint row (``ForwardRequest``)."""
    robot, raw = _robot(request, name), await request.body()  # read first: a 503 then is clean
    async with running.slot():
        body = await run_in_threadpool(_forward, robot, raw)
    return Response(body, media_type="application/json")


@router.post("/{name}/ik")
async def inverse(name: str, request: Request) -> Response:
    """Joint solutions for a TCP pose (``InverseRequest``); ``best`` is nearest ``joints_ref``."""
    robot, raw = _robot(request, name), await request.body()
    async with running.slot():
        body = await run_in_threadpool(_inverse, robot, raw)
    return Response(body, media_type="application/json")


@router.post("/{name}/move", status_code=202)
async def move(name: str, request: Request) -> dict[str, Any]:
    """Command a synchronised move to ``joints`` (``MoveRequest``); 403 where not allowed."""
    robot = _robot(request, name)
    body = parse_body(MoveRequest, await request.body())  # a few floats: cheap enough on the loop
    try:
        async with running.slot():
            await runtime_of(request).move(robot, body.joints)
    except MoveError as exc:
        raise HTTPException(status_code=exc.status, detail=str(exc)) from exc
    return {"ok": True, "robot": name, "joints": body.joints}
