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
controller without a motion app has no axes.
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass, field
from typing import Any

from ..ctrlx import DataLayerClient, DataLayerError, NodeNotFound

AXES, KINEMATICS = "motion/axs", "motion/kin"
ACTUAL_POS, SETPOINT_POS = "state/values/actual/pos", "state/values/ipo/pos"


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


@dataclass(frozen=True)
class Controller:
    """Everything ``describe`` found."""

    url: str
    axes: tuple[Axis, ...]
    kinematics: tuple[Kinematics, ...]
    notes: tuple[str, ...] = ()
    """What could not be read, one line each."""


async def describe(client: DataLayerClient) -> Controller:
    """Browse ``client``'s data layer for its motion axes and kinematics.

    Raises DataLayerError only when the controller cannot be used at all
    (unreachable, wrong credentials); a missing node becomes a note.
    """
    notes: list[str] = []
    names = await _browse(client, AXES, notes, "no motion axes (is the motion app installed?)")
    axes = await asyncio.gather(*(_axis(client, name, notes) for name in names))
    kin_names = await _browse(client, KINEMATICS, notes, None)
    kinematics = await asyncio.gather(*(_kinematics(client, name, notes) for name in kin_names))
    found = tuple(a for a in axes if a is not None)
    return Controller(client.base_url, found, tuple(k for k in kinematics if k), tuple(notes))


async def _browse(
    client: DataLayerClient, node: str, notes: list[str], missing: str | None
) -> list[str]:
    try:
        return sorted(await client.browse(node))
    except NodeNotFound:
        if missing:
            notes.append(f"{node}: {missing}")
        return []


async def _axis(client: DataLayerClient, name: str, notes: list[str]) -> Axis | None:
    base = f"{AXES}/{name}"
    node = f"{base}/{ACTUAL_POS}"
    try:
        meta = await client.metadata(node)
        value: float | None = await client.read_number(node)
    except DataLayerError as exc:
        notes.append(f"axis {name}: {node} cannot be read ({exc})")
        return None
    unit = _text(meta.get("unit")) or await _object_text(
        client, f"{base}/state/values/actual", "actualPosUnit"
    )
    setpoint: str | None = f"{base}/{SETPOINT_POS}"
    try:
        await client.metadata(f"{base}/{SETPOINT_POS}")
    except DataLayerError:
        setpoint = None
    properties = await _object(client, f"{base}/cfg/properties")
    limits = await _object(client, f"{base}/cfg/lim")
    kind = _text(properties.get("axsType"))
    return Axis(
        name=name,
        node=node,
        unit=unit,
        kind=kind.upper() if kind else None,
        value=value if value is not None and math.isfinite(value) else None,
        setpoint=setpoint,
        limits=(_number(limits.get("posMin")), _number(limits.get("posMax"))),
    )


async def _kinematics(client: DataLayerClient, name: str, notes: list[str]) -> Kinematics | None:
    config = await _object(client, f"{KINEMATICS}/{name}/cfg")
    entries = [e for e in config.get("axsCfg") or [] if isinstance(e, dict) and e.get("axsName")]
    if not entries:
        notes.append(f"kinematics {name}: {KINEMATICS}/{name}/cfg names no axes")
        return None
    entries.sort(key=_acs_index)
    axes = tuple(str(e["axsName"]) for e in entries)
    sets = (config.get("mcs") or {}).get("axsTrafoSets") or []
    first = sets[0] if sets and isinstance(sets[0], dict) else {}
    params: dict[str, tuple[float, str]] = {}
    for group in (first.get("param") or {}).get("groups") or []:
        for param in group.get("param") or [] if isinstance(group, dict) else []:
            value = _number(param.get("valueDouble")) if isinstance(param, dict) else None
            if value is not None and param.get("name"):
                params[str(param["name"])] = (value, _text(param.get("unit")) or "")
    return Kinematics(name, axes, _text(first.get("jntTrafo")), params)


def _acs_index(entry: dict[str, Any]) -> int:
    index = entry.get("acsIndex")
    return index if isinstance(index, int) else 255  # the motion app's "none"


async def _object(client: DataLayerClient, node: str) -> dict[str, Any]:
    """The value of an object node, or ``{}`` when it cannot be read."""
    try:
        body = await client.read(node)
    except DataLayerError:
        return {}
    value = body.get("value") if isinstance(body, dict) else None
    return value if isinstance(value, dict) else {}


async def _object_text(client: DataLayerClient, node: str, key: str) -> str | None:
    return _text((await _object(client, node)).get(key))


def _text(value: Any) -> str | None:
    return value.strip() if isinstance(value, str) and value.strip() else None


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None
