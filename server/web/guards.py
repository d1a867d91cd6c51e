"""Who may watch and how much they may send: Host, Origin, viewer token, request body limit.

Pure ASGI middleware rather than FastAPI dependencies: a refused request is
answered before any route, body parser or WebSocket handshake runs.
"""

from __future__ import annotations

from collections.abc import Iterable

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from ..access import TOKEN_COOKIE, Access, token_given
from ..hosts import HostPolicy

MAX_BODY_BYTES = 1 << 20
"""Request bodies above 1 MiB are refused with 413 before they are read."""
WRITES = frozenset({"POST", "PUT", "PATCH", "DELETE"})
"""Methods that may change state: a cross-site page must not be able to send them."""


class BodyTooLarge(HTTPException):
    """A request body found too large while streaming in (no Content-Length to check first)."""

    def __init__(self) -> None:
        # Closing is the only way to stop a sender mid-body; kept open, it would be drained.
        headers = {"Connection": "close"}
        super().__init__(413, f"request body larger than {MAX_BODY_BYTES} bytes", headers)


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", []):
        if key == name:
            return str(value.decode("latin-1"))
    return None


class Gatekeeper:
    """Refuses other sites' pages and, with a viewer token set, anyone without it.

    The rules are ``access.Access``'s: ``Host`` on every request; ``Origin``
    on ``/ws`` and on every request that may change state (POST, PUT, PATCH,
    DELETE), which must also be JSON: a page on another site can neither open
    the stream nor send a "simple" form or text/plain request, which browsers
    send without asking first; the token on everything. A token given as
    ``?token=`` is set as a cookie (``HttpOnly``, ``SameSite=Strict`` and,
    over TLS, ``Secure``).
    """

    def __init__(
        self,
        app: ASGIApp,
        token: str | None = None,
        allowed_origins: Iterable[str] = (),
        hosts: HostPolicy | None = None,
    ) -> None:
        self.app = app
        self.access = Access(token, allowed_origins, hosts)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refusal = self.access.host_refusal(_header(scope, b"host"))
        if refusal is not None:
            await refuse(scope, send, 403, refusal)
            return
        if scope["type"] == "websocket" and not self._origin_ok(scope):
            await refuse(scope, send, 403, "cross-origin WebSocket refused")
            return
        if scope["type"] == "http" and scope["method"] in WRITES:
            reason = self._write_refusal(scope)
            if reason is not None:
                status, text = reason
                await refuse(scope, send, status, text)
                return
        token = self.access.token
        if token is not None:
            given, from_query = token_given(
                scope.get("query_string", b"").decode("latin-1"),
                _header(scope, b"authorization"),
                _header(scope, b"cookie"),
            )
            if not self.access.token_ok(given):
                await refuse(scope, send, 401, "viewer token missing or wrong")
                return
            if from_query and scope["type"] == "http":
                send = _setting_cookie(send, token, secure=scope.get("scheme") == "https")
        await self.app(scope, receive, send)

    def _write_refusal(self, scope: Scope) -> tuple[int, str] | None:
        if not self._origin_ok(scope):
            return 403, (
                "cross-origin request refused: only this server's own page (or an origin "
                "given with --allow-origin) may send it"
            )
        kind = (_header(scope, b"content-type") or "").split(";", 1)[0].strip().lower()
        if kind != "application/json":
            return 415, f"{scope['method']} takes a JSON body (Content-Type: application/json)"
        return None

    def _origin_ok(self, scope: Scope) -> bool:
        secure = scope.get("scheme") in ("https", "wss")
        return self.access.origin_ok(_header(scope, b"origin"), _header(scope, b"host"), secure)


def _setting_cookie(send: Send, token: str, secure: bool) -> Send:
    flags = "; Secure" if secure else ""  # over plain HTTP a browser would drop a Secure one
    cookie = f"{TOKEN_COOKIE}={token}; Path=/; HttpOnly; SameSite=Strict{flags}".encode("latin-1")

    async def send_with_cookie(message: Message) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message["headers"], (b"set-cookie", cookie)]}
        await send(message)

    return send_with_cookie


async def refuse(scope: Scope, send: Send, status: int, reason: str) -> None:
    """Answer ``status`` with ``reason``; for a WebSocket, before the handshake completes."""
    body = reason.encode()
    headers = [
        (b"content-type", b"text/plain; charset=utf-8"),
        (b"content-length", b"%d" % len(body)),
    ]
    if scope["type"] == "websocket":
        if "websocket.http.response" in scope.get("extensions", {}):
            await send(
                {"type": "websocket.http.response.start", "status": status, "headers": headers}
            )
            await send({"type": "websocket.http.response.body", "body": body})
        else:
            await send({"type": "websocket.close", "code": 1008})  # the server answers 403
        return
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class LimitBody:
    """413 for request bodies over MAX_BODY_BYTES: by Content-Length before reading, else
    as soon as the streamed body passes the limit (BodyTooLarge, an HTTPException)."""

    def __init__(self, app: ASGIApp, limit: int = MAX_BODY_BYTES) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        length = _header(scope, b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.limit):
            await _refuse_body(send, self.limit)
            return
        seen = 0

        async def counted() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.limit:
                    raise BodyTooLarge()
            return message

        await self.app(scope, counted, send)


async def _refuse_body(send: Send, limit: int) -> None:
    body = b'{"detail": "request body larger than %d bytes"}' % limit
    await send(
        {
            "type": "http.response.start",
            "status": 413,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", b"%d" % len(body)),
                (b"connection", b"close"),  # the unread body must not be taken as a request
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
