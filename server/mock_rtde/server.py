"""A mock UR controller's RTDE interface: real TCP, the guide's handshake, data packages at 500 Hz.

Each client gets the packages of its own recipe at the frequency it asked
for (at most the controller's loop: 500 Hz, or 125 Hz for a CB3 version),
timed by the controller's clock: ``timestamp`` counts seconds since the mock
started, in steps of its loop period, and the values are the simulated
machine's at exactly that instant. A client that does not keep up misses
packages, as on a controller; none queue. Faults: ``drop`` (connections
closed, refused for a while), ``stall`` (open but silent), ``protective_stop``
and ``emergency_stop``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import struct
import time

from ..mock_ctrlx import Machine
from ..rtde import wire
from .outputs import Outputs, SafetyState

log = logging.getLogger(__name__)

E_SERIES_VERSION = (5, 15, 0, 0)
"""What the mock says it runs (PolyScope 5: e-Series, 500 Hz)."""
BUFFER_LIMIT = 64 * 1024
"""A client whose unsent bytes exceed this misses packages rather than queueing them."""


class RtdeMock:
    """The controller; ``await start(host, port)``, then ``close()``."""

    def __init__(
        self,
        machine: Machine,
        version: tuple[int, int, int, int] = E_SERIES_VERSION,
        boot_s: float | None = None,
    ) -> None:
        self.outputs = Outputs(machine)
        self.version = version
        self.boot_s = time.time() if boot_s is None else boot_s
        """Unix time of the controller's ``timestamp`` 0."""
        self.tick_s = 0.002 if version[0] > 3 else 0.008
        self.server: asyncio.Server | None = None
        self.host, self.port = "127.0.0.1", wire.PORT
        self._clients: set[asyncio.StreamWriter] = set()
        self._handlers: set[asyncio.Task[None]] = set()
        self._down_until = 0.0
        self._silent_until = 0.0
        self.sent = 0
        """Data packages sent to all clients."""
        self.first_sent: float | None = None
        """``time.monotonic()`` of the first data package sent."""
        self.skipped = 0
        self._made: dict[tuple[int, tuple[str, ...]], tuple[float, bytes]] = {}
        """The newest package made per recipe: clients with the same recipe share it."""
        """Packages not sent because a client's socket was full."""

    @property
    def machine(self) -> Machine:
        return self.outputs.machine

    @property
    def safety(self) -> SafetyState:
        return self.outputs.safety

    @property
    def url(self) -> str:
        return f"rtde://{self.host}:{self.port}"

    async def start(self, host: str = "127.0.0.1", port: int = wire.PORT) -> str:
        """Listen on ``host:port`` (0: a free port); the ``rtde://`` address."""
        self.server = await asyncio.start_server(self._serve, host, port)
        self.host, self.port = self.server.sockets[0].getsockname()[:2]
        return self.url

    async def close(self) -> None:
        """Stop listening and close every connection."""
        if self.server is not None:
            self.server.close()
        self.drop()  # every handler then reads the end of its connection and returns
        await asyncio.gather(*self._handlers, return_exceptions=True)
        if self.server is not None:
            await self.server.wait_closed()

    # Faults.
    def drop(self, down_s: float = 0.0) -> None:
        """Close every connection now; refuse new ones for ``down_s``."""
        self._down_until = time.monotonic() + down_s
        for writer in list(self._clients):
            writer.transport.abort()

    def stall(self, seconds: float) -> None:
        """Send no data packages for ``seconds`` (connections stay open)."""
        self._silent_until = time.monotonic() + seconds

    def protective_stop(self, on: bool = True) -> None:
        """Stop the robot where it is (safety mode PROTECTIVE_STOP), or release it."""
        self._stop(wire.PROTECTIVE_STOP if on else wire.NORMAL, wire.RUNNING)

    def emergency_stop(self, on: bool = True) -> None:
        """Robot emergency stop: stopped, powered off; or released and running again."""
        self._stop(7 if on else wire.NORMAL, 3 if on else wire.RUNNING)

    def _stop(self, safety_mode: int, robot_mode: int) -> None:
        safety = self.safety
        stopping = safety_mode != wire.NORMAL
        if stopping and safety.stopped_at is None:
            safety.stopped_at = time.time()
        elif not stopping:
            safety.stopped_at = None
        safety.safety_mode, safety.robot_mode = safety_mode, robot_mode

    # The protocol.
    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if time.monotonic() < self._down_until:
            writer.transport.abort()
            return
        self._clients.add(writer)
        handler = asyncio.current_task()
        assert handler is not None
        self._handlers.add(handler)
        sender: asyncio.Task[None] | None = None
        fields: list[str] = []
        recipe_id, frequency = 0, 0.0
        try:
            while True:
                size, kind = wire.HEADER.unpack(await reader.readexactly(wire.HEADER.size))
                payload = await reader.readexactly(max(0, size - wire.HEADER.size))
                if kind == wire.REQUEST_PROTOCOL_VERSION:
                    ok = len(payload) == 2 and wire.U16.unpack(payload)[0] in (1, 2)
                    writer.write(wire.package(kind, bytes([ok])))
                elif kind == wire.GET_URCONTROL_VERSION:
                    writer.write(wire.package(kind, wire.VERSION.pack(*self.version)))
                elif kind == wire.SETUP_OUTPUTS:
                    frequency = wire.FREQUENCY.unpack_from(payload)[0]
                    names = payload[wire.FREQUENCY.size :].decode(errors="replace").split(",")
                    fields = [n.strip() for n in names if n.strip()]
                    types = self.outputs.types(fields)
                    ok = bool(fields) and wire.NOT_FOUND not in types and frequency > 0
                    recipe_id = recipe_id + 1 if ok else 0
                    reply = bytes([recipe_id]) + ",".join(types).encode()
                    writer.write(wire.package(kind, reply))
                elif kind == wire.SETUP_INPUTS:
                    writer.write(wire.package(kind, b"\x00IN_USE"))  # the mock takes no inputs
                elif kind == wire.START:
                    ok = recipe_id > 0 and sender is None
                    writer.write(wire.package(kind, bytes([ok])))
                    if ok:
                        sender = asyncio.create_task(
                            self._send(writer, recipe_id, fields, frequency)
                        )
                elif kind == wire.PAUSE:
                    if sender is not None:
                        sender.cancel()
                        sender = None
                    writer.write(wire.package(kind, b"\x01"))
                elif kind == wire.TEXT_MESSAGE:
                    log.info("rtde client says: %s", wire.read_text_message(payload))
                else:
                    writer.write(wire.text_message(f"unknown package type {kind}", "mock", 1))
        except (asyncio.IncompleteReadError, ConnectionError, struct.error):
            pass
        finally:
            self._clients.discard(writer)
            self._handlers.discard(handler)
            if sender is not None:
                sender.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await sender
            writer.transport.abort()

    def _package(
        self, recipe_id: int, fields: tuple[str, ...], layout: struct.Struct, timestamp: float
    ) -> bytes:
        """The data package of ``fields`` at ``timestamp``, made once for every client."""
        made = self._made.get((recipe_id, fields))
        if made is not None and made[0] == timestamp:
            return made[1]
        values = self.outputs.values(fields, timestamp, self.boot_s + timestamp)
        data = wire.package(wire.DATA_PACKAGE, layout.pack(recipe_id, *values))
        self._made[recipe_id, fields] = (timestamp, data)
        return data

    async def _send(
        self, writer: asyncio.StreamWriter, recipe_id: int, fields: list[str], frequency: float
    ) -> None:
        """Data packages every few controller ticks, on the controller's clock, until cancelled."""
        every = max(1, round(1.0 / (min(frequency, 1.0 / self.tick_s) * self.tick_s)))
        step = every * self.tick_s
        layout = self.outputs.layout(fields)
        key = tuple(fields)
        k = math.ceil((time.time() - self.boot_s) / step)
        transport = writer.transport
        while not transport.is_closing():
            due = self.boot_s + k * step
            delay = due - time.time()
            if delay > 0:
                await asyncio.sleep(delay)
            # A tick missed (the loop was busy) is skipped, as a controller skips packages.
            k = max(k, math.floor((time.time() - self.boot_s) / step))
            timestamp = round(k * step, 9)
            k += 1
            if time.monotonic() < self._silent_until:
                continue
            if transport.get_write_buffer_size() > BUFFER_LIMIT:
                self.skipped += 1
                continue
            transport.write(self._package(recipe_id, key, layout, timestamp))
            if self.first_sent is None:
                self.first_sent = time.monotonic()
            self.sent += 1
