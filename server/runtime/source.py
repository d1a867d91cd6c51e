"""One data source at run time: its connector (and embedded mock, if any), health and acquisition.

Whatever the kind of source (``kinds``), what follows a sample is the same:
one ``Acquisition`` per source, its history tap, its health.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass, field

import numpy as np

from ..cell import Robot, Source
from ..history import History
from ..history.ring import Array, IntArray
from ..recording import ReplayConnector, SourceReplay, load_source
from ..sources import Closable, Connector, SourceError
from ..stream import Acquisition, Hub, PollSettings, SourceHealth
from .defaults import SourceDefaults
from .kinds import OPENERS

log = logging.getLogger(__name__)

__all__ = [
    "RunningSource",
    "SourceDefaults",
    "fingerprint",
    "may_command",
    "mock_hold_s",
    "start_source",
]


@dataclass
class RunningSource:
    """A source being followed; ``fingerprint`` tells whether a new cell changes it."""

    config: Source
    robots: list[Robot]
    connector: Connector
    health: SourceHealth
    acquisition: Acquisition
    fingerprint: object
    mock: Closable | None = None
    task: asyncio.Task[None] | None = field(default=None, repr=False)

    @property
    def commandable(self) -> bool:
        """Whether the page may move this source's robots: a mock, or allowed explicitly."""
        return may_command(self.config, False)

    def begin(self) -> None:
        """Start the acquisition task (once the viewers know the cell it belongs to)."""
        name = f"acquire:{self.config.name}"
        self.task = asyncio.create_task(self.acquisition.run(), name=name)

    async def stop(self) -> None:
        """Cancel the acquisition, close the connection, stop the mock."""
        if self.task is not None:
            self.task.cancel()
            await asyncio.gather(self.task, return_exceptions=True)
        await self.connector.close()
        if self.mock is not None:
            await self.mock.close()


def may_command(config: Source, allow_commands: bool) -> bool:
    """Whether moves may be sent to ``config``: an embedded mock, or allowed by cell or flag.

    A recording being replayed cannot be moved.
    """
    if config.replay is not None:
        return False
    return config.url is None or config.allow_commands or allow_commands


def mock_hold_s(config: Source, defaults: SourceDefaults) -> float | None:
    """How long ``config``'s embedded mock holds a commanded pose; None where it has none."""
    return defaults.mock_hold_s if config.url is None and config.replay is None else None


def fingerprint(config: Source, robots: list[Robot]) -> object:
    """What, if changed, needs the source restarted: its settings and what it reads or moves."""
    return (
        config,
        tuple((r.name, r.joints, r.command_node, r.demo_targets) for r in robots),
    )


async def start_source(
    config: Source,
    robots: list[Robot],
    hub: Hub,
    defaults: SourceDefaults,
    history: History | None = None,
) -> RunningSource:
    """Ready to follow ``config`` for ``robots`` (its kind's mock if no URL); then ``begin``."""
    if config.replay is not None:
        return await _start_replay(config, robots, hub, history or History(defaults.history_s))
    opened = await OPENERS[config.type](config, robots, defaults)
    try:
        if opened.mock is not None:
            log.info("source %s: embedded mock %s at %s", config.name, config.type, opened.url)
        health = SourceHealth(name=config.name, url=opened.url, mock=opened.mock is not None)
        period = config.period_s or defaults.period_s
        poll = PollSettings(period, sample_cost_s=defaults.sample_cost_s)
        tap = None if history is None else history.source(config.name, nodes_of(robots), period)
        acquisition = Acquisition(opened.connector, robots, hub, health, poll, tap=tap)
    except BaseException:  # opened, then failed: nothing of it may stay open (Runtime.apply)
        await _closed(opened.connector, opened.mock)
        raise
    return RunningSource(
        config,
        robots,
        opened.connector,
        health,
        acquisition,
        fingerprint(config, robots),
        opened.mock,
    )


async def _closed(*parts: Closable | None) -> None:
    """Close each of ``parts``; one that fails to close is logged and the others still closed."""
    for part in parts:
        if part is None:
            continue
        try:
            await part.close()
        except Exception:
            log.exception("closing %r failed", part)


def nodes_of(robots: list[Robot]) -> list[str]:
    """Every node the robots read."""
    return [node for robot in robots for node in robot.nodes]


async def _start_replay(
    config: Source, robots: list[Robot], hub: Hub, history: History
) -> RunningSource:
    """A source whose samples come from a recording; its history is the whole file."""
    assert config.replay is not None
    try:
        # Reading a long recording takes a while: not on the event loop.
        replay = await asyncio.to_thread(load_source, config.replay, config.name, robots)
    except SourceError as exc:  # the source shows the error; the server and others go on
        log.error("source %s: %s", config.name, exc)
        nodes = tuple(sorted(set(nodes_of(robots))))
        replay = SourceReplay(config.name, nodes, *_empty(len(nodes)))
    tap = history.source(config.name, replay.nodes, replay.period_s, samples=max(2, len(replay.t)))
    tap.ring.write_many(replay.seq, replay.t, replay.values)
    tap.frozen = True
    log.info("source %s: replaying %d samples of %s", config.name, len(replay.t), config.replay)
    connector = ReplayConnector(replay.play, replay.warning)
    health = SourceHealth(name=config.name, url=f"replay:{config.replay.name}")
    poll = PollSettings(replay.period_s)
    acquisition = Acquisition(connector, robots, hub, health, poll, tap=tap)
    return RunningSource(
        config, robots, connector, health, acquisition, fingerprint(config, robots)
    )


def _empty(columns: int) -> tuple[Array, IntArray, Array]:
    return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, columns))
