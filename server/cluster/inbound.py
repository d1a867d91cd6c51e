"""What a replica reads from Redis, checked like a request before anything of it is used.

Redis is shared by every role of a cluster, so whatever can write to it can
publish on ``linkview:frames`` and set ``health:<source>``. A replica takes
from there only what a worker of the same cell publishes: the keys
``frames1:<source>``, ``frames2:<source>`` and ``status:<source>`` of the
cell's sources (so its hub keeps at most three messages per source), each
with its protocol and payload type, laid out as the protocol says, within
stated sizes; status records match their schema and name only the source's
own robots. Anything else raises ``Refused``: the replica counts it, drops
it and goes on.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

import numpy as np
import orjson
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..cell import Cell
from ..protocol import SourceStatus, frames_layout
from ..stream import RobotHealth
from .envelope import Item

MAX_FRAMES_BYTES = 1 << 20
"""A protocol-2 frames message of one source (a 20-robot source of 100 links: 120 KiB)."""
MAX_TEXT_BYTES = 64 * 1024
"""One protocol-1 frame (one robot) or one status record."""
MAX_TEXT = 4096
"""Characters of any one text of a status record (an error, a URL, a worker's id)."""
MAX_JOINTS = 64
FRAMES_PROTOCOL = {"frames1": 1, "frames2": 2}
ITEMS_PER_SOURCE = 3
"""Items of one source in a batch: a worker publishes each of its three keys once."""

Text = Annotated[str, Field(max_length=MAX_TEXT)]


class Refused(ValueError):
    """Something read from Redis that no worker of this cell would have written."""

    def __init__(self, kind: str, reason: str) -> None:
        super().__init__(reason)
        self.kind = kind
        """What was refused: ``key``, ``frames``, ``record``, ``batch``, ``answer``."""


class _Record(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RobotRecord(_Record):
    """A robot's health as a worker publishes it (``Worker._describe``)."""

    ok: bool
    error: Text | None
    frames: int = Field(ge=0)
    values: Annotated[list[float | None], Field(max_length=MAX_JOINTS)] | None
    """Node values (orjson writes NaN as null)."""

    def health(self) -> RobotHealth:
        """As the replica's health keeps it."""
        values = None
        if self.values is not None:
            values = np.array([math.nan if v is None else v for v in self.values])
        return RobotHealth(ok=self.ok, error=self.error, frames=self.frames, values=values)


class StatusRecord(_Record):
    """A source's status record: its state, its robots' health, the worker following it."""

    status: SourceStatus
    robots: dict[Text, RobotRecord]
    worker: Annotated[str, Field(min_length=1, max_length=200)]


class Inbound:
    """Checks items and records against the cell this replica serves."""

    def __init__(self, cell: Cell) -> None:
        self.robots = {s.name: {r.name for r in cell.robots_of(s.name)} for s in cell.sources}
        self.robot_count = len(cell.robots)

    def item(self, item: Item) -> tuple[str, str]:
        """The key's kind and source, if the item is one a worker publishes; else Refused."""
        key, message, protocol = item
        kind, _, source = key.partition(":")
        if source not in self.robots:
            raise Refused("key", f"an item of unknown key {key[:80]!r}")
        payload = message.payload
        if kind == "status":
            if protocol is not None or not isinstance(payload, str):
                raise Refused("key", f"{key}: a status record is text for every protocol")
            return kind, source
        expected = FRAMES_PROTOCOL.get(kind)
        if expected is None:
            raise Refused("key", f"an item of unknown key {key[:80]!r}")
        if protocol != expected:
            raise Refused("frames", f"{key}: protocol {protocol}, not {expected}")
        if message.t_source is not None and not math.isfinite(message.t_source):
            raise Refused("frames", f"{key}: t_source {message.t_source}")
        if kind == "frames2":
            self._frames2(key, payload)
        else:
            self._frames1(key, source, payload)
        return kind, source

    def _frames2(self, key: str, payload: Any) -> None:
        if not isinstance(payload, bytes) or len(payload) > MAX_FRAMES_BYTES:
            raise Refused("frames", f"{key}: not a frames message of at most {MAX_FRAMES_BYTES} B")
        try:
            _, count, _, _, layout = frames_layout(payload)
        except ValueError as exc:
            raise Refused("frames", f"{key}: {exc}") from None
        if count > self.robot_count or any(
            r.robot_index >= self.robot_count or r.joint_count > MAX_JOINTS for r in layout
        ):
            raise Refused("frames", f"{key}: robots beyond the cell's {self.robot_count}")

    def _frames1(self, key: str, source: str, payload: Any) -> None:
        robots = self.robots[source]
        if not isinstance(payload, tuple) or len(payload) > len(robots):
            raise Refused("frames", f"{key}: more frames than the source has robots")
        for text in payload:
            if len(text) > MAX_TEXT_BYTES:
                raise Refused("frames", f"{key}: a frame over {MAX_TEXT_BYTES} B")
            try:
                frame = orjson.loads(text)
            except orjson.JSONDecodeError:
                raise Refused("frames", f"{key}: a frame that is not JSON") from None
            if not isinstance(frame, dict) or frame.get("type") != "frame":
                raise Refused("frames", f"{key}: a frame that is not a frame message")
            if frame.get("robot") not in robots:
                raise Refused("frames", f"{key}: a frame of a robot not on {source}")

    def record(self, source: str, data: bytes | str) -> StatusRecord:
        """A status record of ``source``, checked; Refused if it is not one."""
        if len(data) > MAX_TEXT_BYTES:
            raise Refused("record", f"status of {source}: {len(data)} B, over {MAX_TEXT_BYTES}")
        try:
            record = StatusRecord.model_validate_json(data)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(map(str, first["loc"])) or "(record)"
            raise Refused("record", f"status of {source}: {where}: {first['msg']}") from None
        if record.status.name != source:
            raise Refused("record", f"status of {source} names {record.status.name[:80]!r}")
        strangers = set(record.robots) - self.robots[source]
        if strangers:
            shown = sorted(strangers)[0][:80]
            raise Refused("record", f"status of {source}: robot {shown!r} is not on it")
        return record


def answer_of(data: bytes) -> tuple[str, int, str]:
    """A worker's answer to a move: (id, HTTP status, detail); Refused if it is not one."""
    try:
        answer = _Answer.model_validate_json(data)
    except ValidationError:
        raise Refused("answer", "a garbled answer to a move") from None
    return answer.id, answer.status, answer.detail


class _Answer(_Record):
    id: Annotated[str, Field(max_length=200)]
    status: int = Field(ge=200, le=599)
    detail: Text


__all__ = ["Inbound", "Refused", "StatusRecord", "answer_of"]
