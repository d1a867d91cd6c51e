"""The starter cell for what ``browse`` found on an OPC UA server, written with tomlkit.

One ``opcua`` source, one robot per MotionDevice (or, under a folder, per object
holding numeric variables), every axis a joint mapped to its ActualPosition's
NodeId (namespace by URI). A joint whose node declares a unit linkview converts
has no ``unit`` key: its EngineeringUnits are read at each connection. What only
a person can choose is marked ``TODO``: where each robot stands, and its
kinematics. The Robotics specification describes none; a MotionDevice whose
maker and model linkview knows gets that table (the KUKA LBR iiwa 7 R800, the
IndraMotion MLC kinematic Type 12), any other a placeholder chain of its axes
that runs as written, drawn as ball and stick, until its URDF is given.

Server text (names, makers, units) only ever becomes a TOML string (quoted and
escaped by tomlkit) or a comment passed through ``one_line``: a hostile server
cannot add a key. The text is parsed again and refused unless it reads back as
built.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import tomlkit
from tomlkit.items import Array, Comment, Table

from ...mock_ctrlx.machine import IIWA_TRAFO, TYPE12_TRAFO
from ...text import plural, printable
from ..starter import _NAME, CHAIN_STEP_MM, SPACING_MM, _unique
from .browse import Axis, Device, Found

MAX_CHAIN = 6
"""Axes an ``axis_group`` placeholder holds (MotionPlus' limit); more: a URDF to give."""


@dataclass(frozen=True)
class SourceSpec:
    """The ``[[source]]`` of the starter cell."""

    name: str
    url: str
    security: str = "None"
    server_certificate: str | None = None
    user: str | None = None
    password_env: str | None = None


def one_line(text: str) -> str:
    """``text`` as a comment may hold it: one line, control characters escaped."""
    return printable(text).strip()


def _comment(text: str) -> Comment:
    return tomlkit.comment(one_line(text))


def starter_cell(found: Found, source: SourceSpec, command: str) -> str:
    """The TOML text of the starter cell."""
    doc = tomlkit.document()
    for line in (
        f"A starter cell written by `{command}`.",
        "Check it with `python -m server check FILE`, serve it with",
        "`python -m server --cell FILE`; docs/cell.md describes every key.",
        "Lines marked TODO need a choice only a person can make.",
        *(f"Not read: {note}" for note in found.notes),
    ):
        doc.add(_comment(line))
    doc.add(tomlkit.nl())
    sources = tomlkit.aot()
    sources.append(_source(source))
    doc.append("source", sources)
    robots = tomlkit.aot()
    names: set[str] = set()
    for system, devices in found.systems.items():
        for device in devices:
            if not device.axes:
                doc.add(_comment(f"{system}/{device.name}: no axes with a position; left out."))
                continue
            robots.append(_robot(system, device, _unique(device.name, names), source, len(names)))
    if robots:
        doc.add(tomlkit.nl())
        doc.append("robot", robots)
    else:
        doc.add(_comment("TODO: no motion devices were found: add [[robot]] tables by hand."))
    text: str = tomlkit.dumps(doc)
    if tomllib.loads(text) != doc.unwrap():
        raise ValueError("the cell written does not read back as built")
    return text


def _source(spec: SourceSpec) -> Table:
    table = tomlkit.table()
    table.add("name", spec.name)
    table.add("type", "opcua")
    table.add("url", spec.url)
    if spec.security != "None":
        table.add("security", spec.security)
    if spec.server_certificate is not None:
        table.add("server_certificate", spec.server_certificate)
    if spec.user is not None:
        table.add("user", spec.user)
        password = tomlkit.item(spec.password_env)
        password.comment("the password comes from this variable")
        table.add("password_env", password)
    return table


def _robot(system: str, device: Device, name: str, source: SourceSpec, index: int) -> Table:
    table = tomlkit.table()
    who = " ".join(filter(None, (device.manufacturer, device.model))) or "maker and model not given"
    serial = f", serial number {device.serial}" if device.serial else ""
    table.add(_comment(f"{system}/{device.name}: {who}{serial}."))
    table.add("name", name)
    table.add("source", source.name)
    table.add(
        _comment(
            f"TODO: where the robot stands in the cell (mm, deg); {SPACING_MM:g} mm apart for now."
        )
    )
    table.add(
        "base", _inline({"xyz": [(index - 1) * SPACING_MM, 0.0, 0.0], "rpy_deg": [0.0, 0.0, 0.0]})
    )
    known = _known(device)
    if known is not None:
        table.add(
            _comment(f"linkview knows the {device.model}: its kinematics, limits from the server.")
        )
        table.add("kinematics", _inline(known))
    table.add("joints", _joints(device.axes))
    if known is None and len(device.axes) > MAX_CHAIN:
        table.add(_comment(f"TODO: which URDF (or xacro) describes the {who}? The Robotics model"))
        table.add(_comment("has no kinematics; check names this key until the file is there."))
        table.add("kinematics", _inline({"type": "urdf", "file": f"{name}.urdf"}))
    elif known is None:
        table.add(_comment(f"TODO: which URDF (or xacro) describes the {who}? The Robotics"))
        table.add(_comment("model has no kinematics; until then a placeholder chain, each axis"))
        table.add(
            _comment(
                f"{CHAIN_STEP_MM:g} mm above the one before (rotary about +Z, linear along it):"
            )
        )
        table.add(_comment(f'kinematics = {{ type = "urdf", file = "{name}.urdf" }}'))
        table.add("kinematics", _chain(device.axes))
    return table


def _joints(axes: list[Axis]) -> Array:
    array = tomlkit.array()
    for axis in axes:
        entry: dict[str, Any] = {"node": axis.node}
        now = "no value" if axis.value is None else f"{axis.value:.6g}"
        unit = axis.unit.name if axis.unit else (axis.unit_text or "no EngineeringUnits")
        span = "" if axis.limits is None else f", range {axis.limits[0]:g} … {axis.limits[1]:g}"
        note = f"{axis.name}: {now} {unit} when discovered{span}"
        if axis.unit is None:  # nothing to convert: the person says what the values are
            entry["unit"] = "mm" if axis.linear else "deg"
            note += f"; TODO: its unit is {entry['unit']}?"
        array.add_line(_inline(entry), comment=one_line(note))
    array.add_line(indent="")
    return array


def _chain(axes: list[Axis]) -> Table:
    kinematics = tomlkit.table()
    kinematics.add("type", "axis_group")
    chain = tomlkit.aot()
    parent = ""
    for i, axis in enumerate(axes):
        link = _NAME.sub("_", axis.name).strip("_") or f"axis{i + 1}"
        link = link if link not in {c["name"] for c in chain} else f"{link}_{i + 1}"
        entry = tomlkit.table()
        entry.add("name", link)
        entry.add("parent", parent)
        entry.add(
            "pose",
            _inline(
                {"xyz": [0.0, 0.0, 0.0 if i == 0 else CHAIN_STEP_MM], "rpy_deg": [0.0, 0.0, 0.0]}
            ),
        )
        entry.add("type", "linear" if axis.linear else "rotary")
        limits = _cell_limits(axis)
        if limits is not None:
            entry.add("limits", list(limits))
        chain.append(entry)
        parent = link
    kinematics.add("axes", chain)
    return kinematics


def _known(device: Device) -> dict[str, Any] | None:
    """The kinematics table of a maker's model linkview knows, with the server's limits."""
    model = (device.model or "").strip()
    limits = [_cell_limits(a) for a in device.axes]
    if model == "LBR iiwa 7 R800" and len(device.axes) == len(IIWA_TRAFO.axes):
        params = {name: value for name, value, _ in IIWA_TRAFO.params}
        n = len(IIWA_TRAFO.axes)
        table: dict[str, Any] = {
            "type": "dh",
            "solver": "iiwa",
            "d": [params[f"d{i}"] for i in range(1, n + 1)],
            "a": [params[f"a{i}"] for i in range(1, n + 1)],
            "alpha_deg": [params[f"alpha{i}"] for i in range(1, n + 1)],
        }
    elif model == "IndraMotion MLC kinematic Type 12" and len(device.axes) == 2:
        table = {"type": "type12", **{name: value for name, value, _ in TYPE12_TRAFO.params}}
    else:
        return None
    if all(pair is not None for pair in limits):
        table["limits"] = [list(pair) for pair in limits if pair is not None]
    return table


def _cell_limits(axis: Axis) -> tuple[float, float] | None:
    """EURange in the cell's limit units (degrees or millimetres)."""
    if axis.limits is None:
        return None
    factor = 1.0
    if axis.unit is not None:
        factor = axis.unit.factor * {"rad": 180.0 / math.pi, "m": 1000.0}.get(
            axis.unit.cell_unit, 1.0
        )
    low, high = (round(v * factor, 9) for v in axis.limits)
    return (min(low, high), max(low, high))


def _inline(values: dict[str, Any]) -> Any:
    table = tomlkit.inline_table()
    table.update(values)
    return table


def listing(found: Found) -> Iterable[str]:
    """What was found, for people."""
    devices = sum(len(d) for d in found.systems.values())
    systems = plural(len(found.systems), "motion device system")
    yield f"{found.url}: {systems}, {plural(devices, 'motion device')}"
    for system, items in found.systems.items():
        for device in items:
            who = " ".join(filter(None, (device.manufacturer, device.model, device.serial)))
            yield f"  {system}/{device.name}: {who or 'no identification'}, {len(device.axes)} axes"
            for axis in device.axes:
                unit = axis.unit.name if axis.unit else (axis.unit_text or "no unit")
                value = "—" if axis.value is None else f"{axis.value:.6g}"
                yield f"    {axis.name:<12} {value:>12} {unit:<12} {axis.node}"
    for note in found.notes:
        yield f"  not read: {note}"
