"""Frames written straight to a viewer's socket: framed once per message, one write per viewer.

Every viewer gets the same bytes, and a server's WebSocket frames are not
masked, so a message can be framed once and the frame written to each
viewer's transport as it is. Going through ASGI instead costs a task switch,
an event, a dict and a framing per viewer and message; at 500 viewers and 50
frames a second that is most of a core. uvicorn's sans-I/O WebSocket protocol
is extended with one method, offered to the app as an ASGI extension.
"""

from __future__ import annotations

import struct
from collections.abc import Callable

from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol
from websockets.http11 import Request

from ..stream.hub import Payload

EXTENSION = "linkview.write_frame"
_TEXT, _BINARY = 0x81, 0x82  # FIN + opcode


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
    """uvicorn's sans-I/O WebSocket protocol that can also write ready-made frames."""

    def handle_connect(self, event: Request) -> None:
        super().handle_connect(event)
        if hasattr(self, "scope"):
            self.scope["extensions"][EXTENSION] = {"write": self.write_frame}

    def write_frame(self, frame: bytes) -> bool:
        """Write ``frame`` now if the connection is open and keeping up; False if not."""
        if (
            not self.handshake_complete
            or self.close_sent
            or self.disconnected
            or not self.writable.is_set()  # the socket's buffer is full: a slow viewer
        ):
            return False
        self.transport.write(frame)
        return True


FrameWriter = Callable[[bytes], bool]
