"""The hub of an acquisition worker: what its acquisitions publish goes to Redis, in batches.

The acquisition is unchanged: it calls ``Hub.publish`` with the bytes it
encoded once, and this hub forwards those bytes. Like the viewer hub it
keeps the newest message per key while the broker is busy or away: a slow
Redis makes replicas skip stale frames, it never builds a backlog.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

import orjson
from redis.asyncio import Redis
from redis.exceptions import RedisError

from ..stream import Hub, Message
from . import envelope
from .broker import FRAMES, health_key

log = logging.getLogger(__name__)

LINGER_S = 0.002
"""A batch waits this long for more frames: fewer Redis messages for a little delay."""
HEALTH_TTL_MS = 10_000
"""A stored status record outlives its worker this long (replicas that start meanwhile read it)."""
LOCAL_KEYS = ("hello", "cell")
"""Keys every replica makes from its own cell file: not published."""

Describe = Callable[[str], dict[str, object] | None]
"""A source's status record (status, robots, worker) by name; None for a source not held."""


class BrokerHub(Hub):
    """Publishes each hub message to the broker's ``frames`` channel; viewers never join it."""

    def __init__(self, redis: Redis, describe: Describe) -> None:
        super().__init__()
        self._redis = redis
        self._describe = describe
        self._pending: dict[str, envelope.Item] = {}
        self._records: dict[str, bytes] = {}
        self._wake = asyncio.Event()
        self.json_wanted = False
        """Whether some replica has protocol-1 viewers (so JSON frames are worth encoding)."""
        self.batches = 0
        self.items = 0
        self.skipped = 0
        """Messages overwritten by a newer one of the same key before they could be sent."""
        self.lost = 0
        """Messages the broker did not take (it was unreachable)."""

    def publish(self, key: str, message: Message, protocol: int | None = None) -> None:
        """Queue ``message`` for the next batch (replacing an unsent one of the same key)."""
        kind, _, source = key.partition(":")
        if kind in LOCAL_KEYS:
            return
        if kind == "status":
            record = self._describe(source)
            if record is None:
                return
            self._records[source] = orjson.dumps(record)
            message = Message(self._records[source].decode())
        if key in self._pending:
            self.skipped += 1
        self._pending[key] = (key, message, protocol)
        self._wake.set()

    def wants(self, protocol: int) -> bool:
        """Protocol 2 always (health follows its frames); protocol 1 while some replica asks."""
        return protocol != 1 or self.json_wanted

    async def run(self) -> None:
        """Send batches until cancelled; a failed send is counted and logged by the lease loop."""
        while True:
            await self._wake.wait()
            await asyncio.sleep(LINGER_S)
            self._wake.clear()
            batch, self._pending = list(self._pending.values()), {}
            records, self._records = self._records, {}
            try:
                await self._send(batch, records)
            except (RedisError, OSError) as exc:
                self.lost += len(batch)
                log.debug("batch of %d lost: %s", len(batch), exc)
                continue
            self.batches += 1
            self.items += len(batch)

    async def _send(self, batch: list[envelope.Item], records: dict[str, bytes]) -> None:
        data = envelope.pack(batch)
        if not records:
            await self._redis.publish(FRAMES, data)
            return
        async with self._redis.pipeline(transaction=False) as pipe:
            pipe.publish(FRAMES, data)
            for source, record in records.items():
                pipe.set(health_key(source), record, px=HEALTH_TTL_MS)
            await pipe.execute()
