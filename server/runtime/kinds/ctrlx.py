"""The ``ctrlx`` kind: a ctrlX CORE's REST data layer, or (no ``url``) the embedded mock of one."""

from __future__ import annotations

from aiohttp import web

from ...cell import Robot, Source
from ...cell.schema import CtrlxSource
from ...ctrlx import Credentials, CtrlxConnector, DataLayerClient, check_base_url, client_ssl
from ...mock_ctrlx import build_app, serve
from ..defaults import SourceDefaults
from ..simulation import machine_for
from .opened import Opened, closed_on_failure


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
    if config.url is None:
        machine = machine_for(robots, defaults.mock_hold_s)
        runner, url = await serve(build_app(machine), "127.0.0.1", 0)
        mock = _StoppedWith(runner)
        async with closed_on_failure(mock):
            return Opened(_connector(config, url, options, defaults), url, mock)
    return Opened(_connector(config, config.url, options, defaults), config.url)


def _connector(
    config: Source, url: str, options: CtrlxSource, defaults: SourceDefaults
) -> CtrlxConnector:
    client = DataLayerClient(
        url,
        Credentials(config.user, config.password),
        api=options.api,
        ssl_context=client_ssl(insecure=config.insecure),
        ca_file=None if config.insecure else config.ca,
        timeout_s=defaults.timeout_s,
    )
    client.warning = check_base_url(url)  # plain http to another machine: credentials in clear
    return CtrlxConnector(client, options.mode or defaults.mode, defaults.keepalive_s)
