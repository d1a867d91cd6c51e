"""The kinds of source a cell can name, each opened into a connector (and its embedded mock).

A kind is one opener: from the cell's source and its robots to a ``Connector``
the shared acquisition follows, the address health shows, and, for a source
without ``url``, the embedded mock it started. Adding a protocol is adding an
opener here (and its keys to ``server.cell.schema``); nothing downstream changes.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from aiohttp import web

from ..cell import Robot, Source
from ..cell.schema import CtrlxSource
from ..ctrlx import Credentials, CtrlxConnector, DataLayerClient, check_base_url, client_ssl
from ..mock_ctrlx import build_app, serve
from ..sources import Closable, Connector
from .defaults import SourceDefaults
from .simulation import machine_for


@dataclass
class Opened:
    """A source ready to follow: its connector, its address, and its embedded mock, if any."""

    connector: Connector
    url: str
    """What health shows as the source's address."""
    mock: Closable | None = None
    """An embedded mock, closed with the source."""


Opener = Callable[[Source, list[Robot], SourceDefaults], Awaitable[Opened]]


class _StoppedWith:
    """An aiohttp app runner as something a source closes."""

    def __init__(self, runner: web.AppRunner) -> None:
        self.runner = runner

    async def close(self) -> None:
        await self.runner.cleanup()


async def open_ctrlx(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
    """A ctrlX data layer at ``config.url``, or an embedded mock serving the robots' nodes."""
    options = config.options if isinstance(config.options, CtrlxSource) else None
    options = options or CtrlxSource(name=config.name)
    mock: _StoppedWith | None = None
    url = config.url
    if url is None:
        machine = machine_for(robots, defaults.mock_hold_s)
        runner, url = await serve(build_app(machine), "127.0.0.1", 0)
        mock = _StoppedWith(runner)
    client = DataLayerClient(
        url,
        Credentials(config.user, config.password),
        api=options.api,
        ssl_context=client_ssl(insecure=config.insecure),
        ca_file=None if config.insecure else config.ca,
        timeout_s=defaults.timeout_s,
    )
    client.warning = check_base_url(url)  # plain http to another machine: credentials in clear
    connector = CtrlxConnector(client, options.mode or defaults.mode, defaults.keepalive_s)
    return Opened(connector, url, mock)


OPENERS: dict[str, Opener] = {
    "ctrlx": open_ctrlx,
}
"""The opener of each ``type`` a cell's source may have (``server.cell.schema.SOURCE_TYPES``)."""
