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

import json
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

from .browse import Axis, Controller, Kinematics
from .units import is_rotary, mapping

KNOWN_TRAFOS = ("IndraMotionType12", "DenavitHartenberg")
"""Joint transformations turned into linkview kinematics (type12, dh); the mock's names."""
SPACING_MM = 1000.0
"""Robots are first set out this far apart along X."""
CHAIN_STEP_MM = 200.0
"""Placeholder distance between consecutive axes of a loose axis group."""
_NAME = re.compile(r"[^A-Za-z0-9_.\-]+")


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
    lines = [
        f"# A starter cell written by `{command}`.",
        "# Check it with `python -m server check FILE`, serve it with",
        "# `python -m server --cell FILE`; docs/cell.md describes every key.",
        "# Lines marked TODO need a choice only a person can make.",
        *(f"# Not read: {note}" for note in controller.notes),
        "",
        *_source(source),
    ]
    axes = {a.name: a for a in controller.axes}
    used: set[str] = set()
    names: set[str] = set()
    robots = 0
    for kin in controller.kinematics:
        members = [axes[n] for n in kin.axes if n in axes]
        if len(members) != len(kin.axes) or not members:
            missing = ", ".join(n for n in kin.axes if n not in axes)
            lines += ["", f"# Kinematics {kin.name} left out: axes not readable ({missing})."]
            continue
        used.update(kin.axes)
        lines += ["", *_kinematics_robot(kin, members, _unique(kin.name, names), source, robots)]
        robots += 1
    for group, members in _loose_groups([a for a in controller.axes if a.name not in used]):
        lines += ["", *_axis_group_robot(group, members, _unique(group, names), source, robots)]
        robots += 1
    if robots == 0:
        lines += ["", "# TODO: no motion axes were found: add [[robot]] tables by hand."]
    return "\n".join(lines) + "\n"


def _source(source: SourceSpec) -> list[str]:
    lines = [
        "[[source]]",
        f"name = {_q(source.name)}",
        f"url = {_q(source.url)}",
        f"user = {_q(source.user)}",
        f"password_env = {_q(source.password_env)}  # the password comes from this variable",
    ]
    if source.api != "v2":
        lines.append(f"api = {_q(source.api)}")
    if source.ca is not None:
        lines.append(f"ca = {_q(source.ca)}")
    if source.insecure:
        lines.append("insecure = true  # TODO: trust the device's certificate (ca) instead")
    return lines


def _head(name: str, source: SourceSpec, index: int, what: str) -> list[str]:
    return [
        f"# {what}",
        "[[robot]]",
        f"name = {_q(name)}",
        f"source = {_q(source.name)}",
        f"# TODO: where the robot stands in the cell (mm, deg); {SPACING_MM:g} mm apart for now.",
        f"base = {{ xyz = [{index * SPACING_MM:.1f}, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }}",
    ]


def _joints(axes: list[Axis]) -> list[str]:
    # A robot's joints have setpoints all or none (docs/cell.md): keep them only if all do.
    setpoints = all(axis.setpoint is not None for axis in axes)
    lines = ["joints = ["]
    for axis in axes:
        m = mapping(axis.unit, axis.kind)
        now = "no value" if axis.value is None else f"{axis.value:.6g} {axis.unit or ''}".strip()
        lo, hi = axis.limits
        span = "" if lo is None or hi is None else f", limits {lo:g} … {hi:g}"
        kind = axis.kind or "kind unknown"
        lines.append(f"    # {axis.name}: {kind}, {now} when discovered{span}")
        if m.guessed:
            lines.append(
                f"    # TODO: the controller gives the unit {axis.unit!r}: check unit and scale"
            )
        entry = f"node = {_q(axis.node)}, unit = {_q(m.unit)}"
        if m.scale != 1.0:
            entry += f", scale = {m.scale!r}"
        if setpoints and axis.setpoint is not None:
            entry += f", setpoint = {_q(axis.setpoint)}"
        lines.append(f"    {{ {entry} }},")
    return [*lines, "]"]


def _kinematics_robot(
    kin: Kinematics, axes: list[Axis], name: str, source: SourceSpec, index: int
) -> list[str]:
    what = f"Kinematics {kin.name}: joint transformation {kin.trafo or 'not given'}, axes "
    lines = _head(name, source, index, what + ", ".join(kin.axes) + ".")
    table = _known_table(kin, axes)
    if table is None:
        lines += [
            f"# TODO: which URDF (or xacro) describes {kin.name}? linkview cannot compute the",
            f"# joint transformation {kin.trafo or '(none given)'}; joints follow the URDF's",
            '# movable joints in file order (add `joint = "..."` to each entry otherwise).',
            f'kinematics = {{ type = "urdf", file = {_q(name + ".urdf")} }}',
        ]
    else:
        lines += [
            f"# From the controller's {kin.trafo} parameters. TODO for meshes: a URDF instead,",
            f'# kinematics = {{ type = "urdf", file = {_q(name + ".urdf")} }}',
            f"kinematics = {table}",
        ]
    return [*lines, *_joints(axes)]


def _known_table(kin: Kinematics, axes: list[Axis]) -> str | None:
    """The inline kinematics table for a transformation linkview knows, else None."""
    params = {k: _mm_or_deg(v, unit) for k, (v, unit) in kin.params.items()}
    limits = _limits(axes)
    if kin.trafo == "IndraMotionType12" and len(axes) == 2:
        lengths = [params.get(f"L{i}") for i in range(1, 6)]
        if all(v is not None for v in lengths):
            keys = ", ".join(f"L{i} = {v!r}" for i, v in enumerate(lengths, 1))
            return f'{{ type = "type12", {keys}{limits} }}'
    if kin.trafo == "DenavitHartenberg" and all(is_rotary(a.unit, a.kind) for a in axes):
        n = len(axes)
        rows = {k: [params.get(f"{k}{i}") for i in range(1, n + 1)] for k in ("d", "a", "alpha")}
        offsets = [params.get(f"offset{i}", 0.0) for i in range(1, n + 1)]
        if all(v is not None for row in rows.values() for v in row):
            return (
                f'{{ type = "dh", d = {_list(rows["d"])}, a = {_list(rows["a"])}, '
                f"alpha_deg = {_list(rows['alpha'])}, offset_deg = {_list(offsets)}{limits} }}"
            )
    return None


def _axis_group_robot(
    group: str, axes: list[Axis], name: str, source: SourceSpec, index: int
) -> list[str]:
    what = f"Axes no kinematics uses: {', '.join(a.name for a in axes)}."
    lines = [*_head(name, source, index, what), *_joints(axes)]
    lines += [
        "",
        "# TODO: the pose of each axis in its parent at zero position (mm, deg): these are",
        f"# placeholders, each axis {CHAIN_STEP_MM:g} mm above the one before; rotary axes turn",
        "# about their +Z, linear ones move along it.",
        "[robot.kinematics]",
        'type = "axis_group"',
    ]
    parent = ""
    for i, axis in enumerate(axes):
        rotary = is_rotary(axis.unit, axis.kind)
        step = 0.0 if i == 0 else CHAIN_STEP_MM
        lines += [
            "",
            "[[robot.kinematics.axes]]",
            f"name = {_q(_NAME.sub('_', axis.name))}",
            f"parent = {_q(parent)}",
            f"pose = {{ xyz = [0.0, 0.0, {step:.1f}], rpy_deg = [0.0, 0.0, 0.0] }}",
            f"type = {_q('rotary' if rotary else 'linear')}",
        ]
        lo, hi = (_to_cell(v, axis) for v in axis.limits)
        if lo is not None and hi is not None:
            lines.append(f"limits = [{lo!r}, {hi!r}]")
        parent = _NAME.sub("_", axis.name)
    return lines


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


def _limits(axes: list[Axis]) -> str:
    """``, limits = [[lo, hi], ...]`` in degrees or mm when every axis has both; else ``""``."""
    pairs = [tuple(_to_cell(v, a) for v in a.limits) for a in axes]
    if any(lo is None or hi is None for lo, hi in pairs):
        return ""
    return ", limits = [" + ", ".join(f"[{lo!r}, {hi!r}]" for lo, hi in pairs) + "]"


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


def _unique(wanted: str, taken: set[str]) -> str:
    base = _NAME.sub("_", wanted).strip("_") or "robot"
    name, k = base[:60], 2
    while name in taken:
        name, k = f"{base[:56]}_{k}", k + 1
    taken.add(name)
    return name


def _list(values: Iterable[float | None]) -> str:
    return "[" + ", ".join(repr(float(v or 0.0)) for v in values) + "]"


def _q(text: str) -> str:
    """A TOML basic string (JSON's escapes are TOML's)."""
    return json.dumps(text, ensure_ascii=False)
