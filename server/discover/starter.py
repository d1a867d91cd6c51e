"""A starter cell file (TOML, docs/cell.md) for what ``browse.describe`` found.

One robot per kinematics, and one per group of axes that no kinematics uses
(axes named ``<group>_<axis>`` group by prefix; the others form one group).
Every joint is mapped to its node with its unit, and to its setpoint node
where the axis has one. What only a person can choose is marked ``TODO``:

* a kinematics whose joint transformation linkview knows (``KNOWN_TRAFOS``)
  becomes that kinematics table, and runs as written;
* any other kinematics becomes ``type = "urdf"`` with a file to supply:
  ``check`` fails until it exists;
* loose axes become an ``axis_group`` chain with placeholder poses, which
  runs as written (drawn as ball and stick) until someone measures them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import tomlkit
from tomlkit.items import AoT, Array, Table

from .browse import Axis, Controller, Kinematics
from .units import is_rotary, mapping
from .writer import CellDocument, comment, commented, inline, lines, table, unique_name

KNOWN_TRAFOS = ("IndraMotionType12", "DenavitHartenberg")
"""Joint transformations turned into linkview kinematics (type12, dh); the mock's names."""
SPACING_MM = 1000.0
"""Robots are first set out this far apart along X."""
CHAIN_STEP_MM = 200.0
"""Placeholder distance between consecutive axes of a loose axis group."""


@dataclass(frozen=True)
class SourceSpec:
    """The ``[[source]]`` the starter cell connects through."""

    name: str
    url: str
    user: str
    password_env: str
    api: str = "v2"
    ca: str | None = None
    insecure: bool = False


def starter_cell(controller: Controller, source: SourceSpec, command: str) -> str:
    """The TOML text of a cell for ``controller``; ``command`` is how it was made (a comment)."""
    header = [
        f"A starter cell written by `{command}`.",
        "Check it with `python -m server check FILE`, serve it with",
        "`python -m server --cell FILE`; docs/cell.md describes every key.",
        "Lines marked TODO need a choice only a person can make.",
        *(f"Not read: {note}" for note in controller.notes),
    ]
    axes = {a.name: a for a in controller.axes}
    used: set[str] = set()
    kinematics: list[tuple[Kinematics, list[Axis]]] = []
    for kin in controller.kinematics:
        members = [axes[n] for n in kin.axes if n in axes]
        if len(members) != len(kin.axes) or not members:
            missing = ", ".join(n for n in kin.axes if n not in axes)
            header.append(f"Kinematics {kin.name} left out: axes not readable ({missing}).")
            continue
        used.update(kin.axes)
        kinematics.append((kin, members))
    loose = _loose_groups([a for a in controller.axes if a.name not in used])
    if not kinematics and not loose:
        header.append("TODO: no motion axes were found: add [[robot]] tables by hand.")
    # Each robot is written as it is built: one robot's tomlkit items at a time in memory.
    cell = CellDocument(*header)
    cell.add("source", _source(source))
    names: set[str] = set()
    for index, (kin, members) in enumerate(kinematics):
        cell.add(
            "robot", _kinematics_robot(kin, members, unique_name(kin.name, names), source, index)
        )
    for index, (group, members) in enumerate(loose, start=len(kinematics)):
        cell.add("robot", _axis_group_robot(members, unique_name(group, names), source, index))
    return cell.text()


def _source(source: SourceSpec) -> Table:
    keys: dict[str, Any] = {
        "name": source.name,
        "url": source.url,
        "user": source.user,
        "password_env": commented(source.password_env, "the password comes from this variable"),
    }
    if source.api != "v2":
        keys["api"] = source.api
    if source.ca is not None:
        keys["ca"] = source.ca
    if source.insecure:
        keys["insecure"] = commented(True, "TODO: trust the device's certificate (ca) instead")
    return table(**keys)


def _head(name: str, source: SourceSpec, index: int, *notes: str) -> Table:
    robot = table(*notes, name=name, source=source.name)
    robot.add(comment(f"TODO: where the robot stands in the cell (mm, deg); "
                      f"{SPACING_MM:g} mm apart for now."))  # fmt: skip
    robot.add("base", inline({"xyz": [index * SPACING_MM, 0.0, 0.0], "rpy_deg": [0.0, 0.0, 0.0]}))
    return robot


def _joints(axes: list[Axis]) -> Array:
    """One entry per axis, with what the controller said of it beside it."""
    # A robot's joints have setpoints all or none (docs/cell.md): keep them only if all do.
    setpoints = all(axis.setpoint is not None for axis in axes)
    entries: list[tuple[dict[str, Any], str | None]] = []
    for axis in axes:
        m = mapping(axis.unit, axis.kind)
        now = "no value" if axis.value is None else f"{axis.value:.6g} {axis.unit or ''}".strip()
        lo, hi = axis.limits
        span = "" if lo is None or hi is None else f", limits {lo:g} … {hi:g}"
        note = f"{axis.name}: {axis.kind or 'kind unknown'}, {now} when discovered{span}"
        if m.guessed:
            note += f"; TODO: the controller gives the unit {axis.unit!r}: check unit and scale"
        entry: dict[str, Any] = {"node": axis.node, "unit": m.unit}
        if m.scale != 1.0:
            entry["scale"] = m.scale
        if setpoints and axis.setpoint is not None:
            entry["setpoint"] = axis.setpoint
        entries.append((entry, note))
    return lines(entries)


def _kinematics_robot(
    kin: Kinematics, axes: list[Axis], name: str, source: SourceSpec, index: int
) -> Table:
    what = f"Kinematics {kin.name}: joint transformation {kin.trafo or 'not given'}, axes "
    robot = _head(name, source, index, what + ", ".join(kin.axes) + ".")
    known = _known_table(kin, axes)
    if known is None:
        for note in (
            f"TODO: which URDF (or xacro) describes {kin.name}? linkview cannot compute the",
            f"joint transformation {kin.trafo or '(none given)'}; joints follow the URDF's",
            'movable joints in file order (add `joint = "..."` to each entry otherwise).',
        ):
            robot.add(comment(note))
        robot.add("kinematics", inline({"type": "urdf", "file": f"{name}.urdf"}))
    else:
        robot.add(comment(f"From the controller's {kin.trafo} parameters. TODO for meshes: "
                          "a URDF instead,"))  # fmt: skip
        robot.add(comment(f'kinematics = {{ type = "urdf", file = "{name}.urdf" }}'))
        robot.add("kinematics", inline(known))
    robot.add("joints", _joints(axes))
    return robot


def _known_table(kin: Kinematics, axes: list[Axis]) -> dict[str, Any] | None:
    """The kinematics table for a transformation linkview knows, else None."""
    params = {k: _mm_or_deg(v, unit) for k, (v, unit) in kin.params.items()}
    limits = _limits(axes)
    if kin.trafo == "IndraMotionType12" and len(axes) == 2:
        lengths = [params.get(f"L{i}") for i in range(1, 6)]
        if all(v is not None for v in lengths):
            return {"type": "type12", **{f"L{i}": v for i, v in enumerate(lengths, 1)}, **limits}
    if kin.trafo == "DenavitHartenberg" and all(is_rotary(a.unit, a.kind) for a in axes):
        n = len(axes)
        rows = {k: [params.get(f"{k}{i}") for i in range(1, n + 1)] for k in ("d", "a", "alpha")}
        offsets = [params.get(f"offset{i}", 0.0) for i in range(1, n + 1)]
        if all(v is not None for row in rows.values() for v in row):
            return {
                "type": "dh",
                "d": _list(rows["d"]),
                "a": _list(rows["a"]),
                "alpha_deg": _list(rows["alpha"]),
                "offset_deg": _list(offsets),
                **limits,
            }
    return None


def _axis_group_robot(axes: list[Axis], name: str, source: SourceSpec, index: int) -> Table:
    what = f"Axes no kinematics uses: {', '.join(a.name for a in axes)}."
    robot = _head(name, source, index, what)
    robot.add("joints", _joints(axes))
    group = table(
        "TODO: the pose of each axis in its parent at zero position (mm, deg): these are",
        f"placeholders, each axis {CHAIN_STEP_MM:g} mm above the one before; rotary axes turn",
        "about their +Z, linear ones move along it.",
        type="axis_group",
    )
    chain = [(axis.name, is_rotary(axis.unit, axis.kind), _cell_limits(axis)) for axis in axes]
    group.add("axes", axis_chain(chain))
    robot.add(tomlkit.nl())
    robot.add("kinematics", group)
    return robot


def axis_chain(axes: Iterable[tuple[str, bool, tuple[float, float] | None]]) -> AoT:
    """The ``axes`` of an ``axis_group`` placeholder from ``(name, rotary, limits)`` of each axis:
    each a child of the one before, ``CHAIN_STEP_MM`` above it, turning about (rotary) or moving
    along its +Z; names made plain and unique."""
    chain = tomlkit.aot()
    names: set[str] = set()
    parent = ""
    for i, (name, rotary, limits) in enumerate(axes):
        link = unique_name(name, names, f"axis{i + 1}")
        entry = table(
            name=link,
            parent=parent,
            pose=inline(
                {"xyz": [0.0, 0.0, 0.0 if i == 0 else CHAIN_STEP_MM], "rpy_deg": [0.0, 0.0, 0.0]}
            ),  # fmt: skip
            type="rotary" if rotary else "linear",
        )
        if limits is not None:
            entry.add("limits", list(limits))
        chain.append(entry)
        parent = link
    return chain


def _cell_limits(axis: Axis) -> tuple[float, float] | None:
    """The axis's limits as the cell takes them (degrees or mm), if it has both."""
    lo, hi = (_to_cell(v, axis) for v in axis.limits)
    return None if lo is None or hi is None else (lo, hi)


def _loose_groups(axes: list[Axis]) -> list[tuple[str, list[Axis]]]:
    """Axes named ``<group>_<rest>`` by group (two or more); the others together as ``axes``."""
    prefixes: dict[str, list[Axis]] = {}
    for axis in axes:
        prefix = axis.name.rsplit("_", 1)[0] if "_" in axis.name.strip("_") else ""
        prefixes.setdefault(prefix, []).append(axis)
    groups = [(p, members) for p, members in prefixes.items() if p and len(members) > 1]
    rest = [a for p, members in prefixes.items() if not p or len(members) == 1 for a in members]
    if rest:
        groups.append(("axes", rest))
    return groups


def _limits(axes: list[Axis]) -> dict[str, Any]:
    """``{"limits": [[lo, hi], ...]}`` in degrees or mm when every axis has both; else ``{}``."""
    pairs = [_cell_limits(a) for a in axes]
    return {"limits": [list(pair) for pair in pairs if pair is not None]} if all(pairs) else {}


def _to_cell(value: float | None, axis: Axis) -> float | None:
    """A position in the axis's node unit as the cell's limits take it (degrees or mm)."""
    if value is None:
        return None
    m = mapping(axis.unit, axis.kind)
    x = value * m.scale
    factor = {"rad": 180.0 / math.pi, "m": 1000.0}.get(m.unit, 1.0)
    return round(x * factor, 9)


def _mm_or_deg(value: float, unit: str) -> float:
    """A transformation parameter in mm (lengths) or degrees (angles)."""
    factor = {"m": 1000.0, "rad": 180.0 / math.pi, "cm": 10.0}.get(unit.strip(), 1.0)
    return round(value * factor, 9)


def _list(values: Iterable[float | None]) -> list[float]:
    return [float(v or 0.0) for v in values]
