"""Server CPU per robot-sample, stage by stage, from the SSE bytes to the socket write.

bench/plant.py measures the whole process against real controllers; on a
shared 2-core machine its figure moves with the load. This one runs the same
code path in one thread, without sockets, so each stage's cost is steady
enough to compare changes: the events of one publish cycle of a 7-axis arm
(seven ``update`` events, as the mock and a ctrlX CORE send them) are parsed
and decoded (``server.ctrlx.sse`` and ``updates``), gathered into a sample (the subscription's
latest-value store), kept in the history, turned into poses and encoded
(``Acquisition``), and offered to one protocol-2 viewer whose connection takes
it at once (the WebSocket frame made once per message). What it leaves out
(the event loop, aiohttp's reading, the kernel) is the difference to
bench/plant.py's figure.

Usage: ``python bench/sample_path.py [--samples 20000] [--quick]``; writes
docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402
from cluster import ARM_JOINTS, cell_text  # noqa: E402

from server.cell.load import load_cell  # noqa: E402
from server.ctrlx.sample import Sample  # noqa: E402
from server.ctrlx.sse import SseParser  # noqa: E402
from server.ctrlx.subscribed import Latest  # noqa: E402
from server.ctrlx.timestamps import filetime_from_unix  # noqa: E402
from server.ctrlx.updates import Update, decode_event, plain_updates  # noqa: E402
from server.history import History  # noqa: E402
from server.mock_ctrlx.events import sse  # noqa: E402
from server.stream.acquisition import Acquisition, PollSettings  # noqa: E402
from server.stream.batches import sample_batch  # noqa: E402
from server.stream.hub import Hub, Message  # noqa: E402
from server.stream.status import SourceHealth  # noqa: E402
from server.web.wire import ws_frames  # noqa: E402

PERIOD_S = 0.02
REPEATS = 5
TURN_SIZES = (1, 10, 50, 200)
NODES_PREFIX = "/automation/api/v2/nodes/"


class _Connector:
    """What Acquisition asks of its connector off the network: its warning and device state."""

    warning: str | None = None
    device: str | None = None
    halted: str | None = None


def publish_cycles(count: int) -> list[bytes]:
    """``count`` chunks, each one publish cycle of the arm's seven nodes (deg, moving)."""
    chunks, event_id, t0 = [], 0, time.time()
    for i in range(count):
        stamp = filetime_from_unix(t0 + i * PERIOD_S)
        parts = []
        for j, node in enumerate(ARM_JOINTS):
            event_id += 1
            value = 40.0 * math.sin(0.01 * i + j)
            data = {"event": "update", "node": node, "timestamp": stamp}
            parts.append(sse("update", event_id, {**data, "value": value, "type": "double"}))
        chunks.append(b"".join(parts))
    return chunks


def acquisitions(folder: Path, count: int) -> tuple[list[Acquisition], list[Message]]:
    """``count`` arms, each on its own source with its history, and what one viewer was sent."""
    cell_file = folder / "cell.toml"
    cell_file.write_text(cell_text([f"http://127.0.0.1:{1 + i}" for i in range(count)]))
    cell = load_cell(cell_file, env={"CLUSTER_PASSWORD": "x"}, cache_dir=folder)
    hub, sent = Hub(), []

    def send_now(message: Message) -> bool:
        if message.wire is None:
            message.wire = ws_frames(message.payload)
        sent.append(message)
        return True

    hub.join(protocol=2, send_now=send_now)
    history, nodes, out = History(60.0), sorted(ARM_JOINTS), []
    for robot in cell.robots:
        health = SourceHealth(name=robot.source, url="http://127.0.0.1:1", mock=False)
        tap = history.source(robot.source, nodes, PERIOD_S)
        settings = PollSettings(PERIOD_S)
        out.append(Acquisition(_Connector(), [robot], hub, health, settings, tap=tap))  # type: ignore[arg-type]
    return out, sent


def per_sample_us(stage: Callable[[int], object], count: int) -> float:
    """Median over REPEATS of the µs per call of ``stage(i)`` for i < count."""
    times = []
    for _ in range(REPEATS):
        gc.collect()
        start = time.perf_counter()
        for i in range(count):
            stage(i)
        times.append((time.perf_counter() - start) / count * 1e6)
    return statistics.median(times)


async def acquire_us(samples: list[Sample], sources: int) -> float:
    """µs per robot-sample of the acquisitions when ``sources`` share each batch."""
    with tempfile.TemporaryDirectory() as tmp:
        sourced, sent = acquisitions(Path(tmp), sources)
        turns, batch = max(len(samples) // sources, 50), sample_batch()
        times = []
        for _ in range(REPEATS):
            gc.collect()
            start = time.perf_counter()
            for i in range(turns):
                for acquisition in sourced:
                    acquisition._on_sample(samples[i % len(samples)])
                batch.flush()  # as the batch window's end would: computed and sent
            times.append((time.perf_counter() - start) / (turns * sources) * 1e6)
        frames = sum(m.t_source is not None for m in sent)  # status messages have none
        assert frames == REPEATS * turns * sources, "every sample must reach the viewer"
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument(
        "--quick", action="store_true", help="200 samples, 1 and 10 sources; no docs update"
    )
    args = parser.parse_args()
    count = 200 if args.quick else args.samples
    chunks = publish_cycles(count)
    nodes = sorted(ARM_JOINTS)
    items = [[decode_event(e, NODES_PREFIX) for e in SseParser().feed(c)] for c in chunks]
    samples = [
        Sample(it[0].t_source or 0.0, {u.node: u.value for u in it if isinstance(u, Update)})
        for it in items  # type: ignore[union-attr]
    ]
    sse_parser, latest = SseParser(), Latest(nodes, grace_s=1.0)
    cycles = [plain_updates(SseParser().usual_updates(c) or []) for c in chunks]

    def parse(i: int) -> object:  # as EventStream reads a chunk of a publish cycle
        datas = sse_parser.usual_updates(chunks[i])
        assert datas is not None, "a publish cycle takes the fast path"
        return plain_updates(datas)

    def gather(i: int) -> object:
        latest.add(cycles[i])  # type: ignore[arg-type]
        return latest.take()

    read_us = per_sample_us(parse, count) + per_sample_us(gather, count)
    rows = []
    for sources in TURN_SIZES[:2] if args.quick else TURN_SIZES:
        acquire = asyncio.run(acquire_us(samples, sources))
        rows.append([str(sources), f"{read_us:.1f}", f"{acquire:.1f}", f"{read_us + acquire:.1f}"])
        print(" | ".join(rows[-1]), flush=True)
    header = [
        "sources per batch",
        "parse, decode, gather (µs)",
        "history, poses, encode, offer (µs)",
        "total µs per robot-sample",
    ]
    notes = (
        f"One thread, no sockets; {count} publish cycles of a KUKA LBR iiwa 7 R800's seven "
        "joint nodes. Parse, decode, gather: SseParser.usual_updates and plain_updates (a "
        "publish cycle of plain float updates, as EventStream reads it) and the subscription's "
        "latest-value store, per sample. History, poses, encode, offer: Acquisition with "
        "every source's history and one protocol-2 viewer whose socket takes each frame at "
        "once (its WebSocket frame made once), for K sources whose samples arrive within "
        "one batch window, computed as one batch. Median of "
        f"{REPEATS} runs. The event loop, aiohttp's reading and the kernel are not in it: "
        "bench/plant.py measures those too."
    )
    body = f"{notes}\n\n{markdown_table(header, rows)}\n"
    print(body)
    if not args.quick:
        publish("bench/sample_path.py", "Server CPU per robot-sample, stage by stage", body)


if __name__ == "__main__":
    main()
