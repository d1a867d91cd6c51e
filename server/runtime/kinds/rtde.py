"""The ``rtde`` kind: a Universal Robots controller's RTDE interface, or an embedded mock one."""

from __future__ import annotations

from ...cell import Robot, Source
from ...cell.schema import RtdeSource
from ...mock_rtde import RtdeMock
from ...rtde import RtdeConnector, RtdeSettings
from ...rtde.wire import rtde_address
from ..defaults import SourceDefaults
from ..simulation import machine_for
from .opened import MovedInSimulation, Opened, closed_on_failure


async def open_rtde(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
    """A UR controller's RTDE interface at ``rtde://HOST[:PORT]``, or an embedded mock one."""
    options = config.options if isinstance(config.options, RtdeSource) else None
    frequency = options.frequency_hz if options else RtdeSource(name="-", type="rtde").frequency_hz
    if config.url is None:
        machine = machine_for(robots, defaults.mock_hold_s)
        mock = RtdeMock(machine)
        url = await mock.start("127.0.0.1", 0)
        async with closed_on_failure(mock):
            settings = RtdeSettings(mock.host, mock.port, frequency, defaults.timeout_s)
            connector = MovedInSimulation(RtdeConnector(settings), machine, robots)
            return Opened(connector, url, mock)
    host, port = rtde_address(config.url)
    settings = RtdeSettings(host, port, frequency, defaults.timeout_s)
    return Opened(RtdeConnector(settings), config.url)
