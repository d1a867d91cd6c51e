"""Robots per core: K arms, each on its own mock controller, one linkview process on one core.

For each K: K mock controllers (the real mock, bench/_mock_farm.py, 25 per
process), a cell with one source per controller (subscriptions at 50 Hz, as
bench/cluster.py makes it), ``python -m server`` pinned to CPU 0 and the
mocks pinned to the other CPUs, the light viewer too where there are more
than two (on two it starved beside the mocks, so it is not pinned). After a
warm-up, one protocol-2 viewer (bench/_viewer_client.py) counts every robot's
frames over the window. Reported: the server's CPU, frames/s per robot as the
viewer received them (min, median) and as the server made them (/api/health),
the delay from the controller's sample time to the viewer's receipt (p50,
p99), the sources' states at the end (connected, stale, error), the samples
the server made into frames against those the controllers sent (its own
count, where it has one) and the event loop's lateness.

The issue's sizes (K = 10 ... 400, the default on 16 cores or more) are for
a machine with cores to spare for the mocks; with fewer the mocks share what
is left, so the default list is scaled down (K = 10 ... 200; on 2 cores the
mocks send a little under 50 Hz at K = 200).

``--sample-cost-ms C`` makes every sample burn C ms of CPU more (the test
knob LINKVIEW_SAMPLE_COST_S): the server is then overloaded at sizes this
machine's mocks can send, and the table adds how evenly the robots slowed
down and what /api/health said.

Usage: ``python bench/plant.py [--robots 10,50,100,200,400] [--seconds 5]
[--warmup 4] [--sample-cost-ms 0] [--quick]``; writes docs/benchmarks.md except
in quick runs.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.request
from collections import defaultdict
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402
from cluster import PASSWORD_ENV, cell_text, health, start_farms  # noqa: E402
from viewers import cpu_seconds, free_port, stop  # noqa: E402

CLIENT = ROOT / "bench" / "_viewer_client.py"
CPUS = sorted(os.sched_getaffinity(0))
"""The CPUs this process may use (a container's share, not the host's count)."""
SERVER_CPU = CPUS[0]
OTHER_CPUS = set(CPUS[1:]) or {SERVER_CPU}
FULL_SIZE_CORES = 16
"""Where the issue's K = 10 ... 400 are measured: mocks for 400 controllers take several cores."""
Case = dict[str, Any]
COLUMNS = {
    "robots": "{robots}",
    "server CPU": "{server_cpu:.0%}",
    "server CPU ms per robot-sample": "{cpu_per_sample_ms:.3f}",
    "delivered frames/s per robot (min)": "{fps_min:.1f}",
    "(median)": "{fps_median:.1f}",
    "made frames/s per robot (median)": "{made_median:.1f}",
    "sent/s per robot": "{sent_hz}",
    "samples made into frames": "{processed}",
    "sample→receipt p50 ms": "{p50_ms:.0f}",
    "p99 ms": "{p99_ms:.0f}",
    "loop lag (newest) ms": "{lag_ms:.0f}",
    "loop paced": "{paced}",
    "loop wake-ups/s (unpaced)": "{wakeups:.0f}",
    "samples per batch": "{per_batch:.1f}",
    "sources connected / stale / error": "{connected} / {stale} / {error}",
    "mocks CPU": "{mocks_cpu:.0%}",
}


OVERLOAD_COLUMNS = {
    "slowest / median": "{evenness:.2f}",
    "health": "{overloaded}",
}


def pin(pid: int, cpus: set[int]) -> None:
    """Keep a process (every thread it has now) on ``cpus``."""
    for task in os.listdir(f"/proc/{pid}/task"):
        os.sched_setaffinity(int(task), cpus)


def metrics(port: int) -> dict[str, float]:
    """The server's /metrics, unlabelled samples by name (NaN where one is not exported)."""
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10) as resp:
        text = resp.read().decode()
    found = re.findall(r"^([a-z_]+) (\S+)$", text, re.M)
    return defaultdict(lambda: float("nan"), {name: float(value) for name, value in found})


def cpu_list(cpus: set[int]) -> str:
    """``{1, 2, 3, 5}`` as ``1-3, 5``."""
    runs: list[list[int]] = []
    for cpu in sorted(cpus):
        if runs and cpu == runs[-1][-1] + 1:
            runs[-1].append(cpu)
        else:
            runs.append([cpu])
    return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)


def per_batch(before: dict[str, float], after: dict[str, float]) -> float:
    """Samples made into frames per batch (those of one 2 ms window) over the measuring window."""
    turns = after["linkview_sample_batches_total"] - before["linkview_sample_batches_total"]
    done = after["linkview_samples_computed_total"] - before["linkview_samples_computed_total"]
    return done / turns if turns > 0 else float("nan")


def start_server(
    stack: ExitStack, cell: Path, port: int, log: Path, sample_cost_ms: float
) -> subprocess.Popen[bytes]:
    """``python -m server`` for the cell, on SERVER_CPU from its first instruction."""
    prefix = ["taskset", "-c", str(SERVER_CPU)]
    env = {**os.environ, "PYTHONPATH": str(ROOT), PASSWORD_ENV: "boschrexroth"}
    if sample_cost_ms:  # the test knob: every sample burns this much more CPU (an overload)
        env["LINKVIEW_SAMPLE_COST_S"] = str(sample_cost_ms / 1e3)
    with open(log, "ab") as out:
        server = subprocess.Popen(
            [*prefix, sys.executable, "-m", "server", "--cell", str(cell), "--port", str(port)],
            cwd=ROOT,
            env=env,
            stdout=out,
            stderr=out,
        )
    stack.callback(stop, server)
    return server


def wait_connected(port: int, server: subprocess.Popen[bytes], timeout_s: float) -> float:
    """Seconds until every source is connected (or the timeout, past which it goes on)."""
    begin = time.monotonic()
    while time.monotonic() - begin < timeout_s and server.poll() is None:
        try:
            if all(s["state"] == "connected" for s in health(port)["sources"]):
                break
        except OSError:
            pass
        time.sleep(0.3)
    if server.poll() is not None:
        raise RuntimeError(f"the server ended ({server.returncode}) before its sources connected")
    return time.monotonic() - begin


def made(port: int) -> tuple[float, dict[str, int]]:
    """(monotonic now, frames the server made so far, by robot)."""
    return time.monotonic(), {r["name"]: r["frames"] for r in health(port)["robots"]}


def run_case(robots: int, warmup: float, seconds: float, sample_cost_ms: float = 0.0) -> Case:
    """Mocks, a server on one core and one viewer; one window measured."""
    with ExitStack() as stack, tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        farms, urls = start_farms(stack, robots, folder)
        for pid in farms:
            pin(pid, OTHER_CPUS)
        cell = folder / "cell" / "cell.toml"  # a folder of its own: the server watches it
        cell.parent.mkdir()
        cell.write_text(cell_text(urls))
        port = free_port()
        server = start_server(stack, cell, port, folder / "server.log", sample_cost_ms)
        connect_s = wait_connected(port, server, 60 + robots * 0.5)
        out = folder / "delays"
        viewer = subprocess.Popen(
            [sys.executable, str(CLIENT), "--port", str(port), "--viewers", "1"]
            + ["--protocol", "2", "--out", str(out)],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        stack.callback(stop, viewer)
        if len(OTHER_CPUS) > 1:  # on one other core, beside the mocks, it starved at K = 100
            pin(viewer.pid, OTHER_CPUS)
        assert viewer.stdin is not None and viewer.stdout is not None
        if viewer.stdout.readline() != "ready\n":
            raise RuntimeError("the viewer could not connect")
        begin = time.time() + warmup
        viewer.stdin.write(f"{begin!r} {begin + seconds!r}\n")
        viewer.stdin.flush()
        time.sleep(max(0.0, begin - time.time()))
        pids = [server.pid, *farms]
        cpu0, made0, body0 = [cpu_seconds(p) for p in pids], made(port), health(port)
        metrics0 = metrics(port)
        time.sleep(max(0.0, begin + seconds - time.time()))
        cpu = [cpu_seconds(p) - c for p, c in zip(pids, cpu0, strict=True)]
        made1, body1, metrics1 = made(port), health(port), metrics(port)
        summary = json.loads(viewer.communicate(timeout=60)[0].splitlines()[-1])
        delays = np.fromfile(out) if out.exists() else np.zeros(0)
    fps = [n / seconds for n in summary["viewers"][0]["frames"].values()]
    elapsed = made1[0] - made0[0]
    made_fps = [(made1[1][r] - made0[1][r]) / elapsed for r in made1[1]]
    states = [s["state"] for s in body1["sources"]]
    p50, p99 = np.percentile(delays, [50, 99]) * 1e3 if len(delays) else (np.nan, np.nan)
    return {
        "robots": robots,
        "connect_s": connect_s,
        "server_cpu": cpu[0] / elapsed,
        # The yardstick (<= 0.1 ms): SSE bytes to socket write, all of it.
        "cpu_per_sample_ms": 1e3 * cpu[0] / max(sum(made_fps) * elapsed, 1),
        "mocks_cpu": sum(cpu[1:]) / elapsed,
        "fps_min": min(fps),
        "evenness": min(fps) / max(float(np.median(fps)), 1e-9),
        "fps_median": float(np.median(fps)),
        "made_median": float(np.median(made_fps)),
        "made_min": min(made_fps),
        "processed": processed(body0, body1),
        "sent_hz": sent_hz(body0, body1, elapsed, robots),
        "p50_ms": p50,
        "p99_ms": p99,
        "lag_ms": 1e3 * metrics1["linkview_event_loop_lag_newest_seconds"],
        "paced": {0.0: "no", 1.0: "yes"}.get(metrics1["linkview_event_loop_paced"], "?"),
        "wakeups": metrics1["linkview_event_loop_wakeups_per_second"],
        "per_batch": per_batch(metrics0, metrics1),
        "connected": states.count("connected"),
        "stale": states.count("stale"),
        "error": states.count("error"),
        "overloaded": body1.get("samples", {}).get("overloaded") or "no",
        "errors": sorted({s["error"] for s in body1["sources"] if s["state"] == "error"}),
    }


def sent_hz(before: dict[str, Any], after: dict[str, Any], seconds: float, robots: int) -> str:
    """Samples per second each controller sent, as the server counted them (if it does)."""
    if "samples" not in after:
        return "not counted"
    sent = after["samples"]["received"] - before["samples"]["received"]
    return f"{sent / seconds / robots:.1f}"


def processed(before: dict[str, Any], after: dict[str, Any]) -> str:
    """Samples made into frames of those the controllers sent, over the window (if counted)."""
    if "samples" not in after:
        return "not counted"
    done = after["samples"]["processed"] - before["samples"]["processed"]
    sent = after["samples"]["received"] - before["samples"]["received"]
    return f"{done} of {sent} ({done / max(sent, 1):.0%})"


def main() -> None:
    """Run every K, print the table and (unless quick) write it to docs/benchmarks.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--robots",
        help="robot counts (comma list; default 10,50,100,200,400 on 16 cores or more, "
        "else 10,25,50,100,150,200)",
    )
    parser.add_argument("--seconds", type=float, default=5.0, help="measuring window per K")
    parser.add_argument("--warmup", type=float, default=4.0, help="after every source is live")
    parser.add_argument("--quick", action="store_true", help="no docs; default K = 5, 2 s")
    parser.add_argument("--title", default="Robots per core", help="section title")
    parser.add_argument(
        "--sample-cost-ms",
        type=float,
        default=0.0,
        help="CPU every sample burns on top (LINKVIEW_SAMPLE_COST_S): overload the server",
    )
    args = parser.parse_args()
    if args.quick and args.robots is None:
        args.robots, args.seconds, args.warmup = "5", 2.0, 1.0
    full = len(CPUS) >= FULL_SIZE_CORES
    args.robots = args.robots or ("10,50,100,200,400" if full else "10,25,50,100,150,200")
    columns = {**COLUMNS, **OVERLOAD_COLUMNS} if args.sample_cost_ms else COLUMNS
    load0, cases = os.getloadavg(), []
    for k in map(int, args.robots.split(",")):
        cases.append(run_case(k, args.warmup, args.seconds, args.sample_cost_ms))
        print("| " + " | ".join(f.format(**cases[-1]) for f in columns.values()) + " |")
    load1 = os.getloadavg()
    rows = [[f.format(**c) for f in columns.values()] for c in cases]
    errors = [f"K = {c['robots']}: {'; '.join(c['errors'])}" for c in cases if c["errors"]]
    size = (
        f"The issue's sizes, on {len(CPUS)} cores"
        if full
        else f"Scaled down for the {len(CPUS)} cores here (the issue's K = 10 ... 400 "
        "needs cores to spare for the mocks)"
    )
    others = f"CPU {min(OTHER_CPUS)}" if len(OTHER_CPUS) == 1 else f"CPUs {cpu_list(OTHER_CPUS)}"
    viewer = "there too" if len(OTHER_CPUS) > 1 else "on either"
    notes = (
        f"{size}: K KUKA LBR iiwa 7 R800 arms, each on its own mock "
        "controller (bench/_mock_farm.py, 25 per process), one subscription per controller at "
        f"50 Hz. The server runs pinned to CPU {SERVER_CPU} (`taskset`), the mocks on "
        f"{others}, the one protocol-2 viewer {viewer}; the machine may be shared with other "
        "jobs. "
        f"{args.warmup:g} s of warm-up after every source is connected, {args.seconds:g} s "
        "measured. Delivered: frames per robot the viewer received; made: samples per robot "
        "the server made into frames (/api/health); sent: samples per robot the controllers "
        "sent, as the server counted them (below 50: the mocks fall behind); samples made "
        "into frames: the server's count of samples processed against "
        "those the controllers sent (a source that falls behind keeps the newest); samples per "
        "batch: those arriving within 2 ms, made into frames together (/metrics); loop paced: "
        "whether the event loop turned once per 2 ms tick at the end of the window, and its "
        "wake-ups per second in the newest unpaced measure (/metrics, server/loop_pacing.py); "
        "states from "
        "/api/health at the end of the window. CPU: utime + stime over the window, 100 % = one "
        f"core. Load average (1, 5 min) {load0[0]:.2f}, {load0[1]:.2f} before, "
        f"{load1[0]:.2f}, {load1[1]:.2f} after."
    )
    if args.sample_cost_ms:
        notes += (
            f" Overloaded on purpose: every sample burns {args.sample_cost_ms:g} ms of CPU more "
            "(LINKVIEW_SAMPLE_COST_S), so the server carries fewer samples than the controllers "
            "send. Slowest / median: the slowest robot's delivered rate over the median's; "
            "health: /api/health's `samples.overloaded` at the end of the window."
        )
    body = f"{notes}\n\n{markdown_table(list(columns), rows)}\n"
    if errors:
        body += "\nSource errors at the end of the window: " + " / ".join(errors) + "\n"
    if args.quick:
        print("\n" + body)
    else:
        cost = f" --sample-cost-ms {args.sample_cost_ms:g}" if args.sample_cost_ms else ""
        publish(f"bench/plant.py{cost}", args.title, body)


if __name__ == "__main__":
    main()
