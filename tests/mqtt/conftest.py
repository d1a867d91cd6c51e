"""The MQTT tests' fixtures: Debian's Mosquitto per test on a free loopback port, and
followers of nodes on it (tests.mqtt.helpers.Follower)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable

import pytest

from server.mqtt import Mosquitto, MqttConnector, MqttSettings
from tests.conftest import free_port
from tests.mqtt.helpers import Follower


@pytest.fixture
async def broker() -> AsyncIterator[Mosquitto]:
    mosquitto = Mosquitto(port=free_port())
    await mosquitto.start()
    try:
        yield mosquitto
    finally:
        await mosquitto.close()


@pytest.fixture
async def follow(broker: Mosquitto) -> AsyncIterator[Callable[..., Follower]]:
    made: list[Follower] = []

    def start(nodes: list[str], **settings: object) -> Follower:
        connector = MqttConnector(MqttSettings(broker.url, **settings))  # type: ignore[arg-type]
        made.append(Follower(connector, nodes))
        return made[-1]

    yield start
    for follower in made:
        follower.task.cancel()
        await asyncio.gather(follower.task, return_exceptions=True)
