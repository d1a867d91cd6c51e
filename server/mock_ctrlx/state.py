"""What the mock's handlers share, and the Problem answers they give."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from aiohttp import web

from .auth import TokenIssuer
from .faults import Faults
from .machine import Machine
from .nodes import NodeTree

DL_BASE = "/automation/api/v2"


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


@dataclass
class Traffic:
    """What the ctrlX paths served: requests and response body bytes (event streams included)."""

    requests: int = 0
    bytes_out: int = 0


@dataclass
class MockState:
    """Everything the mock handlers share; tests reach it as ``app[STATE_KEY]``."""

    machine: Machine
    tokens: TokenIssuer
    nodes: NodeTree
    faults: Faults = field(default_factory=Faults)
    subscriptions: dict[str, SubscriptionSpec] = field(default_factory=dict)
    changes_only: bool = False
    """Publish a node only when its value changed (the spec's wording); default: every cycle."""
    traffic: Traffic = field(default_factory=Traffic)
    open_streams: int = 0
    closing: bool = False
    """Set on shutdown so open streams end at once."""


STATE_KEY = web.AppKey("state", MockState)


def problem_body(
    status: int, title: str, detail: str, instance: str | None = None
) -> dict[str, Any]:
    """An RFC 7807 Problem object, shaped as in the ctrlX OpenAPI descriptions."""
    body: dict[str, Any] = {"type": "about:blank", "title": title, "status": status}
    body["detail"] = detail
    if instance is not None:
        body["instance"] = instance
    return body


def problem(status: int, title: str, detail: str, instance: str | None = None) -> web.Response:
    """A Problem response (``application/json``, the media type the ctrlX specs declare)."""
    return web.json_response(problem_body(status, title, detail, instance), status=status)
