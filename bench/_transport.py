"""Redis pub/sub against Redis streams for the cluster's frames, for bench/cluster.py.

``publish`` sends, for ``--sources`` sources at ``--rate`` Hz, one frame of
``--size`` bytes each (the first 8 bytes: the send time, unix s, f64), every
2 ms tick as the worker's publisher does; ``subscribe`` receives them as a
replica does (redis-py, asyncio, hiredis) and records each frame's delay.
Both print ``ready``, then measure the window ``START END`` (unix s) read
from stdin, and print a JSON summary.

Transports (``--transport``):

* ``pubsub-batch``: one PUBLISH per tick, the tick's frames packed as the
  cluster does (server.cluster.envelope); what linkview uses;
* ``pubsub-frame``: one PUBLISH per frame, on a channel per source;
* ``streams-batch``: one XADD per tick (MAXLEN ~ 1000), read with XREAD BLOCK;
* ``streams-frame``: one XADD per frame on one stream, read with XREAD BLOCK.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import struct
import sys
import time
from typing import Any

import numpy as np
from redis.asyncio import Redis

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from server.cluster import envelope  # noqa: E402
from server.stream import Message  # noqa: E402

TICK_S = 0.002
STREAM = "bench:frames"
STAMP = struct.Struct("<d")
WINDOW = [float("inf"), float("inf")]


async def read_window() -> None:
    """Print ``ready`` and wait for the measuring window on stdin."""
    print("ready", flush=True)
    line = await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
    WINDOW[:] = map(float, line.split())


async def publish(
    redis: Redis, transport: str, sources: int, rate: float, size: int
) -> dict[str, Any]:
    """Send frames until the window has passed; counts of what was sent in it.

    Every tick sends the frames of its share of the sources (source i in tick
    i mod ticks-per-period), also when the loop runs late: a late tick is sent
    as it would have been, not merged with the next, so every transport gets
    the same batches whatever the machine's load.
    """
    names = [f"s{i}" for i in range(sources)]
    filler = os.urandom(size - STAMP.size)
    per_period = max(1, round(1.0 / rate / TICK_S))
    slots = [names[k::per_period] for k in range(per_period)]
    sent = commands = tick = 0
    start = time.time() + 0.5
    waiting = asyncio.create_task(read_window())
    while time.time() < WINDOW[1] or not waiting.done():
        while (now := time.time()) >= start + tick * TICK_S and now < WINDOW[1]:
            frames = [(name, STAMP.pack(now) + filler) for name in slots[tick % per_period]]
            used = await send(redis, transport, frames)
            if WINDOW[0] <= now < WINDOW[1]:
                sent, commands = sent + len(frames), commands + used
            tick += 1
        await asyncio.sleep(max(0.0, start + tick * TICK_S - time.time()))
    return {"sent": sent, "commands": commands}


async def send(redis: Redis, transport: str, frames: list[tuple[str, bytes]]) -> int:
    """Send one tick's frames; how many Redis commands that took."""
    if transport == "pubsub-batch":
        items = [(f"frames2:{name}", Message(data, None), 2) for name, data in frames]
        await redis.publish(STREAM, envelope.pack(items))
        return 1
    if transport == "streams-batch":
        items = [(f"frames2:{name}", Message(data, None), 2) for name, data in frames]
        await redis.xadd(STREAM, {"d": envelope.pack(items)}, maxlen=1000, approximate=True)
        return 1
    async with redis.pipeline(transaction=False) as pipe:
        for name, data in frames:
            if transport == "pubsub-frame":
                pipe.publish(f"{STREAM}:{name}", data)
            else:
                pipe.xadd(STREAM, {"s": name, "d": data}, maxlen=10_000, approximate=True)
        await pipe.execute()
    return len(frames)


async def subscribe(redis: Redis, transport: str, sources: int) -> dict[str, Any]:
    """Receive until the window has passed; the delays of what arrived in it."""
    delays: list[float] = []

    def got(data: bytes, now: float) -> None:
        if WINDOW[0] <= now < WINDOW[1]:
            delays.append(now - STAMP.unpack_from(data)[0])

    def got_batch(batch: bytes, now: float) -> None:
        for _, message, _ in envelope.unpack(batch):
            assert isinstance(message.payload, bytes)
            got(message.payload, now)

    waiting = asyncio.create_task(read_window())
    if transport.startswith("pubsub"):
        pubsub = redis.pubsub(ignore_subscribe_messages=True)
        if transport == "pubsub-batch":
            await pubsub.subscribe(STREAM)
        else:
            await pubsub.subscribe(*(f"{STREAM}:s{i}" for i in range(sources)))
        while time.time() < WINDOW[1] + 0.5 or not waiting.done():
            message = await pubsub.get_message(timeout=0.5)
            if message is not None and message["type"] == "message":
                now = time.time()
                (got_batch if transport == "pubsub-batch" else got)(message["data"], now)
        await pubsub.aclose()  # type: ignore[no-untyped-call]
    else:
        last = "$"
        while time.time() < WINDOW[1] + 0.5 or not waiting.done():
            answer = await redis.xread({STREAM: last}, block=500, count=1000)
            now = time.time()
            for _, entries in answer:
                for ident, fields in entries:
                    last = ident
                    if transport == "streams-batch":
                        got_batch(fields[b"d"], now)
                    else:
                        got(fields[b"d"], now)
    received = np.array(delays)
    return {
        "received": len(delays),
        "p50_ms": float(np.percentile(received, 50) * 1e3) if len(received) else float("nan"),
        "p99_ms": float(np.percentile(received, 99) * 1e3) if len(received) else float("nan"),
    }


async def main(args: argparse.Namespace) -> None:
    redis = Redis.from_url(args.url)
    if args.role == "publish":
        summary = await publish(redis, args.transport, args.sources, args.rate, args.size)
    else:
        summary = await subscribe(redis, args.transport, args.sources)
    await redis.aclose()
    print(json.dumps(summary), flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("role", choices=["publish", "subscribe"])
    parser.add_argument("--url", required=True)
    parser.add_argument(
        "--transport",
        required=True,
        choices=["pubsub-batch", "pubsub-frame", "streams-batch", "streams-frame"],
    )
    parser.add_argument("--sources", type=int, required=True)
    parser.add_argument("--rate", type=float, default=50.0)
    parser.add_argument("--size", type=int, default=312, help="bytes per frame (an iiwa: 312)")
    asyncio.run(main(parser.parse_args()))
