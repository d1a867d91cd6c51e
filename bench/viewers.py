"""Fan-out: many viewers watching the default cell at once.

Starts ``python -m server`` (embedded mock, default settings: subscription at
50 Hz) as a separate process, connects N WebSocket viewers on loopback, and
reports per viewer the frames per second of each robot and the delay from
the data layer's sample time (``t_source``) to receipt; for the server, its
CPU use (share of one core) and resident memory. Also times the server's
per-sample path (kinematics + encoding one frame) in this process.

Usage: ``python bench/viewers.py [--seconds 5]``; writes docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import statistics
import subprocess
import sys
import time
import timeit
import urllib.request
from pathlib import Path

import orjson
from websockets.asyncio.client import connect

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, write_section  # noqa: E402

from server.cell import load_cell  # noqa: E402
from server.paths import DEMO_CELL  # noqa: E402
from server.stream.frames import compute_frame  # noqa: E402
from server.stream.types import RobotSample  # noqa: E402

VIEWER_COUNTS = (1, 10, 50, 100)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def proc_stats(pid: int) -> tuple[float, int]:
    """(CPU seconds used, resident bytes) of a process, from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    cpu = (int(fields[11]) + int(fields[12])) / ticks
    rss = int(fields[21]) * os.sysconf("SC_PAGE_SIZE")
    return cpu, rss


async def watch(url: str, seconds: float, out: list[tuple[str, float, float]]) -> None:
    """Record (robot, t_source, receipt time) of every frame for ``seconds``."""
    # The default receive queue keeps TCP backpressure, so a viewer that falls
    # behind is coalesced by the server instead of queueing in this client.
    async with connect(url) as ws:
        end = time.time() + seconds
        while (left := end - time.time()) > 0:
            try:
                raw = await asyncio.wait_for(ws.recv(), left)
            except TimeoutError:
                break
            now = time.time()
            msg = orjson.loads(raw)
            if msg["type"] == "frame":
                out.append((msg["robot"], msg["t_source"], now))


async def run_case(base: str, pid: int, viewers: int, seconds: float) -> list[str]:
    records: list[list[tuple[str, float, float]]] = [[] for _ in range(viewers)]
    cpu0, _ = proc_stats(pid)
    t0 = time.monotonic()
    await asyncio.gather(*(watch(base + "/ws", seconds, r) for r in records))
    wall = time.monotonic() - t0
    cpu1, rss = proc_stats(pid)
    robots = sorted({rec[0] for r in records for rec in r})
    per_viewer_fps = [
        sum(1 for rec in r if rec[0] == robot) / seconds for r in records for robot in robots
    ]
    delays = sorted((rec[2] - rec[1]) * 1e3 for r in records for rec in r)
    p99 = delays[int(0.99 * (len(delays) - 1))]
    return [
        str(viewers),
        f"{statistics.median(per_viewer_fps):.1f}",
        f"{min(per_viewer_fps):.1f}",
        f"{statistics.median(delays):.1f}",
        f"{p99:.1f}",
        f"{100 * (cpu1 - cpu0) / wall:.0f}%",
        f"{rss / 2**20:.0f}",
    ]


def per_sample_path_us() -> list[list[str]]:
    """Median time of kinematics + encoding one frame, per robot of the default cell."""
    rows = []
    for robot in load_cell(DEMO_CELL).robots:
        sample = RobotSample(
            seq=1, t_source=time.time(), values=__import__("numpy").full(len(robot.joints), 10.0)
        )
        runs = timeit.repeat(lambda r=robot, s=sample: compute_frame(r, s), number=2000, repeat=7)
        rows.append([robot.name, f"{statistics.median(runs) / 2000 * 1e6:.1f}"])
    return rows


async def main(seconds: float) -> None:
    port = free_port()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "server", "--port", str(port)],
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    base = f"http://127.0.0.1:{port}"
    try:
        for _ in range(100):
            try:
                with urllib.request.urlopen(base + "/api/health", timeout=1) as resp:
                    if json.load(resp)["sources"][0]["state"] == "connected":
                        break
            except OSError:
                pass
            time.sleep(0.1)
        ws_base = base.replace("http", "ws")
        rows = [await run_case(ws_base, proc.pid, n, seconds) for n in VIEWER_COUNTS]
    finally:
        proc.terminate()
        proc.wait(10)
    header = [
        "viewers",
        "frames/s per robot per viewer (median)",
        "(min)",
        "t_source→receipt p50 ms",
        "p99 ms",
        "server CPU",
        "server RSS MiB",
    ]
    table = markdown_table(header, rows)
    path = markdown_table(
        ["robot", "kinematics + encode one frame, µs (median)"], per_sample_path_us()
    )
    body = (
        f"Default cell (3 robots, subscription at 50 Hz, embedded mock in the server "
        f"process), {seconds:.0f} s per case; the viewers run in one client process on "
        f"the same 2 cores, so high counts also measure the client.\n\n{table}\n\n"
        f"Per-sample path in one process:\n\n{path}\n"
    )
    print(body)
    write_section("bench/viewers.py", "Many viewers at once", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0)
    asyncio.run(main(parser.parse_args().seconds))
