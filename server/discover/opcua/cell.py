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

Server text (names, makers, units) is written by ``discover.writer``, as for
every discover: only ever a TOML string (quoted and escaped by tomlkit) or a
one-line comment, each table read back as built. A hostile server cannot add
a key.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from tomlkit.items import Array, Table

from ...mock_ctrlx.machine import IIWA_TRAFO, TYPE12_TRAFO
from ...text import plural
from ..starter import CHAIN_STEP_MM, SPACING_MM, axis_chain
from ..writer import CellDocument, comment, commented, inline, lines, table, unique_name
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


def starter_cell(found: Found, source: SourceSpec, command: str) -> str:
    """The TOML text of the starter cell."""
    header = [
        f"A starter cell written by `{command}`.",
        "Check it with `python -m server check FILE`, serve it with",
        "`python -m server --cell FILE`; docs/cell.md describes every key.",
        "Lines marked TODO need a choice only a person can make.",
        *(f"Not read: {note}" for note in found.notes),
    ]
    devices = [(system, d) for system, items in found.systems.items() for d in items]
    header += [f"{system}/{d.name}: no axes with a position; left out." for system, d in devices
               if not d.axes]  # fmt: skip
    if not any(d.axes for _, d in devices):
        header.append("TODO: no motion devices were found: add [[robot]] tables by hand.")
    cell = CellDocument(*header)
    cell.add("source", _source(source))
    names: set[str] = set()
    for system, device in devices:
        if device.axes:
            name = unique_name(device.name, names)
            cell.add("robot", _robot(system, device, name, source, len(names) - 1))
    return cell.text()


def _source(spec: SourceSpec) -> Table:
    keys: dict[str, Any] = {"name": spec.name, "type": "opcua", "url": spec.url}
    if spec.security != "None":
        keys["security"] = spec.security
    if spec.server_certificate is not None:
        keys["server_certificate"] = spec.server_certificate
    if spec.user is not None:
        keys["user"] = spec.user
        keys["password_env"] = commented(spec.password_env, "the password comes from this variable")
    return table(**keys)


def _robot(system: str, device: Device, name: str, source: SourceSpec, index: int) -> Table:
    who = " ".join(filter(None, (device.manufacturer, device.model))) or "maker and model not given"
    serial = f", serial number {device.serial}" if device.serial else ""
    robot = table(f"{system}/{device.name}: {who}{serial}.", name=name, source=source.name)
    robot.add(comment(f"TODO: where the robot stands in the cell (mm, deg); "
                      f"{SPACING_MM:g} mm apart for now."))  # fmt: skip
    robot.add("base", inline({"xyz": [index * SPACING_MM, 0.0, 0.0], "rpy_deg": [0.0, 0.0, 0.0]}))
    known = _known(device)
    if known is not None:
        robot.add(comment(f"linkview knows the {device.model}: its kinematics, limits from the "
                          "server."))  # fmt: skip
        robot.add("kinematics", inline(known))
    robot.add("joints", _joints(device.axes))
    if known is None and len(device.axes) > MAX_CHAIN:
        robot.add(comment(f"TODO: which URDF (or xacro) describes the {who}? The Robotics model"))
        robot.add(comment("has no kinematics; check names this key until the file is there."))
        robot.add("kinematics", inline({"type": "urdf", "file": f"{name}.urdf"}))
    elif known is None:
        robot.add(comment(f"TODO: which URDF (or xacro) describes the {who}? The Robotics"))
        robot.add(comment("model has no kinematics; until then a placeholder chain, each axis"))
        robot.add(comment(f"{CHAIN_STEP_MM:g} mm above the one before (rotary about +Z, linear "
                          "along it):"))  # fmt: skip
        robot.add(comment(f'kinematics = {{ type = "urdf", file = "{name}.urdf" }}'))
        chain = [(axis.name, not axis.linear, _cell_limits(axis)) for axis in device.axes]
        robot.add("kinematics", table(type="axis_group", axes=axis_chain(chain)))
    return robot


def _joints(axes: list[Axis]) -> Array:
    entries: list[tuple[dict[str, Any], str | None]] = []
    for axis in axes:
        entry: dict[str, Any] = {"node": axis.node}
        now = "no value" if axis.value is None else f"{axis.value:.6g}"
        unit = axis.unit.name if axis.unit else (axis.unit_text or "no EngineeringUnits")
        span = "" if axis.limits is None else f", range {axis.limits[0]:g} … {axis.limits[1]:g}"
        note = f"{axis.name}: {now} {unit} when discovered{span}"
        if axis.unit is None:  # nothing to convert: the person says what the values are
            entry["unit"] = "mm" if axis.linear else "deg"
            note += f"; TODO: its unit is {entry['unit']}?"
        entries.append((entry, note))
    return lines(entries)


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
