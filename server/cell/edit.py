"""Edits of a cell file's text that keep what its author wrote: comments, key order, layout.

The file is read with tomlkit, which keeps every comment, blank line and
quirk of spacing; an edit changes the values it names and leaves the rest of
the text as it was. New keys go after the last key of their table (before the
comments that introduce the next one); new inline tables are written in the
file's own ``{ key = value }`` style. What the page edits is in the units of
the file: lengths in mm and angles in degrees, rounded to 1e-9 of their unit
(a picometre, a nano-degree), so a value read back is the value meant.

Nothing here checks that the result is a valid cell: ``load_cell(path,
text=...)`` does that before anything is written (``server.commissioning``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import tomlkit
from tomlkit.exceptions import TOMLKitError
from tomlkit.items import AoT, Array, InlineTable, Item, Table

DIGITS = 9
"""Decimals kept of a length in mm or an angle in degrees."""


class EditError(ValueError):
    """An edit that does not fit the file (no such robot, joint or axis)."""


def number(value: float) -> float:
    """``value`` as written into the file: rounded to ``DIGITS`` decimals, never ``-0.0``."""
    return round(float(value), DIGITS) + 0.0


def _trivia(item: Any) -> bool:
    """Whether a body entry is a comment or blank line (no key)."""
    return item[0] is None


class CellText:
    """A cell file's text, changed in place by each ``set_*`` call; ``text`` is the result."""

    def __init__(self, text: str) -> None:
        try:
            self.doc = tomlkit.parse(text)
        except TOMLKitError as exc:
            raise EditError(f"the cell file is not valid TOML: {exc}") from None

    @property
    def text(self) -> str:
        """The file as it is now."""
        return self.doc.as_string()

    def robot(self, name: str) -> Table:
        """The ``[[robot]]`` table called ``name``."""
        robots = self.doc.get("robot")
        for table in robots if isinstance(robots, AoT) else []:
            if table.get("name") == name:
                found: Table = table
                return found
        raise EditError(f"the cell file has no [[robot]] named {name!r}")

    def set_joint(
        self, robot: str, joint: str, position: int, values: Mapping[str, float | str]
    ) -> None:
        """Set keys (``scale``, ``offset``, ``unit``) of one entry of ``robot``'s ``joints``.

        The entry is the one naming ``joint`` (``joint = "..."``) where entries
        name their joints, else the one at ``position`` (the kinematics' order).
        """
        entries = self.robot(robot).get("joints")
        if not isinstance(entries, (Array, AoT)):
            raise EditError(f"robot {robot!r} has no joints list")
        tables = list(entries)
        index = _entry(tables, robot, joint, position)
        cleaned = {k: number(v) if isinstance(v, float) else v for k, v in values.items()}
        if isinstance(entries, AoT):
            for key, value in cleaned.items():
                _set(tables[index], key, value)
        else:
            entries[index] = _with_keys(tables[index], cleaned)

    def set_base(self, robot: str, xyz_mm: Sequence[float], rpy_deg: Sequence[float]) -> None:
        """Place ``robot``: its ``base`` (mm, fixed-axis roll, pitch, yaw in degrees)."""
        _set_pose(self.robot(robot), "base", xyz_mm, rpy_deg)

    def set_axis_pose(
        self, robot: str, axis: str, xyz_mm: Sequence[float], rpy_deg: Sequence[float]
    ) -> None:
        """The zero-position ``pose`` of axis ``axis`` of ``robot``'s axis group, in its parent."""
        kinematics = self.robot(robot).get("kinematics")
        axes = kinematics.get("axes") if isinstance(kinematics, (Table, InlineTable)) else None
        tables = list(axes) if isinstance(axes, (Array, AoT)) else []
        found = [i for i, t in enumerate(tables) if t.get("name") == axis]
        if not found or axes is None:
            raise EditError(f"robot {robot!r} has no axis {axis!r}")
        if isinstance(axes, AoT):
            _set_pose(tables[found[0]], "pose", xyz_mm, rpy_deg)
        else:
            pose = _pose_table(xyz_mm, rpy_deg)
            axes[found[0]] = _with_keys(tables[found[0]], {"pose": pose})

    def set_description(
        self,
        robot: str,
        file: str,
        packages: Mapping[str, str],
        joint_names: Mapping[str, str],
    ) -> None:
        """Describe ``robot`` by the URDF or xacro ``file``: its ``kinematics`` table becomes
        ``{ type = "urdf", file, packages }``, the joints entry of each of its joints now
        (``joint_names``: its name now -> the URDF joint's, in its joint order) names its
        URDF joint, and ``mesh_dir`` goes (the URDF brings meshes).
        """
        table = self.robot(robot)
        entries = table.get("joints")
        tables = list(entries) if isinstance(entries, (Array, AoT)) else []
        if len(tables) != len(joint_names):
            raise EditError(
                f"robot {robot!r} has {len(tables)} joints entries, "
                f"{len(joint_names)} joint names given"
            )
        slots = [_entry(tables, robot, now, k) for k, now in enumerate(joint_names)]
        kinematics: dict[str, Any] = {"type": "urdf", "file": file}
        if packages:
            kinematics["packages"] = dict(packages)
        new = _inline(kinematics)
        old = table.get("kinematics")
        if isinstance(old, Table):
            # A [robot.kinematics] section: the comments that end it introduce what comes
            # next in the file, so they stay, now after the new inline table.
            trailing = _trailing_trivia(old)
            del table["kinematics"]
            _add_key(table, "kinematics", new)
            _append_trivia(table, trailing)
        elif old is not None:
            table["kinematics"] = new
        else:
            _add_key(table, "kinematics", new)
        if "mesh_dir" in table:
            del table["mesh_dir"]
        for slot, name in zip(slots, joint_names.values(), strict=True):
            if isinstance(entries, AoT):
                _set(tables[slot], "joint", name)
            elif isinstance(entries, Array):
                entries[slot] = _with_keys(tables[slot], {"joint": name})


def _entry(tables: list[Any], robot: str, joint: str, position: int) -> int:
    """The joints entry of ``joint``: the one naming it where entries name their joints
    (``joint = "..."``), else the one at ``position`` (the kinematics' joint order)."""
    named = [i for i, t in enumerate(tables) if t.get("joint") == joint]
    if named:
        return named[0]
    if any("joint" in t for t in tables) or not 0 <= position < len(tables):
        raise EditError(f"robot {robot!r} has no joints entry for joint {joint!r}")
    return position


def _pose_table(xyz_mm: Sequence[float], rpy_deg: Sequence[float]) -> dict[str, list[float]]:
    return {"xyz": [number(v) for v in xyz_mm], "rpy_deg": [number(v) for v in rpy_deg]}


def _set_pose(
    owner: Table | InlineTable, key: str, xyz_mm: Sequence[float], rpy_deg: Sequence[float]
) -> None:
    """``owner[key]`` = the pose, in whatever form it has there (inline, section, absent)."""
    pose = _pose_table(xyz_mm, rpy_deg)
    current = owner.get(key)
    if isinstance(current, Table):
        for name, value in pose.items():
            _set(current, name, value)
    elif isinstance(current, InlineTable):
        owner[key] = _with_keys(current, pose)
    elif isinstance(owner, Table):
        _add_key(owner, key, _inline(pose))
    else:
        owner[key] = _inline(pose)


def _set(table: Table, key: str, value: Any) -> None:
    """``table[key] = value``; a new key goes after the table's last key (see ``_add_key``)."""
    if key in table:
        table[key] = value
    else:
        _add_key(table, key, value)


def _add_key(table: Table, key: str, value: Any) -> None:
    """A new key after the last key/value of ``table``: before the blank lines and comments
    that end it (which belong to what follows) and before its sub-tables."""
    body = table.value.body
    last = None
    for entry_key, item in body:
        if entry_key is not None and not isinstance(item, (Table, AoT)):
            last = entry_key
    if last is None:
        table[key] = value
    else:
        table.value._insert_after(last, key, value)


def _trailing_trivia(table: Table) -> list[Item]:
    """The comments and blank lines at the end of ``table`` (of its last sub-table, if any)."""
    body = table.value.body
    if body and not _trivia(body[-1]):
        last = body[-1][1]
        if isinstance(last, Table):
            return _trailing_trivia(last)
        if isinstance(last, AoT) and last.body:
            return _trailing_trivia(last.body[-1])
        return []
    trailing: list[Item] = []
    for entry in reversed(body):
        if not _trivia(entry):
            break
        trailing.insert(0, entry[1])
    return trailing


def _append_trivia(table: Table, items: list[Item]) -> None:
    """Comments and blank lines at the very end of ``table``'s text: in its last section."""
    body = table.value.body
    if body and not _trivia(body[-1]):
        last = body[-1][1]
        if isinstance(last, Table):
            _append_trivia(last, items)
            return
        if isinstance(last, AoT) and last.body:
            _append_trivia(last.body[-1], items)
            return
    if items and body and _trivia(body[-1]) and items[0].as_string().strip() == "":
        items = items[1:]  # a blank line there already
    for item in items:
        table.value.append(None, item)


def _format(value: Any) -> str:
    """A value as TOML text, inline tables in the ``{ key = value }`` style."""
    if isinstance(value, Mapping):
        return _inline_text(value)
    text: str = tomlkit.item(value).as_string()
    return text


def _inline_text(values: Mapping[str, Any]) -> str:
    pairs = ", ".join(f"{tomlkit.key(k).as_string()} = {_format(v)}" for k, v in values.items())
    return f"{{ {pairs} }}" if pairs else "{}"


def _parse_item(text: str) -> Item:
    item = tomlkit.parse(f"x = {text}\n").item("x")
    assert isinstance(item, Item)
    return item


def _inline(values: Mapping[str, Any]) -> InlineTable:
    """An inline table written ``{ key = value, ... }``, as cell files (and ``discover``) do."""
    item = _parse_item(_inline_text(values))
    assert isinstance(item, InlineTable)
    return item


def _with_keys(table: InlineTable, values: Mapping[str, Any]) -> InlineTable:
    """``table`` with ``values`` set: keys it has keep their place, new ones go at its end,
    and its own spacing stays (``{ a = 1 }`` gets ``, b = 2`` before the `` }``)."""
    for key, value in values.items():
        if key in table:
            table[key] = _parse_item(_format(value)) if isinstance(value, Mapping) else value
    new = {k: v for k, v in values.items() if k not in table}
    if not new:
        return table
    text = table.as_string().rstrip()
    body = text[:-1]
    closing = " }" if body.endswith(" ") or body.rstrip().endswith("{") else "}"
    body = body.rstrip()
    added = ", ".join(f"{tomlkit.key(k).as_string()} = {_format(v)}" for k, v in new.items())
    joined = f"{body} {added}" if body.endswith("{") else f"{body}, {added}"
    item = _parse_item(joined + closing)
    assert isinstance(item, InlineTable)
    return item
