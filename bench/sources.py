"""Server CPU per robot-sample by kind of source: ctrlX, RTDE (500 Hz in, 50 Hz out), MQTT, OPC UA.

For each kind and K: K robots, each on a source of its own, served by mocks in
processes of their own (so their CPU is not the server's): the ctrlX mock
(``python -m server.mock_ctrlx``, an LBR iiwa's 7 axes subscribed at 50 Hz),
the RTDE mock (``python -m server.mock_rtde``, a UR5e's 6 joints at 500 Hz: ten
packages per frame), Mosquitto with a publisher of the UR5e's joints as one
JSON message per robot at 50 Hz, the mock OPC UA server (``python -m
server.mock_opcua``, the same iiwa's 7 axes, one subscription per source at a
20 ms publishing interval). ``python -m server`` follows the cell with no
viewer; after a warm-up its CPU time (/proc) over the window is divided by the
robot-samples it made into frames (/api/health). Robots per core: what one
core would carry at 50 frames/s per robot. The kinds run alternately, several
rounds; the table has each kind's median and its ratio to ctrlX's from the same
rounds (the machine is shared: the ratio is steadier than the figures).

Usage: ``python bench/sources.py [--robots 10] [--seconds 5] [--rounds 3]
[--kinds ctrlx opcua] [--quick]``; writes docs/benchmarks.md except in quick runs
or when only some kinds were measured.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CACHE = tempfile.TemporaryDirectory(prefix="bench-sources-cache-")
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402
from cluster import ARM_JOINTS, ARM_KINEMATICS, PASSWORD_ENV, health  # noqa: E402
from viewers import cpu_seconds, free_port, stop  # noqa: E402

KINDS = ("ctrlx", "rtde", "mqtt", "opcua")
RTDE_CLIENTS_PER_MOCK = 5
OPCUA_CLIENTS_PER_MOCK = 4
OPCUA_NODES = [
    f"nsu=urn:linkview:mock-opcua;s=iiwa.Axes.iiwa_a{i}.ParameterSet.ActualPosition"
    for i in range(1, 8)
]
"""The mock OPC UA server's iiwa: the same arm as the ctrlX case's, units from the server."""
SENT = re.compile(r"sent (\d+) data packages in ([\d.]+) s")
RATE_HZ = 50.0
UR5E = (
    '{ type = "dh", d = [162.5, 0.0, 0.0, 133.3, 99.7, 99.6], '
    "a = [0.0, -425.0, -392.2, 0.0, 0.0, 0.0], alpha_deg = [90.0, 0.0, 0.0, 90.0, -90.0, 0.0] }"
)


def cell_text(kind: str, robots: int, urls: list[str]) -> str:
    """K robots of ``kind``, each on its own source, at ``urls`` in turn."""
    parts = []
    for i in range(robots):
        url = urls[i % len(urls)]
        base = f"base = {{ xyz = [{1500.0 * (i % 20)}, {1500.0 * (i // 20)}, 0.0] }}"
        if kind == "ctrlx":
            source = f'url = "{url}"\npassword_env = "{PASSWORD_ENV}"'
            joints = ", ".join(f'{{ node = "{n}", unit = "deg" }}' for n in ARM_JOINTS)
            robot = f"joints = [{joints}]\nkinematics = {ARM_KINEMATICS}"
        elif kind == "rtde":
            source, robot = f'type = "rtde"\nurl = "{url}"', f"kinematics = {UR5E}"
        elif kind == "opcua":
            source = f'type = "opcua"\nurl = "{url}"'
            joints = ", ".join(f'{{ node = "{n}" }}' for n in OPCUA_NODES)
            robot = f"joints = [{joints}]\nkinematics = {ARM_KINEMATICS}"
        else:
            source = f'type = "mqtt"\nurl = "{url}"'
            joints = ", ".join(
                f'{{ node = "bench/arm{i}#/joints/{j}", unit = "rad" }}' for j in range(6)
            )
            robot = f"joints = [{joints}]\nkinematics = {UR5E}"
        parts.append(
            f'[[source]]\nname = "s{i}"\n{source}\n\n'
            f'[[robot]]\nname = "arm{i}"\nsource = "s{i}"\n{base}\n{robot}\n'
        )
    return "\n".join(parts)


def start(stack: ExitStack, argv: list[str], log: Path) -> subprocess.Popen[bytes]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), PASSWORD_ENV: "boschrexroth"}
    env["LINKVIEW_CACHE_DIR"] = CACHE.name  # the OPC UA mock's address space, built once
    with open(log, "ab") as out:
        process = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=out, stderr=out)
    stack.callback(stop, process)
    return process


def wait_port(port: int, timeout_s: float = 20.0) -> None:
    import socket

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        with socket.socket() as sock:
            if sock.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise RuntimeError(f"nothing listens on port {port}")


def start_mock(stack: ExitStack, kind: str, robots: int, folder: Path) -> list[str]:
    """The mock of ``kind`` in processes of its own; the URLs the cell's sources use."""
    port = free_port()
    log = folder / f"mock-{kind}.log"
    if kind == "ctrlx":
        start(stack, [sys.executable, "-m", "server.mock_ctrlx", "--port", str(port)], log)
        wait_port(port)
        return [f"http://127.0.0.1:{port}"]
    if kind == "rtde":  # a process sends 500 Hz to a few clients only
        urls = []
        for k in range(math.ceil(robots / RTDE_CLIENTS_PER_MOCK)):
            port = free_port()
            argv = [sys.executable, "-m", "server.mock_rtde", "--port", str(port)]
            start(stack, argv, folder / f"mock-rtde-{k}.log")
            wait_port(port)
            urls.append(f"rtde://127.0.0.1:{port}")
        return urls
    if kind == "opcua":  # an asyncua server publishes to a few sessions only
        urls = []
        for k in range(math.ceil(robots / OPCUA_CLIENTS_PER_MOCK)):
            port = free_port()
            argv = [sys.executable, "-m", "server.mock_opcua", "--port", str(port)]
            start(stack, [*argv, "--security", "None"], folder / f"mock-opcua-{k}.log")
            wait_port(port, timeout_s=120.0)  # the first start builds the address space
            urls.append(f"opc.tcp://127.0.0.1:{port}")
        return urls
    config = folder / "mosquitto.conf"
    config.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
    start(stack, ["mosquitto", "-c", str(config)], log)
    wait_port(port)
    argv = [sys.executable, str(Path(__file__)), "--publish", str(port), str(robots)]
    start(stack, argv, log)
    return [f"mqtt://127.0.0.1:{port}"]


async def publish_mqtt(port: int, robots: int) -> None:
    """The MQTT mock's publisher: each robot's six joints as one JSON message, at 50 Hz."""
    import aiomqtt

    from server.mock_ctrlx import Machine
    from server.mock_rtde import demo_groups
    from server.mqtt.nodes import parse_node
    from server.mqtt.publisher import payloads

    machine = Machine(demo_groups()[:1])
    nodes = {
        f"bench/arm{i}#/joints/{j}": parse_node(f"bench/arm{i}#/joints/{j}")
        for i in range(robots)
        for j in range(6)
    }
    async with aiomqtt.Client("127.0.0.1", port) as client:
        loop = asyncio.get_running_loop()
        due = loop.time()
        while True:
            q = machine.snapshot()
            values = {key: q[f"ur5e_q{key[-1]}"] for key in nodes}
            for topic, payload in payloads(nodes, values).items():
                await client.publish(topic, payload)
            due = max(due + 1.0 / RATE_HZ, loop.time())
            await asyncio.sleep(due - loop.time())


def run_case(kind: str, robots: int, warmup: float, seconds: float) -> dict[str, float]:
    """One kind at one size: CPU per robot-sample and frames/s per robot."""
    with ExitStack() as stack, tempfile.TemporaryDirectory(prefix="bench-sources-") as tmp:
        folder = Path(tmp)
        urls = start_mock(stack, kind, robots, folder)
        cell = folder / "cell.toml"
        cell.write_text(cell_text(kind, robots, urls))
        port = free_port()
        argv = [sys.executable, "-m", "server", "--cell", str(cell), "--port", str(port)]
        server = start(stack, argv, folder / "server.log")
        wait_port(port)
        time.sleep(warmup)
        frames0 = sum(r["frames"] for r in health(port)["robots"])
        cpu0, t0 = cpu_seconds(server.pid), time.monotonic()
        time.sleep(seconds)
        cpu1, t1 = cpu_seconds(server.pid), time.monotonic()
        body = health(port)
        frames = sum(r["frames"] for r in body["robots"]) - frames0
        connected = sum(s["state"] == "connected" for s in body["sources"])
        stack.close()  # the RTDE mocks print what they sent as they stop
        sent = [m.groups() for m in SENT.finditer(_logs(folder, "mock-rtde-*.log"))]
    # The mocks' packages per second and client (rates over their whole run).
    sent_hz = sum(int(n) / float(t) for n, t in sent) / robots if sent else float("nan")
    if frames <= 0:
        raise RuntimeError(f"{kind}: no frames made; see the server's log")
    return {
        "ms": 1e3 * (cpu1 - cpu0) / frames,
        "hz": frames / robots / (t1 - t0),
        "cpu": (cpu1 - cpu0) / (t1 - t0),
        "connected": connected,
        "sent_hz": sent_hz,
    }


def _logs(folder: Path, pattern: str) -> str:
    return "".join(p.read_text(errors="replace") for p in folder.glob(pattern))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=10, help="robots (and sources) per kind")
    parser.add_argument("--seconds", type=float, default=5.0, help="measuring window")
    parser.add_argument("--warmup", type=float, default=4.0)
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds per kind")
    parser.add_argument("--quick", action="store_true", help="2 robots, 1 s, 1 round; no docs")
    parser.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS))
    parser.add_argument("--publish", nargs=2, type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.publish:
        asyncio.run(publish_mqtt(*args.publish))
        return
    if args.quick:
        args.robots, args.seconds, args.warmup, args.rounds = 2, 1.0, 3.0, 1
    kinds = ["ctrlx", *(k for k in KINDS if k in args.kinds and k != "ctrlx")]
    results: dict[str, list[dict[str, float]]] = {kind: [] for kind in kinds}
    for _ in range(args.rounds):
        for kind in kinds:
            case = run_case(kind, args.robots, args.warmup, args.seconds)
            results[kind].append(case)
            print(f"{kind}: {case['ms']:.3f} ms per robot-sample, {case['hz']:.1f} frames/s/robot")
    ctrlx = [c["ms"] for c in results["ctrlx"]]
    rows = []
    for kind in kinds:
        ms = [c["ms"] for c in results[kind]]
        ratios = [m / c for m, c in zip(ms, ctrlx, strict=True)]
        median = statistics.median(ms)
        rows.append(
            [
                kind,
                f"{median:.3f}",
                f"{statistics.median(ratios):.2f}",
                f"{statistics.median(c['hz'] for c in results[kind]):.1f}",
                f"{1e3 / (median * RATE_HZ):.0f}",
                f"{min(c['connected'] for c in results[kind]):.0f} of {args.robots}",
            ]
        )
    rtde = results.get("rtde") or [{"sent_hz": math.nan}]
    packages = statistics.median(c["sent_hz"] for c in rtde)
    header = ["kind", "ms CPU per robot-sample", "x ctrlX", "frames/s per robot"]
    header += ["robots per core at 50 Hz", "sources connected"]
    body = markdown_table(header, rows)
    body += (
        f"\n\n{args.robots} robots per kind, each on its own source; medians of {args.rounds} "
        f"alternating rounds of {args.seconds:g} s after {args.warmup:g} s of warm-up; the "
        "server's CPU (user + system, /proc) over the robot-samples it made into frames, no "
        "viewer. ctrlX: the mock's event streams, an LBR iiwa (7 joints) per source. RTDE: the "
        f"mock UR controllers' data packages ({packages:.0f} per second and source as the mocks "
        f"counted them, {RTDE_CLIENTS_PER_MOCK} sources per mock process), a UR5e (6 joints) "
        "per source; the newest of each 20 ms is unpacked. MQTT: Mosquitto, one JSON message "
        "with a UR5e's joints per robot at 50 Hz. OPC UA: the mock OPC UA server's iiwa (the "
        "same 7 joints as ctrlX's), one session and one subscription (20 ms publishing "
        f"interval) per source, {OPCUA_CLIENTS_PER_MOCK} sources per mock process, units "
        "from its EngineeringUnits. Mocks and broker run in processes of their own on the "
        "same machine."
    )
    if args.quick or len(kinds) < len(KINDS):
        print(body)
    else:
        publish("bench/sources.py", "Sources: CPU per robot-sample by kind", body)


if __name__ == "__main__":
    main()
