"""Mock OPC UA servers on loopback and the connector following them, for the OPC UA tests."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from server.mock_ctrlx import Machine
from server.mock_opcua import MOCK_URI, MockOptions, OpcuaMock
from server.opcua import OpcuaConnector, OpcuaSettings
from server.sources import Sample
from tests.conftest import free_port


def actual(group: str, axis: str) -> str:
    """The node key of a mock axis's ActualPosition, its namespace named by URI."""
    return f"nsu={MOCK_URI};s={group}.Axes.{axis}.ParameterSet.ActualPosition"


IIWA = [actual("iiwa", f"iiwa_a{i}") for i in range(1, 8)]
KIN12 = [actual("kin12", "kin12_a0"), actual("kin12", "kin12_a1")]


@asynccontextmanager
async def running(
    cache: Path, machine: Machine | None = None, **options: Any
) -> AsyncIterator[OpcuaMock]:
    """A mock OPC UA server (default: the demo machine) on a free loopback port."""
    mock = OpcuaMock(machine or Machine(), MockOptions(cache=cache, **options))
    await mock.start("127.0.0.1", free_port())
    try:
        yield mock
    finally:
        await mock.close()


class Following:
    """A connector following nodes in a task; its samples, and how it ended."""

    def __init__(self, connector: OpcuaConnector, nodes: list[str], period_s: float = 0.02):
        self.connector = connector
        self.samples: list[Sample] = []
        self.task = asyncio.create_task(connector.follow(nodes, period_s, self.samples.append))

    async def until(self, condition: Callable[[], object], timeout_s: float = 15.0) -> None:
        """Wait for ``condition`` (failing the test after ``timeout_s``, or if follow ended)."""
        async with asyncio.timeout(timeout_s):
            while not condition():
                if self.task.done():
                    self.task.result()  # raises what ended it
                    raise AssertionError("follow ended without an error")
                await asyncio.sleep(0.01)

    async def samples_after(self, count: int, timeout_s: float = 15.0) -> list[Sample]:
        """The next ``count`` samples."""
        start = len(self.samples)
        await self.until(lambda: len(self.samples) >= start + count, timeout_s)
        return self.samples[start : start + count]

    async def ended(self, timeout_s: float = 10.0) -> BaseException:
        """How follow ended (it must end within ``timeout_s``)."""
        async with asyncio.timeout(timeout_s):
            exc = await asyncio.gather(self.task, return_exceptions=True)
        error = exc[0]
        assert isinstance(error, BaseException), "follow returned instead of raising"
        return error

    async def stop(self) -> None:
        self.task.cancel()
        await asyncio.gather(self.task, return_exceptions=True)
        await self.connector.close()


@asynccontextmanager
async def following(
    url: str, nodes: list[str], period_s: float = 0.02, **settings: Any
) -> AsyncIterator[Following]:
    """A connector with ``settings`` following ``nodes`` at ``url``."""
    units = settings.pop("units", None)
    connector = OpcuaConnector(OpcuaSettings(url, **settings), units)
    run = Following(connector, nodes, period_s)
    try:
        yield run
    finally:
        await run.stop()
