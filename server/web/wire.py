"""Frames written straight to a viewer's socket: framed once per message, one write per viewer.

Every viewer gets the same bytes, and a server's WebSocket frames are not
masked, so a message can be framed once and the frame written to each
viewer's transport as it is. The frames of every source that published within
``WRITE_EVERY_S`` go out in one write per viewer, all viewers' at one timer (a
system call per viewer and window, not per viewer and source: with a controller
per robot, a plant's thousands of frames a second would each cost a write).
Going through ASGI instead costs a task switch, an event, a dict and a framing
per viewer and message; at 500 viewers and 50 frames a second that is most of
a core. uvicorn's sans-I/O WebSocket protocol is extended with one method,
offered to the app as an ASGI extension.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable

from uvicorn._types import ASGISendEvent
from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol
from websockets.frames import Frame
from websockets.http11 import Request

from .. import flood
from ..flood import MAX_QUEUED_BYTES, MESSAGES_PER_S, MessageBudget
from ..per_loop import PerLoop
from ..stream.hub import Payload

log = logging.getLogger(__name__)

EXTENSION = "linkview.write_frame"
_TEXT, _BINARY = 0x81, 0x82  # FIN + opcode
CLOSE_FRAME_ROOM = 256 * 1024
"""Below this much queued (frames stop at 64 KiB), the close frame is sent after the rest,
and the connection dropped after ``ABORT_AFTER_S`` if the peer does not take it; above,
everything is dropped at once."""
ABORT_AFTER_S = 5.0
WRITE_EVERY_S = 0.002
"""Frames wait at most this long to share a write; a fraction of a sample period (20 ms).
At 150 controllers the write per turn of the loop was a fifth of the process's CPU."""
READ_AFTER_CLOSE_BYTES = 1 << 20


def _peer(client: tuple[str, int] | None) -> str:
    return "?" if client is None else f"{client[0]}:{client[1]}"


def ws_frames(payload: Payload) -> bytes:
    """Complete, unmasked WebSocket frames: one message, or each of a tuple's, back to back."""
    if isinstance(payload, tuple):
        return b"".join(map(ws_frame, payload))
    return ws_frame(payload)


def ws_frame(payload: str | bytes) -> bytes:
    """One complete, unmasked WebSocket frame (text for str, binary for bytes)."""
    data = payload.encode() if isinstance(payload, str) else payload
    first = _TEXT if isinstance(payload, str) else _BINARY
    size = len(data)
    if size < 126:
        return bytes((first, size)) + data
    if size < 1 << 16:
        return struct.pack("!BBH", first, 126, size) + data
    return struct.pack("!BBQ", first, 127, size) + data


class StreamingWebSocketProtocol(WebSocketsSansIOProtocol):
    """uvicorn's sans-I/O WebSocket protocol that writes ready-made frames, within bounds.

    Each incoming message (pings and pongs included) is paid from the viewer's
    ``MessageBudget``, and a pong is only written while the viewer's write
    buffer is under ``MAX_QUEUED_BYTES``; a viewer past either is closed
    (``flood``).
    """

    _budget: MessageBudget
    _outbox: list[bytes] | None = None
    """Frames waiting for the next write (``WRITE_EVERY_S``); None when none are."""
    _read_after_close = -1
    """Bytes read since the viewer was closed for a bound; -1 while it was not."""

    def data_received(self, data: bytes) -> None:
        if self._read_after_close >= 0:
            self._read_after_close += len(data)
            if self._read_after_close > READ_AFTER_CLOSE_BYTES:
                self.transport.abort()  # it sends on and on, unheeding: nothing more to say
                return
        super().data_received(data)

    def handle_connect(self, event: Request) -> None:
        self._budget = MessageBudget()
        super().handle_connect(event)
        if hasattr(self, "scope"):
            self.scope["extensions"][EXTENSION] = {"write": self.write_frame}

    def handle_cont(self, event: Frame) -> None:
        if self._within_budget():
            super().handle_cont(event)

    def handle_text(self, event: Frame) -> None:
        if self._within_budget():
            super().handle_text(event)

    def handle_bytes(self, event: Frame) -> None:
        if self._within_budget():
            super().handle_bytes(event)

    def handle_pong(self, event: Frame) -> None:
        if self._within_budget():
            super().handle_pong(event)

    def handle_ping(self) -> None:
        if not self._within_budget():
            return
        if self.transport.get_write_buffer_size() > MAX_QUEUED_BYTES:
            self._close_for("queued", "does not read what it asked for (pongs)")
            return
        super().handle_ping()

    def _within_budget(self) -> bool:
        if self.close_sent or self.disconnected:
            return False  # closing: what it still sends is dropped unread
        if self._budget.spend():
            return True
        self._close_for("messages", f"sends more than {MESSAGES_PER_S:g} messages per second")
        return False

    def _close_for(self, bound: str, reason: str) -> None:
        """Close with 1008 and ``reason``; the write buffer is dropped now or within seconds."""
        flood.closed[bound] += 1
        log.warning("viewer %s closed: it %s", _peer(self.client), reason)
        self.conn.send_close(1008, f"viewer {reason}"[:120])
        self.transport.write(b"".join(self.conn.data_to_send()))
        self.close_sent = True
        self._read_after_close = 0
        self.queue.put_nowait({"type": "websocket.disconnect", "code": 1008, "reason": reason})
        if self.transport.get_write_buffer_size() > CLOSE_FRAME_ROOM:
            self.transport.abort()  # behind a backlog the close frame would never arrive
            return
        # Reading on until the peer answers the close (uvicorn then closes the transport and
        # cancels this timer), for up to READ_AFTER_CLOSE_BYTES: closing a socket with
        # unread data resets it, and the reset can destroy the close frame unread.
        self.close_timer = self.loop.call_later(ABORT_AFTER_S, self.transport.abort)

    def write_frame(self, frame: bytes) -> bool:
        """Send ``frame`` in this turn's write if the connection is open and keeping up.

        False if it is not (closing, or a slow viewer whose socket buffer is full).
        """
        if (
            not self.handshake_complete
            or self.close_sent
            or self.disconnected
            or not self.writable.is_set()  # the socket's buffer is full: a slow viewer
        ):
            return False
        if self._outbox is None:
            self._outbox = [frame]
            _WRITES.get().add(self)
        else:
            self._outbox.append(frame)
        return True

    def _flush_outbox(self) -> None:
        """Write the waiting frames at once; dropped if the connection is closing."""
        frames, self._outbox = self._outbox, None
        if not frames or self.close_sent or self.disconnected or self.transport.is_closing():
            return
        self.transport.write(frames[0] if len(frames) == 1 else b"".join(frames))

    async def send(self, message: ASGISendEvent) -> None:
        """The app's own sends (hello, a slow viewer's backlog) go after the frames before them."""
        self._flush_outbox()
        await super().send(message)


class _Writes:
    """The connections with frames waiting, written together when one timer fires."""

    def __init__(self) -> None:
        self._due: list[StreamingWebSocketProtocol] = []

    def add(self, connection: StreamingWebSocketProtocol) -> None:
        if not self._due:
            connection.loop.call_later(WRITE_EVERY_S, self._write)
        self._due.append(connection)

    def _write(self) -> None:
        due, self._due = self._due, []
        for connection in due:
            connection._flush_outbox()


_WRITES = PerLoop(_Writes)
"""The running loop's writes: every viewer of the process shares their timer."""


FrameWriter = Callable[[bytes], bool]
