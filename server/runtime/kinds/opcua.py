"""The ``opcua`` kind of source: an OPC UA server, or (no ``url``) an embedded mock of one.

The embedded mock (``server.mock_opcua``) serves exactly the nodes the cell's
joints name, as Robotics MotionDevices moving as the ctrlX mock's axes do, in
the security mode and with the login the cell asks for (its certificate
trusted automatically). It is started by the connector's first session, in the
background: a cell with one opens at once, its source ``connecting`` meanwhile
(a first start builds the companion models' address space, then cached).
Moves call each MotionDevice's ``MoveJoints`` method over OPC UA.
"""

from __future__ import annotations

import dataclasses
import socket
from pathlib import Path

from ...cell import Robot, Source
from ...cell.load import default_cache_dir
from ...cell.schema import OpcuaSource
from ...mock_opcua import MOCK_URI, MockOptions, OpcuaMock
from ...opcua import OpcuaConnector, OpcuaSettings, UnitRule
from ..defaults import SourceDefaults
from ..simulation import machine_for
from .opened import Opened, closed_on_failure


async def open_opcua(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
    """An OPC UA server at ``config.url``, or an embedded mock serving the robots' nodes."""
    options = config.options if isinstance(config.options, OpcuaSource) else None
    options = options or OpcuaSource(name=config.name, type="opcua")
    folder = config.folder or default_cache_dir() / "opcua"
    settings = OpcuaSettings(
        url=config.url or "",
        source=config.name,
        security=options.security,
        user=config.user or None,
        password=config.password if config.user else None,
        server_certificate=_at(folder, options.server_certificate),
        client_certificate=_at(folder, options.client_certificate) or folder,
        timeout_s=defaults.timeout_s,
        keepalive_s=defaults.keepalive_s,
    )
    units = unit_rules(robots)
    if config.url is not None:
        return Opened(OpcuaConnector(settings, units), config.url)
    users = {settings.user: settings.password or ""} if settings.user else {}
    mock = OpcuaMock(
        machine_for(robots, defaults.mock_hold_s),
        MockOptions(
            security=("None", options.security) if options.security != "None" else ("None",),
            users=users,
            anonymous=not users,
            cache=default_cache_dir(),
            period_s=config.period_s or defaults.period_s,
        ),
    )
    async with closed_on_failure(mock):  # its certificate and folder, made already
        port = _free_port()
        url = f"opc.tcp://127.0.0.1:{port}"
        if options.security != "None":  # the mock's own certificate, trusted as the cell would
            settings = dataclasses.replace(settings, server_certificate=mock.certificate_file)
        commands = {r.command_node: f"nsu={MOCK_URI};s={r.name}.MoveJoints" for r in robots}
        connector = OpcuaConnector(
            dataclasses.replace(settings, url=url),
            units,
            commands,
            prepare=lambda: mock.ensure_started("127.0.0.1", port),
        )
        return Opened(connector, url, mock)


def unit_rules(robots: list[Robot]) -> dict[str, UnitRule]:
    """The unit each joint's nodes (position, setpoint) are delivered in."""
    rules = {}
    for robot in robots:
        for joint in robot.joints:
            rule = UnitRule(joint.source_unit, joint.unit_from_device)
            rules[joint.node] = rule
            if joint.setpoint is not None:
                rules[joint.setpoint] = rule
    return rules


def _at(folder: Path, name: str | None) -> Path | None:
    return None if name is None else folder / Path(name).expanduser()


def _free_port() -> int:
    """A port free now on loopback (the mock binds it when the first session starts)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port
