"""``/scene`` sent by the guard itself: to each client that subscribes, from one shared copy.

The meshes are the one large message (1.3 MB for the demo cell, far more with
detailed meshes). Logged to foxglove-sdk's channel, each subscribe would send
them to every subscriber (the SDK cannot address one client), with a copy
per client in the SDK, in the relay and in each socket's buffer: 40 clients
subscribing again and again held hundreds of MB. Instead the endpoint keeps
them encoded once per cell, and the guard, which reads the server's
advertisements and each client's subscriptions anyway, sends them to the
subscribing client alone, as the protocol's message-data frame (opcode 1,
subscription id u32, log time u64 ns, then the message), in fragments
written only while less than ``write_below`` bytes wait for that client. Every
client shares the one copy; one that does not read holds a fragment's worth.
"""

from __future__ import annotations

import asyncio
import struct
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import orjson
from websockets.asyncio.server import ServerConnection

from ..recording.messages import SCENE_TOPIC

MESSAGE_DATA = 1
FRAGMENT = 64 * 1024
WAIT_S = 0.05
"""How often a paused scene looks whether its client has taken what waited."""

SceneBytes = Callable[[], Awaitable[bytes | None]]
"""The cell's encoded ``foxglove.SceneUpdate`` (None while there is no cell)."""


class Subscriptions:
    """Which channel is ``/scene`` (from the server's advertisements) and who subscribes to it."""

    def __init__(self) -> None:
        self.scene: set[Any] = set()
        """Ids of the channels advertised as ``/scene`` on this connection."""

    def server_said(self, text: str) -> None:
        """A text message from the SDK's server: note (un)advertised channels."""
        message = _json(text)
        if message.get("op") == "advertise" and isinstance(message.get("channels"), list):
            for channel in message["channels"]:
                if isinstance(channel, dict) and channel.get("topic") == SCENE_TOPIC:
                    self.scene.add(channel.get("id"))
        elif message.get("op") == "unadvertise" and isinstance(message.get("channelIds"), list):
            self.scene.difference_update(message["channelIds"])

    def client_asked(self, text: str) -> list[int]:
        """A text message from the client: the ids of its new subscriptions to ``/scene``."""
        message = _json(text)
        if message.get("op") != "subscribe":
            return []
        wanted = message.get("subscriptions", [])
        return [
            s["id"]
            for s in (wanted if isinstance(wanted, list) else [])
            if isinstance(s, dict)
            and isinstance(s.get("channelId"), int)
            and s["channelId"] in self.scene
            and isinstance(s.get("id"), int)
            and 0 <= s["id"] < 1 << 32
        ]


def _json(text: str) -> dict[str, Any]:
    try:
        message = orjson.loads(text)
    except orjson.JSONDecodeError:
        return {}
    return message if isinstance(message, dict) else {}


async def send_scene(
    client: ServerConnection, subscription: int, scene: bytes, write_below: int, timeout_s: float
) -> None:
    """Send ``scene`` to ``client`` for ``subscription``, paced by what it takes.

    TimeoutError if it takes nothing for ``timeout_s``.
    """
    header = struct.pack("<BIQ", MESSAGE_DATA, subscription, time.time_ns())
    view = memoryview(scene)

    async def fragments() -> AsyncIterator[bytes | memoryview]:
        yield header
        for at in range(0, len(view), FRAGMENT):
            waited = 0.0
            while client.transport.get_write_buffer_size() >= write_below:
                if waited >= timeout_s:
                    raise TimeoutError
                await asyncio.sleep(WAIT_S)
                waited += WAIT_S
            yield view[at : at + FRAGMENT]

    await client.send(fragments())
