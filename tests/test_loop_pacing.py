"""A loop flooded by wake-ups turns once per tick, takes every ready byte, and unpaces after.

A thread writes one byte at a time into a socket the loop reads, and each
read costs the loop some CPU, as a chunk of an event stream does. Unpaced,
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
from server.loop_pacing import LoopPacer, loop_pacer


class Counting(asyncio.Protocol):
    def __init__(self, cost_s: float) -> None:
        self.reads = 0
        self.bytes = 0
        self.cost_s = cost_s
        """CPU seconds each read costs, as if its bytes were made into frames."""

    def data_received(self, data: bytes) -> None:
        self.reads += 1
        self.bytes += len(data)
        end = time.thread_time() + self.cost_s
        while time.thread_time() < end:
            pass


@asynccontextmanager
async def bytes_every(
    every_s: float, cost_s: float = 0.0
) -> AsyncIterator[tuple[Counting, list[int]]]:
    """The loop reads a socket into which a thread writes a byte every ``every_s`` (for at
    most 10 s) until the block ends, each read costing ``cost_s`` of CPU; yields the reads
    and ``[bytes sent]``."""
    ours, theirs = socket.socketpair()
    counting, sent, stop = Counting(cost_s), [0], threading.Event()

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
        await until(lambda: counting.bytes == sent[0], 5.0)  # what is still on its way
        transport.close()
        theirs.close()


async def until(condition: Callable[[], bool], timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < end:
        await asyncio.sleep(0.02)
    return condition()


@pytest.fixture
async def pacer() -> LoopPacer:
    """The test's event loop's pacer, started."""
    started = loop_pacer()
    started.start()
    return started


async def test_a_flooded_loop_reads_once_per_tick_and_loses_nothing(
    pacer: LoopPacer, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(loop_pacing, "PROBE_AFTER_S", 0.4)  # a probe's 0.1 s unpaced each
    caplog.set_level(logging.INFO, "server.loop_pacing")

    def said(text: str) -> int:
        return sum(text in r.getMessage() for r in caplog.records)

    async with bytes_every(0.0002, cost_s=0.00015) as (counting, sent):
        assert await until(lambda: pacer.paced, 3.0), "a flood of wake-ups, and never paced"
        assert pacer.wakes_per_s > loop_pacing.ON_WAKES_PER_S
        assert pacer.busy > loop_pacing.BUSY_ABOVE
        reads, taken = counting.reads, counting.bytes
        await asyncio.sleep(1.0)  # past two probes: the flood goes on, so does the pacing
        reads, taken = counting.reads - reads, counting.bytes - taken
        assert pacer.paced and said("unpaced again") == 0
    assert taken > 0 and reads < 0.6 * taken, (reads, taken)  # unpaced: about one read each
    assert counting.bytes == sent[0], "bytes were lost"
    assert await until(lambda: not pacer.paced, 3.0), "the flood ended, and still paced"
    assert said("busy: one turn per 2 ms from now on") == 1
    assert await until(lambda: said("unpaced again") == 1, 1.0)


async def test_a_loop_woken_now_and_then_is_not_paced(pacer: LoopPacer) -> None:
    async with bytes_every(0.005) as (counting, sent):
        await asyncio.sleep(0.8)
    assert counting.bytes == sent[0]
    assert not pacer.paced, (pacer.wakes_per_s, pacer.busy)
    assert 0 < pacer.wakes_per_s < loop_pacing.ON_WAKES_PER_S


async def test_a_loop_woken_often_but_seldom_busy_is_not_paced(pacer: LoopPacer) -> None:
    # Pacing would save little CPU that anyone needs, and delay every frame.
    async with bytes_every(0.0005) as (counting, sent):
        await asyncio.sleep(0.8)
    assert counting.bytes == sent[0]
    measured = (pacer.wakes_per_s, pacer.busy)
    assert pacer.wakes_per_s > loop_pacing.ON_WAKES_PER_S, ("the test's flood is weak", measured)
    assert pacer.busy < loop_pacing.BUSY_ABOVE, measured
    assert not pacer.paced, measured


async def test_a_saturated_loop_is_paced_though_it_seldom_waits(pacer: LoopPacer) -> None:
    # Always behind, it seldom sleeps; unpaced, a little relief would flood it with wake-ups.
    async with bytes_every(0.0002, cost_s=0.002) as (counting, sent):
        assert await until(lambda: pacer.paced, 3.0), (pacer.wakes_per_s, pacer.busy)
        assert pacer.busy > loop_pacing.SATURATED_ABOVE
    assert counting.bytes == sent[0]
