"""What a data layer's events say: update, keepalive and error events decoded into values."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from urllib.parse import unquote

import orjson

from .bodies import loads
from .problem import DataLayerError, ProblemError, StreamEnded, problem_for_status
from .sse import SseEvent
from .timestamps import FIRST_FILETIME_S, parse_filetime, unix_from_filetime
from .values import SCALAR_TYPES, number_from_data


class InvalidEvent(StreamEnded):
    """One event we cannot use (malformed JSON, an update naming no node); the stream may go on."""


@dataclass(slots=True)  # not frozen: made per event, and frozen init costs 2.5x
class Update:
    """A node's new value (or why it has none) at data-layer time ``t_source`` (unix s)."""

    node: str
    t_source: float | None
    value: float | Exception


@dataclass(slots=True)  # not frozen: made per event, and frozen init costs 2.5x
class Keepalive:
    """The stream is alive; nothing changed up to ``t_source`` (unix s, if stated)."""

    t_source: float | None


def decode_event(event: SseEvent, nodes_prefix: str) -> Update | Keepalive | None:
    """Turn one SSE event into an Update or Keepalive; None for events we do not use.

    An ``error`` event that names no node is a failure of the whole stream and
    is raised; an event we cannot read raises InvalidEvent. NaN and Infinity
    literals are read, so they spoil only the node that carries them.
    """
    if event.event not in ("update", "keepalive", "error"):
        return None
    try:
        data = loads(event.data) if event.data and not event.data.isspace() else {}
    except ValueError:
        raise InvalidEvent(f"{event.event} event with malformed JSON {event.data[:40]!r}") from None
    if not isinstance(data, dict):
        data = {}
    t_source = parse_filetime(data.get("timestamp"))
    if event.event == "keepalive":
        return Keepalive(t_source)
    node = data.get("node")
    if event.event == "error":
        status = data.get("status")
        status = status if isinstance(status, int) and 400 <= status <= 599 else 500
        problem = problem_for_status(status, data, "subscription error")
        node = node if isinstance(node, str) else _node_of_instance(problem, nodes_prefix)
        if node is None:
            raise problem
        return Update(node, t_source, problem)
    if not isinstance(node, str):
        raise InvalidEvent("update event without a node")
    value: float | Exception
    try:
        value = number_from_data(node, data)
    except DataLayerError as exc:
        value = exc
    return Update(node, t_source, value)


@dataclass(slots=True)
class PlainUpdates:
    """Updates of plain numbers in arrival order, as three columns: one object for a chunk.

    What ``decode_event`` makes of each event, without an object per event.
    """

    nodes: list[str]
    t_sources: list[float | None]
    values: list[float]


def plain_updates(datas: Sequence[str]) -> PlainUpdates | None:
    """The ``data`` of ``update`` events decoded as ``decode_event`` would, if all are updates
    of plain numbers; else None.

    The usual publish cycle (an update per node: a float value, a FILETIME
    stamp, a scalar type) is read without the general path's layers of calls
    and objects: in a process following 100 controllers decoding took half of
    reading a stream. Anything else (NaN, integer or object values, stamps as
    strings, malformed JSON) returns None and is decoded event by event.
    tests/ctrlx/test_ctrlx_units.py checks that both agree.
    """
    nodes, t_sources, values = [], [], []
    for data in datas:
        try:
            body = orjson.loads(data)
        except orjson.JSONDecodeError:
            return None
        if type(body) is not dict:
            return None
        node, value, stamp = body.get("node"), body.get("value"), body.get("timestamp")
        if (
            type(node) is not str
            or type(value) is not float
            or type(stamp) is not int
            or body.get("type") not in SCALAR_TYPES
            or not math.isfinite(value)
        ):
            return None
        nodes.append(node)
        values.append(value)
        t_source = unix_from_filetime(stamp)
        t_sources.append(t_source if t_source >= FIRST_FILETIME_S else None)
    return PlainUpdates(nodes, t_sources, values)


def _node_of_instance(problem: ProblemError, nodes_prefix: str) -> str | None:
    """The node an error names in ``instance`` (``/automation/api/v2/nodes/<path>``)."""
    if problem.instance and problem.instance.startswith(nodes_prefix):
        return unquote(problem.instance[len(nodes_prefix) :])
    return None


Items = Callable[[Sequence[Update | Keepalive | PlainUpdates], bool], None]
"""Takes the usable events of a chunk, and whether the chunk ended inside an event."""
