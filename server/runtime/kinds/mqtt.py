"""The ``mqtt`` kind: values on an MQTT broker, or an embedded Mosquitto with a demo publisher."""

from __future__ import annotations

import dataclasses

from ...cell import Robot, Source
from ...cell.schema import MqttSource
from ...mqtt import MachinePublisher, Mosquitto, MqttConnector, MqttSettings
from ...sources import SourceError
from ..defaults import SourceDefaults
from ..simulation import machine_for
from .opened import Closing, MovedInSimulation, Opened, Unusable, closed_on_failure


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
        return Opened(Unusable(str(exc)), "mqtt:// (no broker)")
    async with closed_on_failure(broker):
        machine = machine_for(robots, defaults.mock_hold_s)
        publisher = MachinePublisher(machine, broker.host, broker.port, defaults.period_s)
        publisher.start()
    mock = Closing(publisher, broker)
    async with closed_on_failure(mock):
        connector = MqttConnector(dataclasses.replace(settings, url=url, user=None, password=None))
        return Opened(MovedInSimulation(connector, machine, robots), url, mock)
