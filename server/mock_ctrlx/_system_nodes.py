"""The data layer's own ``datalayer/...`` nodes, and the system metrics of ctrlX OS.

The mock has no retain memory, no CurveZMQ and no real-time nodes, so their
values are plausible constants; the settings are stored when written. The
``framework/metrics/system/...`` values change with time.
"""

from __future__ import annotations

import math
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


METRICS = "framework/metrics/system"
"""The system metrics ctrlX's own examples read (cpu-utilisation-percent, memused-mb, ...)."""
METRIC_NAMES = (
    "cpu-utilisation-percent",
    "memavailable-mb",
    "membuffers-mb",
    "memcache-mb",
    "memfree-mb",
    "memtotal-mb",
    "memused-mb",
    "memused-percent",
)
MEMTOTAL_MB = 3906.25
"""A 4 GB ctrlX CORE."""


def metrics(t: float) -> dict[str, dict[str, Any]]:
    """The ``framework/metrics/system/...`` doubles at unix time ``t``: a load that wanders.

    A pure function of time, so every client reading at one instant agrees;
    the memory figures add up as Linux's do (used + free + buffers + cache = total).
    """
    cpu = 12.0 + 6.0 * math.sin(0.7 * t) + 3.0 * math.sin(2.3 * t + 1.0)
    used = 920.0 + 40.0 * math.sin(0.05 * t)
    buffers, cache = 118.0, 1_024.0 + 16.0 * math.sin(0.11 * t)
    free = MEMTOTAL_MB - used - buffers - cache
    values = {
        "cpu-utilisation-percent": round(min(max(cpu, 0.0), 100.0), 1),
        "memavailable-mb": free + buffers + cache,
        "membuffers-mb": buffers,
        "memcache-mb": cache,
        "memfree-mb": free,
        "memtotal-mb": MEMTOTAL_MB,
        "memused-mb": used,
        "memused-percent": round(100.0 * used / MEMTOTAL_MB, 1),
    }
    return {f"{METRICS}/{name}": {"type": "double", "value": v} for name, v in values.items()}
