"""CPU per event-stream chunk: what reading K controllers' subscriptions costs, layer by layer.

bench/plant.py measures the whole server; bench/sample_path.py our own code
without sockets. This one measures the part between them: K real mock
controllers (bench/_mock_farm.py, on CPU 1) each stream one 7-axis arm's
subscription at 50 Hz (seven ``update`` events per publish cycle, one network
chunk), and one process on CPU 0 reads all K streams with uvloop, as the
server does, up to a given layer:

- ``socket``: an asyncio protocol that only counts chunks (the floor: uvloop
  and the kernel);
- ``aiohttp``: the subscription's response opened by aiohttp and read with
  ``readany()`` (aiohttp's HTTP parser, stream reader and a task wake-up per
  chunk), as linkview read every stream before server/ctrlx/stream_wire.py;
- ``EventStream``: linkview's own GET, its chunks parsed and decoded as
  they arrive (no task);
- ``follow_into()``: the samples as the acquisition gets them (the
  gathering of a cycle's events into a sample).

Reported: chunks per second, this process's CPU, and CPU µs per chunk
(= per robot-sample). Each layer runs in a fresh process.

Usage: ``python bench/sse_read.py [--robots 100] [--seconds 8] [--quick]``;
writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402
from cluster import ARM_JOINTS, start_farms  # noqa: E402
from yarl import URL  # noqa: E402

from server.ctrlx import Credentials, DataLayerClient, follow_into  # noqa: E402
from server.ctrlx.events import Subscription, SubscriptionSettings  # noqa: E402

LAYERS = {
    "socket": "socket only (uvloop, kernel)",
    "aiohttp": "aiohttp readany (bytes only)",
    "events": "EventStream: events decoded",
    "follow": "follow_into(): samples",
}
SETTINGS = SubscriptionSettings(publish_interval_ms=20)
WARM_UP_S = 3.0


async def read_layer(layer: str, url: str, count: list[int]) -> None:
    """Read one controller's stream up to ``layer``, counting chunks (samples) in ``count``."""
    client = DataLayerClient(url, Credentials("boschrexroth", "boschrexroth"))

    def counted(*_: object) -> None:
        count[0] += 1

    if layer == "follow":
        await follow_into(client, ARM_JOINTS, 0.02, counted)
    subscription = Subscription(client, ARM_JOINTS, SETTINGS)
    stream = await subscription.open(counted)  # creates the subscription
    if layer == "events":
        await stream.ended
        raise RuntimeError("the stream ended")
    stream.close()
    path = f"{client.paths.events}/{subscription.id}"
    if layer == "socket":
        await socket_only(client, path, count)
    response = await client.open_stream(path)
    while await response.content.readany():
        count[0] += 1


async def socket_only(client: DataLayerClient, path: str, count: list[int]) -> None:
    """The same stream (same URL and token) read by a protocol that only counts chunks."""
    url, token = URL(client.base_url + path), await client.tokens.current()

    class Counting(asyncio.Protocol):
        def data_received(self, data: bytes) -> None:
            count[0] += 1

    transport, _ = await asyncio.get_running_loop().create_connection(Counting, url.host, url.port)
    transport.write(
        f"GET {url.raw_path_qs} HTTP/1.1\r\nHost: {url.host}:{url.port}\r\n"
        f"Authorization: Bearer {token}\r\nAccept: text/event-stream\r\n\r\n".encode()
    )
    await asyncio.Event().wait()


async def measure(layer: str, urls: list[str], seconds: float) -> dict[str, Any]:
    count = [0]
    tasks = [asyncio.create_task(read_layer(layer, url, count)) for url in urls]
    await asyncio.sleep(WARM_UP_S)
    chunks, cpu = count[0], time.process_time()
    await asyncio.sleep(seconds)
    chunks, cpu = count[0] - chunks, time.process_time() - cpu
    for task in tasks:
        task.cancel()
    failed = [t for t in tasks if t.done() and not t.cancelled() and t.exception()]
    if failed:
        raise RuntimeError(f"{layer}: {failed[0].exception()!r}")
    return {"chunks_s": chunks / seconds, "cpu": cpu / seconds, "us": 1e6 * cpu / max(chunks, 1)}


def one_layer(layer: str, urls: list[str], seconds: float) -> None:
    """Child process: pinned to CPU 0, measure ``layer``, print one JSON line."""
    import uvloop

    os.sched_setaffinity(0, {0})
    print(json.dumps(uvloop.run(measure(layer, urls, seconds))), flush=True)
    os._exit(0)  # the read tasks' connections are dropped with the process


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument(
        "--quick", action="store_true", help="K = 5, 1 s, the follow layer only; no docs update"
    )
    parser.add_argument("--layer", help=argparse.SUPPRESS)  # the child's
    parser.add_argument("--urls", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.layer:
        return one_layer(args.layer, args.urls.split(","), args.seconds)
    if args.quick:
        args.robots, args.seconds = 5, 1.0
    load0, rows = os.getloadavg(), []
    with ExitStack() as stack, tempfile.TemporaryDirectory() as folder:
        farms, urls = start_farms(stack, args.robots, Path(folder))
        for pid in farms:
            os.sched_setaffinity(pid, {1})
        for layer, name in LAYERS.items() if not args.quick else list(LAYERS.items())[-1:]:
            out = subprocess.run(
                [sys.executable, __file__, "--layer", layer, "--urls", ",".join(urls)]
                + ["--seconds", str(args.seconds)],
                capture_output=True,
                text=True,
                check=True,
                timeout=60 + args.seconds,
            ).stdout
            got = json.loads(out.splitlines()[-1])
            rows.append([name, f"{got['chunks_s']:.0f}", f"{got['cpu']:.0%}", f"{got['us']:.1f}"])
            print(" | ".join(rows[-1]), flush=True)
    load1 = os.getloadavg()
    header = ["read up to", "chunks/s (all streams)", "CPU", "CPU µs per chunk"]
    notes = (
        f"{args.robots} mock controllers (bench/_mock_farm.py, pinned to CPU 1), one "
        "subscription each to a 7-axis arm's joints at 50 Hz: a chunk is one publish cycle "
        "(seven update events), i.e. one robot-sample. One reading process per layer, pinned "
        f"to CPU 0, uvloop; {WARM_UP_S:g} s of warm-up, {args.seconds:g} s measured. Below "
        "50 chunks/s per controller the mocks (one core for all) fall behind. Load average "
        f"(1 min) {load0[0]:.2f} before, {load1[0]:.2f} after."
    )
    body = f"{notes}\n\n{markdown_table(header, rows)}\n"
    if args.quick:
        print("\n" + body)
    else:  # prints it too
        publish("bench/sse_read.py", "Reading event streams: CPU per chunk, layer by layer", body)


if __name__ == "__main__":
    main()
