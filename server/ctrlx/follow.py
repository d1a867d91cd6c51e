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

This module chooses the way and falls back; each way lives in a module of
its own (``subscribed``, ``polled``), the policies beside them
(``interruptions``: reconnecting; ``refusal``: asking a refused path again).
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import AsyncGenerator, Callable, Coroutine
from typing import Literal

from .client import DataLayerClient
from .interruptions import DEFAULT_RETRY, Interruptions, RetryPolicy, samples_again
from .polled import poll
from .problem import DataLayerError, Unsupported
from .refusal import Refusal
from .sample import Sample
from .subscribed import subscribe

Mode = Literal["subscribe", "poll", "get"]
MODES: tuple[Mode, ...] = ("subscribe", "poll", "get")

REPROBE_S = 60.0
"""How often a refused better data path (subscriptions, bulk reads) is tried again."""


def follow(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    mode: Mode = "subscribe",
    *,
    keepalive_s: float = 1.0,
    retry: RetryPolicy = DEFAULT_RETRY,
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
    retry: RetryPolicy = DEFAULT_RETRY,
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
    interruptions = Interruptions(retry)
    # A firmware without the service (paths None) is no refusal: nothing to note or re-probe.
    events = None
    if mode == "subscribe" and client.paths.events is not None:
        events = Refusal(client, "subscriptions", "polling instead", reprobe_s)
    bulk = None
    if mode != "get" and client.paths.bulk is not None:
        bulk = Refusal(client, "bulk reads", "one GET per node instead", reprobe_s)

    def streamed(sample: Sample) -> None:
        if events is not None:
            events.worked()
        samples_again(client)
        deliver(sample)

    try:
        while True:
            if events is not None and events.due():
                events.retry()
                try:
                    await subscribe(client, nodes, period_s, keepalive_s, interruptions, streamed)
                except Unsupported as exc:
                    events.refused(exc)
            async for sample in poll(client, nodes, period_s, bulk, events, interruptions):
                samples_again(client)
                deliver(sample)
    except DataLayerError as exc:
        client.failed_starts += 1
        raise client.redact.error(exc) from None
