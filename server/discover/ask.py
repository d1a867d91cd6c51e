"""Asking a controller many questions without flooding it: a handful at a time, each retried.

``discover`` reads a few nodes per axis. Sent all at once (100 000 axes: half
a million requests), they exhausted the client's memory and the device's
patience, and the requests that timed out dropped their axes without a word.
Here at most ``CONCURRENCY`` requests are in flight; where the data layer has
bulk requests, ``CHUNK`` nodes share one; a request that fails in a way that
may pass (no answer, 5xx, 429) is sent again after a growing pause, and what
still fails is returned as the error of each node it concerns, for the caller
to name.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Sequence
from typing import Any, Literal, TypeVar

from ..ctrlx import (
    DataLayerClient,
    DataLayerError,
    ProblemError,
    RetryPolicy,
    Unsupported,
    transient,
)

T = TypeVar("T")
Kind = Literal["read", "metadata"]

CONCURRENCY = 4
"""Requests in flight at once: a controller serves its own motion first."""
CHUNK = 100
"""Nodes per bulk request: a few kB each way."""
TRIES = 4
RETRY = RetryPolicy(first_s=0.2, max_s=2.0)


async def in_turn(
    items: Sequence[T], work: Callable[[T], Awaitable[None]], workers: int = CONCURRENCY
) -> None:
    """``work(item)`` for every item, ``workers`` at a time: memory for a few, not for all."""
    pending = iter(items)

    async def worker() -> None:
        for item in pending:  # shared: each item is taken by one worker
            await work(item)

    await asyncio.gather(*(worker() for _ in range(min(workers, len(items)))))


class Asker:
    """Requests to one controller, at most ``concurrency`` at once, each tried ``tries`` times."""

    def __init__(
        self, client: DataLayerClient, concurrency: int = CONCURRENCY, tries: int = TRIES
    ) -> None:
        self.client = client
        self.tries = tries
        self._gate = asyncio.Semaphore(concurrency)
        self._bulk: dict[Kind, bool] = {}
        """Per kind, whether bulk requests work (absent: not tried yet)."""
        self.retried = 0
        """Requests sent again after a failure that might pass."""

    async def call(self, make: Callable[[], Awaitable[T]]) -> T:
        """``make()``'s answer, sent again while it fails in a way that may pass."""
        for attempt in range(self.tries):
            await asyncio.sleep(RETRY.delay(attempt))  # 0 s before the first try
            try:
                async with self._gate:
                    return await make()
            except DataLayerError as exc:
                if not transient(exc) or attempt == self.tries - 1:
                    raise
                self.retried += 1
        raise AssertionError("unreachable")

    async def many(self, kind: Kind, nodes: Sequence[str]) -> dict[str, Any]:
        """Each node's Data (``read``) or metadata body; a node that failed holds its error.

        Chunks go one after another: callers run a few ``many`` at once (``in_turn``).
        """
        found: dict[str, Any] = {}
        for start in range(0, len(nodes), CHUNK):
            found.update(await self._chunk(kind, list(nodes[start : start + CHUNK])))
        return found

    async def _chunk(self, kind: Kind, nodes: list[str]) -> dict[str, Any]:
        if self._bulk.get(kind, True):
            try:
                entries = await self.call(lambda: self.client.bulk(kind, nodes))
            except (Unsupported, ProblemError) as exc:
                if isinstance(exc, ProblemError) and transient(exc):
                    return dict.fromkeys(nodes, exc)
                self._bulk[kind] = False  # no bulk service (or not for this kind): one by one
            except DataLayerError as exc:  # still failing after every try
                return dict.fromkeys(nodes, exc)
            else:
                self._bulk[kind] = True
                return dict(zip(nodes, entries, strict=True))
        answers = await asyncio.gather(
            *(self._one(kind, node) for node in nodes), return_exceptions=True
        )
        return dict(zip(nodes, answers, strict=True))

    async def _one(self, kind: Kind, node: str) -> Any:
        if kind == "read":
            return await self.call(lambda: self.client.read(node))
        path = self.client.node_url_path(node)
        return await self.call(
            lambda: self.client.request("GET", path, params={"type": "metadata"})
        )
