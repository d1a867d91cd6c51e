"""Fan-out: many viewers watching the demo cell at once, protocol 1 (JSON) beside 2 (binary).

Each case (viewer count x protocol) gets a fresh ``python -m server`` (demo
cell, embedded mock at 50 Hz) and light viewers in separate processes
(bench/_viewer_client.py). After every viewer has its hello and a warm-up, it
measures frames/s per robot per viewer, the delay from the data layer's sample
time to receipt (same machine clock), frame bytes on the wire per link, the
server's CPU and RSS and the clients' CPU.

Usage: ``python bench/viewers.py [--viewers 1,10,100,500] [--protocol 1,2]
[--seconds 5] [--quick]``; writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, write_section  # noqa: E402

CLIENT = ROOT / "bench" / "_viewer_client.py"
VIEWERS_PER_CLIENT = 250
"""Beyond this one client process would measure itself (one asyncio loop, one core)."""
TICKS = os.sysconf("SC_CLK_TCK")
COLUMNS = {
    "viewers": "{viewers:.0f}",
    "protocol": "{protocol:.0f}",
    "frames/s per robot per viewer (median)": "{fps_median:.1f}",
    "(min)": "{fps_min:.1f}",
    "sample→receipt p50 ms": "{p50_ms:.1f}",
    "p99 ms": "{p99_ms:.1f}",
    "bytes/link": "{bytes_per_link:.1f}",
    "server frames/s": "{server_fps:.1f}",
    "server CPU": "{server_cpu:.0%}",
    "server RSS MiB": "{server_rss_mib:.0f}",
    "client CPU (processes)": "{client_cpu:.0%} ({clients:.0f})",
}
"""Table header -> format of a case's figures (a dict of floats)."""
Case = dict[str, float]
NOTES = (
    "Viewers: bench/_viewer_client.py (byte search for protocol 1, fixed headers for 2), up to "
    f"{VIEWERS_PER_CLIENT} per process, on the same 2 cores as the server (and other jobs); "
    "their CPU is the last column, their own queueing adds to the delays. Bytes/link: frame "
    "messages on the wire, WebSocket header included, per link pose delivered. Server "
    "frames/s: samples per robot made into frames (/api/health); below 50 the source itself "
    "is starved. CPU: utime + stime over the window, 100 % = one core (server: mock included)."
)


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) a process has used, from /proc/<pid>/stat."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def rss_mib(pid: int) -> float:
    """Resident memory (VmRSS) of a process, MiB."""
    status = Path(f"/proc/{pid}/status").read_text()
    return int(status.split("VmRSS:", 1)[1].split()[0]) / 1024


def health(port: int) -> dict[str, Any]:
    """The server's /api/health."""
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=10) as resp:
        return dict(json.load(resp))


def frames_made(port: int) -> tuple[float, int]:
    """(monotonic now, fewest frames made so far for any robot)."""
    return time.monotonic(), min(r["frames"] for r in health(port)["robots"])


def start_server(stack: ExitStack, port: int) -> subprocess.Popen[bytes]:
    """``python -m server`` on ``port``, returned once its source is connected."""
    server = subprocess.Popen(
        [sys.executable, "-m", "server", "--port", str(port)],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    stack.callback(stop, server)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and server.poll() is None:
        try:
            if health(port)["sources"][0]["state"] == "connected":
                return server
        except OSError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"the server on port {port} did not connect to its data source")


def stop(process: subprocess.Popen[Any]) -> None:
    """Terminate a process we started (kill it if it lingers)."""
    process.terminate()
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def run_case(viewers: int, protocol: int, warmup: float, seconds: float) -> Case:
    """Start a server and the viewers, measure one window, stop both."""
    port, clients = free_port(), -(-viewers // VIEWERS_PER_CLIENT)
    with ExitStack() as stack, tempfile.TemporaryDirectory() as tmp:
        server = start_server(stack, port)
        procs = []
        for i in range(clients):
            share = viewers // clients + (i < viewers % clients)
            args = ["--port", port, "--viewers", share, "--protocol", protocol, "--out", i]
            proc = subprocess.Popen(
                [sys.executable, CLIENT, *map(str, args)],
                cwd=tmp,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            )
            stack.callback(stop, proc)
            procs.append(proc)
        if any(p.stdout and p.stdout.readline() != "ready\n" for p in procs):
            raise RuntimeError(f"a client could not connect its viewers ({server.poll()=})")
        start = time.time() + warmup
        for proc in procs:  # one window for every client, on the shared wall clock
            assert proc.stdin is not None
            proc.stdin.write(f"{start!r} {start + seconds!r}\n")
            proc.stdin.flush()
        time.sleep(max(0.0, start - time.time()))
        pids = [server.pid] + [p.pid for p in procs]
        cpu0, made0 = [cpu_seconds(pid) for pid in pids], frames_made(port)
        time.sleep(max(0.0, start + seconds - time.time()))
        cpu = [(cpu_seconds(pid) - c0) / seconds for pid, c0 in zip(pids, cpu0, strict=True)]
        rss, made1 = rss_mib(server.pid), frames_made(port)
        summaries = [json.loads(p.communicate(timeout=60)[0].splitlines()[-1]) for p in procs]
        delays = np.concatenate([np.fromfile(f"{tmp}/{i}") for i in range(clients)])
    mismatches = [m for s in summaries for m in s["mismatches"]]
    if mismatches or any(s["unchecked"] for s in summaries):
        raise RuntimeError(f"the light parse disagrees with a full decode: {mismatches}")
    each = [v for s in summaries for v in s["viewers"]]
    fps = [n / seconds for v in each for n in v["frames"].values()]
    p50, p99 = np.percentile(delays, [50, 99]) * 1e3 if len(delays) else (np.nan, np.nan)
    return {
        "viewers": viewers,
        "protocol": protocol,
        "fps_median": float(np.median(fps)),
        "fps_min": min(fps),
        "p50_ms": p50,
        "p99_ms": p99,
        "bytes_per_link": sum(v["bytes"] for v in each) / max(1, sum(v["links"] for v in each)),
        "server_fps": (made1[1] - made0[1]) / (made1[0] - made0[0]),
        "server_cpu": cpu[0],
        "server_rss_mib": rss,
        "client_cpu": sum(cpu[1:]),
        "clients": clients,
        "lost": sum(v["lost"] for v in each),
    }


def goals(cases: list[Case]) -> list[str]:
    """The issue's fan-out goals, met or not, for the cases measured."""
    lines = []
    for c in cases:
        where = f"- {c['viewers']:.0f} viewers, protocol {c['protocol']:.0f}:"
        if c["viewers"] == 100:
            lines.append(f"{where} p99 {c['p99_ms']:.1f} ms <= 20 ms: {yes(c['p99_ms'] <= 20)}")
        if c["viewers"] == 500:
            ok = c["fps_min"] >= 45 and c["p99_ms"] <= 50
            lines.append(f"{where} min frames/s >= 45 and p99 <= 50 ms: {yes(ok)}")
        if c["protocol"] == 2 and c["viewers"] == cases[0]["viewers"]:
            size = c["bytes_per_link"]
            lines.append(f"- protocol 2: {size:.1f} bytes/link <= 42: {yes(size <= 42)}")
    return lines


def yes(ok: bool) -> str:
    """Goal-met marker."""
    return "yes" if ok else "**no**"


def main() -> None:
    """Run every case, print the table and (unless quick) write it to docs/benchmarks.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--viewers", default="1,10,100,500", help="viewer counts (comma list)")
    parser.add_argument("--protocol", default="1,2", help="protocols (comma list of 1, 2)")
    parser.add_argument("--seconds", type=float, default=5.0, help="measuring window per case")
    parser.add_argument("--warmup", type=float, default=1.5, help="after every viewer is in")
    parser.add_argument(
        "--quick", action="store_true", help="smoke run: 10 viewers on protocol 2, 1 s"
    )
    args = parser.parse_args()
    if args.quick:
        args.viewers, args.protocol, args.seconds, args.warmup = "10", "2", 1.0, 0.5
    cases, load0 = [], os.getloadavg()[0]
    for n in map(int, args.viewers.split(",")):
        for protocol in map(int, args.protocol.split(",")):
            cases.append(run_case(n, protocol, args.warmup, args.seconds))
            print("| " + " | ".join(f.format(**cases[-1]) for f in COLUMNS.values()) + " |")
    rows = [[f.format(**c) for f in COLUMNS.values()] for c in cases]
    lost = [f"{c['viewers']:.0f} on protocol {c['protocol']:.0f}" for c in cases if c["lost"]]
    notes = (
        f"Demo cell (3 robots, 15 links, one embedded mock source at 50 Hz), a fresh server per "
        f"case, {args.warmup:g} s of warm-up after every hello, {args.seconds:g} s measured. "
        f"{NOTES} Load average (1 min) {load0:.2f} before, {os.getloadavg()[0]:.2f} after."
    )
    body = (
        f"{notes}\n\n{markdown_table(list(COLUMNS), rows)}\n\n"
        + "\n".join(goals(cases))
        + (f"\n\nViewers the server hung up on: {'; '.join(lost)}." if lost else "")
        + "\n"
    )
    print("\n" + body)
    if not args.quick:
        write_section("bench/viewers.py", "Many viewers at once", body)


if __name__ == "__main__":
    main()
