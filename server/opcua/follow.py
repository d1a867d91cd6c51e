"""Following resolved nodes in one session: one subscription with every node, or reads.

One subscription holds every node of the source (publishing interval = the
period, queue size 1: the server keeps only the newest value of each). Our
publish loop (publish.py: requests in batches, the usual response decoded lean)
hands us each PublishResponse whole (``on_publish``), and one response makes one
Sample: no task, no call per item. An OPC UA server sends
only what changed, so a robot at rest sends nothing; its last values are
delivered again each period, with their time, for as long as the server shows
it is alive (responses or keep-alives), and ``received`` counts the publishing
cycles a sample stands for. A server that refuses subscriptions (or publishes slower
than twice the period) is read instead: one Read of every node per period.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable

from asyncua import ua
from asyncua.ua.attribute_ids import AttributeIds
from asyncua.ua.uaerrors import UaStatusCodeError

from ..ctrlx.pacing import Pacer
from ..sources import Sample, SourceError
from .publish import Change, Changes, Publisher, create_subscription
from .resolve import Resolved
from .session import Session, status_name

log = logging.getLogger(__name__)

KEEPALIVE_S = 0.25
"""How often a quiet server is asked to show it is alive (keep-alive publish responses)."""
STALL_KEEPALIVES = 4
"""After this many keep-alive intervals without any response, the server counts as stalled."""
LIFETIME_S = 10.0
"""How long the server keeps the subscription without our publish requests."""
REFUSED = ("BadTooManySubscriptions", "BadServiceUnsupported", "BadTooManyMonitoredItems")
HOLD_AFTER = 2.5
"""Periods without a publish response after which the last values are delivered again (a late
response is not worth a repeated sample: under load that would add work)."""
SLOWEST_PUBLISHING = 2.0
"""A revised publishing interval beyond this many periods: read instead."""


class Follower:
    """Delivers samples of ``keys`` from one session until it is lost (then raises SourceError)."""

    def __init__(
        self,
        session: Session,
        keys: list[str],
        resolved: Resolved,
        period_s: float,
        deliver: Callable[[Sample], None],
    ) -> None:
        self.session = session
        self.period_s = period_s
        self.deliver = deliver
        self.values: dict[str, float | Exception] = dict(resolved.errors)
        self.keys = [k for k in keys if k in resolved.ids]
        """Followed nodes, by client handle (their index)."""
        self.ids = [resolved.ids[k] for k in self.keys]
        self.gains = [resolved.factors.get(k, 1.0) for k in self.keys]
        self.missing = set(range(len(self.keys)))
        """Handles without a first value yet: samples start once every node has one."""
        self.interval_s = period_s
        self.warning: str | None = None
        self._loop = asyncio.get_running_loop()
        self._t_source = 0.0
        self._last_response = self._loop.time()
        self._last_delivery = self._loop.time()
        self._cycles = 0.0
        self._timer: asyncio.TimerHandle | None = None
        self._held = False
        """True while the last values are being delivered again (each period)."""
        self._holding = False
        """True while subscribed: a quiet period delivers the last values again."""
        self._alive_s = 1.0
        self._publishing: asyncio.Task[None] | None = None

    async def run(self) -> None:
        """Follow until the session is lost; raises SourceError saying why."""
        try:
            if not self.keys:  # nothing to follow: every node is in error; show them each period
                self._alive_s, self._holding = math.inf, True
                self._deliver_all_errors()
                await self._watch()
            elif await self._subscribe():
                await self._watch()
            else:
                await self._poll()
        finally:
            if self._timer is not None:
                self._timer.cancel()
            if self._publishing is not None:
                self._publishing.cancel()

    # -- subscription --------------------------------------------------------------------------

    async def _subscribe(self) -> bool:
        """Subscribe to every node; False where the server refuses (then read instead)."""
        uaclient = self.session.client.uaclient
        params = ua.CreateSubscriptionParameters(
            RequestedPublishingInterval=self.period_s * 1000.0,
            RequestedLifetimeCount=max(3, math.ceil(LIFETIME_S / self.period_s)),
            RequestedMaxKeepAliveCount=max(1, math.ceil(KEEPALIVE_S / self.period_s)),
            MaxNotificationsPerPublish=0,
            PublishingEnabled=True,
        )
        try:
            created = await create_subscription(self.session.client, params)
            revised = created.RevisedPublishingInterval / 1000.0
            if revised > SLOWEST_PUBLISHING * self.period_s:
                self.warning = (
                    f"the server publishes no faster than every {revised * 1000:g} ms: "
                    f"reading every {self.period_s * 1000:g} ms instead"
                )
                return False
            self.interval_s = max(revised, 1e-3)
            keepalive_s = self.interval_s * max(1, created.RevisedMaxKeepAliveCount)
            self._alive_s = max(1.0, STALL_KEEPALIVES * keepalive_s)
            self._holding = True  # before the items: their first values may come at once
            results = await uaclient.create_monitored_items(self._items(created.SubscriptionId))
        except UaStatusCodeError as exc:
            if status_name(exc.code) not in REFUSED:
                raise
            self.warning = f"subscriptions refused ({status_name(exc.code)}): reading instead"
            return False
        for handle, result in enumerate(results):
            if not result.StatusCode.is_good():
                self._fail(handle, result.StatusCode.name)
        self._publishing = asyncio.create_task(self._publish_loop())
        return True

    async def _publish_loop(self) -> None:
        try:
            await Publisher(self.session.client, self.on_publish).run()
        except (UaStatusCodeError, ConnectionError) as exc:
            self.session.lose(exc)
        except Exception as exc:  # never silently: the source says why it stopped
            log.exception("source %s: publishing failed", self.session.settings.source)
            self.session.mark_lost(f"internal error: {exc!r}")

    def _items(self, subscription: int) -> ua.CreateMonitoredItemsParameters:
        return ua.CreateMonitoredItemsParameters(
            SubscriptionId=subscription,
            TimestampsToReturn=ua.TimestampsToReturn.Source,
            ItemsToCreate=[
                ua.MonitoredItemCreateRequest(
                    ItemToMonitor=ua.ReadValueId(NodeId=node, AttributeId=AttributeIds.Value),
                    MonitoringMode=ua.MonitoringMode.Reporting,
                    RequestedParameters=ua.MonitoringParameters(
                        ClientHandle=handle,
                        SamplingInterval=self.period_s * 1000.0,
                        QueueSize=1,
                        DiscardOldest=True,
                    ),
                )
                for handle, node in enumerate(self.ids)
            ],
        )

    def on_publish(self, result: ua.PublishResult | Changes) -> None:
        """One PublishResponse (the Publisher's): its changes made into one sample."""
        try:
            self._publish(result)
        except Exception as exc:  # a fault of ours: end the session, say why
            log.exception("source %s: a publish response failed", self.session.settings.source)
            self.session.mark_lost(f"internal error: {exc!r}")

    def _publish(self, result: ua.PublishResult | Changes) -> None:
        now = self._loop.time()
        self._last_response = now
        if isinstance(result, Changes):  # the usual response, decoded lean (publish.py)
            self._changes(now, result.items)
            return
        data = result.NotificationMessage.NotificationData
        if not data:
            return  # a keep-alive: the server lives; held values go on being delivered
        stamp = None
        for notification in data:
            if type(notification) is ua.DataChangeNotification:
                for item in notification.MonitoredItems:
                    value = item.Value
                    stamp = value.SourceTimestamp or stamp
                    self._store(item.ClientHandle, value)
            elif isinstance(notification, ua.StatusChangeNotification):
                status = notification.Status
                self.session.mark_lost(f"the subscription ended: {status.name}")
                return
        self._sampled(now, stamp.timestamp() if stamp is not None else None)

    def _changes(self, now: float, items: list[Change]) -> None:
        """Good numbers that changed (publish.Changes): one sample, as ``_publish`` makes."""
        if not items:
            return  # a keep-alive
        stamp = None
        values, keys, gains, missing = self.values, self.keys, self.gains, self.missing
        for handle, value, source_time in items:
            values[keys[handle]] = value * gains[handle]
            missing.discard(handle)
            stamp = source_time or stamp
        self._sampled(now, stamp)

    def _sampled(self, now: float, t_source: float | None) -> None:
        """A response's changes are stored: a sample, once every node has a value."""
        self._t_source = t_source if t_source is not None else time.time()
        if not self.missing:
            self._send(now, 1)

    def _store(self, handle: int, value: ua.DataValue) -> None:
        status = value.StatusCode
        if status is not None and status.value and status.is_bad():  # uncertain values are used
            self._fail(handle, status.name)
            return
        body = value.Value.Value if value.Value is not None else None
        if type(body) is float:  # the usual case first: a Double
            self.values[self.keys[handle]] = body * self.gains[handle]
        elif isinstance(body, int | float) and not isinstance(body, bool):
            self.values[self.keys[handle]] = float(body) * self.gains[handle]
        else:
            kind = type(body).__name__ if body is not None else "no value"
            self._fail(handle, f"not a number ({kind})")
            return
        self.missing.discard(handle)

    def _fail(self, handle: int, why: str) -> None:
        self.values[self.keys[handle]] = SourceError(f"{self.keys[handle]}: {why}")
        self.missing.discard(handle)

    def _send(self, now: float, least: int) -> None:
        """Deliver the current values; ``least``: the cycles it stands for at minimum."""
        self._cycles += (now - self._last_delivery) / self.interval_s
        received = max(least, int(self._cycles))
        self._cycles = max(0.0, self._cycles - received)
        self._last_delivery = now
        self._held = self._held and least == 0  # new values end a spell of held ones
        self.deliver(Sample(self._t_source, dict(self.values), received))
        if self._holding and self._timer is None:
            self._timer = self._loop.call_at(now + HOLD_AFTER * self.period_s, self._hold)

    def _hold(self) -> None:
        """No change for a while: the last values again, while the server shows it is alive.

        They keep their time: the device said nothing newer (a robot at rest, or a late
        publish), so the sample repeats the last one rather than claim a time it has no
        values for. One timer, moved on rather than re-armed per sample (that cost 5 us).
        """
        self._timer = None
        now = self._loop.time()
        quiet = now - self._last_delivery
        if quiet < HOLD_AFTER * self.period_s and not self._held:
            # Samples came meanwhile: wait for the rest of the quiet time.
            wait = HOLD_AFTER * self.period_s - quiet
            self._timer = self._loop.call_at(now + wait, self._hold)
            return
        if now - self._last_response > self._alive_s:
            self._held = False
            return  # the server went quiet: no sample (the source turns stale; _watch ends it)
        self._held = True
        self._timer = self._loop.call_at(now + self.period_s, self._hold)
        self._send(now, 0)

    def _deliver_all_errors(self) -> None:
        self._t_source = time.time()
        self._send(self._loop.time(), 1)

    async def _watch(self) -> None:
        """Wait until the session is lost or the server stalls; raise SourceError."""
        lost = self.session.lost
        while True:
            try:
                why = await asyncio.wait_for(asyncio.shield(lost), min(self._alive_s, 1.0))
            except TimeoutError:
                silent = self._loop.time() - self._last_response
                if silent > self._alive_s:
                    raise SourceError(
                        f"{self.session.settings.url}: no publish response for {silent:.1f} s "
                        "(the server stalled)"
                    ) from None
                continue
            raise SourceError(f"{self.session.settings.url}: {why}")

    # -- reads ---------------------------------------------------------------------------------

    async def _poll(self) -> None:
        """One Read of every node per period, until the session is lost."""
        request = ua.ReadParameters(
            TimestampsToReturn=ua.TimestampsToReturn.Source,
            NodesToRead=[
                ua.ReadValueId(NodeId=n, AttributeId=AttributeIds.Value) for n in self.ids
            ],
        )
        pacer = Pacer(self.period_s)
        uaclient = self.session.client.uaclient
        self.interval_s = self.period_s
        while not self.session.lost.done():
            values = await uaclient.read(request)
            now = self._loop.time()
            stamp = None
            for handle, value in enumerate(values):
                stamp = value.SourceTimestamp or stamp
                self._store(handle, value)
            self._t_source = stamp.timestamp() if stamp is not None else time.time()
            self._last_response = now
            self._send(now, 1)
            await pacer.wait()
        raise SourceError(f"{self.session.settings.url}: {self.session.lost.result()}")
