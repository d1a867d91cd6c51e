"""uvicorn, configured for a service many viewers share: hard limits on what any client sends.

* request heads above 64 KiB are refused (h11 rather than httptools: it bounds
  the head it buffers, and the HTTP side carries little traffic here);
* a connection has ``REQUEST_TIMEOUT_S`` to deliver a complete request, so
  idle and half-sent connections are closed (uvicorn's keep-alive timer is
  reset by every byte, which lets a slow sender hold a connection forever);
* WebSocket messages from viewers above 4 KiB close the connection (1009);
* no per-message deflate: it would compress every frame once per viewer.
"""

from __future__ import annotations

import asyncio

import h11
import uvicorn
from fastapi import FastAPI
from uvicorn.protocols.http.h11_impl import H11Protocol

from .wire import StreamingWebSocketProtocol

MAX_HEAD_BYTES = 64 * 1024
MAX_VIEWER_MESSAGE_BYTES = 4 * 1024
REQUEST_TIMEOUT_S = 10.0


class GuardedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol with a deadline for each complete request."""

    timeout_s = REQUEST_TIMEOUT_S
    _deadline: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if self.conn.their_state is not h11.IDLE and self.conn.their_state is not h11.SEND_BODY:
            self._disarm()  # the request is in (or the connection switched to WebSocket)

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if self.conn.their_state is h11.IDLE:  # keep-alive: the next request gets a deadline
            self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def _arm(self) -> None:
        self._disarm()
        self._deadline = self.loop.call_later(self.timeout_s, self._expire)

    def _disarm(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _expire(self) -> None:
        self._deadline = None
        if self.transport.get_protocol() is self and not self.transport.is_closing():
            self.transport.close()


def server_config(
    app: FastAPI,
    host: str,
    port: int,
    request_timeout_s: float = REQUEST_TIMEOUT_S,
    **extra: object,
) -> uvicorn.Config:
    """The uvicorn configuration every linkview server runs with (tests included)."""
    protocol = type("GuardedH11Protocol", (GuardedH11Protocol,), {"timeout_s": request_timeout_s})
    return uvicorn.Config(
        app,
        host=host,
        port=port,
        log_level="warning",
        http=protocol,
        h11_max_incomplete_event_size=MAX_HEAD_BYTES,
        ws=StreamingWebSocketProtocol,
        ws_max_size=MAX_VIEWER_MESSAGE_BYTES,
        ws_per_message_deflate=False,
        timeout_keep_alive=5,
        **extra,  # type: ignore[arg-type]
    )
