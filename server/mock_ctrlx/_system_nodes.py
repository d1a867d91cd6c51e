"""The data layer's own ``datalayer/...`` nodes, as the published description lists them.

The mock has no retain memory, no CurveZMQ and no real-time nodes, so their
values are plausible constants; the settings are stored when written.
"""

from __future__ import annotations

from typing import Any

SYSTEM = "datalayer"
NODE_NAMES = f"{SYSTEM}/nodes"
"""Its value is every node address of the mock, computed when read."""

RETAIN_STATS = {
    "total": 122880,
    "free": 122880,
    "used": 0,
    "biggestFree": 122880,
    "syncCounter": 0,
    "lastUsed": 0,
    "info": "emulated",
}
_RETAIN_LEAVES = {
    "total": "total",
    "free": "free",
    "used": "used",
    "biggest-free": "biggestFree",
    "sync-counter": "syncCounter",
    "last-used": "lastUsed",
}

SETTINGS = (f"{SYSTEM}/server/settings", f"{SYSTEM}/subscriptions/settings")
"""System nodes a client may write (an object, as read)."""

FOLDERS = (f"{SYSTEM}/retain/chunks",)
"""Folders without children: the mock keeps no retain chunks."""


def system_nodes(min_publish_ms: int) -> dict[str, dict[str, Any]]:
    """Every ``datalayer/...`` leaf and its Data (``{"type", "value"}``), except ``nodes``."""
    nodes: dict[str, dict[str, Any]] = {
        f"{SYSTEM}/nodesrt": {"type": "arstring", "value": []},
        f"{SYSTEM}/curvemq/publickey": {"type": "string", "value": ""},
        f"{SYSTEM}/server/settings": {
            "type": "object",
            "value": {"serverIdlePingTimeout": 30000, "serverWaitResponseTimeout": 3000},
        },
        f"{SYSTEM}/subscriptions/settings": {
            "type": "object",
            "value": {
                "minimumPublishInterval": min_publish_ms,
                "minimumSampleInterval": min_publish_ms * 1000,
                "maximumBufferSize": 50,
                "minimumErrorInterval": min_publish_ms,
            },
        },
        f"{SYSTEM}/retain/stats": {"type": "object", "value": dict(RETAIN_STATS)},
        f"{SYSTEM}/retain/stats/info": {"type": "string", "value": RETAIN_STATS["info"]},
    }
    for leaf, key in _RETAIN_LEAVES.items():
        nodes[f"{SYSTEM}/retain/stats/{leaf}"] = {"type": "uint32", "value": RETAIN_STATS[key]}
    return nodes
