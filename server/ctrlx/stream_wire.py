"""An event stream's bytes, handed on as they arrive: our own HTTP/1.1 GET for the happy path.

Why our own: aiohttp hands a response body to a task that awaits it, so
every network chunk costs its HTTP parser, a stream reader, a future and a
task wake-up, and a chunk of an event stream is one sample of one robot.
Following 100 controllers that way cost about 120 µs of CPU per sample,
this way (with plain cycles decoded in one pass) 86 (bench/sse_read.py).
Here the event loop calls ``data_received``, and the ready queue then takes
the chunked framing off and calls ``feed``: no task runs.

Only a working stream is read this way. Any other outcome of the GET (an
error status, a token the device refused, trouble connecting or with TLS, a
framing we do not read) is asked again through the client, which says what
went wrong as for every other request and renews tokens; a stream it then
opens is read the usual way, by a task (``_Pump``).
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Callable
from typing import Protocol, cast

import aiohttp
from yarl import URL

from ..lateness import PatientTimeout
from .client import DataLayerClient
from .connection import connection_error, cut_short, os_error
from .problem import StreamEnded

Feed = Callable[[bytes], None]
"""Takes the body's bytes as they come; must not raise."""
End = Callable[[Exception], None]
"""Takes why the stream ended (called once at most, never after ``close``)."""

MAX_HEAD_BYTES = 64 * 1024
MAX_SIZE_LINE = 1024
"""A chunk-size line (hex size, maybe extensions) is a few bytes."""
_HEX = re.compile(rb"[0-9A-Fa-f]{1,15}")
_CHUNK_HEAD = re.compile(rb"([0-9A-Fa-f]{1,15})\r\n")
"""A chunk's size line, as servers write it (no extensions, CRLF)."""


class ByteSource(Protocol):
    """What feeds an event stream; ``close`` drops the connection."""

    def close(self) -> None: ...


class _NotAStream(Exception):
    """The GET gave no event stream we read ourselves: the client asks again and says why."""


async def open_stream_into(
    client: DataLayerClient, path: str, params: dict[str, str] | None, feed: Feed, end: End
) -> ByteSource:
    """GET the event stream at ``path``; its body goes to ``feed``, how it ended to ``end``.

    Raises what ``client.open_stream`` raises when there is no stream to read.
    """
    try:
        return await _open_direct(client, path, params, feed, end)
    except _NotAStream:
        pass
    return _Pump(await client.open_stream(path, params=params), client, feed, end)


async def _open_direct(
    client: DataLayerClient, path: str, params: dict[str, str] | None, feed: Feed, end: End
) -> ByteSource:
    url = URL(client.base_url + path)
    if params:
        url = url.with_query(params)
    if url.scheme not in ("http", "https") or not url.raw_host or url.port is None:
        raise _NotAStream
    tls = client.stream_ssl() if url.scheme == "https" else None
    token = await client.tokens.current()
    host = f"[{url.raw_host}]" if ":" in url.raw_host else url.raw_host
    authority = host if url.explicit_port is None else f"{host}:{url.port}"
    request = (
        f"GET {url.raw_path_qs} HTTP/1.1\r\nHost: {authority}\r\n"
        f"Authorization: Bearer {token}\r\nAccept: text/event-stream\r\n"
        "Accept-Encoding: identity\r\nCache-Control: no-cache\r\n\r\n"
    ).encode("latin-1")
    client.traffic.requests += 1
    connection = _Connection(request, client, feed, end)
    try:
        async with PatientTimeout(client.timeout_s):
            await asyncio.get_running_loop().create_connection(
                lambda: connection,
                url.raw_host,
                url.port,
                ssl=tls,
                server_hostname=url.raw_host if tls is not None else None,
            )
            is_stream = await connection.head
    except BaseException as exc:
        connection.close()  # and never calls ``end``: the caller learns it from the raise
        if isinstance(exc, TimeoutError):  # before OSError, of which it is one
            raise client.no_answer("GET", path) from None
        if isinstance(exc, OSError):  # refused, unreachable, TLS: the client's attempt says why
            raise _NotAStream from None
        raise
    if not is_stream:
        connection.close()
        raise _NotAStream
    client.tokens.accepted()
    return connection


class _Connection(asyncio.Protocol):
    """One GET: writes the request, reads the answer's head, then passes the body on."""

    def __init__(self, request: bytes, client: DataLayerClient, feed: Feed, end: End) -> None:
        self._request = request
        self._client = client
        self._feed = feed
        self._end = end
        self._loop = asyncio.get_running_loop()
        self.head: asyncio.Future[bool] = self._loop.create_future()
        """True once a 200 event stream began; False for any other answer."""
        self._head = b""
        self._body: _Chunked | _Counted | None = None
        self._transport: asyncio.Transport | None = None
        self._received: list[bytes] | None = None
        """Bytes read but not yet taken (see data_received)."""
        self._ended = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # A Transport in fact, though uvloop's do not derive from asyncio's class.
        self._transport = cast(asyncio.Transport, transport)
        self._transport.write(self._request)

    def data_received(self, data: bytes) -> None:
        # Taken in the loop's queue of ready callbacks, not in the read: where each read did
        # a sample's work, an overloaded uvloop read 16 equal streams 10 to 19 times a
        # second, and robots must slow down evenly. The queue serves each once per turn.
        if self._received is None:
            self._received = [data]
            self._loop.call_soon(self._take_received)
        else:
            self._received.append(data)

    def _take_received(self) -> None:
        received, self._received = self._received or [], None
        data = received[0] if len(received) == 1 else b"".join(received)
        if self._ended:
            return
        if self._body is None:
            rest = self._read_head(data)
            if rest is None:
                return
            data = rest
        assert self._body is not None
        try:
            body = self._body.take(data)
        except StreamEnded as exc:
            self._finish(exc)
            return
        if body:
            self._client.traffic.bytes_in += len(body)
            self._feed(body)
        if self._body.done:
            self._finish(StreamEnded("the server closed the event stream"))

    def _read_head(self, data: bytes) -> bytes | None:
        """The bytes after the head once it is complete (and an event stream); else None."""
        buffer = self._head + data
        cut = _head_end(buffer)
        if cut is None:
            self._head = buffer
            if len(buffer) > MAX_HEAD_BYTES:
                self._refuse()
            return None
        self._head = b""
        self._body = _body_of(buffer[: cut[0]])
        if self._body is None:
            self._refuse()
            return None
        if self.head.done():  # the opener gave up meanwhile
            self._ended = True
            return None
        self.head.set_result(True)
        return buffer[cut[1] :]

    def _refuse(self) -> None:
        self._ended = True
        if not self.head.done():
            self.head.set_result(False)

    def connection_lost(self, exc: Exception | None) -> None:
        self._loop.call_soon(self._lost, exc)  # after the bytes read before it are taken

    def _lost(self, exc: Exception | None) -> None:
        if self._ended:
            return
        if not self.head.done():
            self.head.set_exception(exc or ConnectionResetError("closed before answering"))
            self.head.exception()  # retrieved: the opener may have given up on it already
            return
        if exc is None and self._body is not None and self._body.ends_with_connection:
            self._finish(StreamEnded("the server closed the event stream"))
        elif exc is None:  # in the middle of a chunk or of the announced length
            self._finish(StreamEnded(f"event stream broke: {cut_short(self._client.base_url)}"))
        else:
            reason = os_error(self._client.base_url, exc) if isinstance(exc, OSError) else exc
            self._finish(StreamEnded(f"event stream broke: {reason}"))

    def _finish(self, why: Exception) -> None:
        if not self._ended:
            self._ended = True
            self._end(why)
        if self._transport is not None:
            self._transport.abort()

    def close(self) -> None:
        """Drop the connection; ``end`` is not called (the owner knows)."""
        self._ended = True
        if self._transport is not None:
            self._transport.abort()


def _head_end(buffer: bytes) -> tuple[int, int] | None:
    """Where the head ends and the body begins: at the first empty line (CRLF, or bare LF
    as some small servers send it)."""
    ends = [
        (at, at + len(blank)) for blank in (b"\r\n\r\n", b"\n\n") if (at := buffer.find(blank)) >= 0
    ]
    return min(ends) if ends else None


def _body_of(head: bytes) -> _Chunked | _Counted | None:
    """How the body of a ``200 text/event-stream`` answer is framed; None for any other answer."""
    lines = [line.rstrip("\r") for line in head.decode("latin-1").split("\n")]
    version, _, rest = lines[0].partition(" ")
    if not version.startswith("HTTP/1.") or rest.partition(" ")[0] != "200":
        return None
    headers: dict[str, str] = {}
    for line in lines[1:]:
        name, colon, value = line.partition(":")
        if not colon or name[:1] in (" ", "\t"):
            return None  # folded or broken: the client's parser judges it
        key = name.strip().lower()
        headers[key] = f"{headers[key]}, {value.strip()}" if key in headers else value.strip()
    kind = headers.get("content-type", "").split(";", 1)[0].strip().lower()
    encoding = headers.get("content-encoding", "identity").strip().lower()
    if kind != "text/event-stream" or encoding not in ("", "identity"):
        return None
    transfer = headers.get("transfer-encoding", "").strip().lower()
    if transfer:
        return _Chunked() if transfer == "chunked" else None
    length = headers.get("content-length")
    if length is None:
        return _Counted(None)  # the body ends when the connection does
    return _Counted(int(length)) if length.isascii() and length.isdigit() else None


class _Counted:
    """A body of ``Content-Length`` bytes, or (None) one that ends with the connection."""

    def __init__(self, length: int | None) -> None:
        self._left = length
        self.ends_with_connection = length is None
        self.done = length == 0

    def take(self, data: bytes) -> bytes:
        if self._left is None:
            return data
        data = data[: self._left]
        self._left -= len(data)
        self.done = self._left == 0
        return data


class _Chunked:
    """Takes the chunked transfer coding off, whatever the network's cuts (RFC 9112, 7.1)."""

    ends_with_connection = False

    def __init__(self) -> None:
        self._left = 0
        """Bytes of the current chunk still to come."""
        self._line_end = False
        """True after a chunk's data, until the line end that must follow it."""
        self._cr = False
        self._line = b""
        self.done = False

    def take(self, data: bytes) -> bytes:
        """The payload in ``data``; raises StreamEnded where the framing is broken."""
        parts: list[bytes] = []
        pos, size = self._whole_chunks(data, parts), len(data)
        while pos < size and not self.done:
            if self._left:
                piece = data[pos : pos + self._left]
                parts.append(piece)
                pos += len(piece)
                self._left -= len(piece)
                self._line_end = not self._left
            elif self._line_end:  # CRLF (or a bare LF), nothing else: else sizes went wrong
                if data[pos] == 0x0D and not self._cr:
                    self._cr = True
                elif data[pos] == 0x0A:
                    self._cr = self._line_end = False
                else:
                    raise _malformed()
                pos += 1
            else:
                pos = self._size_line(data, pos)
        return parts[0] if len(parts) == 1 else b"".join(parts)

    def _whole_chunks(self, data: bytes, parts: list[bytes]) -> int:
        """Takes off the whole chunks ``data`` begins with, one match each; where the rest begins.

        A device sends a chunk per publish cycle, and a read holds one or a few
        of them: the byte-wise way (``take``) costs three times as much.
        """
        pos = 0
        if self.done or self._left or self._line_end or self._line:
            return pos
        while (head := _CHUNK_HEAD.match(data, pos)) is not None:
            start = head.end()
            end = start + int(head[1], 16)
            if end == start or data[end : end + 2] != b"\r\n":
                break  # the last chunk, or one cut short: read byte-wise
            parts.append(data[start:end])
            pos = end + 2
        return pos

    def _size_line(self, data: bytes, pos: int) -> int:
        """Reads a chunk-size line from ``pos``; where the data after it begins."""
        cut = data.find(b"\n", pos)
        line = self._line + (data[pos:] if cut < 0 else data[pos:cut])
        if len(line) > MAX_SIZE_LINE:
            raise _malformed()
        if cut < 0:
            self._line = line
            return len(data)
        self._line = b""
        digits = line.split(b";", 1)[0].strip()
        if _HEX.fullmatch(digits) is None:
            raise _malformed()
        self._left = int(digits, 16)
        self.done = self._left == 0  # the last chunk: trailers may follow; the stream is over
        return cut + 1


def _malformed() -> StreamEnded:
    return StreamEnded("event stream sent a malformed chunk (size or line end); dropped")


class _Pump:
    """A stream the client opened (aiohttp), read by a task into the same ``feed``."""

    def __init__(
        self, response: aiohttp.ClientResponse, client: DataLayerClient, feed: Feed, end: End
    ) -> None:
        self._response = response
        self._client = client
        self._feed = feed
        self._end = end
        self._task = asyncio.create_task(self._run(), name=f"event stream {client.base_url}")

    async def _run(self) -> None:
        try:
            while chunk := await self._response.content.readany():
                self._client.traffic.bytes_in += len(chunk)
                self._feed(chunk)
        except aiohttp.ClientError as exc:
            reason = connection_error(self._client.base_url, exc)
            self._end(StreamEnded(f"event stream broke: {reason}"))
            return
        self._end(StreamEnded("the server closed the event stream"))

    def close(self) -> None:
        self._task.cancel()
        self._response.close()
