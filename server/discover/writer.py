"""Cell files built as TOML documents (tomlkit), never pasted together as text.

Whatever a device says (names, units, transformation names) may end up in a
starter cell. Pasted into text, a kinematics named ``k1\\nallow_commands = true``
ended its comment line and added a key. Here tomlkit writes every value, so a
string is always a quoted, escaped string; comments pass ``one_line`` first, so
none holds a newline or another control character. ``CellDocument.text``
parses its own output again and refuses it unless it reads back as built.

Kept apart from ``starter`` so that starter cells for other kinds of source
(OPC UA, RTDE) are written the same way.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

import tomlkit
from tomlkit.items import AoT, Array, Comment, InlineTable, Item, Table

from ..text import printable


def one_line(text: str) -> str:
    """``text`` as a comment may hold it: one line, control characters escaped."""
    return printable(text).strip()


def comment(text: str) -> Comment:
    """A whole-line ``# text`` comment."""
    return tomlkit.comment(one_line(text))


def commented(value: Any, note: str) -> Item:
    """``value`` with ``# note`` after it on its line."""
    item: Item = tomlkit.item(value)
    item.comment(one_line(note))
    return item


def inline(values: Mapping[str, Any]) -> InlineTable:
    """An inline table ``{ key = value, ... }``."""
    table = tomlkit.inline_table()
    table.update(values)
    return table


def table(*notes: str, **values: Any) -> Table:
    """A table: comment lines first, then ``values`` in order."""
    made = tomlkit.table()
    for note in notes:
        made.add(comment(note))
    for key, value in values.items():
        made.add(key, value)
    return made


def lines(entries: Iterable[tuple[Mapping[str, Any], str | None]]) -> Array:
    """An array of inline tables, one a line, each with its comment (if any) after it."""
    array = tomlkit.array()
    for values, note in entries:
        array.add_line(inline(values), comment=None if note is None else one_line(note))
    array.add_line(indent="")  # the closing bracket on a line of its own
    return array


class CellDocument:
    """A cell file being written: header comments, ``[[source]]`` and ``[[robot]]`` tables."""

    def __init__(self, *header: str) -> None:
        self.doc = tomlkit.document()
        for note in header:
            self.doc.add(comment(note))
        self._sections: dict[str, AoT] = {}

    def add(self, section: str, item: Table) -> None:
        """Append ``item`` to the array of tables ``section`` (``source``, ``robot``)."""
        if section not in self._sections:
            self._sections[section] = tomlkit.aot()
            self.doc.add(tomlkit.nl())
            self.doc.append(section, self._sections[section])
        self._sections[section].append(item)

    def text(self) -> str:
        """The TOML text; ValueError if it would not read back as the document built."""
        text = tomlkit.dumps(self.doc)
        if tomllib.loads(text) != self.doc.unwrap():
            raise ValueError("the cell written does not read back as built")
        return text
