"""One data source at run time: its embedded mock (if any), client, health and acquisition task."""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass, field

from aiohttp import web

from ..cell import Robot, Source
from ..ctrlx import Credentials, DataLayerClient, Mode, check_base_url, client_ssl
from ..mock_ctrlx import build_app, serve
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
    """Whether moves may be sent to ``config``: an embedded mock, or allowed by cell or flag."""
    return config.url is None or config.allow_commands or allow_commands


def fingerprint(config: Source, robots: list[Robot]) -> object:
    """What, if changed, needs the source restarted: its settings and what it reads or moves."""
    return (
        config,
        tuple((r.name, r.joints, r.command_node, r.demo_targets) for r in robots),
    )


async def start_source(
    config: Source, robots: list[Robot], hub: Hub, defaults: SourceDefaults
) -> RunningSource:
    """Ready to follow ``config`` for ``robots`` (a mock first if it has no URL); then ``begin``."""
    mock: web.AppRunner | None = None
    url = config.url
    if url is None:
        mock, url = await serve(build_app(machine_for(robots)), "127.0.0.1", 0)
        log.info("source %s: embedded mock data layer at %s", config.name, url)
    client = DataLayerClient(
        url,
        Credentials(config.user, config.password),
        api=config.api,
        ssl_context=client_ssl(config.ca, config.insecure),
        timeout_s=defaults.timeout_s,
    )
    client.warning = check_base_url(url)  # plain http to another machine: credentials in clear
    health = SourceHealth(name=config.name, url=url, mock=mock is not None)
    period = config.period_s or defaults.period_s
    poll = PollSettings(period, config.mode or defaults.mode, keepalive_s=defaults.keepalive_s)
    acquisition = Acquisition(client, robots, hub, health, poll)
    return RunningSource(
        config, robots, client, health, acquisition, fingerprint(config, robots), mock
    )
