"""Publishing to and following nodes on the MQTT tests' broker."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import aiomqtt

from server.mqtt import Mosquitto, MqttConnector
from server.sources import Sample, SourceError
from tests.conftest import wait_until


async def publish(broker: Mosquitto, topic: str, payload: bytes, retain: bool = False) -> None:
    async with aiomqtt.Client(broker.host, broker.port) as client:
        await client.publish(topic, payload, qos=1, retain=retain)


class Follower:
    """Follows nodes as the acquisition does: follow again after a SourceError."""

    def __init__(self, connector: MqttConnector, nodes: list[str]) -> None:
        self.connector = connector
        self.samples: list[Sample] = []
        self.errors: list[str] = []
        self.task = asyncio.create_task(self._run(nodes))

    async def _run(self, nodes: list[str]) -> None:
        while True:
            try:
                await self.connector.follow(nodes, 0.02, self.samples.append)
            except SourceError as exc:
                self.errors.append(str(exc))
            await asyncio.sleep(0.5)

    async def value(self, node: str, accept: Callable[[object], bool]) -> object:
        await wait_until(lambda: bool(self.samples) and accept(self.samples[-1].values[node]))
        return self.samples[-1].values[node]

    async def subscribed(self) -> None:
        await wait_until(lambda: bool(self.samples) or self.connector.messages > 0 or False, 0.5)
