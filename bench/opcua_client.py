"""Where an OPC UA sample's CPU goes in linkview's client, beside the ctrlX client's.

One connector follows an LBR iiwa's 7 axes at 50 Hz from a mock in a process of
its own (``python -m server.mock_opcua`` or ``python -m server.mock_ctrlx``),
in this process and nothing else: its thread CPU time over the window divided by
the samples delivered is the client's cost per sample, without the server's
kinematics, frames and hub (bench/sources.py has those). For OPC UA the time is
split by wrapping functions with CPU clocks: decoding the PublishResponse,
sending PublishRequests (encoding, chunking, the socket write), reading the
response off the socket (chunks, the request's future), and linkview's own
handler (one Sample per response); the rest is the event loop and the publish
loop between them. The kinds run alternately;
medians of the rounds.

Usage: ``python bench/opcua_client.py [--seconds 8] [--rounds 3] [--quick]``;
writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import statistics
import sys
import time
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402
from cluster import ARM_JOINTS  # noqa: E402
from sources import CACHE, OPCUA_NODES, start, wait_port  # noqa: E402
from viewers import free_port  # noqa: E402

from server.opcua.publish import BATCH  # noqa: E402

PARTS = {
    "decode": "decoding the PublishResponse (server/opcua/publish.py, asyncua's where unusual)",
    "request": f"sending PublishRequests ({BATCH} per corked socket write, every {BATCH}th sample)",
    "receive": "reading the response off the socket (asyncua)",
    "handler": "linkview's handler: one Sample per response",
}
_spent: collections.Counter[str] = collections.Counter()


def _timed(owner: Any, name: str, part: str) -> None:
    """Count the CPU time of ``owner.name`` into ``part``."""
    inner: Callable[..., Any] = getattr(owner, name)

    def timed(*args: Any, **kwargs: Any) -> Any:
        began = time.thread_time()
        try:
            return inner(*args, **kwargs)
        finally:
            _spent[part] += time.thread_time() - began

    setattr(owner, name, timed)


def _instrument() -> None:
    import asyncua.client.ua_client as ua_client

    from server.opcua import publish
    from server.opcua.follow import Follower

    _timed(publish, "decode", "decode")
    _timed(publish, "struct_from_binary", "decode")
    _timed(publish.Publisher, "_top_up", "request")
    _timed(ua_client.UASocketProtocol, "data_received", "receive")
    _timed(Follower, "on_publish", "handler")


async def _follow(kind: str, url: str, warmup: float, seconds: float) -> dict[str, float]:
    from server.ctrlx import Credentials, CtrlxConnector, DataLayerClient
    from server.opcua import OpcuaConnector, OpcuaSettings

    if kind == "opcua":
        connector: Any = OpcuaConnector(OpcuaSettings(url))
        nodes = OPCUA_NODES
    else:
        connector = CtrlxConnector(
            DataLayerClient(url, Credentials("boschrexroth", "boschrexroth"))
        )
        nodes = ARM_JOINTS
    count = [0]

    def deliver(_: object) -> None:
        count[0] += 1

    task = asyncio.create_task(connector.follow(nodes, 0.02, deliver))
    try:
        await asyncio.sleep(warmup)
        _spent.clear()
        cpu0, n0 = time.thread_time(), count[0]
        await asyncio.sleep(seconds)
        cpu, samples = time.thread_time() - cpu0, count[0] - n0
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        await connector.close()
    if samples <= 0:
        raise RuntimeError(f"{kind}: no samples")
    result = {"ms": 1e3 * cpu / samples, "hz": samples / seconds}
    result |= {part: 1e3 * _spent[part] / samples for part in PARTS}
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="measuring window")
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    parser.add_argument("--quick", action="store_true", help="1 round of 2 s; no docs")
    args = parser.parse_args()
    if args.quick:
        args.seconds, args.rounds = 2.0, 1
    _instrument()
    results: dict[str, list[dict[str, float]]] = {"ctrlx": [], "opcua": []}
    with ExitStack() as stack:
        folder = Path(stack.enter_context(_temporary()))
        urls = {}
        for kind, module, scheme in (
            ("ctrlx", "server.mock_ctrlx", "http"),
            ("opcua", "server.mock_opcua", "opc.tcp"),
        ):
            port = free_port()
            argv = [sys.executable, "-m", module, "--port", str(port)]
            argv += ["--security", "None"] if kind == "opcua" else []
            start(stack, argv, folder / f"{kind}.log")
            wait_port(port, timeout_s=120.0)
            urls[kind] = f"{scheme}://127.0.0.1:{port}"
        for _ in range(args.rounds):
            for kind in results:
                case = asyncio.run(_follow(kind, urls[kind], args.warmup, args.seconds))
                results[kind].append(case)
                print(f"{kind}: {case['ms']:.3f} ms CPU per sample, {case['hz']:.1f} samples/s")
    median = {k: {f: statistics.median(c[f] for c in v) for f in v[0]} for k, v in results.items()}
    opcua, ctrlx = median["opcua"], median["ctrlx"]
    rows = [["ctrlX client, all of it", f"{ctrlx['ms']:.3f}", f"{ctrlx['hz']:.1f}"]]
    rows.append(["OPC UA client, all of it", f"{opcua['ms']:.3f}", f"{opcua['hz']:.1f}"])
    rows += [[f"OPC UA: {text}", f"{opcua[part]:.3f}", ""] for part, text in PARTS.items()]
    rest = opcua["ms"] - sum(opcua[part] for part in PARTS)
    rows.append(["OPC UA: the rest (event loop, the publish loop between)", f"{rest:.3f}", ""])
    body = markdown_table(["part", "ms CPU per sample", "samples/s"], rows)
    body += (
        f"\n\nOne connector in one process following an LBR iiwa's 7 axes at 50 Hz from the "
        f"mock in a process of its own; medians of {args.rounds} alternating rounds of "
        f"{args.seconds:g} s after {args.warmup:g} s; the process's thread CPU time over the "
        "samples delivered, the parts by CPU clocks around asyncua's functions (the clocks "
        "themselves cost a little). The mock OPC UA server sends SourceTimestamps only, as "
        "linkview asks."
    )
    if args.quick:
        print(body)
    else:
        publish("bench/opcua_client.py", "OPC UA: where a sample's CPU goes in the client", body)


def _temporary() -> Any:
    import tempfile

    return tempfile.TemporaryDirectory(prefix="bench-opcua-client-")


if __name__ == "__main__":
    assert CACHE  # the mock OPC UA server's address space is cached for the run
    main()
