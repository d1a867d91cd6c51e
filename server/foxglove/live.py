"""``--foxglove PORT``: the cell live over Foxglove's WebSocket protocol (foxglove-sdk).

The same channels as a recording (``/tf``, ``/scene``, ``/log``,
``/<robot>/joints``), taken from the histories every DRAIN_S and encoded in
a worker thread, only while a client subscribes. A client that subscribes to
``/scene`` or ``/tf`` gets the meshes and the base frames again, since the SDK
keeps no message for late joiners.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from ..cell import Cell
from ..history import History, HistoryReader
from ..recording.encode import Encoded, encode_batch
from ..recording.messages import (
    LOG_TOPIC,
    SCENE_TOPIC,
    SCHEMAS,
    TF_TOPIC,
    RobotFrames,
    base_transforms,
    joints_schema,
    joints_topic,
    nanoseconds,
    scene_update,
)
from .guard import TokenGuard

log = logging.getLogger(__name__)

DRAIN_S = 0.05
NAME = "linkview"


class _Listener(ServerListener):
    """Counts subscriptions; notes when the meshes and base frames must be sent again."""

    def __init__(self) -> None:
        self.subscriptions = 0
        self.resend = False

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.subscriptions += 1
        if channel.topic in (SCENE_TOPIC, TF_TOPIC):
            self.resend = True

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        self.subscriptions = max(0, self.subscriptions - 1)


class FoxgloveEndpoint:
    """Serves a running cell's histories live to Foxglove on ``host:port``."""

    def __init__(
        self,
        history: History,
        cell_of: Callable[[], Cell],
        host: str,
        port: int,
        token: str | None = None,
    ) -> None:
        self.cell_of = cell_of
        self.host, self.port, self.token = host, port, token
        self.reader = HistoryReader(history, from_start=False)
        self.listener = _Listener()
        self.context = foxglove.Context()
        self.server: WebSocketServer | None = None
        self.guard: TokenGuard | None = None
        self.sent = 0
        """Messages logged to the server so far."""
        self._cell: Cell | None = None
        self._frames: dict[str, RobotFrames] = {}
        self._channels: dict[str, foxglove.Channel] = {}

    async def start(self) -> int:
        """Listen; returns the port clients connect to."""
        behind_guard = self.token is not None
        self.server = foxglove.start_server(
            name=NAME,
            host="127.0.0.1" if behind_guard else self.host,
            port=0 if behind_guard else self.port,
            context=self.context,
            server_listener=self.listener,
        )
        if self.token is None:
            self.port = self.server.port
        else:
            self.guard = TokenGuard(self.token, self.server.port)
            self.port = await self.guard.start(self.host, self.port)
        log.info("foxglove: serving ws://%s:%d", self.host, self.port)
        return self.port

    async def run(self, drain_s: float = DRAIN_S) -> None:
        """Send what the histories gain, until cancelled; then stop listening."""
        try:
            while True:
                await asyncio.sleep(drain_s)
                await self.drain()
        finally:
            await self.stop()

    async def drain(self) -> None:
        """Send the rows added since the last drain (skipped while nobody subscribes)."""
        cell = self.cell_of()
        if cell is not self._cell:
            self._advertise(cell)
        sources, marks = self.reader.take(cell)
        if self.listener.subscriptions == 0:
            return
        messages = await asyncio.to_thread(encode_batch, sources, marks, self._frames)
        if self.listener.resend:
            self.listener.resend = False
            first = [float(s.rows.t[0]) for s in sources if len(s.rows)]
            messages = self._cell_messages(cell, min(first, default=time.time())) + messages
        self._log(messages)

    def _advertise(self, cell: Cell) -> None:
        """Channels for ``cell`` (a reload replaces those of robots gone)."""
        for channel in self._channels.values():
            channel.close()
        self._channels = {
            topic: foxglove.Channel(
                topic, schema=schema, message_encoding="protobuf", context=self.context
            )
            for topic, schema in SCHEMAS.items()
        }
        for robot in cell.robots:
            self._channels[joints_topic(robot.name)] = foxglove.Channel(
                joints_topic(robot.name),
                schema=joints_schema(robot),
                message_encoding="json",
                context=self.context,
            )
        self._cell = cell
        self._frames = {r.name: RobotFrames(r) for r in cell.robots}
        self.listener.resend = True

    def _cell_messages(self, cell: Cell, now: float) -> list[Encoded]:
        robots = list(cell.robots)
        return [
            (SCENE_TOPIC, nanoseconds(now), scene_update(robots, now)),
            (TF_TOPIC, nanoseconds(now), base_transforms(robots, now)),
        ]

    def _log(self, messages: list[Encoded]) -> None:
        for topic, log_time, data in messages:
            channel = self._channels.get(topic)
            if channel is not None:
                channel.log(data, log_time=log_time)
                self.sent += 1

    async def stop(self) -> None:
        """Stop the server (and the guard)."""
        if self.guard is not None:
            await self.guard.stop()
            self.guard = None
        if self.server is not None:
            with contextlib.suppress(Exception):
                self.server.stop()
            self.server = None
        for channel in self._channels.values():
            channel.close()
        self._channels = {}


__all__ = ["FoxgloveEndpoint", "LOG_TOPIC"]
