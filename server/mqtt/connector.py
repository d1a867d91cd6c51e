"""Values on an MQTT broker as a linkview source (``type = "mqtt"``), through aiomqtt.

Each topic the robots name is subscribed to once; each message updates the
values of the nodes on its topic (the number itself, or found in its JSON by
a pointer; a payload that does not hold it becomes that node's error, so only
its robot shows it). The newest values are delivered at most once per period
(``Throttle``). MQTT carries no sample time: the receive time stands in. A
retained message is the broker's copy of the last value, of unknown age: its
topic is named in ``warning`` until a live message arrives. A lost broker is
ridden out by reconnecting with growing delays; only one that stays away for
``give_up_s`` is a SourceError. ``received`` counts the messages of the busiest
topic since the last delivery (a robot with a topic per joint gets one message
per topic each cycle).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import ssl
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import aiomqtt

from ..ctrlx import client_ssl
from ..lateness import Mark, lateness
from ..sources import Sample, SourceError, Throttle
from . import sparkplug
from .nodes import Node, PayloadError, mqtt_address, parse_node, parsed, value_in

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MqttSettings:
    """How to reach a broker and how patient to be with it."""

    url: str
    user: str | None = None
    password: str | None = None
    ca: Path | None = None
    insecure: bool = False
    client_id: str | None = None
    timeout_s: float = 5.0
    give_up_s: float = 1.5
    """Reconnecting after a drop for this long: report the broker as down."""


class NoMessageYet(SourceError):
    """A topic that has had no message since the subscription."""


class MqttConnector:
    """Follows ``topic`` and ``topic#/pointer`` nodes on one broker."""

    device: str | None = None
    halted: str | None = None

    def __init__(self, settings: MqttSettings) -> None:
        self.settings = settings
        self.host, self.port, self.tls = mqtt_address(settings.url)
        self.standing = _standing_warning(self.host, self.tls, settings)
        """What health shows whatever the messages: a login in clear, an unchecked broker."""
        self.retained: str | None = None
        """Set while some topic's newest value is a retained message (age unknown)."""
        self.messages = 0
        """Messages received on the followed topics, in all."""

    @property
    def warning(self) -> str | None:
        """The standing caveat and the retained messages, for health."""
        return "; ".join(w for w in (self.standing, self.retained) if w) or None

    def _context(self) -> ssl.SSLContext | None:
        if not self.tls:
            return None
        verify = client_ssl(self.settings.ca, self.settings.insecure)
        context = verify if isinstance(verify, ssl.SSLContext) else ssl.create_default_context()
        if verify is False:
            context.check_hostname, context.verify_mode = False, ssl.CERT_NONE
        return context

    async def _check_tls(self, context: ssl.SSLContext) -> None:
        """The TLS handshake on our own first: paho leaves its socket open when it fails (a
        ResourceWarning per attempt), and a broker whose certificate we refuse is named."""
        try:
            async with asyncio.timeout(self.settings.timeout_s):
                _, writer = await asyncio.open_connection(
                    self.host, self.port, ssl=context, server_hostname=self.host
                )
        except (OSError, TimeoutError) as exc:
            raise aiomqtt.MqttError(str(exc) or type(exc).__name__) from None
        writer.close()
        with contextlib.suppress(OSError, ssl.SSLError):
            await writer.wait_closed()

    async def _client(self) -> aiomqtt.Client:
        context = self._context()
        if context is not None:
            await self._check_tls(context)
        return aiomqtt.Client(
            self.host,
            self.port,
            username=self.settings.user or None,
            password=self.settings.password if self.settings.user else None,
            identifier=self.settings.client_id,
            tls_context=context,
            timeout=self.settings.timeout_s,
            keepalive=10,
        )

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Deliver the newest values of ``nodes`` at most once per ``period_s``."""
        state = _Topics({node: parse_node(node) for node in nodes}, deliver, self)
        throttle = Throttle(period_s, state.emit)
        down: Mark | None = None
        attempt = 0
        ever_up = False
        try:
            while True:
                up = False
                try:
                    async with await self._client() as client:
                        for topic in state.filters:
                            await client.subscribe(topic)
                        up = ever_up = True
                        topics = len(state.filters)
                        log.info("%s: subscribed to %d topics", self.settings.url, topics)
                        async for message in client.messages:
                            state.received(message)
                            throttle.offer()
                except aiomqtt.MqttError as exc:
                    why = f"{self.settings.url}: {exc}"
                    if up:
                        down, attempt = None, 0
                    if not ever_up:
                        raise SourceError(why) from None  # never reached: nothing to ride out
                    if down is None:
                        log.info("%s; reconnecting", why)
                        down = lateness().mark()
                    elif down.on_time_s() > self.settings.give_up_s:
                        raise SourceError(why) from None
                    await asyncio.sleep(min(0.5, 0.05 * 2.0**attempt))
                    attempt += 1
        finally:
            throttle.cancel()

    async def move(self, command_node: str, values: list[float]) -> None:
        """Refused: linkview only reads values on a broker."""
        raise SourceError(f"{self.settings.url}: moves are not supported over MQTT")

    async def close(self) -> None:
        """Nothing held between follows: each follow closes its own session."""


def _standing_warning(host: str, tls: bool, settings: MqttSettings) -> str | None:
    if tls and settings.insecure:
        return "the broker's TLS certificate is not checked (insecure)"
    loopback = host in ("localhost", "::1") or host.startswith("127.")
    if not tls and settings.user and not loopback:
        return "mqtt:// with a login: the password travels in clear (use mqtts://)"
    return None


class _Topics:
    """The newest value of every node, by topic; which topics only had a retained message."""

    def __init__(
        self, nodes: dict[str, Node], deliver: Callable[[Sample], None], owner: MqttConnector
    ) -> None:
        self.topics: dict[str, list[tuple[str, Node]]] = {}
        """The nodes by topic (a Sparkplug device's by its key, spBv1.0/GROUP/EDGE/DEVICE)."""
        metrics: dict[str, set[str]] = {}
        for key, node in nodes.items():
            self.topics.setdefault(node.topic, []).append((key, node))
            if node.metric is not None:
                metrics.setdefault(node.topic, set()).add(node.metric)
        self.sparkplug = sparkplug.Devices(metrics)
        self.filters = list(
            dict.fromkeys(
                f
                for topic in self.topics
                for f in (sparkplug.filters(topic) if topic in metrics else [topic])
            )
        )
        """What to subscribe to: each topic, and each Sparkplug key's births, data and deaths."""
        self.values: dict[str, float | Exception] = {
            key: NoMessageYet(f"{node.topic}: no message since linkview subscribed")
            for key, node in nodes.items()
        }
        self.retained: set[str] = set()
        self.deliver = deliver
        self.owner = owner
        self.counts: dict[str, int] = {}
        """Messages per topic since the last delivery: a publish cycle is one per topic."""
        self.fresh = False

    def received(self, message: aiomqtt.Message) -> None:
        topic = message.topic.value
        payload = message.payload
        if not isinstance(payload, bytes | bytearray):
            payload = str(payload).encode()
        if self.sparkplug.wanted and (spb := sparkplug.topic_parts(topic)) is not None:
            self._sparkplug(*spb, payload, message.retain)
            return
        on_topic = self.topics.get(topic)
        if on_topic is None:
            return
        self._count(topic)
        document: object = None
        try:
            if any(node.pointer is not None for _, node in on_topic):
                document = parsed(payload, topic)
            for key, node in on_topic:
                try:
                    self.values[key] = value_in(node, payload, document)
                except PayloadError as exc:
                    self.values[key] = exc
        except PayloadError as exc:
            for key, _ in on_topic:
                self.values[key] = exc
        self._retained(topic, message.retain)

    def _sparkplug(self, kind: str, key: str, payload: bytes | bytearray, retain: bool) -> None:
        """A Sparkplug B message: the values (or errors) it brings to the nodes of its keys
        (a node's death reaches its devices' nodes)."""
        for changed, metrics in self.sparkplug.received(kind, key, payload).items():
            for node_key, node in self.topics[changed]:
                if node.metric in metrics:
                    self.values[node_key] = metrics[node.metric]
            self.fresh = True
        if key in self.topics:
            self._count(key)
            self._retained(key, retain)

    def _count(self, topic: str) -> None:
        self.owner.messages += 1
        self.counts[topic] = self.counts.get(topic, 0) + 1
        self.fresh = True

    def _retained(self, topic: str, retain: bool) -> None:
        before = len(self.retained)
        if retain:
            self.retained.add(topic)
        else:
            self.retained.discard(topic)
        if len(self.retained) != before:
            self.owner.retained = (
                "last value, age unknown (retained message on "
                + ", ".join(sorted(self.retained))
                + ")"
                if self.retained
                else None
            )

    def emit(self) -> None:
        if not self.fresh:
            return
        self.fresh = False
        # The publisher's cycles this sample stands for: one, unless we fell behind.
        received = max(self.counts.values(), default=1)
        self.counts.clear()
        self.deliver(Sample(time.time(), dict(self.values), received))
