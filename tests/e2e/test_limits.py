"""Hostile clients get a clean answer, and a reading viewer keeps its stream meanwhile.

One server process (token set, 2 s request deadline) serves the whole module. A
viewer in a background thread reads the protocol-2 stream throughout and
timestamps every frames message; each test attacks from the main thread and
checks the frames that arrived during its attack against the rate the same
viewer got in the second just before it (a ratio from the same run: absolute
frame rates on a shared machine are benchmark figures, ``bench/hostile.py``),
and the server's RSS; the last test checks every attack window together.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import statistics
import struct
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect as connect_sync

from tests.conftest import free_port
from tests.web._browser import ROOT, server_process

TOKEN = "limits-test-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
WINDOW_SHARE = 1 / 3
"""In each attack the viewer keeps at least this share of the rate it had in the second just
before (the same run, the machine's load of that moment), and no frame comes later than
FREEZE_S after the one before. An attack that holds the server (its event loop, its GIL)
stops the frames for whole seconds; the machine's other work took up to 54 % of a window
(22.5 of 48.6 frames/s, with a busy loop and browser tests running beside). The median over
all attacks (MEDIAN_SHARE) holds the rate itself; bench/hostile.py measures it."""
FREEZE_S = 1.0
MEDIAN_SHARE = 0.9
"""Over all the attacks, the median share: issue 20's mark (45 of 50 frames a second)."""
QUIET_S = 2.0
BEFORE_S = 1.0
MIB = 1 << 20


class Viewer(threading.Thread):
    """Reads the stream in its own event loop and records when each frames message arrived."""

    def __init__(self, ws_url: str) -> None:
        super().__init__(daemon=True)
        self.ws_url = ws_url
        self.arrivals: list[float] = []
        self.stop = threading.Event()
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            asyncio.run(self._read())
        except BaseException as exc:  # reported by the test that notices the gap
            self.error = exc

    async def _read(self) -> None:
        async with connect(self.ws_url, subprotocols=["linkview.2"], additional_headers=AUTH) as ws:
            while not self.stop.is_set():
                if isinstance(await ws.recv(), bytes):
                    self.arrivals.append(time.monotonic())

    def longest_gap(self, start: float, end: float) -> float:
        """The longest time between start, the frames messages that came, and end."""
        times = [start, *(t for t in self.arrivals if start <= t <= end), end]
        return max(b - a for a, b in zip(times, times[1:], strict=False))

    def fps(self, start: float, end: float) -> float:
        """Frames messages per second (each holds every robot) between two instants."""
        return sum(start <= t <= end for t in self.arrivals) / (end - start)


class Server:
    def __init__(self, url: str, pid: int, viewer: Viewer, quiet_fps: float) -> None:
        self.url, self.pid, self.viewer = url, pid, viewer
        self.port = int(url.rsplit(":", 1)[1])
        self.quiet_fps = quiet_fps
        """Frames messages per second the viewer got before any attack."""
        self.windows: list[tuple[float, float, float, float]] = []
        """(frames/s, frames/s in the second before, seconds, RSS growth in MiB) of each
        attack window so far."""
        self.cell: Path | None = None
        """The cell file it serves, where the attacks write (tests/e2e/test_hostile_cells.py)."""

    def rss_mib(self) -> float:
        for line in Path(f"/proc/{self.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        raise AssertionError("no VmRSS")

    def attacked(self) -> _Window:
        return _Window(self)


class _Window:
    """``with server.attacked():`` checks the reading viewer's frame rate over the block."""

    def __init__(self, server: Server) -> None:
        self.server = server

    def __enter__(self) -> _Window:
        before = time.monotonic()
        time.sleep(BEFORE_S)  # the reference: the viewer's rate just before, same conditions
        self.start = time.monotonic()
        self.before_fps = self.server.viewer.fps(before, self.start)
        self.rss_before = self.server.rss_mib()
        return self

    def __exit__(self, *exc: object) -> None:
        end = max(time.monotonic(), self.start + 2.0)
        while time.monotonic() < end:  # a window of at least 2 s
            time.sleep(0.05)
        server, viewer = self.server, self.server.viewer
        assert viewer.is_alive(), f"the reading viewer died: {viewer.error!r}"
        fps = viewer.fps(self.start, end)
        self.rss_growth = server.rss_mib() - self.rss_before
        server.windows.append((fps, self.before_fps, end - self.start, self.rss_growth))
        assert fps >= WINDOW_SHARE * self.before_fps, (
            f"reading viewer fell to {fps:.1f} frames/s from {self.before_fps:.1f} just before"
        )
        gap = viewer.longest_gap(self.start, end)
        assert gap < FREEZE_S, f"no frame for {gap:.2f} s during the attack"


def _pid_with_arguments(part: bytes) -> int:
    """The process whose command line holds ``part`` (others may come and go meanwhile)."""
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and part in (proc / "cmdline").read_bytes():
                return int(proc.name)
        except OSError:
            continue
    raise AssertionError(f"no process with {part!r} in its command line")


@contextlib.contextmanager
def limits_server(log: Path, *args: str) -> Iterator[Server]:
    """The server these attacks hit (``python -m server ARGS``), a viewer reading it, and that
    viewer's quiet frame rate."""
    env = {"LINKVIEW_VIEWER_TOKEN": TOKEN, "LINKVIEW_CLIENT_TIMEOUT_S": "2"}
    with server_process(free_port(), log, *args, env=env) as url:
        pid = _pid_with_arguments(f"--port\0{url.rsplit(':', 1)[1]}".encode())
        viewer = Viewer(url.replace("http", "ws") + "/ws")
        viewer.start()
        deadline = time.monotonic() + 15
        while len(viewer.arrivals) < 50:  # streaming before any attack
            assert time.monotonic() < deadline, f"no frames: {viewer.error!r}"
            time.sleep(0.05)
        start = time.monotonic()
        time.sleep(QUIET_S)
        quiet = viewer.fps(start, start + QUIET_S)
        try:
            yield Server(url, pid, viewer, quiet)
        finally:
            viewer.stop.set()


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    with limits_server(tmp_path_factory.mktemp("limits") / "server.log") as running:
        yield running


def _answer(sock: socket.socket, limit: int = 65536) -> bytes:
    """What the server says before it closes (or the first 64 KiB)."""
    sock.settimeout(10)
    data = bytearray()  # grown in place: bytes += would copy a 2 MB answer 500 times
    try:
        while len(data) < limit and (chunk := sock.recv(65536)):
            data += chunk
    except (ConnectionResetError, TimeoutError):
        pass
    return bytes(data)


def _status(answer: bytes) -> int:
    return int(answer.split(b" ", 2)[1])


def test_a_100_mb_body_is_refused_before_it_is_read(server: Server) -> None:
    head = (
        f"POST /api/robots/kin12/fk HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n"
        f"Authorization: Bearer {TOKEN}\r\nContent-Type: application/json\r\n"
    )
    with server.attacked() as window:
        with socket.create_connection(("127.0.0.1", server.port)) as sock:
            sock.sendall(f"{head}Content-Length: {100 * MIB}\r\n\r\n".encode())
            declared = _answer(sock)
        # Without a length the body streams in; the server stops it after 1 MiB.
        with socket.create_connection(("127.0.0.1", server.port)) as sock:
            sock.sendall(f"{head}Transfer-Encoding: chunked\r\n\r\n".encode())
            chunk = b"%x\r\n%s\r\n" % (64 * 1024, b"[" * (64 * 1024))
            sent = 0
            try:
                while sent < 100 * MIB:
                    sock.sendall(chunk)
                    sent += 64 * 1024
            except (BrokenPipeError, ConnectionResetError):
                pass
            streamed = _answer(sock)
    assert _status(declared) == 413 and b"larger than 1048576 bytes" in declared
    assert _status(streamed) == 413, streamed[:200]
    assert sent < 20 * MIB, f"the server kept reading: {sent / MIB:.0f} MiB accepted"
    assert window.rss_growth < 20, f"RSS grew by {window.rss_growth:.0f} MiB"


def test_a_1_mb_header_is_refused(server: Server) -> None:
    with server.attacked() as window:
        with socket.create_connection(("127.0.0.1", server.port)) as sock:
            sock.sendall(b"GET /api/health HTTP/1.1\r\nHost: x\r\nX-Pad: ")
            try:
                for _ in range(16):
                    sock.sendall(b"a" * 65536)
                sock.sendall(b"\r\n\r\n")
            except (BrokenPipeError, ConnectionResetError):
                pass
            answer = _answer(sock)
    assert _status(answer) in (400, 431), answer[:200]
    assert window.rss_growth < 20


@pytest.mark.parametrize("size_mib", [1, 16])
def test_large_viewer_messages_close_that_viewer_with_1009(server: Server, size_mib: int) -> None:
    ws_url = server.url.replace("http", "ws") + "/ws"
    with server.attacked() as window:
        with connect_sync(ws_url, additional_headers=AUTH, max_size=None) as ws:
            ws.recv()  # hello
            # The message's frame header (binary, masked, 64-bit length) and its first MiB:
            # the server must refuse on the declared size, not after buffering it all.
            header = struct.pack("!BBQ", 0x82, 0x80 | 127, size_mib * MIB) + b"\0\0\0\0"
            ws.socket.sendall(header + b"\0" * min(size_mib * MIB, MIB))
            try:
                while True:
                    ws.recv(timeout=10)
            except ConnectionClosed as exc:
                closed = exc
    assert closed.rcvd is not None and closed.rcvd.code == 1009
    assert window.rss_growth < 20


def test_2000_idle_and_half_sent_connections_are_closed(server: Server) -> None:
    socks: list[socket.socket] = []
    with contextlib.ExitStack() as closing, server.attacked() as window:
        for i in range(2000):
            sock = socket.create_connection(("127.0.0.1", server.port))
            if i % 2:  # half of them start a request and never finish it
                sock.sendall(b"GET /api/health HTTP/1.1\r\nHost: x\r\n")
            socks.append(closing.enter_context(sock))
        deadline = time.monotonic() + 15  # the server's deadline is 2 s
        open_ = list(socks)
        while open_ and time.monotonic() < deadline:
            time.sleep(0.2)
            still = []
            for sock in open_:
                sock.setblocking(False)
                try:
                    if sock.recv(1) != b"":
                        still.append(sock)
                except BlockingIOError:
                    still.append(sock)
                except ConnectionResetError:
                    pass
            open_ = still
    assert not open_, f"{len(open_)} connections still open after 15 s"
    assert window.rss_growth < 20


def test_foreign_origins_and_bad_tokens_are_refused_without_slowing_viewers(
    server: Server,
) -> None:
    ws_url = server.url.replace("http", "ws") + "/ws"
    cases = [
        ({"Origin": "https://evil.example"}, 403),
        ({"Origin": "https://evil.example", **AUTH}, 403),
        ({}, 401),
        ({"Authorization": "Bearer wrong"}, 401),
    ]
    refused: list[int] = []
    with server.attacked():
        for _ in range(25):
            for headers, _expected in cases:
                try:
                    with connect_sync(ws_url, additional_headers=headers, open_timeout=5):
                        refused.append(101)
                except InvalidStatus as exc:
                    refused.append(exc.response.status_code)
    assert refused == [expected for _ in range(25) for _, expected in cases]


def _ws_handshake(port: int) -> socket.socket:
    """A raw WebSocket connection to /ws, handshake done, nothing read after it."""
    sock = socket.create_connection(("127.0.0.1", port))
    sock.sendall(
        (
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
            f"Sec-WebSocket-Version: 13\r\nAuthorization: Bearer {TOKEN}\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return sock


def _masked(opcode: int, payload: bytes) -> bytes:
    """A client frame (masked with a zero key, which leaves the payload as it is)."""
    return struct.pack("!BB", 0x80 | opcode, 0x80 | len(payload)) + b"\0\0\0\0" + payload


def _metric(server: Server, name: str) -> float:

    request = urllib.request.Request(server.url + "/metrics", headers=AUTH)
    with urllib.request.urlopen(request, timeout=10) as response:
        text = response.read().decode()
    return sum(float(line.rsplit(" ", 1)[1]) for line in text.splitlines() if line.startswith(name))


def test_a_ping_flood_that_never_reads_is_cut_off_and_its_memory_freed(server: Server) -> None:
    closed_before = _metric(server, 'linkview_viewers_closed_total{bound="messages"}')
    ping = _masked(0x9, b"p" * 125)  # each asks for a 127-byte pong
    sock = _ws_handshake(server.port)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # and never reads one
    sent = 0
    with contextlib.closing(sock), server.attacked() as window:
        deadline = time.monotonic() + 12
        try:
            while time.monotonic() < deadline:
                sock.sendall(ping * 64)
                sent += 64
        except (BrokenPipeError, ConnectionResetError):
            pass  # cut off: what it sent after that was refused
        peak = server.rss_mib() - window.rss_before
    assert time.monotonic() < deadline, f"still connected after {sent} pings"
    assert peak < 20, f"RSS grew by {peak:.0f} MiB during the flood"
    assert window.rss_growth < 20
    assert _metric(server, 'linkview_viewers_closed_total{bound="messages"}') > closed_before


def test_a_message_flood_is_closed_with_1008(server: Server) -> None:
    ws_url = server.url.replace("http", "ws") + "/ws"
    with server.attacked() as window:
        with connect_sync(ws_url, additional_headers=AUTH) as ws:
            try:
                for _ in range(5000):
                    ws.send("x" * 100)
                while True:
                    ws.recv(timeout=10)
            except ConnectionClosed as exc:
                closed = exc
    assert closed.rcvd is not None and closed.rcvd.code == 1008, closed
    assert "messages per second" in closed.rcvd.reason
    assert window.rss_growth < 20


def test_heavy_transformation_requests_are_bounded_and_the_stream_holds(server: Server) -> None:

    client = [sys.executable, "-m", "tests.e2e._heavy_client", str(server.port), TOKEN]
    with server.attacked():
        done = subprocess.run(
            client, cwd=ROOT, capture_output=True, text=True, timeout=120, check=True
        )
    answers = json.loads(done.stdout)
    statuses = sorted(status for status, _ in answers)
    assert set(statuses) == {200, 503}, statuses  # some computed, the rest told to wait
    assert all(retry == "1" for status, retry in answers if status == 503), answers


def test_the_attacks_together_left_the_reading_viewer_its_rate(server: Server) -> None:
    """Over every attack window of this module (run it whole): the median share of the
    viewer's rate kept is issue 20's mark, and no attack left memory behind."""
    assert len(server.windows) >= 9, "run the whole module: the attacks come first"
    shares = [fps / before for fps, before, _, _ in server.windows]
    assert statistics.median(shares) >= MEDIAN_SHARE, server.windows
    assert all(growth < 20 for *_, growth in server.windows), server.windows
