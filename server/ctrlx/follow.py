"""Following a set of nodes over time: a stream of samples, however they are fetched.

Three ways, chosen by ``mode``:

* ``subscribe``: one data-layer subscription, its events streamed (SSE). Falls
  back to ``poll`` when the server offers no subscriptions.
* ``poll``: one bulk read of every node per period. Falls back to ``get`` when
  the server has no bulk service (older firmware).
* ``get``: one GET per node per period, as simple relays do.

Short interruptions of a source that was working (a stream that closes, a
token that expires, a request that fails) are ridden out by reconnecting with
exponential backoff and jitter; what lasts longer, or a source that never
worked, is raised as DataLayerError for the caller to report and retry.

A fallback is no verdict: a 404 may come from a device that is still starting
up, so the refused path is tried again every ``reprobe_s`` (60 s), and the
fallback meanwhile shows as a standing caveat in ``client.warning``.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import random
import time
from collections.abc import AsyncGenerator, AsyncIterator, Callable, Coroutine, Sequence
from dataclasses import dataclass
from typing import Literal

from ..lateness import Mark, lateness
from ..text import plural
from .client import DataLayerClient
from .events import (
    EventStream,
    Items,
    Keepalive,
    PlainUpdates,
    Subscription,
    SubscriptionSettings,
    Update,
)
from .pacing import Pacer
from .problem import AuthError, DataLayerError, ProblemError, StreamEnded, Unsupported

log = logging.getLogger(__name__)

Mode = Literal["subscribe", "poll", "get"]
MODES: tuple[Mode, ...] = ("subscribe", "poll", "get")


@dataclass(slots=True)  # not frozen: made per sample; a frozen init costs 1.5 µs more
class Sample:
    """Values of the followed nodes at one instant, in data-layer units.

    A node that could not be read holds the exception saying why, so one bad
    node spoils only the robot that uses it.
    """

    t_source: float
    """Unix time (s) the data layer sampled the values."""
    values: dict[str, float | Exception]
    received: int = 1
    """The device's samples this one stands for: a reader that falls behind keeps the newest
    values of several (latest wins) rather than queueing them."""


REPROBE_S = 60.0
"""How often a refused better data path (subscriptions, bulk reads) is tried again."""


@dataclass(frozen=True)
class RetryPolicy:
    """How to ride out interruptions: delays grow from ``first_s`` to ``max_s``, with jitter."""

    first_s: float = 0.05
    max_s: float = 1.0
    """Short, so a device that behaves again is streaming within 2 s."""
    give_up_s: float = 3.0
    """Raise to the caller (who shows the error) once a working source has failed this long."""

    def delay(self, attempt: int) -> float:
        """Seconds before reconnect ``attempt`` (0: at once, since most drops are one-offs)."""
        if attempt == 0:
            return 0.0
        # Jitter spreads the reconnects of many clients after a controller restart.
        return min(self.max_s, self.first_s * 2.0 ** (attempt - 1)) * random.uniform(0.5, 1.0)


def follow(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    mode: Mode = "subscribe",
    *,
    keepalive_s: float = 1.0,
    retry: RetryPolicy = RetryPolicy(),
    reprobe_s: float | None = None,
) -> AsyncGenerator[Sample, None]:
    """The samples of ``nodes``, about every ``period_s`` seconds, until cancelled.

    ``follow_into``'s samples, for code that iterates: a consumer that falls
    behind gets the newest values (``received`` counts the samples they
    stand for). Raises DataLayerError when the source is unusable.
    """
    _check_mode(mode)
    nodes = list(nodes)
    return _iterate(
        lambda deliver: follow_into(
            client,
            nodes,
            period_s,
            deliver,
            mode,
            keepalive_s=keepalive_s,
            retry=retry,
            reprobe_s=reprobe_s,
        )
    )


async def follow_into(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    deliver: Callable[[Sample], None],
    mode: Mode = "subscribe",
    *,
    keepalive_s: float = 1.0,
    retry: RetryPolicy = RetryPolicy(),
    reprobe_s: float | None = None,
) -> None:
    """Call ``deliver`` with the samples of ``nodes``, about every ``period_s`` s, until cancelled.

    From a subscription, ``deliver`` is called as the bytes arrive, by the
    event loop's reading of the socket, not by a task: a sample then costs
    no task wake-up (see stream_wire). ``keepalive_s`` is the subscription's
    keepalive interval; a stream silent for 2.5 times as long counts as dead.
    A refused subscription or bulk service is tried again every ``reprobe_s``
    (default REPROBE_S). Raises DataLayerError when the source is unusable
    (see the module docstring), and whatever ``deliver`` raises.
    """
    _check_mode(mode)
    reprobe = REPROBE_S if reprobe_s is None else reprobe_s
    await _follow(client, list(nodes), period_s, mode, keepalive_s, retry, reprobe, deliver)


def _check_mode(mode: str) -> None:
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, not {mode!r}")


async def _iterate(
    start: Callable[[Callable[[Sample], None]], Coroutine[None, None, None]],
) -> AsyncGenerator[Sample, None]:
    """The samples ``start(deliver)`` delivers, the newest if several came since the last."""
    newest: list[Sample] = []
    arrived = asyncio.Event()

    def keep(sample: Sample) -> None:
        if newest:  # not taken yet: the newest values win, standing for both
            received = newest[0].received + sample.received
            newest[0] = dataclasses.replace(sample, received=received)
        else:
            newest.append(sample)
        arrived.set()

    following = asyncio.ensure_future(start(keep))
    try:
        while True:
            if not newest:
                waiting = asyncio.ensure_future(arrived.wait())
                try:
                    await asyncio.wait((waiting, following), return_when=asyncio.FIRST_COMPLETED)
                finally:
                    waiting.cancel()
                if not newest:
                    following.result()  # it ended: raises why
                    raise AssertionError("follow_into returned")
            arrived.clear()
            yield newest.pop()
    finally:
        following.cancel()
        await asyncio.gather(following, return_exceptions=True)


def _samples_again(client: DataLayerClient) -> None:
    """A sample came: say so once if starts had failed before.

    A device that is down is tried again and again (by whoever restarts
    ``follow``); each attempt's own lines then go to DEBUG (``_news``), the
    failed starts are counted on the client, and the first sample says how
    many attempts it took.
    """
    if client.failed_starts:
        failed = plural(client.failed_starts, "failed attempt")
        log.info("%s: samples again, after %s", client.base_url, failed)
        client.failed_starts = 0


def _news(client: DataLayerClient) -> int:
    """INFO for a start after samples came, DEBUG while attempts keep failing."""
    return logging.DEBUG if client.failed_starts else logging.INFO


async def _follow(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    mode: Mode,
    keepalive_s: float,
    retry: RetryPolicy,
    reprobe_s: float,
    deliver: Callable[[Sample], None],
) -> None:
    interruptions = _Interruptions(retry)
    # A firmware without the service (paths None) is no refusal: nothing to note or re-probe.
    events = None
    if mode == "subscribe" and client.paths.events is not None:
        events = _Refusal(client, "subscriptions", "polling instead", reprobe_s)
    bulk = None
    if mode != "get" and client.paths.bulk is not None:
        bulk = _Refusal(client, "bulk reads", "one GET per node instead", reprobe_s)

    def streamed(sample: Sample) -> None:
        if events is not None:
            events.worked()
        _samples_again(client)
        deliver(sample)

    try:
        while True:
            if events is not None and events.due():
                events.retry()
                try:
                    await _subscribe(client, nodes, period_s, keepalive_s, interruptions, streamed)
                except Unsupported as exc:
                    events.refused(exc)
            async for sample in _poll(client, nodes, period_s, bulk, events, interruptions):
                _samples_again(client)
                deliver(sample)
    except DataLayerError as exc:
        client.failed_starts += 1
        raise client.redact.error(exc) from None


class _Refusal:
    """A better data path the device refused: when, the caveat it leaves, when to ask again.

    The time of the refusal lives on the client, so the acquisition restarting
    ``follow()`` after an error neither delays the next attempt nor repeats
    the warning.
    """

    def __init__(self, client: DataLayerClient, what: str, instead: str, reprobe_s: float) -> None:
        self._client = client
        self._what = what
        self._instead = instead
        self._reprobe_s = reprobe_s

    @property
    def _at(self) -> float | None:
        return self._client.capabilities.refused_at.get(self._what)

    def due(self) -> bool:
        """True when the path may be used: never refused, or time to try it again."""
        at = self._at
        return at is None or time.monotonic() - at >= self._reprobe_s

    def retry(self) -> None:
        """Forget the client's verdict so the next request asks the device again."""
        if self._at is not None:
            log.debug("%s: trying %s again", self._client.base_url, self._what)
            if self._what == "subscriptions":
                self._client.capabilities.subscribe = None
            else:
                self._client.capabilities.bulk = None

    def refused(self, exc: DataLayerError) -> None:
        """The device refused the path (again)."""
        first = self._at is None
        self._client.capabilities.refused_at[self._what] = time.monotonic()
        text = f"{self._what} refused ({exc}); {self._instead}, asking again every "
        text += f"{self._reprobe_s:g} s"
        self._client.note(self._what, text)
        log.log(logging.WARNING if first else logging.DEBUG, "%s: %s", self._client.base_url, text)

    def worked(self) -> None:
        """The path works (again)."""
        if self._client.capabilities.refused_at.pop(self._what, None) is not None:
            self._client.note(self._what, None)
            log.info("%s: %s work again", self._client.base_url, self._what)


class _Interruptions:
    """Decides, after a failure, whether to wait and reconnect or to give up."""

    def __init__(self, policy: RetryPolicy) -> None:
        self._policy = policy
        self._worked = False
        self._attempt = 0
        self._since: Mark | None = None
        """When this streak of failures began (its length counts our on-time loop only)."""

    def succeeded(self) -> None:
        self._worked, self._attempt, self._since = True, 0, None

    async def failed(self, exc: DataLayerError) -> None:
        """Sleep before the next attempt, or raise ``exc`` if it is no passing interruption."""
        self._since = lateness().mark() if self._since is None else self._since
        too_long = self._since.on_time_s() > self._policy.give_up_s
        if not (self._worked and _transient(exc)) or too_long:
            raise exc
        delay = self._policy.delay(self._attempt)
        level = logging.INFO if self._attempt == 0 else logging.DEBUG  # news once per streak
        self._attempt += 1
        log.log(level, "data layer interrupted (%s); retrying in %.2f s", exc, delay)
        await asyncio.sleep(delay)


def _transient(exc: DataLayerError) -> bool:
    """True for failures that may pass by themselves (network, timeouts, 5xx, closed streams)."""
    if isinstance(exc, AuthError | Unsupported):
        return False
    if isinstance(exc, ProblemError):
        return exc.status >= 500 or exc.status in (408, 429)
    return True


class _Latest:
    """The newest value of every node, gathered from events, handed out as Samples."""

    def __init__(self, nodes: list[str], grace_s: float) -> None:
        self._values: dict[str, float | Exception] = {}
        self._nodes = nodes
        self._wanted = frozenset(nodes)
        self._grace_s = grace_s
        self._opened = time.monotonic()
        self._t: float | None = None
        self._changed = False
        self._cycles = 0
        """Publish cycles (distinct timestamps) gathered since the last sample."""

    def add(self, item: Update | Keepalive | PlainUpdates) -> None:
        if isinstance(item, PlainUpdates):
            self._gather(item.nodes, item.t_sources, item.values)
        elif isinstance(item, Update):
            self._gather((item.node,), (item.t_source,), (item.value,))
        else:  # a keepalive says "nothing changed until t": a fresh sample of the same values
            self._gather((), (item.t_source,), ())

    def _gather(
        self,
        nodes: Sequence[str],
        t_sources: Sequence[float | None],
        values: Sequence[float | Exception],
    ) -> None:
        """Updates in arrival order (no nodes: a keepalive's time alone)."""
        wanted, t, cycles = self._wanted, self._t, self._cycles
        for k, t_source in enumerate(t_sources):
            if nodes:
                if nodes[k] not in wanted:
                    continue
                self._values[nodes[k]] = values[k]
            if t_source is not None:
                # The events of one publish cycle share its timestamp: a new one is a new cycle.
                cycles += t_source != t
                t = t_source if t is None or t_source > t else t
            self._changed = True
        self._t, self._cycles = t, cycles

    def take(self) -> Sample | None:
        """A sample if anything changed and every node was heard from (or waiting is over)."""
        if not self._changed:
            return None
        complete = len(self._values) == len(self._nodes)
        if not complete and time.monotonic() - self._opened < self._grace_s:
            return None  # the initial events of some nodes are still on their way
        self._changed, received, self._cycles = False, max(self._cycles, 1), 0
        if complete:
            values = {n: self._values[n] for n in self._nodes}
        else:
            missing = DataLayerError("the subscription sent no value for this node")
            values = {n: self._values.get(n, missing) for n in self._nodes}
        t_source = self._t if self._t is not None else time.time()
        return _checked(Sample(t_source, values, received))


async def _subscribe(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    keepalive_s: float,
    interruptions: _Interruptions,
    deliver: Callable[[Sample], None],
) -> None:
    """Streams samples to ``deliver`` until the source fails for good (or is refused)."""
    settings = SubscriptionSettings(
        publish_interval_ms=max(1, round(period_s * 1000)),
        keepalive_interval_ms=max(1, round(keepalive_s * 1000)),
        error_interval_ms=max(1, round(keepalive_s * 1000)),
    )
    subscription = Subscription(client, nodes, settings)
    latest = _Latest(nodes, grace_s=keepalive_s)
    unusable: list[DataLayerError] = []
    """Why every node failed, if they did: then the source as a whole is unusable, which is
    no passing interruption of its stream."""

    def on_items(items: Sequence[Update | Keepalive | PlainUpdates], mid_event: bool) -> None:
        for item in items:
            latest.add(item)
        if mid_event:
            return  # the rest of this publish cycle is in the next chunk
        try:
            sample = latest.take()
        except DataLayerError as exc:
            unusable[:] = [exc]
            raise
        if sample is not None:
            unusable.clear()
            interruptions.succeeded()
            deliver(sample)

    stream: EventStream | None = None
    log.log(
        _news(client),
        "%s: subscribing to %d nodes (publish every %d ms)",
        client.base_url,
        len(nodes),
        settings.publish_interval_ms,
    )
    try:
        while True:
            try:
                if stream is None:
                    stream = await subscription.open(on_items)
                # Planned on our monotonic clock from the token's lifetime, never its exp.
                wait = client.tokens.seconds_to_renewal()
                if wait is not None and wait <= 0.0:
                    stream = await _hand_over(client, subscription, stream, on_items)
                    continue
                done, _ = await asyncio.wait((stream.ended,), timeout=wait)
                if not done:
                    continue  # time to renew the token
                raise stream.ended.result()
            except Unsupported:
                raise
            except DataLayerError as exc:
                if stream is not None:
                    stream.close()
                stream = None
                if unusable and exc is unusable[0]:
                    raise exc from None
                await interruptions.failed(exc)
    finally:
        if stream is not None:
            stream.close()
        await subscription.delete()


async def _hand_over(
    client: DataLayerClient,
    subscription: Subscription,
    old: EventStream,
    on_items: Items,
) -> EventStream:
    """Make before break: open a stream with a fresh token, then drop the old one.

    A server may end a stream when the token it was opened with expires, so
    the new stream must be running by then or viewers would see a gap.
    """
    await client.tokens.current()
    try:
        fresh = await subscription.open(on_items)
    finally:
        old.close()
    if old.ended.done():  # it ended while the new one opened: a broken stream is no news,
        why = old.ended.result()  # but a failure of the source or a bug is
        if not isinstance(why, StreamEnded):
            fresh.close()
            raise why
    return fresh


async def _poll(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    bulk: _Refusal | None,
    events: _Refusal | None,
    interruptions: _Interruptions,
) -> AsyncIterator[Sample]:
    """Polls until the refused subscriptions are due to be tried again (if ever)."""
    use_bulk = bulk is not None and bulk.due()
    how = "bulk reads" if use_bulk else "one GET per node"
    log.log(
        _news(client),
        "%s: polling %d nodes every %g s (%s)",
        client.base_url,
        len(nodes),
        period_s,
        how,
    )
    pacer, skipped = Pacer(period_s), 0
    while events is None or not events.due():
        if bulk is not None and not use_bulk and bulk.due():
            bulk.retry()
            use_bulk = True
        try:
            sample = await (_read_bulk(client, nodes) if use_bulk else read_all(client, nodes))
        except Unsupported as exc:
            if bulk is None or not use_bulk:
                raise
            bulk.refused(exc)
            use_bulk = False
            continue
        except DataLayerError as exc:
            await interruptions.failed(exc)
            continue
        if use_bulk and bulk is not None:
            bulk.worked()
        interruptions.succeeded()
        # A tick skipped because we were late is a sample the device had and we did not take.
        yield dataclasses.replace(sample, received=1 + pacer.skipped - skipped)
        skipped = pacer.skipped
        await pacer.wait()


async def _read_bulk(client: DataLayerClient, nodes: list[str]) -> Sample:
    wall, mono = time.time(), time.monotonic()
    read = await client.bulk_read(nodes)
    t_source = read.t_source if read.t_source is not None else _midpoint(wall, mono)
    return _checked(Sample(t_source, read.values))


async def read_all(client: DataLayerClient, nodes: list[str]) -> Sample:
    """One concurrent GET per node; raises when all of them fail (the source is unusable).

    A plain GET carries no timestamp, so the sample time is the middle of the
    round trip.
    """
    wall, mono = time.time(), time.monotonic()
    results = await asyncio.gather(*(client.read_number(n) for n in nodes), return_exceptions=True)
    values: dict[str, float | Exception] = {}
    for node, result in zip(nodes, results, strict=True):
        if isinstance(result, BaseException) and not isinstance(result, Exception):
            raise result
        values[node] = result
    return _checked(Sample(_midpoint(wall, mono), values))


def _checked(sample: Sample) -> Sample:
    """``sample``, unless every node failed: then the source as a whole is unusable."""
    failures = [v for v in sample.values.values() if isinstance(v, Exception)]
    if failures and len(failures) == len(sample.values):
        first = failures[0]
        raise first if isinstance(first, DataLayerError) else DataLayerError(str(first))
    return sample


def _midpoint(wall: float, mono: float) -> float:
    return wall + (time.monotonic() - mono) / 2.0
