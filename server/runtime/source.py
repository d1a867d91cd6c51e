"""One data source at run time: its embedded mock (if any), client, health and acquisition task."""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass, field

import numpy as np
from aiohttp import web

from ..cell import Robot, Source
from ..ctrlx import Credentials, DataLayerClient, DataLayerError, Mode, check_base_url, client_ssl
from ..history import History
from ..history.ring import Array, IntArray
from ..mock_ctrlx import HOLD_S, build_app, serve
from ..recording import SourceReplay, load_source
from ..stream import Acquisition, Hub, PollSettings, SourceHealth
from .simulation import machine_for

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SourceDefaults:
    """What a cell's source takes from the server's settings unless it says otherwise."""

    period_s: float = 0.02
    mode: Mode = "subscribe"
    keepalive_s: float = 1.0
    timeout_s: float = 5.0
    allow_commands: bool = False
    history_s: float = 600.0
    """Seconds of samples every source keeps (see server.history)."""
    mock_hold_s: float = HOLD_S
    """How long an embedded mock holds a commanded pose before its demo cycle resumes."""
    sample_cost_s: float = 0.0
    """CPU seconds wasted per sample (a test knob, see Settings.sample_cost_s)."""


@dataclass
class RunningSource:
    """A source being followed; ``fingerprint`` tells whether a new cell changes it."""

    config: Source
    robots: list[Robot]
    client: DataLayerClient
    health: SourceHealth
    acquisition: Acquisition
    fingerprint: object
    mock: web.AppRunner | None = None
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
        """Cancel the acquisition, log out, stop the mock."""
        if self.task is not None:
            self.task.cancel()
            await asyncio.gather(self.task, return_exceptions=True)
        await self.client.close()
        if self.mock is not None:
            await self.mock.cleanup()


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
    """Ready to follow ``config`` for ``robots`` (a mock first if it has no URL); then ``begin``."""
    if config.replay is not None:
        return await _start_replay(config, robots, hub, history or History(defaults.history_s))
    mock: web.AppRunner | None = None
    url = config.url
    if url is None:
        machine = machine_for(robots, defaults.mock_hold_s)
        mock, url = await serve(build_app(machine), "127.0.0.1", 0)
        log.info("source %s: embedded mock data layer at %s", config.name, url)
    client = DataLayerClient(
        url,
        Credentials(config.user, config.password),
        api=config.api,
        ssl_context=client_ssl(insecure=config.insecure),
        ca_file=None if config.insecure else config.ca,
        timeout_s=defaults.timeout_s,
    )
    client.warning = check_base_url(url)  # plain http to another machine: credentials in clear
    health = SourceHealth(name=config.name, url=url, mock=mock is not None)
    period = config.period_s or defaults.period_s
    poll = PollSettings(
        period,
        config.mode or defaults.mode,
        keepalive_s=defaults.keepalive_s,
        sample_cost_s=defaults.sample_cost_s,
    )
    tap = None if history is None else history.source(config.name, nodes_of(robots), period)
    acquisition = Acquisition(client, robots, hub, health, poll, tap=tap)
    return RunningSource(
        config, robots, client, health, acquisition, fingerprint(config, robots), mock
    )


def nodes_of(robots: list[Robot]) -> list[str]:
    """Every node the robots read."""
    return [node for robot in robots for node in robot.nodes]


REPLAY_CLIENT_URL = "http://127.0.0.1:9"
"""A replay has a client only so it fits where sources have one; it never connects."""


async def _start_replay(
    config: Source, robots: list[Robot], hub: Hub, history: History
) -> RunningSource:
    """A source whose samples come from a recording; its history is the whole file."""
    assert config.replay is not None
    try:
        # Reading a long recording takes a while: not on the event loop.
        replay = await asyncio.to_thread(load_source, config.replay, config.name, robots)
    except DataLayerError as exc:  # the source shows the error; the server and others go on
        log.error("source %s: %s", config.name, exc)
        nodes = tuple(sorted(set(nodes_of(robots))))
        replay = SourceReplay(config.name, nodes, *_empty(len(nodes)))
    tap = history.source(config.name, replay.nodes, replay.period_s, samples=max(2, len(replay.t)))
    tap.ring.write_many(replay.seq, replay.t, replay.values)
    tap.frozen = True
    log.info("source %s: replaying %d samples of %s", config.name, len(replay.t), config.replay)
    client = DataLayerClient(REPLAY_CLIENT_URL, Credentials(config.user, config.password))
    health = SourceHealth(name=config.name, url=f"replay:{config.replay.name}")
    poll = PollSettings(replay.period_s)
    acquisition = Acquisition(client, robots, hub, health, poll, tap=tap, samples=replay.play)
    return RunningSource(config, robots, client, health, acquisition, fingerprint(config, robots))


def _empty(columns: int) -> tuple[Array, IntArray, Array]:
    return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, columns))
