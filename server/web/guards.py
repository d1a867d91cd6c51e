"""Who may watch and how much they may send: Origin check, viewer token, request body limit.

Pure ASGI middleware rather than FastAPI dependencies: a refused request is
answered before any route, body parser or WebSocket handshake runs.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterable
from http.cookies import SimpleCookie
from urllib.parse import parse_qs, urlsplit

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

MAX_BODY_BYTES = 1 << 20
"""Request bodies above 1 MiB are refused with 413 before they are read."""
TOKEN_COOKIE = "linkview_token"


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


def origin_of(url: str) -> str:
    """``scheme://host[:port]`` of a URL, lower-cased, default ports dropped."""
    parts = urlsplit(url.strip())
    scheme = (parts.scheme or "http").lower()
    host = (parts.hostname or "").lower()
    default = {"http": 80, "https": 443, "ws": 80, "wss": 443}.get(scheme)
    port = "" if parts.port in (None, default) else f":{parts.port}"
    return f"{scheme}://{host}{port}"


class Gatekeeper:
    """Refuses foreign origins on ``/ws`` and, with a viewer token set, anyone without it.

    * ``Origin`` (sent by browsers) must be the server's own origin or one of
      ``allowed_origins``; a page on another site cannot open the stream. A
      missing Origin is a non-browser client, which the token (if any) guards.
    * The token comes as a cookie (set by opening the page with ``?token=``,
      ``HttpOnly`` and ``SameSite=Strict``), a ``?token=`` query, or an
      ``Authorization: Bearer`` header.
    """

    def __init__(
        self, app: ASGIApp, token: str | None = None, allowed_origins: Iterable[str] = ()
    ) -> None:
        self.app = app
        self.token = token or None
        self.allowed = {origin_of(o) for o in allowed_origins}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket" and not self._origin_ok(scope):
            await refuse(scope, send, 403, "cross-origin WebSocket refused")
            return
        if self.token is not None:
            given, from_query = self._token_of(scope)
            if given is None or not secrets.compare_digest(given.encode(), self.token.encode()):
                await refuse(scope, send, 401, "viewer token missing or wrong")
                return
            if from_query and scope["type"] == "http":
                send = _setting_cookie(send, self.token)
        await self.app(scope, receive, send)

    def _origin_ok(self, scope: Scope) -> bool:
        origin = _header(scope, b"origin")
        if origin is None:
            return True
        host = _header(scope, b"host") or ""
        scheme = "https" if scope.get("scheme") in ("https", "wss") else "http"
        own = origin_of(f"{scheme}://{host}")
        return origin_of(origin) in self.allowed | {own}

    def _token_of(self, scope: Scope) -> tuple[str | None, bool]:
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        if "token" in query:
            return query["token"][0], True
        auth = _header(scope, b"authorization")
        if auth is not None and auth.startswith("Bearer "):
            return auth[7:], False
        cookies = SimpleCookie(_header(scope, b"cookie") or "")
        morsel = cookies.get(TOKEN_COOKIE)
        return (morsel.value if morsel is not None else None), False


def _setting_cookie(send: Send, token: str) -> Send:
    cookie = f"{TOKEN_COOKIE}={token}; Path=/; HttpOnly; SameSite=Strict".encode("latin-1")

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
