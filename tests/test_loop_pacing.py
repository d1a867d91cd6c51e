"""A loop flooded by wake-ups turns once per tick, takes every ready byte, and unpaces after.

What the pacer decides from depends on the machine (how often its thread is
woken, how much CPU it uses), so the tests set those measures themselves
(``Measures``): the decisions are checked against the module's thresholds, and
the pacing itself on a real loop reading a real socket into which a thread
writes one byte at a time. Paced, a turn reads what arrived during the tick's
sleep, at most one read per turn. How much pacing saves on a given machine is
a benchmark's question (bench/wakeups.py, bench/plant.py).
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from types import SimpleNamespace

import pytest

from server import loop_pacing
from server.lateness import lateness
from server.loop_pacing import LoopPacer, loop_pacer


class Counting(asyncio.Protocol):
    def __init__(self) -> None:
        self.reads = 0
        self.bytes = 0

    def data_received(self, data: bytes) -> None:
        self.reads += 1
        self.bytes += len(data)


@asynccontextmanager
async def bytes_every(every_s: float) -> AsyncIterator[tuple[Counting, list[int]]]:
    """The loop reads a socket into which a thread writes a byte every ``every_s`` (0: as
    fast as it can; for at most 10 s) until the block ends; yields the reads and
    ``[bytes sent]``."""
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
        await until(lambda: counting.bytes == sent[0], 5.0)  # what is still on its way
        transport.close()
        theirs.close()


async def until(condition: Callable[[], bool], timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < end:
        await asyncio.sleep(0.02)
    return condition()


class Measures:
    """The loop thread's wake-ups and CPU as the pacer reads them, at rates the test sets."""

    def __init__(self) -> None:
        self.wakes_per_s = 0.0
        self.busy = 0.0
        self._at = time.monotonic()
        self._wakes = 0.0
        self._cpu = 0.0

    def _advance(self) -> None:
        now = time.monotonic()
        self._wakes += self.wakes_per_s * (now - self._at)
        self._cpu += self.busy * (now - self._at)
        self._at = now

    def wakes_so_far(self) -> int:
        self._advance()
        return int(self._wakes)

    def thread_time(self) -> float:
        self._advance()
        return self._cpu

    def set(self, wakes_per_s: float, busy: float) -> None:
        self._advance()
        self.wakes_per_s, self.busy = wakes_per_s, busy


@pytest.fixture
def measures(monkeypatch: pytest.MonkeyPatch) -> Measures:
    """What the pacers made from now on read, instead of this machine's figures."""
    fake = Measures()
    monkeypatch.setattr(loop_pacing, "wakes_so_far", fake.wakes_so_far)
    clock = {"monotonic": time.monotonic, "sleep": time.sleep, "thread_time": fake.thread_time}
    monkeypatch.setattr(loop_pacing, "time", SimpleNamespace(**clock))
    return fake


@pytest.fixture
async def pacer() -> LoopPacer:
    """The test's event loop's pacer, started."""
    started = loop_pacer()
    started.start()
    return started


async def periods(count: int) -> None:
    """Until the loop's measure ticked ``count`` times more (the pacer measures at each)."""
    ticks = [0]

    def tick(_late_s: float) -> None:
        ticks[0] += 1

    lateness().listen(tick)
    try:
        assert await until(lambda: ticks[0] >= count, 10.0 + count * 0.5)
    finally:
        lateness().unlisten(tick)


FLOOD = (5 * loop_pacing.ON_WAKES_PER_S, (loop_pacing.BUSY_ABOVE + 1.0) / 2)
"""Woken five times as often as pacing is switched on for, and busy enough to be worth it."""
CALM = (loop_pacing.ON_WAKES_PER_S / 10, loop_pacing.BUSY_ABOVE / 5)


async def test_a_flooded_loop_reads_once_per_tick_loses_nothing_and_unpaces_after(
    measures: Measures, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(loop_pacing, "PROBE_AFTER_S", 60.0)  # no probe while it is counted
    caplog.set_level(logging.INFO, "server.loop_pacing")

    def said(text: str) -> int:
        return sum(text in r.getMessage() for r in caplog.records)

    measures.set(*FLOOD)
    pacer = loop_pacer()
    pacer.start()
    async with bytes_every(0.0) as (counting, sent):  # as fast as the thread can
        assert await until(lambda: pacer.paced, 5.0), "a flood of wake-ups, and never paced"
        reads, taken, start = counting.reads, counting.bytes, time.monotonic()
        await asyncio.sleep(1.0)
        reads, taken = counting.reads - reads, counting.bytes - taken
        elapsed = time.monotonic() - start
        assert pacer.paced
        # At most one read per turn; a paced turn waits for its tick, and only a turn that
        # ran past its tick is followed by one that does not: at most two per tick. A slower
        # machine turns less often, never more.
        assert reads <= 2 * elapsed / loop_pacing.TICK_S + 2, (reads, taken, elapsed)
        measures.set(*CALM)  # the flood's measure ends; the next probe sees it
        monkeypatch.setattr(loop_pacing, "PROBE_AFTER_S", 0.3)
        assert await until(lambda: not pacer.paced, 5.0), "the flood ended, and still paced"
    assert counting.bytes == sent[0], "bytes were lost"
    assert said("busy: one turn per 2 ms from now on") == 1
    assert said("unpaced again") == 1


async def test_one_flooded_period_alone_does_not_pace(measures: Measures) -> None:
    pacer = LoopPacer()
    measures.set(*FLOOD)
    await asyncio.sleep(0.01)
    pacer._measure(0.0)
    measures.set(*CALM)
    await asyncio.sleep(0.01)
    pacer._measure(0.0)
    assert not pacer.paced
    measures.set(*FLOOD)
    for _ in range(2):
        await asyncio.sleep(0.01)
        pacer._measure(0.0)
    assert pacer.paced, "two flooded periods in a row"
    pacer.paced = False  # ends the chain of turns it started


@pytest.mark.parametrize(
    ("wakes_per_s", "busy", "paced"),
    [
        (loop_pacing.ON_WAKES_PER_S / 5, loop_pacing.BUSY_ABOVE / 5, False),  # now and then
        # Woken often but seldom busy: pacing would save little CPU anyone needs.
        (5 * loop_pacing.ON_WAKES_PER_S, loop_pacing.BUSY_ABOVE / 2, False),
        # Saturated: always behind, it seldom waits; unpaced, relief would bring the flood.
        (loop_pacing.ON_WAKES_PER_S / 5, (loop_pacing.SATURATED_ABOVE + 1.0) / 2, True),
        (5 * loop_pacing.ON_WAKES_PER_S, (loop_pacing.BUSY_ABOVE + 1.0) / 2, True),  # a flood
    ],
    ids=["seldom", "often but idle", "saturated", "flooded"],
)
async def test_what_a_loop_is_paced_for(
    measures: Measures, wakes_per_s: float, busy: float, paced: bool
) -> None:
    measures.set(wakes_per_s, busy)
    pacer = loop_pacer()
    pacer.start()
    await periods(5)
    assert pacer.paced is paced, (pacer.wakes_per_s, pacer.busy)
    assert pacer.wakes_per_s == pytest.approx(wakes_per_s, rel=0.05)
    assert pacer.busy == pytest.approx(busy, rel=0.05)
    pacer.paced = False


async def test_the_real_measure_of_a_loop_woken_now_and_then(pacer: LoopPacer) -> None:
    # This machine's own figures: a byte every 5 ms wakes the loop far less than pacing
    # is switched on for, on any machine; the measure sees the wake-ups.
    async with bytes_every(0.005) as (counting, sent):
        await periods(5)
    assert counting.bytes == sent[0]
    assert not pacer.paced, (pacer.wakes_per_s, pacer.busy)
    assert 0 < pacer.wakes_per_s < loop_pacing.ON_WAKES_PER_S
    assert 0.0 <= pacer.busy < loop_pacing.BUSY_ABOVE
