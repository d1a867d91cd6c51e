"""One TCP connection to a controller's RTDE interface: the handshake, then data packages.

An ``asyncio.Protocol`` rather than a stream reader: the bytes of a 500 Hz
stream are split into packages where they arrive (``data_received``), and only
the newest data package of each read is handed on, with how many it stands
for. No task wakes per package, and nothing queues behind a slow reader.
"""

from __future__ import annotations

import asyncio
import logging
import socket
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

from . import wire
from .recipe import Recipe, answered

log = logging.getLogger(__name__)

OnData = Callable[[bytes, int], None]
"""Called with the newest data package of a read and how many arrived in it."""


class LinkClosed(ConnectionError):
    """The controller closed the connection, or it broke."""


@dataclass(frozen=True)
class Controller:
    """What the handshake learnt: the controller's version and the recipe it accepted."""

    version: tuple[int, int, int, int]
    recipe: Recipe
    missing: tuple[str, ...] = ()
    """Fields the controller answered NOT_FOUND (left out of ``recipe``)."""

    @property
    def version_text(self) -> str:
        """``URControl 5.15.0.12345``, as the controller's version reads."""
        return "URControl " + ".".join(map(str, self.version))


class RtdeLink(asyncio.Protocol):
    """The client side of one RTDE connection (see the module doc)."""

    def __init__(self, where: str) -> None:
        self.where = where
        """``rtde://host:port``, for messages."""
        self.on_data: OnData | None = None
        self.closed: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.messages: list[str] = []
        """Text messages the controller sent (the newest few)."""
        self._buffer = bytearray()
        self._transport: asyncio.Transport | None = None
        self._waiting: dict[int, asyncio.Future[bytes]] = {}

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # A TCP transport (uvloop's is no subclass of asyncio.Transport, but behaves as one).
        self._transport = cast(asyncio.Transport, transport)

    def data_received(self, data: bytes) -> None:
        # The usual read holds whole packages: parsed where it lies, no copy but the newest.
        buffer: bytes | bytearray = data
        if self._buffer:
            self._buffer += data
            buffer = self._buffer
        start, end = 0, len(buffer)
        newest, count = -1, 0
        header = wire.HEADER
        while end - start >= 3:
            size, kind = header.unpack_from(buffer, start)
            if size < 3:
                self._fail(
                    LinkClosed(f"{self.where}: package size {size} is shorter than its header")
                )
                return
            if end - start < size:
                break
            if kind == wire.DATA_PACKAGE:
                newest, count = start, count + 1
            else:
                self._control(kind, bytes(buffer[start + 3 : start + size]))
            start += size
        payload = None
        if newest >= 0:
            size = header.unpack_from(buffer, newest)[0]
            payload = bytes(buffer[newest + 3 : newest + size])
        if buffer is self._buffer:
            del self._buffer[:start]
        elif start < end:
            self._buffer += data[start:]
        if payload is not None and self.on_data is not None:
            self.on_data(payload, count)

    def _control(self, kind: int, payload: bytes) -> None:
        """A package other than data: a text message, or the reply a request waits for."""
        if kind == wire.TEXT_MESSAGE:
            text = wire.read_text_message(payload)
            log.info("%s says: %s", self.where, text)
            self.messages = [*self.messages[-4:], text]
            return
        waiting = self._waiting.pop(kind, None)
        if waiting is not None and not waiting.done():
            waiting.set_result(payload)

    def connection_lost(self, exc: Exception | None) -> None:
        why = f": {exc}" if exc else ""
        self._fail(LinkClosed(f"{self.where}: the controller closed the connection{why}"))

    def _fail(self, exc: LinkClosed) -> None:
        for waiting in self._waiting.values():
            if not waiting.done():
                waiting.set_exception(exc)
        self._waiting.clear()
        if not self.closed.done():
            self.closed.set_exception(exc)
            self.closed.exception()  # retrieved: whoever awaits it sees it; nobody must
        if self._transport is not None:
            self._transport.abort()

    async def request(self, kind: int, payload: bytes = b"") -> bytes:
        """Send a package of type ``kind``; the payload of the controller's reply of that type."""
        if self._transport is None or self._transport.is_closing():
            raise LinkClosed(f"{self.where}: not connected")
        reply: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        self._waiting[kind] = reply
        self._transport.write(wire.package(kind, payload))
        return await reply

    def wake_after(self, nbytes: int) -> None:
        """Let the kernel wake us only once ``nbytes`` are waiting (SO_RCVLOWAT).

        At 500 packages a second, each read woken by one package costs the event loop a
        wake-up and a system call; the frames need one package per period. Where the
        socket option is refused, every package wakes us, as before.
        """
        sock: Any = None if self._transport is None else self._transport.get_extra_info("socket")
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVLOWAT, max(1, nbytes))
        except (AttributeError, OSError) as exc:
            log.debug("%s: SO_RCVLOWAT refused: %s", self.where, exc)

    def close(self) -> None:
        """Close the connection (without waiting)."""
        if self._transport is not None:
            self._transport.abort()


async def handshake(link: RtdeLink, fields: Sequence[str], frequency_hz: float) -> Controller:
    """Protocol version 2, the controller's version, the output recipe (NOT_FOUND fields left
    out), start. Raises LinkClosed, or ``wire.WireError`` for a refusal it cannot ride out."""
    version_2 = wire.U16.pack(wire.PROTOCOL_VERSION)
    accepted = await link.request(wire.REQUEST_PROTOCOL_VERSION, version_2)
    if not accepted or not accepted[0]:
        raise wire.WireError(f"the controller refused RTDE protocol {wire.PROTOCOL_VERSION}")
    reply = await link.request(wire.GET_URCONTROL_VERSION)
    if len(reply) < wire.VERSION.size:
        raise wire.WireError(f"controller version of {len(reply)} bytes: expected 16")
    version: tuple[int, int, int, int] = wire.VERSION.unpack_from(reply)
    wanted = list(fields)
    missing: list[str] = []
    while True:
        payload = wire.FREQUENCY.pack(frequency_hz) + ",".join(wanted).encode()
        recipe_id, types = answered(wanted, await link.request(wire.SETUP_OUTPUTS, payload))
        lacking = [f for f, t in zip(wanted, types, strict=True) if t == wire.NOT_FOUND]
        if not lacking:
            break
        # The whole recipe is refused for one unknown field: ask again without them.
        missing += lacking
        wanted = [f for f in wanted if f not in lacking]
        if not wanted:
            raise wire.WireError(f"the controller has none of the outputs {', '.join(missing)}")
    if recipe_id == 0:
        raise wire.WireError(f"the controller refused the output recipe {','.join(wanted)}")
    recipe = Recipe(recipe_id, tuple(wanted), tuple(types))
    started = await link.request(wire.START)
    if not started or not started[0]:
        raise wire.WireError("the controller refused to start sending data packages")
    return Controller(version, recipe, tuple(missing))
