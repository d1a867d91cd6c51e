"""Data-layer traffic and latency: subscription vs bulk polling vs one GET per node.

Runs the standalone mock (``python -m server.mock_ctrlx``) and the real server
(``python -m server --ctrlx URL --mode M``) as separate processes, for the
default cell at 50 Hz and 100 Hz, and watches with a WebSocket viewer on
loopback. For each case it reports data-layer requests and response body bytes
per second (counted by the mock), frames per second per robot, and the delay
from the data layer's sample time (``t_source``) to the viewer's receipt.

``get`` frames carry no data-layer timestamp (a plain GET has none), so their
``t_source`` is the middle of the round trip: their delay is slightly
understated.

Usage: ``python bench/datalayer.py [--seconds 5] [--quick]``; writes docs/benchmarks.md except in
quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import aiohttp
from websockets.asyncio.client import connect

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402

from tests.conftest import free_port  # noqa: E402

MODES = ("subscribe", "poll", "get")
RATES_HZ = (50, 100)


@dataclass(frozen=True)
class Result:
    mode: str
    rate_hz: int
    requests_per_s: float
    bytes_per_s: float
    """On the wire between server and data layer, both directions."""
    body_bytes_per_s: float
    """Response bodies only, as the mock counts them."""
    frames_per_s: float
    p50_ms: float
    p99_ms: float


@contextlib.contextmanager
def process(args: list[str], env: dict[str, str] | None = None) -> Iterator[subprocess.Popen[str]]:
    """A child Python process, stopped (and waited for) on exit."""
    proc = subprocess.Popen(
        [sys.executable, *args],
        cwd=ROOT,
        env={**os.environ, **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        yield proc
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


class Relay:
    """A TCP relay between server and mock that counts the bytes on the wire, both ways.

    Headers, bearer tokens and chunk framing included, which body counts miss.
    """

    def __init__(self, target_port: int) -> None:
        self.target_port = target_port
        self.bytes = 0
        self.port = 0
        self._server: asyncio.Server | None = None
        self._writers: set[asyncio.StreamWriter] = set()

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._handle, "127.0.0.1", 0)
        self.port = self._server.sockets[0].getsockname()[1]

    async def stop(self) -> None:
        """Stop listening and close every relayed connection, so the pumps end by themselves."""
        if self._server is not None:
            self._server.close()
        for writer in self._writers:
            writer.close()
        await asyncio.sleep(0.2)

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target_port)
        except OSError:
            writer.close()
            return
        self._writers |= {writer, up_writer}
        await asyncio.gather(self._pump(reader, up_writer), self._pump(up_reader, writer))
        self._writers -= {writer, up_writer}

    async def _pump(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            while chunk := await reader.read(65536):
                self.bytes += len(chunk)
                writer.write(chunk)
                await writer.drain()
        except ConnectionError:
            pass
        finally:
            writer.close()


async def mock_stats(http: aiohttp.ClientSession, mock_url: str) -> dict[str, int]:
    async with http.get(mock_url + "/mock/stats") as resp:
        stats: dict[str, int] = await resp.json()
        return stats


async def wait_connected(http: aiohttp.ClientSession, base: str) -> None:
    async with asyncio.timeout(30):
        while True:
            with contextlib.suppress(aiohttp.ClientError):
                async with http.get(base + "/api/health") as resp:
                    health = await resp.json()
                    if health["sources"] and health["sources"][0]["state"] == "connected":
                        return
            await asyncio.sleep(0.1)


async def watch(base: str, until: float) -> list[tuple[float, str, float]]:
    """(monotonic receipt, robot, receipt - t_source) of every frame until ``until``."""
    out: list[tuple[float, str, float]] = []
    async with connect(base.replace("http", "ws") + "/ws", max_size=None) as ws:
        async with asyncio.timeout(until - time.monotonic() + 10):
            while time.monotonic() < until:
                raw = await ws.recv()
                received, mono = time.time(), time.monotonic()
                msg = json.loads(raw)
                if msg.get("type") == "frame":
                    out.append((mono, msg["robot"], received - msg["t_source"]))
    return out


async def run_case(mock_url: str, relay: Relay, mode: str, rate_hz: int, seconds: float) -> Result:
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = {"LINKVIEW_POLL_INTERVAL_S": str(1.0 / rate_hz)}
    relayed = f"http://127.0.0.1:{relay.port}"
    args = ["-m", "server", "--port", str(port), "--ctrlx", relayed, "--mode", mode]
    with process(args, env):
        async with aiohttp.ClientSession() as http:
            await wait_connected(http, base)
            begin = time.monotonic() + 1.0  # warm-up first
            end = begin + seconds
            viewer = asyncio.create_task(watch(base, end))
            await asyncio.sleep(begin - time.monotonic())
            stats0, wire0 = await mock_stats(http, mock_url), relay.bytes
            await asyncio.sleep(end - time.monotonic())
            stats1, wire1 = await mock_stats(http, mock_url), relay.bytes
            frames = [f for f in await viewer if begin <= f[0] < end]
    delays = [delay for _, _, delay in frames]
    robots = {robot for _, robot, _ in frames}
    per_robot = min(sum(1 for f in frames if f[1] == r) for r in robots)
    q = statistics.quantiles(delays, n=100)
    return Result(
        mode=mode,
        rate_hz=rate_hz,
        requests_per_s=(stats1["requests"] - stats0["requests"]) / seconds,
        bytes_per_s=(wire1 - wire0) / seconds,
        body_bytes_per_s=(stats1["bytes_out"] - stats0["bytes_out"]) / seconds,
        frames_per_s=per_robot / seconds,
        p50_ms=q[49] * 1000,
        p99_ms=q[98] * 1000,
    )


async def main(
    seconds: float, modes: tuple[str, ...] = MODES, rates_hz: tuple[int, ...] = RATES_HZ
) -> list[Result]:
    port = free_port()
    mock_url = f"http://127.0.0.1:{port}"
    results: list[Result] = []
    with process(["-m", "server.mock_ctrlx", "--port", str(port)]) as mock:
        assert mock.stdout is not None
        mock.stdout.readline()  # "mock ctrlX data layer at ..." once it listens
        relay = Relay(port)
        await relay.start()
        for rate_hz in rates_hz:
            for mode in modes:
                result = await run_case(mock_url, relay, mode, rate_hz, seconds)
                print(
                    f"{mode:9s} {rate_hz:3d} Hz: {result.requests_per_s:7.1f} req/s "
                    f"{result.bytes_per_s / 1000:7.1f} kB/s on the wire "
                    f"({result.body_bytes_per_s / 1000:5.1f} kB/s bodies) "
                    f"{result.frames_per_s:6.1f} frames/s "
                    f"p50 {result.p50_ms:6.2f} ms p99 {result.p99_ms:6.2f} ms",
                    flush=True,
                )
                results.append(result)
        await relay.stop()
    return results


def report(results: list[Result], seconds: float, nodes: int, quick: bool) -> None:
    header = [
        "mode", "rate", "data-layer requests/s", "bytes/s on the wire", "of which response bodies",
        "frames/s per robot", "t_source → viewer p50", "p99",
    ]  # fmt: skip
    rows = [
        [
            r.mode,
            f"{r.rate_hz} Hz",
            f"{r.requests_per_s:.1f}",
            f"{r.bytes_per_s / 1000:.1f} k",
            f"{r.body_bytes_per_s / 1000:.1f} k",
            f"{r.frames_per_s:.1f}",
            f"{r.p50_ms:.2f} ms",
            f"{r.p99_ms:.2f} ms",
        ]
        for r in results
    ]
    body = (
        f"Default cell ({nodes} joint nodes), mock and server as separate processes, one "
        f"WebSocket viewer, {seconds:g} s per case after 1 s of warm-up. Wire bytes are "
        "counted by a TCP relay between server and mock, both directions, headers and bearer "
        "tokens included (the relay adds its hop to every delay). `get` frames have no "
        "data-layer timestamp: their delay is from the middle of the round trip.\n\n"
        + markdown_table(header, rows)
    )
    title = "Data layer: subscription vs bulk poll vs GET per node"
    publish("bench/datalayer.py", title, body, quick=quick)


def cell_nodes() -> int:
    from server.cell import load_cell
    from server.paths import DEMO_CELL

    return sum(len(robot.joints) for robot in load_cell(DEMO_CELL).robots)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="measuring time per case")
    parser.add_argument(
        "--quick", action="store_true", help="subscribe at 50 Hz only, 1 s; no docs update"
    )
    options = parser.parse_args()
    if options.quick:
        options.seconds = 1.0
        found = asyncio.run(main(options.seconds, ("subscribe",), (50,)))
    else:
        found = asyncio.run(main(options.seconds))
    report(found, options.seconds, cell_nodes(), options.quick)
