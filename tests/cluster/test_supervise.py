"""A supervised task that fails is logged and started again; a bug cannot spin."""

from __future__ import annotations

import asyncio
import logging

import pytest

from server.cluster import supervise


async def test_a_failing_task_is_logged_and_started_again(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(supervise, "RESTART_MIN_S", 0.01)
    runs: list[float] = []
    finished = asyncio.Event()

    async def listener() -> None:
        runs.append(asyncio.get_running_loop().time())
        if len(runs) == 1:
            raise KeyError("state")  # a forged record's missing key, say
        if len(runs) == 2:
            return  # ended without being asked to
        finished.set()
        await asyncio.sleep(3600)

    restarts: dict[str, int] = {}
    with caplog.at_level(logging.ERROR, logger="server.cluster.supervise"):
        task = supervise.supervised("broker:listen", listener, restarts)
        await asyncio.wait_for(finished.wait(), 5)
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
    assert len(runs) == 3 and restarts == {"broker:listen": 2}
    failed, ended = caplog.records
    assert "task broker:listen failed" in failed.getMessage() and failed.exc_info is not None
    assert failed.exc_info[0] is KeyError
    assert "task broker:listen ended" in ended.getMessage()
    # The pause doubles while it keeps dying young: 0.01 s, then 0.02 s (sleeps never end early).
    assert runs[1] - runs[0] >= 0.01 and runs[2] - runs[1] >= 0.02


async def test_cancelling_stops_it_for_good() -> None:
    started = asyncio.Event()

    async def forever() -> None:
        started.set()
        await asyncio.sleep(3600)

    task = supervise.supervised("poll", forever)
    await asyncio.wait_for(started.wait(), 5)
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    assert task.cancelled()
