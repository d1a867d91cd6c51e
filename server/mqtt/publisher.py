"""Publishes a simulated machine's joint values to a broker, as the nodes of a cell name them.

What an MQTT source without ``url`` follows: the embedded mock is a Mosquitto
broker (``broker.Mosquitto``) and this publisher, moving the robots as the
ctrlX mock does (``server.runtime.simulation.machine_for``). A ``topic`` node
gets the number as text, ``topic#/pointer`` nodes of one topic share one JSON
document with each value at its pointer. Sparkplug B metrics are published as an
edge node does: a birth certificate with names and aliases on connecting, then
data messages by alias.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Iterable

import aiomqtt
import orjson

from ..mock_ctrlx import Machine
from . import sparkplug
from .nodes import Node, parse_node

log = logging.getLogger(__name__)


def document(values: Iterable[tuple[tuple[str, ...], float]]) -> object:
    """The JSON document holding each value at its pointer (digit tokens make arrays)."""
    root: dict[str, object] = {}
    for tokens, value in values:
        at = root
        for token in tokens[:-1]:
            nested = at.setdefault(token, {})
            assert isinstance(nested, dict)
            at = nested
        at[tokens[-1]] = value
    return _arrays(root)


def _arrays(value: object) -> object:
    if not isinstance(value, dict):
        return value
    items = {k: _arrays(v) for k, v in value.items()}
    indices = sorted(int(k) for k in items if k.isdigit())
    if items and indices == list(range(len(items))):
        return [items[str(i)] for i in range(len(items))]
    return items


def payloads(nodes: dict[str, Node], values: dict[str, float]) -> dict[str, bytes]:
    """Each topic's payload for ``values`` (by node key)."""
    plain: dict[str, bytes] = {}
    pointed: dict[str, list[tuple[tuple[str, ...], float]]] = {}
    for key, node in nodes.items():
        if key not in values or node.metric is not None:
            continue
        if node.pointer is None or not node.pointer:
            plain[node.topic] = repr(values[key]).encode()
        else:
            pointed.setdefault(node.topic, []).append((node.pointer, values[key]))
    out = {topic: orjson.dumps(document(items)) for topic, items in pointed.items()}
    return {**out, **plain}


class SparkplugEdge:
    """The births and data messages of the Sparkplug keys among ``nodes``."""

    def __init__(self, nodes: dict[str, Node]) -> None:
        self.metrics: dict[str, dict[str, tuple[int, str]]] = {}
        """By Sparkplug key: metric name -> (alias, node key)."""
        for key, node in nodes.items():
            if node.metric is not None:
                metrics = self.metrics.setdefault(node.topic, {})
                metrics.setdefault(node.metric, (len(metrics) + 1, key))
        self.seq = 0

    def births(self, values: dict[str, float], t_ms: int) -> dict[str, bytes]:
        """NBIRTH of every edge node (bdSeq 0), then DBIRTH of every device, with names."""
        edges = {"/".join(key.split("/")[:3]) for key in self.metrics}
        self.seq = 0
        out = {}
        for edge in sorted(edges):
            named = self._metrics(edge, values, names=True) + [("bdSeq", None, 0.0)]
            out[_topic(edge, "NBIRTH")] = self._payload(named, t_ms)
        for key in sorted(k for k in self.metrics if k not in edges):
            out[_topic(key, "DBIRTH")] = self._payload(self._metrics(key, values, True), t_ms)
        return out

    def data(self, values: dict[str, float], t_ms: int) -> dict[str, bytes]:
        """One NDATA or DDATA per key, its metrics by alias alone."""
        return {
            _topic(key, "NDATA" if key.count("/") == 2 else "DDATA"): self._payload(
                self._metrics(key, values, names=False), t_ms
            )
            for key in self.metrics
        }

    def _metrics(
        self, key: str, values: dict[str, float], names: bool
    ) -> list[tuple[str | None, int | None, float]]:
        return [
            (name if names else None, alias, values[node_key])
            for name, (alias, node_key) in self.metrics.get(key, {}).items()
            if node_key in values
        ]

    def _payload(self, metrics: list[tuple[str | None, int | None, float]], t_ms: int) -> bytes:
        payload = sparkplug.encoded(metrics, self.seq, t_ms)
        self.seq = (self.seq + 1) % 256
        return payload


def _topic(key: str, kind: str) -> str:
    """``spBv1.0/G/E[/D]`` with its message type: ``spBv1.0/G/KIND/E[/D]``."""
    parts = key.split("/")
    return "/".join([*parts[:2], kind, *parts[2:]])


class MachinePublisher:
    """Publishes ``machine``'s axes (named by node key) to ``url`` every ``period_s``."""

    def __init__(self, machine: Machine, host: str, port: int, period_s: float = 0.02) -> None:
        self.machine = machine
        self.host, self.port = host, port
        self.period_s = period_s
        self.nodes = {
            axis.position_node: parse_node(axis.position_node) for axis in machine.axes.values()
        }
        self.setpoints = {
            axis.setpoint_node: axis.name for axis in machine.axes.values() if axis.setpoint_node
        }
        self.nodes.update({key: parse_node(key) for key in self.setpoints})
        self.task: asyncio.Task[None] | None = None
        self.published = 0

    def start(self) -> None:
        self.task = asyncio.create_task(self._run(), name="mqtt-mock-publisher")

    def values(self, t: float) -> dict[str, float]:
        actual = self.machine.snapshot(t)
        planned = self.machine.snapshot(t, setpoints=True)
        out = {axis.position_node: actual[name] for name, axis in self.machine.axes.items()}
        out.update({key: planned[name] for key, name in self.setpoints.items()})
        return out

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            try:
                async with aiomqtt.Client(self.host, self.port) as client:
                    due = loop.time()
                    edge = SparkplugEdge(self.nodes)
                    t = self.machine.now()
                    for topic, payload in edge.births(self.values(t), int(t * 1000)).items():
                        await client.publish(topic, payload)
                    while True:
                        t = self.machine.now()
                        now = self.values(t)
                        messages = {**payloads(self.nodes, now), **edge.data(now, int(t * 1000))}
                        for topic, payload in messages.items():
                            await client.publish(topic, payload)
                        self.published += 1
                        due = max(due + self.period_s, loop.time())
                        await asyncio.sleep(due - loop.time())
            except aiomqtt.MqttError as exc:
                log.debug("mock publisher: %s; again in 0.5 s", exc)
                await asyncio.sleep(0.5)

    async def close(self) -> None:
        if self.task is not None:
            self.task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self.task
