"""Turn data-layer ``{"type": ..., "value": ...}`` bodies into numbers."""

from __future__ import annotations

import math
from typing import Any

from .problem import BadValue

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
