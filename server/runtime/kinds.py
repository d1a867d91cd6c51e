"""The kinds of source a cell can name, each opened into a connector (and its embedded mock).

A kind is one opener: from the cell's source and its robots to a ``Connector``
the shared acquisition follows, the address health shows, and, for a source
without ``url``, the embedded mock it started. Adding a protocol is adding an
opener here (and its keys to ``server.cell.schema``); nothing downstream changes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from aiohttp import web

from ..cell import Robot, Source
from ..cell.schema import CtrlxSource, MqttSource, RtdeSource
from ..ctrlx import Credentials, CtrlxConnector, DataLayerClient, check_base_url, client_ssl
from ..mock_ctrlx import Machine, build_app, serve
from ..mock_rtde import RtdeMock
from ..mqtt import MachinePublisher, Mosquitto, MqttConnector, MqttSettings
from ..rtde import RtdeConnector, RtdeSettings
from ..rtde.wire import rtde_address
from ..sources import Closable, Connector, Sample, SourceError
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


class _MovedInSimulation:
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


class _Closing:
    """Several things an embedded mock runs, closed in order."""

    def __init__(self, *parts: Closable) -> None:
        self.parts = parts

    async def close(self) -> None:
        for part in self.parts:
            await part.close()


class _Unusable:
    """A source that cannot be followed at all (its mock cannot run): says why, each time."""

    warning: str | None = None
    device: str | None = None

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


async def open_rtde(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
    """A UR controller's RTDE interface at ``rtde://HOST[:PORT]``, or an embedded mock one."""
    options = config.options if isinstance(config.options, RtdeSource) else None
    frequency = options.frequency_hz if options else RtdeSource(name="-", type="rtde").frequency_hz
    if config.url is None:
        machine = machine_for(robots, defaults.mock_hold_s)
        mock = RtdeMock(machine)
        url = await mock.start("127.0.0.1", 0)
        settings = RtdeSettings(mock.host, mock.port, frequency, defaults.timeout_s)
        connector = _MovedInSimulation(RtdeConnector(settings), machine, robots)
        return Opened(connector, url, mock)
    host, port = rtde_address(config.url)
    settings = RtdeSettings(host, port, frequency, defaults.timeout_s)
    return Opened(RtdeConnector(settings), config.url)


async def open_mqtt(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
    """A broker at ``mqtt(s)://HOST[:PORT]``; or an embedded mock: Mosquitto (when installed)
    on a loopback port, and a publisher moving the robots as the ctrlX mock does."""
    options = config.options if isinstance(config.options, MqttSource) else None
    settings = MqttSettings(
        config.url or "",
        user=config.user or None,
        password=config.password or None,
        ca=config.ca,
        insecure=config.insecure,
        client_id=options.client_id if options else None,
        timeout_s=defaults.timeout_s,
    )
    if config.url is not None:
        return Opened(MqttConnector(settings), config.url)
    broker = Mosquitto()
    try:
        url = await broker.start()
    except SourceError as exc:
        await broker.close()
        return Opened(_Unusable(str(exc)), "mqtt:// (no broker)")
    machine = machine_for(robots, defaults.mock_hold_s)
    publisher = MachinePublisher(machine, broker.host, broker.port, defaults.period_s)
    publisher.start()
    connector = MqttConnector(dataclasses.replace(settings, url=url, user=None, password=None))
    moved = _MovedInSimulation(connector, machine, robots)
    return Opened(moved, url, _Closing(publisher, broker))


def _open_opcua(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Awaitable[Opened]:
    from .opcua_source import open_opcua  # it imports Opened from here

    return open_opcua(config, robots, defaults)


OPENERS: dict[str, Opener] = {
    "ctrlx": open_ctrlx,
    "rtde": open_rtde,
    "mqtt": open_mqtt,
    "opcua": _open_opcua,
}
"""The opener of each ``type`` a cell's source may have (``server.cell.schema.SOURCE_TYPES``)."""
