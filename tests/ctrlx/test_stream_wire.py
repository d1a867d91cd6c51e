"""Event streams read by our own HTTP/1.1 GET (server/ctrlx/stream_wire.py), and its fallback.

The framings a device may use, cut wherever the network cuts them, over
real loopback sockets; anything but a plain event stream goes through the
client (aiohttp), which renews tokens and says what went wrong.
"""

from __future__ import annotations

import asyncio
import gzip
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import orjson
import pytest
import uvloop
from hypothesis import given
from hypothesis import strategies as st

from server.ctrlx import DataLayerError, StreamEnded, follow
from server.ctrlx.stream_wire import _Chunked, _Connection, open_stream_into
from tests.ctrlx.helpers import IIWA, client, collect, running

EVENTS = b"".join(
    b'event: update\ndata: {"node":"a","value":%d.5,"timestamp":1,"type":"double"}\n\n' % i
    for i in range(40)
)
PATH = "/automation/api/v2/events"


def chunked(payload: bytes, sizes: list[int], extensions: bool = True) -> bytes:
    """``payload`` in the chunked coding, in chunks of ``sizes`` (cycled), with extensions
    or, as devices send them, plain."""
    out, pos, turn = [], 0, 0
    while pos < len(payload):
        size = max(1, sizes[turn % len(sizes)])
        piece, pos, turn = payload[pos : pos + size], pos + size, turn + 1
        extension = b";ext=%d" % turn if extensions else b""
        out.append(b"%x%s\r\n%s\r\n" % (len(piece), extension, piece))
    return b"".join(out) + b"0\r\nTrailer: x\r\n\r\n"


def cut(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in zip(points, points[1:], strict=False)]


@given(
    st.binary(min_size=1, max_size=600),
    st.lists(st.integers(1, 90), min_size=1, max_size=5),
    st.lists(st.integers(0, 10_000), max_size=30),
    st.booleans(),
)
def test_chunked_bodies_come_out_whole_whatever_the_cuts(
    payload: bytes, sizes: list[int], cuts: list[int], extensions: bool
) -> None:
    """Whole plain chunks are taken off by match, the rest byte by byte: the same bytes."""
    body = _Chunked()
    wire = chunked(payload, sizes, extensions)
    out = b"".join(body.take(piece) for piece in cut(wire, cuts))
    assert out == payload
    assert body.done


@pytest.mark.parametrize(
    "after",
    [b"zz\r\n", b"1" * 2000 + b"\r\n", b"-5\r\n", b"5\r\nhelloXY\r\n", b"2\r\nab\r\r\n"],
    ids=["not-hex", "endless-size", "negative", "wrong-size", "two-CRs"],
)
def test_broken_chunk_framing_ends_the_stream(after: bytes) -> None:
    body = _Chunked()
    assert body.take(b"3\r\nabc\n") == b"abc"  # a bare LF after the data is all right
    with pytest.raises(StreamEnded, match="malformed chunk"):
        body.take(after)


Answer = Callable[[int], list[bytes]]
"""What the device writes for the nth GET of the stream (1, 2, ...): pieces, sent apart."""
STALL = b""
"""A piece that makes the device wait 30 s before going on."""


class Device:
    """A loopback HTTP/1.1 device of our own: login answers a token, the stream GET ``answer``."""

    def __init__(self, answer: Answer) -> None:
        self.answer = answer
        self.gets = 0
        self.logins = 0

    async def serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            while head := await reader.readuntil(b"\r\n\r\n"):
                line = head.split(b"\r\n", 1)[0]
                length = 0
                for header in head.split(b"\r\n"):
                    if header.lower().startswith(b"content-length:"):
                        length = int(header.split(b":", 1)[1])
                await reader.readexactly(length)
                if line.startswith(b"POST"):
                    self.logins += 1
                    token = orjson.dumps({"access_token": f"t{self.logins}"})
                    writer.write(
                        b"HTTP/1.1 201 Created\r\nContent-Type: application/json\r\n"
                        b"Content-Length: %d\r\n\r\n%s" % (len(token), token)
                    )
                    continue
                if not line.startswith(b"GET"):  # the logout
                    writer.write(b"HTTP/1.1 204 No Content\r\n\r\n")
                    continue
                self.gets += 1
                for n, piece in enumerate(self.answer(self.gets)):
                    if piece == STALL:
                        await asyncio.sleep(30)
                    if n:
                        await asyncio.sleep(0.005)  # separate network chunks
                    writer.write(piece)
                    await writer.drain()
                writer.close()  # at once: the last bytes and the close may arrive together
                return
        except (asyncio.IncompleteReadError, ConnectionError, asyncio.CancelledError):
            writer.close()


@asynccontextmanager
async def device(answer: Answer) -> AsyncIterator[tuple[Device, str]]:
    fake = Device(answer)
    server = await asyncio.start_server(fake.serve, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    try:
        yield fake, f"http://127.0.0.1:{port}"
    finally:
        server.close()


async def read_all(url: str, **options: object) -> tuple[bytes, Exception, bool]:
    """The stream's bytes, why it ended, and whether a task read it (the client's fallback)."""
    got: list[bytes] = []
    ended: asyncio.Future[Exception] = asyncio.get_running_loop().create_future()
    async with client(url, **options) as c:
        source = await open_stream_into(c, PATH, None, got.append, ended.set_result)
        by_task = any(t.get_name().startswith("event stream") for t in asyncio.all_tasks())
        why = await asyncio.wait_for(ended, 10.0)
        source.close()
    return b"".join(got), why, by_task


def head(*headers: bytes, status: bytes = b"200 OK") -> bytes:
    return b"HTTP/1.1 " + status + b"\r\n" + b"".join(h + b"\r\n" for h in headers) + b"\r\n"


SSE = b"Content-Type: text/event-stream; charset=utf-8"


@pytest.mark.parametrize(
    "framing",
    [
        # The head and the first chunk in one piece, the rest cut anywhere.
        lambda: (
            [head(SSE, b"Transfer-Encoding: chunked") + chunked(EVENTS, [50])[:70]]
            + cut(chunked(EVENTS, [50])[70:], [13, 200, 777, 1500])
        ),
        lambda: [head(SSE, b"Content-Length: %d" % len(EVENTS)), *cut(EVENTS, [5, 1000])],
        lambda: [head(SSE, b"Connection: close"), EVENTS],  # ends with the connection
        lambda: [head(SSE, b"Connection: close").replace(b"\r\n", b"\n"), EVENTS],
        lambda: [head(SSE, b"Connection: close") + EVENTS],  # and closed at once
    ],
    ids=["chunked", "content-length", "until-close", "bare-LF-head", "all-at-once"],
)
@pytest.mark.parametrize("run", [asyncio.run, uvloop.run], ids=["asyncio", "uvloop"])
def test_every_framing_is_read_without_a_task(
    framing: Callable[[], list[bytes]], run: Callable[[Any], Any]
) -> None:
    """On both loops: the server runs on uvloop, whose transports differ from asyncio's."""

    async def main() -> tuple[bytes, Exception, bool, int]:
        async with device(lambda _: framing()) as (fake, url):
            return *(await read_all(url)), fake.gets

    data, why, by_task, gets = run(main())
    assert data == EVENTS
    assert isinstance(why, StreamEnded) and "closed the event stream" in str(why)
    assert not by_task
    assert gets == 1


async def test_the_reads_of_one_turn_are_fed_together_once() -> None:
    """Reads wait in the loop's queue, and a stream's reads of one turn are fed at once: under
    overload each stream is then served once per turn, and robots slow down evenly."""
    fed: list[bytes] = []
    async with client("http://127.0.0.1:9") as c:
        connection = _Connection(b"", c, fed.append, lambda why: None)
        reads = [head(SSE, b"Content-Length: %d" % len(EVENTS)), EVENTS[:100], EVENTS[100:]]
        for read in reads:
            connection.data_received(read)
        assert fed == []
        await asyncio.sleep(0)  # the loop's next turn
        assert fed == [EVENTS]


async def test_a_compressed_stream_is_read_by_the_client_instead() -> None:
    answer = [head(SSE, b"Content-Encoding: gzip", b"Connection: close"), gzip.compress(EVENTS)]
    async with device(lambda _: answer) as (fake, url):
        data, why, by_task = await read_all(url)
    assert data == EVENTS and by_task
    assert fake.gets == 2  # ours, then the client's


async def test_a_refused_token_is_renewed_by_the_client_and_the_stream_read() -> None:
    def answer(get: int) -> list[bytes]:
        if get <= 2:  # ours and the client's first attempt, with the first token
            return [head(b"Content-Length: 0", status=b"401 Unauthorized")]
        return [head(SSE, b"Connection: close"), EVENTS]

    async with device(answer) as (fake, url):
        data, _, by_task = await read_all(url)
    assert data == EVENTS and by_task
    assert fake.logins == 2


async def test_an_answer_that_never_comes_is_a_timeout_naming_the_device() -> None:
    ends: list[Exception] = []
    async with device(lambda _: [b"HTTP/1.1 200 OK\r\n", STALL]) as (_, url):
        async with client(url, timeout_s=0.3) as c:
            with pytest.raises(DataLayerError, match=r"no answer from .* within 0.3 s"):
                await open_stream_into(c, PATH, None, print, ends.append)
            await asyncio.sleep(0.1)  # the connection's close has come and gone
    assert ends == []  # the open's error says it all: ``end`` is for streams that began


async def test_a_stream_cut_in_the_middle_of_a_chunk_says_so() -> None:
    answer = [head(SSE, b"Transfer-Encoding: chunked"), chunked(EVENTS, [64])[:100]]
    async with device(lambda _: answer) as (_, url):
        data, why, _ = await read_all(url)
    assert EVENTS.startswith(data) and data
    assert "event stream broke" in str(why) and "in the middle of an answer" in str(why)


async def test_a_slow_device_is_not_silent_while_the_stream_opens() -> None:
    """Login, the subscription and the GET take 0.9 s each: longer together than the 2.5 s
    of silence after which an open stream counts as dead."""
    async with running() as mock:
        mock.state.faults.latency_s = 0.9
        async with client(mock.url) as c:
            samples = follow(c, IIWA, 0.05, keepalive_s=1.0)
            first = await asyncio.wait_for(anext(samples), 20)
            await samples.aclose()
    assert len(first.values) == 7


async def test_https_streams_are_read_without_a_task(tmp_path: Path) -> None:
    async with running(tls_dir=tmp_path) as mock:
        assert mock.cert is not None
        async with client(mock.url, ca_file=mock.cert.ca_file) as c:
            samples = follow(c, IIWA, 0.02)
            first = await anext(samples)
            tasks = [t.get_name() for t in asyncio.all_tasks()]
            rest = await collect(samples, duration_s=0.3, at_least=5)
    assert len(first.values) == 7 and len(rest) >= 5
    assert not [name for name in tasks if name.startswith("event stream")]


def test_nothing_is_taken_after_the_last_chunk() -> None:
    """Bytes after the last chunk (trailers, or a broken server's chunk-like lines) are no
    payload."""
    body = _Chunked()
    assert body.take(b"3\r\nabc\r\n0\r\n") == b"abc"
    assert body.done
    assert body.take(b"3\r\nxyz\r\n") == b""
