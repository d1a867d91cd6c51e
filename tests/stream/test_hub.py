"""The hub coalesces: a slow viewer gets the newest message per key, never a backlog."""

from __future__ import annotations

import asyncio

from server.stream import Hub


async def test_slow_viewer_gets_only_newest_message_per_key() -> None:
    hub = Hub()
    slow, fast = hub.join(), hub.join()
    fast_got: list[str] = []
    for i in range(100):
        hub.publish("frame:a", f"a{i}")
        hub.publish("frame:b", f"b{i}")
        fast_got += await fast.take()
    assert await slow.take() == ["a99", "b99"]
    assert slow.dropped == 198
    assert fast.dropped == 0 and len(fast_got) == 200
    assert hub.dropped == 198


async def test_new_viewer_is_primed_with_latest_messages() -> None:
    hub = Hub()
    hub.publish("status:ctrlx", "s1")
    hub.publish("frame:a", "a1")
    hub.publish("frame:a", "a2")
    viewer = hub.join()
    assert await viewer.take() == ["s1", "a2"]


async def test_take_waits_until_something_is_published() -> None:
    hub = Hub()
    viewer = hub.join()
    waiter = asyncio.create_task(viewer.take())
    await asyncio.sleep(0.01)
    assert not waiter.done()
    hub.publish("frame:a", "x")
    assert await asyncio.wait_for(waiter, 1) == ["x"]


async def test_departed_viewer_is_no_longer_offered_messages() -> None:
    hub = Hub()
    viewer = hub.join()
    hub.publish("k", "1")
    hub.publish("k", "2")
    hub.leave(viewer)
    hub.publish("k", "3")
    assert hub.viewer_count == 0
    assert hub.dropped == 1
    assert await viewer.take() == ["2"]


async def test_closing_a_viewer_wakes_its_waiting_take() -> None:
    viewer = Hub().join()
    waiter = asyncio.create_task(viewer.take())
    await asyncio.sleep(0.01)
    viewer.close()
    assert await asyncio.wait_for(waiter, 1) == []


async def test_a_discarded_message_greets_no_new_viewer() -> None:
    hub = Hub()
    hub.publish("frames1:ctrlx", "old frame", protocol=1)
    hub.publish("status:ctrlx", "s1")
    hub.discard("frames1:ctrlx")  # nobody spoke protocol 1 while newer samples came
    viewer = hub.join(protocol=1)
    assert await viewer.take() == ["s1"]
