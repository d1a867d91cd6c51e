"""Starts and stops the moving parts: embedded mock, data-layer clients, acquisition tasks."""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass, field

from aiohttp import web

from .cell import Robot, default_cell
from .config import Settings
from .ctrlx import Credentials, DataLayerClient, client_ssl
from .mock_ctrlx import build_app, serve
from .stream import Acquisition, Hub, PollSettings, SourceHealth

log = logging.getLogger(__name__)


@dataclass
class Runtime:
    """The running service: the hub every viewer reads and the health of every source."""

    robots: list[Robot]
    hub: Hub = field(default_factory=Hub)
    sources: list[SourceHealth] = field(default_factory=list)
    _tasks: list[asyncio.Task[None]] = field(default_factory=list)
    _clients: list[DataLayerClient] = field(default_factory=list)
    _mock: web.AppRunner | None = None

    @classmethod
    async def start(cls, settings: Settings, robots: list[Robot] | None = None) -> Runtime:
        """Start the embedded mock (when no controller URL is set) and one acquisition task."""
        runtime = cls(robots=robots if robots is not None else default_cell())
        url = settings.ctrlx_url
        if url is None:
            runtime._mock, url = await serve(build_app(), "127.0.0.1", settings.mock_port)
            log.info("embedded mock ctrlX data layer at %s", url)
        client = DataLayerClient(
            url,
            Credentials(settings.ctrlx_user, settings.ctrlx_password.get_secret_value()),
            api=settings.ctrlx_api,
            ssl_context=client_ssl(settings.ctrlx_ca, settings.insecure),
            timeout_s=settings.request_timeout_s,
        )
        health = SourceHealth(name="ctrlx", url=url)
        poll = PollSettings(
            settings.poll_interval_s, settings.ctrlx_mode, keepalive_s=settings.keepalive_s
        )
        acquisition = Acquisition(client, runtime.robots, runtime.hub, health, poll)
        runtime._clients.append(client)
        runtime.sources.append(health)
        runtime._tasks.append(asyncio.create_task(acquisition.run(), name=f"acquire:{url}"))
        return runtime

    async def stop(self) -> None:
        """Cancel acquisition, close clients, stop the mock."""
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        for client in self._clients:
            await client.close()
        if self._mock is not None:
            await self._mock.cleanup()

    def robot(self, name: str) -> Robot | None:
        """The robot called ``name``, if any."""
        return next((r for r in self.robots if r.name == name), None)
