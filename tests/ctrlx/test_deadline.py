"""The event stream's read deadline: wakes a read in time, loses nothing, passes real cancels."""

from __future__ import annotations

import asyncio
import math

import pytest

from server.ctrlx.deadline import ReadDeadline


async def test_a_late_read_gives_none_and_its_data_goes_to_the_next_read() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    assert await deadline.wait(reader.read(100), 0.02) is None
    reader.feed_data(b"event: update\n")
    assert await deadline.wait(reader.read(100), 0.02) == b"event: update\n"
    deadline.close()


async def test_reads_that_keep_finishing_move_the_deadline_on() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    loop = asyncio.get_running_loop()
    for i in range(20):  # 20 reads of 5 ms each, every one within its own 50 ms
        loop.call_later(0.005, reader.feed_data, b"x")
        assert await deadline.wait(reader.read(1), 0.05) == b"x", f"read {i} woken early"
    deadline.close()


async def test_a_sooner_deadline_than_the_armed_one_is_kept() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    reader.feed_data(b"x")
    assert await deadline.wait(reader.read(1), 60.0) == b"x"  # arms a timer for a minute
    async with asyncio.timeout(2.0):  # fails the test rather than waiting that minute
        assert await deadline.wait(reader.read(1), 0.02) is None
    deadline.close()


async def test_no_deadline_waits_for_the_data() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    asyncio.get_running_loop().call_later(0.05, reader.feed_data, b"late")
    assert await deadline.wait(reader.read(100), math.inf) == b"late"


async def test_cancelling_the_reading_task_still_cancels_it() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    task = asyncio.create_task(deadline.wait(reader.read(100), 10.0))
    await asyncio.sleep(0.01)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    deadline.close()


async def test_a_real_cancel_in_the_same_turn_as_the_deadline_is_not_swallowed() -> None:
    reader, deadline = asyncio.StreamReader(), ReadDeadline()
    task = asyncio.create_task(deadline.wait(reader.read(100), 10.0))
    await asyncio.sleep(0.01)  # the task waits in its read

    def both() -> None:  # in one callback: the deadline passes, and someone cancels the task
        deadline._at = 0.0
        deadline._fire()
        task.cancel()

    asyncio.get_running_loop().call_soon(both)
    with pytest.raises(asyncio.CancelledError):
        await task
    deadline.close()
