"""Looking back: what recording costs, how fast files grow, how fast the timeline gets a window.

* CPU: the demo cell (3 robots, 11 nodes, embedded mock at 50 Hz) served by
  ``python -m server`` with and without ``--record``, CPU seconds of the whole
  process over the same window, alternating runs; and, in this process, the
  recorder's own work (batch kinematics, encoding, writing) per second of data.
* Size: one 7-link arm (the LBR iiwa 7 R800 of the demo cell) moving for a
  while at 50 Hz, written as a recording; the growth per robot-hour.
* Timeline: a 10-minute history of 10 seven-axis robots on one source, fetched
  over loopback (``GET /api/history``, binary) as the page does: the whole
  window of joints, and a minute with link poses.

Usage: ``python bench/recording.py [--quick]``; writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402

from server.cell import Cell, Robot, load_cell  # noqa: E402
from server.config import Settings  # noqa: E402
from server.history import History, NewRows, encode_binary, source_window  # noqa: E402
from server.paths import DEMO_CELL  # noqa: E402
from server.recording import McapFile, encode_batch  # noqa: E402

TICKS = os.sysconf("SC_CLK_TCK")
PERIOD_S = 0.02


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def server_cpu(record: Path | None, warmup_s: float, window_s: float) -> float:
    """Share of one core the server process used over ``window_s`` after ``warmup_s``."""
    port = free_port()
    args = [sys.executable, "-m", "server", "--port", str(port)]
    if record is not None:
        args += ["--record", str(record)]
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=2):
                    break
            except OSError:
                time.sleep(0.2)
        time.sleep(warmup_s)
        c0, t0 = cpu_seconds(proc.pid), time.monotonic()
        time.sleep(window_s)
        return (cpu_seconds(proc.pid) - c0) / (time.monotonic() - t0)
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def motion(t: np.ndarray, joints: int, seed: int) -> np.ndarray:
    """Smooth joint values (deg): slow sines of different periods, like point-to-point moves."""
    rng = np.random.default_rng(seed)
    periods = rng.uniform(4.0, 12.0, joints)
    phases = rng.uniform(0.0, 2 * np.pi, joints)
    return 60.0 * np.sin(2 * np.pi * t[:, None] / periods + phases)


def history_of(robots: list[Robot], seconds: float) -> tuple[History, NewRows]:
    """``seconds`` of 50 Hz samples of ``robots`` on one source, in a history."""
    nodes = sorted({n for r in robots for n in r.nodes})
    history = History(seconds)
    source = history.source("demo", nodes, PERIOD_S)
    t = time.time() - seconds + np.arange(int(seconds / PERIOD_S)) * PERIOD_S
    values = np.zeros((len(t), len(nodes)))
    column = source.ring.column
    for k, robot in enumerate(robots):
        values[:, [column[n] for n in robot.nodes]] = motion(t, len(robot.joints), k)
    source.ring.write_many(np.arange(1, len(t) + 1), t, values)
    rows = source.ring.rows(0)
    return history, NewRows("demo", list(enumerate(robots)), column, rows, 0)


def recorder_work(cell: Cell, seconds: float, folder: Path) -> tuple[float, int]:
    """CPU seconds to record ``seconds`` of ``cell``'s robots at 50 Hz, and the file's bytes."""
    _, rows = history_of(list(cell.robots), seconds)
    path = folder / f"{len(cell.robots)}-{len(rows.rows)}.mcap"
    c0 = time.process_time()
    file = McapFile(path, cell, float(rows.rows.t[0]))
    for start in range(0, len(rows.rows), int(1 / PERIOD_S)):  # one drain per second, as live
        part = dataclasses.replace(
            rows,
            rows=rows.rows.__class__(
                rows.rows.t[start : start + 50],
                rows.rows.seq[start : start + 50],
                rows.rows.values[start : start + 50],
                start,
            ),
        )
        file.write(encode_batch([part], [], file.frames))
    file.close()
    return time.process_time() - c0, path.stat().st_size


def ten_arms(iiwa: Robot) -> list[Robot]:
    """Ten LBR iiwa arms, each with its own nodes."""
    out = []
    for k in range(10):
        joints = tuple(
            dataclasses.replace(j, node=f"motion/axs/arm{k}_{j.name}/state/values/actual/pos")
            for j in iiwa.joints
        )
        out.append(dataclasses.replace(iiwa, name=f"arm{k}", joints=joints, demo_targets=()))
    return out


async def window_timing(repeats: int) -> dict[str, Any]:
    """Median seconds for the page's requests over loopback, 10 robots, 10 minutes held."""
    import aiohttp
    import uvicorn

    from server.web import create_app
    from server.web.serve import server_config

    demo = load_cell(DEMO_CELL)
    arms = ten_arms(demo.robots[1])
    cell = dataclasses.replace(demo, path=None, robots=tuple(arms))
    app = create_app(Settings(history_s=600.0), cell)
    port = free_port()
    server = uvicorn.Server(server_config(app, "127.0.0.1", port, lifespan="on"))
    task = asyncio.create_task(server.serve())
    while not server.started:
        await asyncio.sleep(0.05)
    runtime = app.state.runtime
    kept = runtime.history.sources["demo"]
    kept.frozen = True  # the bench's 10 minutes stand for what a live source would have kept
    filled, _ = history_of(arms, 600.0)
    kept.ring = filled.sources["demo"].ring
    t_end = float(kept.ring.span()[1])
    out: dict[str, Any] = {}
    base = f"http://127.0.0.1:{port}/api/history"
    cases = {
        "10 min, joints": ({"source": "demo", "from": str(t_end - 600), "poses": "none"}, 600),
        "1 min, link poses": ({"source": "demo", "from": str(t_end - 60), "poses": "links"}, 60),
        "31 s, link poses (a seek)": (
            {"source": "demo", "from": str(t_end - 31), "poses": "links"},
            31,
        ),
    }
    robots = list(enumerate(arms))
    async with aiohttp.ClientSession() as http:
        for name, (params, span) in cases.items():
            times, cpu, size = [], [], 0
            for _ in range(repeats):
                t0 = time.perf_counter()
                async with http.get(base, params=params) as response:
                    body = await response.read()
                times.append(time.perf_counter() - t0)
                size = len(body)
                # The server's own work for the same window, on CPU time (load-independent).
                c0 = time.process_time()
                rows = kept.ring.between(t_end - span, np.inf)
                windows = source_window(robots, rows, kept.ring.column, params["poses"])
                encode_binary("demo", 0.0, 0.0, rows, windows, params["poses"])
                cpu.append(time.process_time() - c0)
            out[name] = (float(np.median(times)), float(np.median(cpu)), size)
    server.should_exit = True
    await task
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs; no docs update")
    args = parser.parse_args()
    runs, window = (1, 2.0) if args.quick else (3, 20.0)
    load = os.getloadavg()[0]
    demo = load_cell(DEMO_CELL)
    with tempfile.TemporaryDirectory() as folder:
        off, on = [], []
        for _ in range(runs):
            warm_up = 1.0 if args.quick else 4.0
            off.append(server_cpu(None, warm_up, window))
            on.append(server_cpu(Path(folder) / "rec", warm_up, window))
        data_s = 10.0 if args.quick else 300.0
        work_demo, size_demo = recorder_work(demo, data_s, Path(folder))
        iiwa_cell = dataclasses.replace(demo, robots=(demo.robots[1],))
        work_arm, size_arm = recorder_work(iiwa_cell, data_s, Path(folder))
    timing = asyncio.run(window_timing(1 if args.quick else 7))

    arm_mb_h = size_arm / data_s * 3600 / 1e6
    demo_mb_h = size_demo / data_s * 3600 / 1e6
    rows = [
        ["server CPU, demo cell at 50 Hz, not recording (median of runs)", f"{np.median(off):.1%}"],
        ["server CPU, recording (`--record`)", f"{np.median(on):.1%}"],
        ["difference (process, noisy)", f"{np.median(on) - np.median(off):+.1%} of one core"],
        ["recorder's own work, demo cell", f"{work_demo / data_s:.2%} of one core"],
        ["file growth, one 7-link arm at 50 Hz", f"{arm_mb_h:.1f} MB per robot-hour"],
        ["file growth, demo cell (3 robots)", f"{demo_mb_h:.1f} MB per hour"],
    ]
    for name, (seconds, cpu, size) in timing.items():
        rows.append(
            [
                f"/api/history, 10 robots: {name}",
                f"{seconds * 1000:.0f} ms to the last byte ({size / 1e6:.1f} MB); "
                f"server work {cpu * 1000:.0f} ms CPU",
            ]
        )
    body = markdown_table(["what", "figure"], rows) + (
        f"\n\nLoad average at the start: {load:.1f} (2 cores shared with other work). Process CPU "
        f"over {window:.0f} s windows, {runs} alternating runs each; the recorder's own work is "
        f"CPU time to batch, pose, encode and write {data_s:.0f} s of 50 Hz data in one-second "
        "drains (zstd chunks of 1 MiB), the steadier figure. Window timings: median over "
        "loopback, request to last byte, 10 LBR iiwa arms (70 nodes) with 10 minutes held; "
        "client and server share this process and the loaded cores. Server work: the same "
        "window cut, posed and encoded in this process, CPU time. The page asks for 31 s "
        "with link poses per source when it seeks (11 s back, 20 s ahead)."
    )
    if args.quick:
        print(body)
    else:
        publish("bench/recording.py", "Recording, replay and the timeline", body)


if __name__ == "__main__":
    main()
