"""A cluster on one machine: one Redis, 2 acquisition workers, 2 web replicas, robots, viewers.

Three parts, each a table in docs/benchmarks.md:

1. **Transport.** Redis pub/sub against Redis streams for the frames, at the
   robot count of the run (50 Hz each, 312-byte frames as a 7-axis arm
   makes), one publisher and two subscribers (bench/_transport.py, redis-py
   with hiredis, as workers and replicas use it): CPU per frame of each
   side and of redis-server, and the delay from publish to receipt.
2. **Cluster.** ``--robots`` arms, each on its own mock controller (the real
   mock, bench/_mock_farm.py), a cell with one source per controller;
   ``python -m server acquire`` twice, ``python -m server --broker`` twice,
   ``--viewers`` protocol-2 viewers (bench/_viewer_client.py) split over the
   replicas. Over a window: each role's CPU, the share of samples the
   workers turned into frames, frames/s per robot per viewer (min, median)
   and the p99 delay from the controller's sample to the viewer's receipt.
3. **Failover.** A viewer on one replica records when each source's frames
   arrive; the worker holding the first source is killed (SIGKILL: no
   lease given back), and the gap in its sources' frames is measured; then,
   with a new worker in, the holder is stopped cleanly (SIGTERM: leases given
   back at once).

The issue's full sizes are 400 robots and 2 000 viewers (``--full``); every
viewer gets every robot's frames, 40 million messages a second at 50 Hz,
which no single machine fans out; by default a scaled-down cluster runs.

Usage: ``python bench/cluster.py [--robots 20] [--viewers 20] [--seconds 6]
[--full] [--quick]``; writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import functools
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np
import redis
from websockets.asyncio.client import connect
from websockets.typing import Subprotocol

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402
from viewers import cpu_seconds, free_port, stop  # noqa: E402

from server.protocol import decode_frames  # noqa: E402

FARM = ROOT / "bench" / "_mock_farm.py"
CLIENT = ROOT / "bench" / "_viewer_client.py"
TRANSPORT = ROOT / "bench" / "_transport.py"
RATE_HZ = 50
MOCKS_PER_PROCESS = 25
VIEWERS_PER_CLIENT = 250
PASSWORD_ENV = "CLUSTER_PASSWORD"
TRANSPORTS = ("pubsub-batch", "pubsub-frame", "streams-batch", "streams-frame")
ARM_JOINTS = [f"motion/axs/iiwa_a{i}/state/values/actual/pos" for i in range(1, 8)]
ARM_KINEMATICS = (
    '{ type = "dh", convention = "standard", solver = "iiwa", '
    "d = [340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0], a = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "
    "alpha_deg = [-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0] }"
)
Case = dict[str, Any]
FAILOVER_WATCH_S = 10.0
"""How long a source's frames are watched after its worker is stopped."""


def health(port: int) -> dict[str, Any]:
    """A replica's /api/health, also when it answers 503 (no source live at that instant)."""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=10) as resp:
            return dict(json.load(resp))
    except urllib.error.HTTPError as exc:
        if exc.code != 503:
            raise
        return dict(json.load(exc))


def cell_text(urls: list[str]) -> str:
    """One source per mock URL, one 7-axis arm on each."""
    joints = ", ".join(f'{{ node = "{n}", unit = "deg" }}' for n in ARM_JOINTS)
    return "\n".join(
        f'[[source]]\nname = "c{i}"\nurl = "{url}"\npassword_env = "{PASSWORD_ENV}"\n\n'
        f'[[robot]]\nname = "arm{i}"\nsource = "c{i}"\n'
        f"base = {{ xyz = [{1500.0 * (i % 20)}, {1500.0 * (i // 20)}, 0.0] }}\n"
        f"joints = [{joints}]\nkinematics = {ARM_KINEMATICS}\n"
        for i, url in enumerate(urls)
    )


def start_redis(stack: ExitStack, folder: Path) -> tuple[subprocess.Popen[bytes], str]:
    """redis-server on a free loopback port, no persistence; its process and URL."""
    port = free_port()
    proc = subprocess.Popen(
        ["redis-server", "--port", str(port), "--bind", "127.0.0.1", "--save", ""]
        + ["--appendonly", "no", "--dir", str(folder)],
        stdout=subprocess.DEVNULL,
    )
    stack.callback(stop, proc)
    client = redis.Redis(port=port)
    for _ in range(200):
        try:
            client.ping()
            break
        except redis.ConnectionError:
            time.sleep(0.05)
    client.close()
    return proc, f"redis://127.0.0.1:{port}/0"


def start(
    stack: ExitStack,
    args: list[str],
    log: Path,
    env: dict[str, str] | None = None,
    pipe: bool = False,
) -> Any:
    """A Python process of ours, its errors in ``log`` (its output too, unless ``pipe``)."""
    with open(log, "ab") as out:
        proc = subprocess.Popen(
            [sys.executable, *args],
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE if pipe else out,
            stderr=out,
            text=True,
        )
    stack.callback(stop, proc)
    return proc


def transport_case(transport: str, sources: int, seconds: float) -> Case:
    """One publisher, two subscribers over a fresh redis-server."""
    with ExitStack() as stack, tempfile.TemporaryDirectory() as tmp:
        server, url = start_redis(stack, Path(tmp))
        common = ["--url", url, "--transport", transport, "--sources", str(sources)]
        procs = []
        for role in ("subscribe", "subscribe", "publish"):
            proc = subprocess.Popen(
                [sys.executable, str(TRANSPORT), role, *common],
                cwd=ROOT,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            )
            stack.callback(stop, proc)
            assert proc.stdout is not None
            if proc.stdout.readline() != "ready\n":
                raise RuntimeError(f"{role} ({transport}) did not start")
            procs.append(proc)
        begin = time.time() + 1.5
        for proc in procs:
            proc.stdin.write(f"{begin!r} {begin + seconds!r}\n")
            proc.stdin.flush()
        pids = [server.pid] + [p.pid for p in procs]
        time.sleep(max(0.0, begin - time.time()))
        cpu0 = [cpu_seconds(p) for p in pids]
        time.sleep(max(0.0, begin + seconds - time.time()))
        cpu = [cpu_seconds(p) - c for p, c in zip(pids, cpu0, strict=True)]
        out = [json.loads(p.communicate(timeout=60)[0].splitlines()[-1]) for p in procs]
    sent = max(out[2]["sent"], 1)
    received = out[0]["received"] + out[1]["received"]
    return {
        "transport": transport,
        "sources": sources,
        "frames_s": sent / seconds,
        "redis_commands_s": out[2]["commands"] / seconds,
        "pub_us": 1e6 * cpu[3] / sent,
        "redis_us": 1e6 * cpu[0] / sent,
        "sub_us": 1e6 * (cpu[1] + cpu[2]) / max(received, 1),
        "received": received / (2 * sent),
        "p50_ms": max(o["p50_ms"] for o in out[:2]),
        "p99_ms": max(o["p99_ms"] for o in out[:2]),
    }


def start_farms(stack: ExitStack, robots: int, folder: Path) -> tuple[list[int], list[str]]:
    """Mock controllers, MOCKS_PER_PROCESS per process: their pids and URLs."""
    pids, urls = [], []
    for first in range(0, robots, MOCKS_PER_PROCESS):
        count = min(MOCKS_PER_PROCESS, robots - first)
        proc = subprocess.Popen(
            [sys.executable, str(FARM), "--count", str(count)],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        stack.callback(stop, proc)
        assert proc.stdout is not None
        started = json.loads(proc.stdout.readline())
        pids.append(started["pid"])
        urls += started["urls"]
    return pids, urls


class Cluster:
    """Redis, mocks, two workers and two replicas for one cell; stopped with the stack."""

    def __init__(self, stack: ExitStack, folder: Path, robots: int) -> None:
        self.stack, self.folder = stack, folder
        self.redis, self.url = start_redis(stack, folder)
        self.farms, urls = start_farms(stack, robots, folder)
        # A folder of its own: every role watches the cell's folder, and logs are busy files.
        self.cell = folder / "cell" / "cell.toml"
        self.cell.parent.mkdir()
        self.cell.write_text(cell_text(urls))
        self.sources = [f"c{i}" for i in range(robots)]
        self.workers = [self.worker(f"w{i}") for i in (1, 2)]
        self.ports = [free_port(), free_port()]
        self.replicas = [
            start(
                stack,
                ["-m", "server", "--cell", str(self.cell), "--broker", self.url, "--port", str(p)],
                folder / f"r{i}.log",
                {PASSWORD_ENV: "boschrexroth"},
            )
            for i, p in enumerate(self.ports)
        ]

    def worker(self, name: str) -> Any:
        args = ["-m", "server", "acquire", "--cell", str(self.cell), "--broker", self.url]
        return start(self.stack, args, self.folder / f"{name}.log", {PASSWORD_ENV: "boschrexroth"})

    def wait_live(self, timeout_s: float = 180.0) -> None:
        """Until both replicas see every source connected."""
        deadline = time.monotonic() + timeout_s
        for port in self.ports:
            while True:
                try:
                    if all(s["state"] == "connected" for s in health(port)["sources"]):
                        break
                except OSError:
                    pass
                if time.monotonic() > deadline:
                    raise RuntimeError(f"replica on {port} never saw every source live")
                time.sleep(0.3)

    def holders(self) -> dict[str, str | None]:
        with redis.Redis.from_url(self.url) as client:
            values = client.mget([f"linkview:lease:{s}" for s in self.sources])
        return {s: v.decode() if v else None for s, v in zip(self.sources, values, strict=True)}

    def balanced(self, workers: list[Any], timeout_s: float = 60.0) -> dict[str, str | None]:
        """Until each of ``workers`` holds its share of the sources."""
        deadline = time.monotonic() + timeout_s
        share = -(-len(self.sources) // len(workers))
        while time.monotonic() < deadline:
            held = self.holders()
            counts = [sum(f"-{w.pid}-" in (h or "") for h in held.values()) for w in workers]
            if sum(counts) == len(self.sources) and max(counts) <= share:
                return held
            time.sleep(0.2)
        raise RuntimeError("the workers never shared the sources out")

    def made(self) -> int:
        """Frames made so far, every robot together (the workers' records, via a replica)."""
        return sum(r["frames"] for r in health(self.ports[0])["robots"])


def cluster_case(cluster: Cluster, viewers: int, warmup: float, seconds: float) -> Case:
    """Viewers over both replicas; CPU of each role and what the viewers got."""
    clients, folder = [], cluster.folder
    per_replica = [viewers // 2 + viewers % 2, viewers // 2]
    for port, count in zip(cluster.ports, per_replica, strict=True):
        for k in range(0, count, VIEWERS_PER_CLIENT):
            n = min(VIEWERS_PER_CLIENT, count - k)
            out = folder / f"delays-{port}-{k}"
            args = [str(CLIENT), "--port", str(port), "--viewers", str(n), "--protocol", "2"]
            proc = start(cluster.stack, [*args, "--out", str(out)], folder / "v.log", pipe=True)
            clients.append((proc, out))
    for proc, _ in clients:
        if proc.stdout.readline() != "ready\n":
            raise RuntimeError("a viewer client could not connect")
    begin = time.time() + warmup
    for proc, _ in clients:
        proc.stdin.write(f"{begin!r} {begin + seconds!r}\n")
        proc.stdin.flush()
    roles = {
        "worker 1": [cluster.workers[0].pid],
        "worker 2": [cluster.workers[1].pid],
        "replica 1": [cluster.replicas[0].pid],
        "replica 2": [cluster.replicas[1].pid],
        "redis": [cluster.redis.pid],
        "mocks": cluster.farms,
        "viewers": [p.pid for p, _ in clients],
    }
    time.sleep(max(0.0, begin - time.time()))
    cpu0 = {k: sum(map(cpu_seconds, pids)) for k, pids in roles.items()}
    made0 = cluster.made()
    time.sleep(max(0.0, begin + seconds - time.time()))
    cpu = {k: (sum(map(cpu_seconds, pids)) - cpu0[k]) / seconds for k, pids in roles.items()}
    made = cluster.made() - made0
    summaries = [json.loads(p.communicate(timeout=60)[0].splitlines()[-1]) for p, _ in clients]
    delays = np.concatenate([np.fromfile(out) for _, out in clients])
    robots = len(cluster.sources)
    fps = [n / seconds for s in summaries for v in s["viewers"] for n in v["frames"].values()]
    fps += [0.0] * (robots * viewers - len(fps))
    delivered = sum(fps) * seconds
    return {
        "robots": robots,
        "viewers": viewers,
        "cpu": cpu,
        "worker_ms_per_sample": 1e3 * (cpu["worker 1"] + cpu["worker 2"]) * seconds / max(made, 1),
        "replica_us_per_frame": 1e6
        * (cpu["replica 1"] + cpu["replica 2"])
        * seconds
        / max(delivered, 1),
        "processed": made / (robots * RATE_HZ * seconds),
        "fps_min": min(fps),
        "fps_median": float(np.median(fps)),
        "p50_ms": float(np.percentile(delays, 50) * 1e3) if len(delays) else float("nan"),
        "p99_ms": float(np.percentile(delays, 99) * 1e3) if len(delays) else float("nan"),
        "lost": sum(v["lost"] for s in summaries for v in s["viewers"]),
    }


async def gaps_when(
    port: int, sources: list[int], act: Callable[[], None], watch_s: float = FAILOVER_WATCH_S
) -> list[float]:
    """Watch a replica; ``act`` after 2 s; each of ``sources``' longest gap in frames after it.

    Watched for ``watch_s`` after ``act``: a stopping worker may still
    send a few frames, so the gap is the longest silence from just before
    ``act`` on, not the time to the first frame after it.
    """
    arrivals: dict[int, list[float]] = {i: [] for i in sources}
    acted = 0.0
    url = f"ws://127.0.0.1:{port}/ws"
    async with connect(url, subprotocols=[Subprotocol("linkview.2")]) as ws:
        began = time.monotonic()
        async with asyncio.timeout(2.0 + watch_s + 5.0):
            async for data in ws:
                now = time.monotonic()
                if isinstance(data, bytes):
                    index = decode_frames(data).robots[0].robot_index
                    if index in arrivals:
                        arrivals[index].append(now)
                if not acted and now - began > 2.0:
                    act()
                    acted = time.monotonic()
                if acted and now > acted + watch_s:
                    break
    gaps = []
    for times in arrivals.values():
        before = [t for t in times if t < acted]
        points = [before[-1] if before else acted]
        points += [t for t in times if t >= acted] + [acted + watch_s]
        gaps.append(float(np.diff(points).max()))  # never resumed: the whole watch
    return gaps


def failover(
    cluster: Cluster,
    hows: tuple[str, ...] = ("SIGKILL", "SIGTERM"),
    watch_s: float = FAILOVER_WATCH_S,
) -> list[Case]:
    """Kill the holder of the first source, then stop a holder cleanly: the gaps."""
    cases = []
    held = cluster.balanced(cluster.workers)
    for how in hows:
        victim = next(w for w in cluster.workers if f"-{w.pid}-" in (held["c0"] or ""))
        lost = [i for i, s in enumerate(cluster.sources) if f"-{victim.pid}-" in (held[s] or "")]
        sig = signal.SIGKILL if how == "SIGKILL" else signal.SIGTERM
        act = functools.partial(victim.send_signal, sig)
        gaps = asyncio.run(gaps_when(cluster.ports[0], lost, act, watch_s))
        try:
            victim.wait(60)  # a clean stop logs out of every controller first
        except subprocess.TimeoutExpired:
            victim.kill()
            victim.wait()
        cases.append(
            {
                "how": how,
                "sources": len(lost),
                "gap_median_s": float(np.median(gaps)),
                "gap_max_s": max(gaps),
            }
        )
        cluster.workers = [w for w in cluster.workers if w is not victim]
        cluster.workers.append(cluster.worker(f"w{len(cluster.workers) + 3}"))
        held = cluster.balanced(cluster.workers, 180.0)
    return cases


def main() -> None:
    """Run the three parts, print their tables, write them (unless quick)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robots", type=int, default=20, help="robots, one controller each")
    parser.add_argument("--viewers", type=int, default=20, help="protocol-2 viewers, all told")
    parser.add_argument(
        "--transport-sources", type=int, default=100, help="sources of the transport part"
    )
    parser.add_argument("--seconds", type=float, default=6.0, help="measuring window")
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--full", action="store_true", help="the issue's 400 robots, 2 000 viewers")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="pub/sub only, 4 robots, 2 viewers, 1 s; one failover (SIGKILL); no docs",
    )
    parser.add_argument("--transport-only", action="store_true", help="the first part; no docs")
    args = parser.parse_args()
    if args.full:
        args.robots, args.viewers, args.transport_sources = 400, 2000, 400
    transports_run, hows, watch_s = TRANSPORTS, ("SIGKILL", "SIGTERM"), FAILOVER_WATCH_S
    if args.quick:
        args.robots, args.viewers, args.seconds, args.warmup = 4, 2, 1.0, 1.0
        args.transport_sources = 10
        transports_run, hows, watch_s = TRANSPORTS[:1], ("SIGKILL",), 3.0
    load0 = os.getloadavg()[0]

    transports = []
    for transport in transports_run:
        transports.append(transport_case(transport, args.transport_sources, args.seconds))
        print(transports[-1], flush=True)
    if args.transport_only:
        return
    with ExitStack() as stack, tempfile.TemporaryDirectory() as tmp:
        cluster = Cluster(stack, Path(tmp), args.robots)
        cluster.wait_live()
        cluster.balanced(cluster.workers)
        case = cluster_case(cluster, args.viewers, args.warmup, args.seconds)
        gaps = failover(cluster, hows, watch_s)
    body = report(args, transports, case, gaps, load0)
    publish("bench/cluster.py", "A cluster through Redis", body, quick=args.quick)


def report(
    args: argparse.Namespace, transports: list[Case], case: Case, gaps: list[Case], load0: float
) -> str:
    """The three tables and what they are."""
    scaled = (
        "the issue's full sizes"
        if args.full
        else "scaled down from the issue's 400 robots and 2 000 viewers (2-core machine, shared)"
    )
    t_rows = [
        [
            t["transport"],
            f"{t['frames_s']:.0f}",
            f"{t['redis_commands_s']:.0f}",
            f"{t['pub_us']:.1f}",
            f"{t['redis_us']:.1f}",
            f"{t['sub_us']:.1f}",
            f"{t['received']:.1%}",
            f"{t['p50_ms']:.1f}",
            f"{t['p99_ms']:.1f}",
        ]
        for t in transports
    ]
    t_head = [
        "transport",
        "frames/s",
        "Redis commands/s",
        "publisher CPU µs/frame",
        "redis-server µs/frame",
        "subscriber µs/frame",
        "received",
        "p50 ms",
        "p99 ms",
    ]
    cpu = case["cpu"]
    c_head = [*(f"{k} CPU" for k in cpu), "worker CPU ms/sample", "replica CPU µs/frame sent"]
    c_head += ["samples made", "frames/s per robot per viewer (min)"]
    c_head += ["(median)", "sample→receipt p50 ms", "p99 ms"]
    c_rows = [
        [
            *(f"{v:.0%}" for v in cpu.values()),
            f"{case['worker_ms_per_sample']:.3f}",
            f"{case['replica_us_per_frame']:.1f}",
            f"{case['processed']:.0%}",
            f"{case['fps_min']:.1f}",
            f"{case['fps_median']:.1f}",
            f"{case['p50_ms']:.1f}",
            f"{case['p99_ms']:.1f}",
        ]
    ]
    g_rows = [
        [g["how"], f"{g['sources']}", f"{g['gap_median_s']:.2f}", f"{g['gap_max_s']:.2f}"]
        for g in gaps
    ]
    g_head = ["worker stopped by", "its sources", "gap median s", "gap max s"]
    return (
        f"{args.robots} robots (7-axis arms, each on its own mock controller, 50 Hz), "
        f"{args.viewers} protocol-2 viewers: {scaled}. Every role, the mocks and the viewers "
        f"share the machine; CPU is utime + stime over the window, 100 % = one core. Load "
        f"average (1 min) {load0:.2f} before, {os.getloadavg()[0]:.2f} after.\n\n"
        f"**Transport** for the frames ({args.transport_sources} sources at 50 Hz, 2 subscribers, "
        f"{args.seconds:g} s): linkview publishes one batch per 2 ms tick on pub/sub.\n\n"
        f"{markdown_table(t_head, t_rows)}\n\n"
        f"**Cluster**: 2 workers, 2 replicas (viewers split evenly), {args.seconds:g} s after "
        f"{args.warmup:g} s of warm-up.\n\n{markdown_table(c_head, c_rows)}\n\n"
        f"**Failover**: the gap in the frames of every source the stopped worker held, seen by a "
        f"viewer of replica 1 (lease {1.2:g} s).\n\n{markdown_table(g_head, g_rows)}\n"
    )


if __name__ == "__main__":
    main()
