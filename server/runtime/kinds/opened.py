"""What opening a source gives (connector, address, embedded mock), and what mocks are made of."""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass

from ...cell import Robot, Source
from ...mock_ctrlx import Machine
from ...sources import Closable, Connector, Sample, SourceError
from ..defaults import SourceDefaults


@dataclass
class Opened:
    """A source ready to follow: its connector, its address, and its embedded mock, if any."""

    connector: Connector
    url: str
    """What health shows as the source's address."""
    mock: Closable | None = None
    """An embedded mock, closed with the source."""


Opener = Callable[[Source, list[Robot], SourceDefaults], Awaitable[Opened]]
"""From a cell's source, its robots and the server's defaults to an opened source."""


@asynccontextmanager
async def closed_on_failure(part: Closable) -> AsyncIterator[None]:
    """Close ``part`` (an embedded mock just started) if the block raises, whatever it raises.

    An opener that fails after starting its mock (a connector that cannot be
    made) must leave nothing running: a reload that fails goes on with the
    running cell, and a mock left behind would hold its port, or its broker
    process, for the life of the server.
    """
    try:
        yield
    except BaseException:
        await part.close()
        raise


class MovedInSimulation:
    """An embedded mock's connector whose protocol cannot move robots (RTDE, MQTT): a move
    goes to the mock's simulated machine, so the page's commands work on the demo as on ctrlX."""

    def __init__(self, connector: Connector, machine: Machine, robots: list[Robot]) -> None:
        self.connector = connector
        self.machine = machine
        self.groups = {robot.command_node: robot.name for robot in robots}

    @property
    def warning(self) -> str | None:
        return self.connector.warning

    @property
    def device(self) -> str | None:
        return self.connector.device

    @property
    def halted(self) -> str | None:
        return self.connector.halted

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        await self.connector.follow(nodes, period_s, deliver)

    async def move(self, command_node: str, values: list[float]) -> None:
        try:
            self.machine.command(self.groups[command_node], values)
        except (KeyError, ValueError) as exc:
            raise SourceError(f"the mock cannot move there: {exc}") from None

    async def close(self) -> None:
        await self.connector.close()


class Closing:
    """Several things an embedded mock runs, closed in order."""

    def __init__(self, *parts: Closable) -> None:
        self.parts = parts

    async def close(self) -> None:
        for part in self.parts:
            await part.close()


class Unusable:
    """A source that cannot be followed at all (its mock cannot run): says why, each time."""

    warning: str | None = None
    device: str | None = None
    halted: str | None = None

    def __init__(self, why: str) -> None:
        self.why = why

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        raise SourceError(self.why)

    async def move(self, command_node: str, values: list[float]) -> None:
        raise SourceError(self.why)

    async def close(self) -> None:
        pass
