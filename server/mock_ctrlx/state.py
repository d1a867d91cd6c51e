"""What the mock's handlers share: machine, tokens, nodes, faults, subscriptions, traffic."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web

from .auth import TokenIssuer
from .faults import Faults
from .machine import Machine
from .nodes import NodeTree

DL_BASE = "/automation/api/v2"
SUBSCRIPTION_LIFETIME_S = 60.0
"""The spec: a created subscription that is not used within one minute is deleted."""


def bearer_token(request: web.Request) -> str | None:
    """The token of an ``Authorization: Bearer`` header, if there is one."""
    header = request.headers.get("Authorization", "")
    return header[7:] if header.startswith("Bearer ") else None


@dataclass
class SubscriptionSpec:
    """A subscription created by ``POST /events`` (or implied by the short form)."""

    id: str
    nodes: list[str]
    publish_ms: int = 1000
    keepalive_ms: int = 60000
    error_ms: int = 10000
    rules: list[Any] = field(default_factory=list)
    streams: dict[int, web.Request] = field(default_factory=dict, repr=False)
    """The requests of its open event streams, by ``id()`` (requests are not hashable)."""
    idle_since: float = field(default_factory=time.monotonic)
    """Monotonic time since which no stream of it is open."""

    def properties(self) -> dict[str, Any]:
        """Its ``properties`` object, as ``POST /events`` takes it."""
        return {
            "id": self.id,
            "publishInterval": self.publish_ms,
            "keepaliveInterval": self.keepalive_ms,
            "errorInterval": self.error_ms,
            "rules": list(self.rules),
        }

    def live_streams(self) -> int:
        """Open streams whose client has not hung up."""
        return sum(
            1
            for r in self.streams.values()
            if r.transport is not None and not r.transport.is_closing()
        )


@dataclass
class Subscriptions:
    """Created subscriptions by id; one without an open stream for ``lifetime_s`` is gone."""

    lifetime_s: float = SUBSCRIPTION_LIFETIME_S
    clock: Callable[[], float] = time.monotonic
    _by_id: dict[str, SubscriptionSpec] = field(default_factory=dict)

    def _expire(self) -> None:
        now = self.clock()
        for sub_id, spec in list(self._by_id.items()):
            if not spec.streams and now - spec.idle_since > self.lifetime_s:
                del self._by_id[sub_id]

    def get(self, sub_id: str) -> SubscriptionSpec | None:
        """The live subscription ``sub_id``, if any."""
        self._expire()
        return self._by_id.get(sub_id)

    def put(self, spec: SubscriptionSpec) -> SubscriptionSpec:
        """Create a subscription, or update the one of that id (its open streams follow).

        Returns the subscription as stored; its lifetime starts again now.
        """
        self._expire()
        old = self._by_id.get(spec.id)
        if old is not None:
            old.nodes, old.rules = spec.nodes, spec.rules
            old.publish_ms, old.keepalive_ms, old.error_ms = (
                spec.publish_ms,
                spec.keepalive_ms,
                spec.error_ms,
            )
            spec = old
        spec.idle_since = self.clock()
        self._by_id[spec.id] = spec
        return spec

    def pop(self, sub_id: str) -> SubscriptionSpec | None:
        """Remove and return subscription ``sub_id``."""
        self._expire()
        return self._by_id.pop(sub_id, None)

    def opened(self, spec: SubscriptionSpec, request: web.Request) -> None:
        """A stream of ``spec`` started."""
        spec.streams[id(request)] = request

    def closed(self, spec: SubscriptionSpec, request: web.Request) -> None:
        """A stream of ``spec`` ended; its lifetime starts again when it was the last."""
        spec.streams.pop(id(request), None)
        if not spec.streams:
            spec.idle_since = self.clock()

    def __iter__(self) -> Iterator[SubscriptionSpec]:
        self._expire()
        return iter(list(self._by_id.values()))

    def __len__(self) -> int:
        self._expire()
        return len(self._by_id)


@dataclass
class Traffic:
    """What the ctrlX paths served: requests and response body bytes (event streams included)."""

    requests: int = 0
    bytes_out: int = 0
    in_flight: int = 0
    """Requests being answered now (an event stream counts while it starts)."""
    most_in_flight: int = 0
    """The most requests answered at once so far: how hard a client pressed."""


@dataclass
class MockState:
    """Everything the mock handlers share; tests reach it as ``app[STATE_KEY]``."""

    machine: Machine
    tokens: TokenIssuer
    nodes: NodeTree
    faults: Faults = field(default_factory=Faults)
    subscriptions: Subscriptions = field(default_factory=Subscriptions)
    changes_only: bool = False
    """Publish a node only when its value changed (the spec's wording); default: every cycle."""
    traffic: Traffic = field(default_factory=Traffic)
    open_streams: int = 0
    closing: bool = False
    """Set on shutdown so open streams end at once."""


STATE_KEY = web.AppKey("state", MockState)
