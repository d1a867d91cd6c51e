"""A token check in front of the Foxglove WebSocket server, which cannot refuse clients itself.

foxglove-sdk's server has no hook to look at a connecting client's request
(its ServerListener hears of clients only once they subscribe), so with a
viewer token the SDK listens on a loopback port only this process knows,
and this guard listens where the user asked: it reads the WebSocket upgrade
request, refuses it with 401 unless it carries the token (``?token=`` in the
URL, ``Authorization: Bearer``, or the page's cookie), and otherwise pipes
the connection through unchanged.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
from http.cookies import CookieError, SimpleCookie
from urllib.parse import parse_qs, urlsplit

log = logging.getLogger(__name__)

TOKEN_COOKIE = "linkview_token"
"""The page's cookie (server.web.guards sets it), so a browser that opened the page may connect."""
MAX_HEAD_BYTES = 16 * 1024
HEAD_TIMEOUT_S = 10.0
CHUNK = 64 * 1024


def token_of(head: bytes) -> str | None:
    """The viewer token an HTTP request head carries, if any."""
    try:
        lines = head.decode("latin-1").split("\r\n")
        target = lines[0].split(" ")[1]
    except IndexError:
        return None
    query = parse_qs(urlsplit(target).query)
    if "token" in query:
        return query["token"][0]
    for line in lines[1:]:
        name, _, value = line.partition(":")
        name, value = name.strip().lower(), value.strip()
        if name == "authorization" and value.lower().startswith("bearer "):
            return value[7:].strip()
        if name == "cookie":
            with contextlib.suppress(CookieError):
                morsel = SimpleCookie(value).get(TOKEN_COOKIE)
                if morsel is not None:
                    return morsel.value
    return None


class TokenGuard:
    """Listens on ``host:port`` and lets through to ``127.0.0.1:upstream`` who shows ``token``."""

    def __init__(self, token: str, upstream_port: int) -> None:
        self.token = token.encode()
        self.upstream_port = upstream_port
        self.refused = 0
        self._server: asyncio.Server | None = None

    async def start(self, host: str, port: int) -> int:
        """Start listening; returns the port (useful with 0)."""
        self._server = await asyncio.start_server(self._handle, host, port, limit=MAX_HEAD_BYTES)
        return int(self._server.sockets[0].getsockname()[1])

    async def stop(self) -> None:
        """Stop listening and close every connection."""
        if self._server is not None:
            self._server.close()
            if hasattr(self._server, "close_clients"):  # Python 3.13+
                self._server.close_clients()
            await self._server.wait_closed()

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT_S)
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, TimeoutError, OSError):
            writer.close()
            return
        given = token_of(head)
        if given is None or not secrets.compare_digest(given.encode(), self.token):
            self.refused += 1
            body = b"viewer token missing or wrong\n"
            writer.write(
                b"HTTP/1.1 401 Unauthorized\r\nContent-Type: text/plain\r\nConnection: close\r\n"
                + f"Content-Length: {len(body)}\r\n\r\n".encode()
                + body
            )
            with contextlib.suppress(OSError):
                await writer.drain()
            writer.close()
            return
        try:
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.upstream_port)
        except OSError as exc:
            log.error("foxglove endpoint: cannot reach the SDK's server: %s", exc)
            writer.close()
            return
        up_writer.write(head)
        await asyncio.gather(_pipe(reader, up_writer), _pipe(up_reader, writer))


async def _pipe(source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
    """Copy until either side closes."""
    try:
        while data := await source.read(CHUNK):
            sink.write(data)
            await sink.drain()
    except (OSError, asyncio.CancelledError):
        pass
    finally:
        sink.close()
