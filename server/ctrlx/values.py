"""Turn data-layer ``{"type": ..., "value": ...}`` bodies into numbers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .problem import BadValue, DataLayerError, problem_for_result
from .timestamps import parse_filetime

SCALAR_TYPES = frozenset(
    {
        "double",
        "float",
        "float64",
        "float32",
        "int8",
        "int16",
        "int32",
        "int64",
        "uint8",
        "uint16",
        "uint32",
        "uint64",
    }
)
ARRAY_TYPES = frozenset({"arfloat64", "arfloat32", "ardouble", "arfloat"})
"""Float arrays under their current names and the names older firmware used."""


def number_from_data(node: str, body: Any) -> float:
    """The numeric value of a node read; raises BadValue with the node named otherwise.

    The object node ``.../state/values/actual`` answers
    ``{"actualPos": ..., "actualPosUnit": ...}``; its position is the value.
    """
    if not isinstance(body, dict) or "value" not in body:
        raise BadValue(f"{node}: answer has no 'value' field")
    kind, value = body.get("type"), body["value"]
    if isinstance(value, dict) and "actualPos" in value:
        value = value["actualPos"]
    elif kind in ARRAY_TYPES:
        raise BadValue(f"{node}: is an array ({kind}), expected a single number")
    elif kind is not None and kind not in SCALAR_TYPES and kind != "object":
        raise BadValue(f"{node}: has type {kind!r}, expected a number")
    return _finite(node, value)


def numbers_from_data(node: str, body: Any) -> list[float]:
    """The values of a float-array node (``arfloat64``, ``arfloat32``; older ``ardouble``...)."""
    if not isinstance(body, dict) or "value" not in body:
        raise BadValue(f"{node}: answer has no 'value' field")
    kind, value = body.get("type"), body["value"]
    if kind not in ARRAY_TYPES or not isinstance(value, list):
        raise BadValue(f"{node}: has type {kind!r}, expected an array of numbers")
    return [_finite(node, v) for v in value]


def unit_from_data(body: Any) -> str | None:
    """The unit an object node states (``actualPosUnit``), if any."""
    value = body.get("value") if isinstance(body, dict) else None
    unit = value.get("actualPosUnit") if isinstance(value, dict) else None
    return unit if isinstance(unit, str) else None


def _finite(node: str, value: Any) -> float:
    # bool is an int subclass in Python, but a bool8 node is no joint value.
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise BadValue(f"{node}: value {value!r} is not a number")
    number = float(value)
    if not math.isfinite(number):
        raise BadValue(f"{node}: value {number} is not finite")
    return number


@dataclass(frozen=True)
class BulkRead:
    """Values of one bulk read, in request order, and when the data layer sampled them."""

    t_source: float | None
    """Unix time from the answer's FILETIME stamps (the newest); None if it had none."""
    values: dict[str, float | Exception]


def bulk_data(nodes: list[str], entries: Any) -> list[Any]:
    """Each node's entry of a bulk answer (a Data-like ``{"type", "value", ...}``), or its error."""
    if not isinstance(entries, list) or len(entries) != len(nodes):
        raise DataLayerError(f"bulk answer is {type(entries).__name__}, not {len(nodes)} items")
    out: list[Any] = []
    for node, entry in zip(nodes, entries, strict=True):
        if not isinstance(entry, dict):
            out.append(DataLayerError(f"{node}: bulk answer item is not an object"))
            continue
        result = str(entry.get("result", "DL_OK"))
        if result != "DL_OK" or entry.get("type") == "error":
            out.append(problem_for_result(node, result, entry.get("value")))
            continue
        out.append(entry)
    return out


def bulk_values(nodes: list[str], entries: Any) -> BulkRead:
    """The values of a bulk read answer; a node that failed holds its error."""
    values: dict[str, float | Exception] = {}
    for node, entry in zip(nodes, bulk_data(nodes, entries), strict=True):
        try:
            values[node] = entry if isinstance(entry, Exception) else number_from_data(node, entry)
        except DataLayerError as exc:
            values[node] = exc
    stamps = [parse_filetime(e.get("timestamp")) for e in entries if isinstance(e, dict)]
    known = [stamp for stamp in stamps if stamp is not None]
    return BulkRead(max(known) if known else None, values)
