"""An output recipe as the controller accepted it: one precompiled struct for its data packages."""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from .wire import NOT_FOUND, TYPE_FORMATS, TYPE_WIDTH, Key, WireError

RECIPE_FIELDS = (
    "timestamp",
    "actual_q",
    "target_q",
    "actual_TCP_pose",
    "robot_mode",
    "safety_mode",
)
"""Every linkview recipe starts with these (the guide's usual state of an arm)."""


def recipe_fields(keys: Iterable[Key]) -> list[str]:
    """The recipe for ``keys``: ``RECIPE_FIELDS`` and then each other field once, in order."""
    fields = list(RECIPE_FIELDS)
    for key in keys:
        if key.field not in fields:
            fields.append(key.field)
    return fields


@dataclass
class Recipe:
    """Fields and their types as the setup reply gave them; unpacks a data package at once.

    One ``struct.Struct`` for the whole package: unpacking costs one C call,
    whatever the number of fields (measured in bench/sources.py).
    """

    recipe_id: int
    fields: tuple[str, ...]
    types: tuple[str, ...]
    layout: struct.Struct = field(init=False)
    offsets: dict[str, int] = field(init=False)
    """Each field's first position among the unpacked values (after the recipe id)."""

    def __post_init__(self) -> None:
        if len(self.fields) != len(self.types):
            raise WireError(f"{len(self.fields)} fields set up, {len(self.types)} types answered")
        fmt, at = ">B", 1
        self.offsets = {}
        for name, kind in zip(self.fields, self.types, strict=True):
            if kind not in TYPE_FORMATS:
                raise WireError(f"{name}: type {kind!r} is not one of the RTDE guide's")
            self.offsets[name] = at
            fmt += TYPE_FORMATS[kind]
            at += TYPE_WIDTH.get(kind, 1)
        self.layout = struct.Struct(fmt)

    def position(self, key: Key) -> int:
        """Where ``key``'s value is among the unpacked values; KeyError if not in the recipe."""
        return self.offsets[key.field] + (key.index or 0)

    def unpack(self, payload: bytes) -> tuple[float, ...]:
        """All values of a data package, recipe id first; WireError if it is not this recipe's."""
        if len(payload) != self.layout.size or payload[0] != self.recipe_id:
            raise WireError(
                f"data package of {len(payload)} bytes for recipe {payload[:1].hex() or '-'}: "
                f"expected {self.layout.size} bytes for recipe {self.recipe_id}"
            )
        return self.layout.unpack(payload)


def answered(fields: Sequence[str], reply: bytes) -> tuple[int, list[str]]:
    """The recipe id and one type per field from a setup reply; WireError if they disagree."""
    if not reply:
        raise WireError("empty reply to the output setup")
    types = reply[1:].decode(errors="replace").split(",")
    if len(types) != len(fields):
        raise WireError(f"{len(fields)} fields set up, {len(types)} types answered: {types}")
    return reply[0], types


def not_found(fields: Sequence[str], types: Sequence[str]) -> list[str]:
    """The fields the controller answered NOT_FOUND (it has no such output)."""
    return [f for f, t in zip(fields, types, strict=True) if t == NOT_FOUND]
