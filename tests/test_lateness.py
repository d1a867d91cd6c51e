"""Our own lateness is not the device's: watchdogs count only the time the event loop was on time.

Each test blocks the event loop on purpose (``time.sleep``), as a process
does that carries more than it can, and checks that the watchdogs forgive
exactly that, while a device that is really silent is still caught.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

import pytest

from server.ctrlx.follow import follow
from server.ctrlx.subscribed import Latest
from server.ctrlx.updates import Keepalive, Update
from server.lateness import PatientTimeout, lateness
from server.stream import status
from server.stream.status import SourceHealth, load_summary
from tests.ctrlx.helpers import KIN12, client, running


async def ticking() -> None:
    """Start the running loop's ticker, and let it tick once."""
    lateness()
    await asyncio.sleep(0.15)


async def test_a_plain_timeout_blames_the_device_for_our_busy_loop() -> None:
    # The failure the patient timeout exists for: the answer is there, the deadline passed.
    await ticking()
    with pytest.raises(TimeoutError):
        async with asyncio.timeout(0.3):
            time.sleep(0.6)  # our loop is busy; the device answered meanwhile
            await asyncio.sleep(0.01)


async def test_patient_timeout_leaves_out_the_time_our_loop_was_late() -> None:
    await ticking()
    async with PatientTimeout(0.3):
        time.sleep(0.6)
        await asyncio.sleep(0.01)
    assert lateness().total_s >= 0.3


async def test_patient_timeout_still_catches_a_silent_device() -> None:
    await ticking()
    with pytest.raises(TimeoutError):
        async with PatientTimeout(0.3):
            await asyncio.sleep(30)


async def test_a_source_is_not_stale_because_we_were_busy() -> None:
    await ticking()
    health = SourceHealth("c0", "http://127.0.0.1:1", period_s=0.02)
    health.mark_sample()
    time.sleep(0.6)  # more than stale_after_s (0.25 s), all of it our lateness
    assert health.current_state() == "connected"
    await asyncio.sleep(0.5)  # on time, and no sample: the device is silent
    assert health.current_state() == "stale"


def test_overloaded_says_how_many_samples_were_processed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(status, "LOAD_WINDOW_S", 0.0)  # every roll closes a window
    health = SourceHealth("c0", "http://127.0.0.1:1")
    health.roll_window()
    for _ in range(3):
        health.mark_sample(received=4)  # a late reader kept the newest of four
    assert health.roll_window()
    assert health.overloaded is not None
    assert health.overloaded.startswith("overloaded: 3 of 12 samples processed, ")
    summary = load_summary([health, SourceHealth("c1", "http://127.0.0.1:2")])
    assert summary["window"] == {"received": 12, "processed": 3}
    assert str(summary["overloaded"]).startswith("overloaded: 3 of 12 samples processed, ")
    for _ in range(3):
        health.mark_sample()
    assert health.roll_window()  # changed back
    assert health.overloaded is None
    assert load_summary([health])["overloaded"] is None


def test_a_late_reader_counts_every_publish_cycle_it_merged() -> None:
    nodes = ["a", "b"]
    latest = Latest(nodes, grace_s=0.0)
    for t in (100.00, 100.02, 100.04):  # three cycles of two nodes, read in one go
        for node in nodes:
            latest.add(Update(node, t, t))
    sample = latest.take()
    assert sample is not None
    assert sample.received == 3
    assert sample.values == {"a": 100.04, "b": 100.04}  # the newest wins
    latest.add(Keepalive(100.06))
    again = latest.take()
    assert again is not None and again.received == 1


async def test_an_event_stream_outlives_a_busy_loop() -> None:
    async with running() as mock, client(mock.url) as c:
        samples = follow(c, KIN12, 0.02, keepalive_s=0.2)  # silent for 0.5 s: dead
        async with contextlib.aclosing(samples), asyncio.timeout(60):
            await ticking()
            await anext(samples)
            requests = c.requests
            time.sleep(1.5)  # three times the stream's deadline, all of it our own lateness
            for _ in range(10):
                await anext(samples)
            assert c.requests == requests, "the stream was taken for dead and reopened"


def test_a_replica_passes_on_what_its_workers_counted() -> None:
    # A replica makes no frames itself: its sources carry the workers' verdict only.
    health = SourceHealth("c0", "http://127.0.0.1:1")
    health.overloaded = "overloaded: 3 of 12 samples processed, 12 frames/s per robot"
    summary = load_summary([health, SourceHealth("c1", "http://127.0.0.1:2")])
    assert summary["overloaded"] == f"c0: {health.overloaded}"


async def test_a_failing_listener_stops_neither_the_ticker_nor_the_others() -> None:
    """Every source's state check listens to one ticker: one's bug must not silence the rest."""
    heard: list[float] = []

    def broken(_late_s: float) -> None:
        raise RuntimeError("a bug in one listener")

    def leaving(_late_s: float) -> None:
        lateness().unlisten(leaving)  # while the ticker goes through its listeners

    clock = lateness()
    for listener in (broken, leaving, heard.append):
        clock.listen(listener)
    try:
        await asyncio.sleep(0.35)
    finally:
        clock.unlisten(broken)
        clock.unlisten(heard.append)
    assert len(heard) >= 2  # every tick reached it, the broken listener's included
    assert leaving not in clock._listeners
