"""A loop flooded by wake-ups turns once per tick, takes every ready byte, and unpaces after.

A thread writes one byte at a time into a socket the loop reads. Unpaced,
the loop wakes for each byte and reads it alone; paced, a turn reads what
arrived during the tick's sleep, so there are far fewer reads than bytes.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

import pytest

from server import loop_pacing
from server.loop_pacing import loop_pacer


class Counting(asyncio.Protocol):
    def __init__(self) -> None:
        self.reads = 0
        self.bytes = 0

    def data_received(self, data: bytes) -> None:
        self.reads += 1
        self.bytes += len(data)


@asynccontextmanager
async def bytes_every(every_s: float) -> AsyncIterator[tuple[Counting, list[int]]]:
    """The loop reads a socket into which a thread writes a byte every ``every_s`` (for at
    most 10 s) until the block ends; yields the reads and ``[bytes sent]``."""
    ours, theirs = socket.socketpair()
    counting, sent, stop = Counting(), [0], threading.Event()

    def write() -> None:
        end = time.monotonic() + 10.0
        while not stop.is_set() and time.monotonic() < end:
            theirs.send(b"x")
            sent[0] += 1
            time.sleep(every_s)

    loop = asyncio.get_running_loop()
    transport, _ = await loop.connect_accepted_socket(lambda: counting, ours)
    thread = threading.Thread(target=write, daemon=True)
    thread.start()
    try:
        yield counting, sent
    finally:
        stop.set()
        thread.join()
        transport.close()
        theirs.close()


async def until(condition: Callable[[], bool], timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < end:
        await asyncio.sleep(0.02)
    return condition()


async def test_a_flooded_loop_reads_once_per_tick_and_loses_nothing(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(loop_pacing, "PROBE_AFTER_S", 0.4)  # a probe's 0.1 s unpaced each
    caplog.set_level(logging.INFO, "server.loop_pacing")
    pacer = loop_pacer()
    pacer.start()

    def said(text: str) -> int:
        return sum(text in r.getMessage() for r in caplog.records)

    async with bytes_every(0.0002) as (counting, sent):
        assert await until(lambda: pacer.paced, 3.0), "a flood of wake-ups, and never paced"
        assert pacer.wakes_per_s > loop_pacing.ON_WAKES_PER_S
        reads, taken = counting.reads, counting.bytes
        await asyncio.sleep(1.0)  # past two probes: the flood goes on, so does the pacing
        reads, taken = counting.reads - reads, counting.bytes - taken
        assert pacer.paced and said("unpaced again") == 0
    assert taken > 0 and reads < 0.6 * taken, (reads, taken)  # unpaced: about one read each
    assert await until(lambda: counting.bytes == sent[0], 2.0), "bytes were lost"
    assert await until(lambda: not pacer.paced, 3.0), "the flood ended, and still paced"
    assert said("times a second: one turn per 2 ms") == 1
    assert await until(lambda: said("unpaced again") == 1, 1.0)


async def test_a_loop_woken_now_and_then_is_not_paced() -> None:
    pacer = loop_pacer()
    pacer.start()
    async with bytes_every(0.005) as (counting, sent):
        await asyncio.sleep(0.8)
    assert await until(lambda: counting.bytes == sent[0], 2.0)
    assert not pacer.paced
    assert 0 < pacer.wakes_per_s < loop_pacing.ON_WAKES_PER_S
