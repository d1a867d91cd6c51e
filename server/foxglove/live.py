"""``--foxglove PORT``: the cell live over Foxglove's WebSocket protocol (foxglove-sdk).

The same channels as a recording (``/tf``, ``/scene``, ``/log``,
``/<robot>/joints``), taken from the histories every DRAIN_S and encoded in
a worker thread, only while a client subscribes. A client that subscribes to
``/scene`` or ``/tf`` gets the meshes and the base frames again, since the SDK
keeps no message for late joiners. Both are encoded once per cell (in a
worker thread); the meshes are sent by the ``guard`` to the subscribing
client alone (``scene``), the base frames logged again at most every
RESEND_MIN_S, however often clients subscribe. Clients reach the SDK's
server only through the ``guard``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from ..access import Access
from ..cell import Cell
from ..history import History, HistoryReader
from ..recording.encode import Encoded, encode_batch
from ..recording.messages import (
    LOG_TOPIC,
    SCHEMAS,
    TF_TOPIC,
    RobotFrames,
    base_transforms,
    joints_schema,
    joints_topic,
    nanoseconds,
    scene_update,
)
from .guard import Guard

log = logging.getLogger(__name__)

DRAIN_S = 0.05
NAME = "linkview"
BACKLOG = 64
"""Messages the SDK's server keeps for a client that reads slowly (it drops the oldest)."""
RESEND_MIN_S = 5.0
"""The base frames go out again at most this often (each subscribe to /tf asks for them)."""


class _Listener(ServerListener):
    """Counts subscriptions; notes when the base frames must be sent again."""

    def __init__(self) -> None:
        self.subscriptions = 0
        self.resend = False

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.subscriptions += 1
        if channel.topic == TF_TOPIC:
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
        access: Access | None = None,
        max_clients: int = 1000,
        others: Callable[[], int] = lambda: 0,
    ) -> None:
        self.cell_of = cell_of
        self.host, self.port = host, port
        self.access = access or Access()
        self.max_clients = max_clients
        self.others = others
        """The process's other viewers (``/ws``), who share ``max_clients`` with Foxglove's."""
        self.reader = HistoryReader(history, from_start=False)
        self.listener = _Listener()
        self.context = foxglove.Context()
        self.server: WebSocketServer | None = None
        self.guard: Guard | None = None
        self.sent = 0
        """Messages logged to the server so far."""
        self.scene_encodings = 0
        """Times the meshes and base frames were encoded (once per cell)."""
        self._cell: Cell | None = None
        self._scene: tuple[bytes, bytes] | None = None
        """The cell's meshes and base frames, encoded."""
        self._encoding = asyncio.Lock()
        self._resent_at = -RESEND_MIN_S
        self._frames: dict[str, RobotFrames] = {}
        self._channels: dict[str, foxglove.Channel] = {}

    async def start(self) -> int:
        """Listen; returns the port clients connect to."""
        self.server = foxglove.start_server(
            name=NAME,
            host="127.0.0.1",
            port=0,
            context=self.context,
            server_listener=self.listener,
            message_backlog_size=BACKLOG,
        )
        self.guard = Guard(self.access, self.server.port, self.max_clients, self.scene, self.others)
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
        if self.listener.resend and time.monotonic() - self._resent_at >= RESEND_MIN_S:
            self.listener.resend = False
            self._resent_at = time.monotonic()
            first = [float(s.rows.t[0]) for s in sources if len(s.rows)]
            messages = await self._cell_messages(cell, min(first, default=time.time())) + messages
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
        self._scene = None
        self._frames = {r.name: RobotFrames(r) for r in cell.robots}
        self.listener.resend = True

    async def scene(self) -> bytes | None:
        """The running cell's meshes, encoded (None before the first drain)."""
        encoded = await self._encoded()
        return None if encoded is None else encoded[0]

    async def _cell_messages(self, cell: Cell, now: float) -> list[Encoded]:
        """The base frames, logged at ``now`` (the first sample of the drain they go with)."""
        encoded = await self._encoded()
        return [] if encoded is None else [(TF_TOPIC, nanoseconds(now), encoded[1])]

    async def _encoded(self) -> tuple[bytes, bytes] | None:
        """The meshes and base frames of the cell advertised, encoded the first time they are
        asked for (in a worker thread) and stamped then: never younger than a sample sent
        after, so the base frames hold for every later one."""
        async with self._encoding:  # 40 clients subscribing at once: one encoding
            cell = self._cell
            if self._scene is None and cell is not None:
                robots, now = list(cell.robots), time.time()
                scene, bases = await asyncio.to_thread(
                    lambda: (scene_update(robots, now), base_transforms(robots, now))
                )
                self.scene_encodings += 1
                if cell is self._cell:  # else reloaded meanwhile: encoded again when asked
                    self._scene = (scene, bases)
                return scene, bases
            return self._scene

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
