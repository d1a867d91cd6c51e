"""What a controller says about its motion: axes with units and values, kinematics with axes.

Only what the REST data layer offers every client: browse requests and node
metadata (``?type=browse``, ``?type=metadata``) and reads. The motion app's
nodes (see ``server.mock_ctrlx._motion_nodes`` for the mock's copy):

* ``motion/axs`` lists the axes; each has ``state/values/actual/pos`` (its
  unit in the node's metadata), usually ``state/values/ipo/pos`` (the
  setpoint), ``cfg/properties`` (``axsType``) and ``cfg/lim`` (``posMin``,
  ``posMax``);
* ``motion/kin`` lists the kinematics; ``motion/kin/<kin>/cfg`` holds its axes
  (``axsCfg``: ``axsName``, ``acsIndex``) and joint transformations
  (``mcs.axsTrafoSets``: ``jntTrafo`` and parameters with units).

Whatever cannot be read is noted in ``Controller.notes`` and left out; a
controller without a motion app has no axes. Names the controller lists are
requested only if each is one plain node segment (``server.ctrlx.name_problem``):
an axis named ``../../x`` would otherwise send our token to another path.
Requests go a few at a time, in bulk where the data layer has it (``ask``).
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from ..ctrlx import DataLayerClient, DataLayerError, NodeNotFound, name_problem
from ..ctrlx.values import number_from_data
from .ask import CHUNK, CONCURRENCY, Asker, in_turn

AXES, KINEMATICS = "motion/axs", "motion/kin"
ACTUAL_POS, SETPOINT_POS = "state/values/actual/pos", "state/values/ipo/pos"
AXIS_OBJECTS = ("cfg/properties", "cfg/lim")
"""Object nodes read for every axis: ``axsType``, and the limits."""
ACTUAL_OBJECT = "state/values/actual"
"""Read where the position's metadata gives no unit: its ``actualPosUnit``."""


@dataclass(frozen=True)
class Axis:
    """One motion axis: where its position is read, in which unit, and where it is now."""

    name: str
    node: str
    unit: str | None
    """As the node's metadata (or ``actualPosUnit``) says; None: it does not say."""
    kind: str | None
    """``ROTATIONAL`` or ``LINEAR`` (``cfg/properties/axsType``); None: unknown."""
    value: float | None
    """The actual position when browsed, in ``unit``."""
    setpoint: str | None
    """The setpoint node, where the axis has one."""
    limits: tuple[float | None, float | None] = (None, None)
    """``posMin``, ``posMax`` in ``unit``; None where the axis has none."""


@dataclass(frozen=True)
class Kinematics:
    """A kinematics of the motion app: its axes in ACS order and its joint transformation."""

    name: str
    axes: tuple[str, ...]
    trafo: str | None = None
    params: dict[str, tuple[float, str]] = field(default_factory=dict)
    """Transformation parameter -> (value, unit)."""


Found = TypeVar("Found", "Axis", "Kinematics")


@dataclass(frozen=True)
class Controller:
    """Everything ``describe`` found."""

    url: str
    axes: tuple[Axis, ...]
    kinematics: tuple[Kinematics, ...]
    notes: tuple[str, ...] = ()
    """What could not be read, one line each."""


async def describe(client: DataLayerClient, concurrency: int = CONCURRENCY) -> Controller:
    """Browse ``client``'s data layer for its motion axes and kinematics.

    At most ``concurrency`` requests are in flight (``ask``). Raises
    DataLayerError only when the controller cannot be used at all
    (unreachable, wrong credentials); whatever else cannot be read, or is
    refused (a name that is not one plain node segment), becomes a note.
    """
    ask = Asker(client, concurrency)
    notes: list[str] = []
    names = await _names(ask, AXES, "axis", notes, "no motion axes (is the motion app installed?)")
    axes = await _in_chunks(names, lambda part: _axes(ask, part), notes, concurrency)
    kin_names = await _names(ask, KINEMATICS, "kinematics", notes, None)
    kinematics = await _in_chunks(
        kin_names, lambda part: _kinematics(ask, part), notes, concurrency
    )
    return Controller(client.base_url, tuple(axes), tuple(kinematics), tuple(notes))


async def _in_chunks(
    names: list[str],
    read: Callable[[list[str]], Awaitable[tuple[list[Found], list[str]]]],
    notes: list[str],
    concurrency: int,
) -> list[Found]:
    """``read`` each chunk of ``names``, a few at a time; results and notes in name order."""
    chunks = [names[i : i + CHUNK] for i in range(0, len(names), CHUNK)]
    results: dict[int, tuple[list[Found], list[str]]] = {}

    async def one(index: int) -> None:
        results[index] = await read(chunks[index])

    await in_turn(range(len(chunks)), one, concurrency)
    found: list[Found] = []
    for index in range(len(chunks)):
        found += results[index][0]
        notes += results[index][1]
    return found


async def _names(
    ask: Asker, node: str, what: str, notes: list[str], missing: str | None
) -> list[str]:
    """The children of ``node`` that are plain node names; the others are noted, not asked for."""
    try:
        listed = await ask.call(lambda: ask.client.browse(node))
    except NodeNotFound:
        if missing:
            notes.append(f"{node}: {missing}")
        return []
    names = []
    for name in sorted(set(listed)):
        problem = name_problem(name)
        if problem is None:
            names.append(name)
        else:
            notes.append(f"{what} {name!r} left out: {problem}")
    return names


async def _axes(ask: Asker, names: list[str]) -> tuple[list[Axis], list[str]]:
    """The axes ``names`` (a chunk), read in a few bulk requests; and what could not be read."""
    base = {name: f"{AXES}/{name}" for name in names}
    actual = {name: f"{b}/{ACTUAL_POS}" for name, b in base.items()}
    setpoint = {name: f"{b}/{SETPOINT_POS}" for name, b in base.items()}
    meta = await ask.many("metadata", [*actual.values(), *setpoint.values()])
    known = [name for name in names if not isinstance(meta[actual[name]], Exception)]
    extra = [f"{base[name]}/{part}" for name in known for part in AXIS_OBJECTS]
    data = await ask.many("read", [*(actual[name] for name in known), *extra])
    # The unit from the position's metadata, else from its object node (a second, rarer read).
    unitless = [name for name in known if not _text(_value(meta[actual[name]]).get("unit"))]
    data |= await ask.many("read", [f"{base[name]}/{ACTUAL_OBJECT}" for name in unitless])
    axes, notes = [], []
    for name in names:
        node = actual[name]
        try:
            value = number_from_data(node, _answer(data.get(node), meta[node]))
        except DataLayerError as exc:
            notes.append(f"axis {name}: {node} cannot be read ({exc})")
            continue
        unit = _text(_value(meta[node]).get("unit")) or _text(
            _value(data.get(f"{base[name]}/{ACTUAL_OBJECT}")).get("actualPosUnit")
        )
        properties, limits = (_value(data[f"{base[name]}/{part}"]) for part in AXIS_OBJECTS)
        kind = _text(properties.get("axsType"))
        has_setpoint = not isinstance(meta[setpoint[name]], Exception)
        axes.append(
            Axis(
                name=name,
                node=node,
                unit=unit,
                kind=kind.upper() if kind else None,
                value=value,
                setpoint=setpoint[name] if has_setpoint else None,
                limits=(_number(limits.get("posMin")), _number(limits.get("posMax"))),
            )
        )
    return axes, notes


async def _kinematics(ask: Asker, names: list[str]) -> tuple[list[Kinematics], list[str]]:
    """The kinematics ``names`` (a chunk) with their axes and joint transformation."""
    nodes = {name: f"{KINEMATICS}/{name}/cfg" for name in names}
    data = await ask.many("read", list(nodes.values()))
    found, notes = [], []
    for name, node in nodes.items():
        config = _value(data[node])
        entries = [e for e in _list(config.get("axsCfg")) if _text(_dict(e).get("axsName"))]
        if not entries:
            why = f"({data[node]})" if isinstance(data[node], Exception) else "names no axes"
            notes.append(f"kinematics {name}: {node} {why}")
            continue
        entries.sort(key=_acs_index)
        axes = tuple(str(e["axsName"]).strip() for e in entries)
        sets = _list(_dict(config.get("mcs")).get("axsTrafoSets"))
        first = _dict(sets[0]) if sets else {}
        params: dict[str, tuple[float, str]] = {}
        for group in _list(_dict(first.get("param")).get("groups")):
            for param in map(_dict, _list(_dict(group).get("param"))):
                value, key = _number(param.get("valueDouble")), _text(param.get("name"))
                if value is not None and key:
                    params[key] = (value, _text(param.get("unit")) or "")
        found.append(Kinematics(name, axes, _text(first.get("jntTrafo")), params))
    return found, notes


def _answer(data: Any, meta: Any) -> Any:
    """A node's read answer, or raise the error that kept it (its read's or its metadata's)."""
    for answer in (meta, data):
        if isinstance(answer, Exception):
            raise answer if isinstance(answer, DataLayerError) else DataLayerError(str(answer))
    return data


def _acs_index(entry: dict[str, Any]) -> int:
    index = entry.get("acsIndex")
    return index if isinstance(index, int) and not isinstance(index, bool) else 255  # "none"


def _value(body: Any) -> dict[str, Any]:
    """The object value of a Data body, ``{}`` for anything else (an error, another type)."""
    return _dict(_dict(body).get("value"))


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _list(value: Any) -> list[Any]:
    return value if isinstance(value, list) else []


def _text(value: Any) -> str | None:
    return value.strip() if isinstance(value, str) and value.strip() else None


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None
