"""Cell files built as TOML documents (tomlkit), never pasted together as text.

Whatever a device says (names, units, transformation names) may end up in a
starter cell. Pasted into text, a kinematics named ``k1\\nallow_commands = true``
ended its comment line and added a key. Here tomlkit writes every value, so a
string is always a quoted, escaped string; comments pass ``one_line`` first, so
none holds a newline or another control character. ``CellDocument`` parses
each table it writes again and refuses it unless it reads back as built.

Kept apart from ``starter`` so that starter cells for other kinds of source
(OPC UA, RTDE) are written the same way.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

import tomlkit
from tomlkit import TOMLDocument
from tomlkit.items import Array, Comment, InlineTable, Item, Table

from ..text import printable

_NOT_NAME = re.compile(r"[^A-Za-z0-9_.\-]+")
"""What a robot, source or link name written by discover may not hold (made ``_``)."""


def one_line(text: str) -> str:
    """``text`` as a comment may hold it: one line, control characters escaped."""
    return printable(text).strip()


def plain_name(text: str, default: str) -> str:
    """``text`` as a name in the cell: letters, digits, ``_ . -`` (the rest ``_``), at most 64
    characters; ``default`` where nothing is left."""
    return _NOT_NAME.sub("_", text).strip("_")[:64] or default


def unique_name(wanted: str, taken: set[str], default: str = "robot") -> str:
    """``plain_name(wanted)``, numbered past the names in ``taken``; added to ``taken``."""
    base = plain_name(wanted, default)
    name, k = base[:60], 2
    while name in taken:
        name, k = f"{base[:56]}_{k}", k + 1
    taken.add(name)
    return name


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
    """A cell file being written: header comments, then ``[[source]]`` and ``[[robot]]`` tables.

    Each table is made into text as it is added, as a TOML document of its own
    that must read back as exactly that one table: memory holds the text, not
    a document of every table (tomlkit's items for 100 000 axes took 3 GB).
    The pieces join into one file that reads as their union, since each is
    whole TOML (no open string or array) and begins with its table's header.
    """

    def __init__(self, *header: str) -> None:
        head = tomlkit.document()
        for note in header:
            head.add(comment(note))
        self._pieces = [_checked(head)]

    def add(self, section: str, item: Table) -> None:
        """Append ``item`` to the array of tables ``section`` (``source``, ``robot``)."""
        piece = tomlkit.document()
        piece.add(tomlkit.nl())
        tables = tomlkit.aot()
        tables.append(item)
        piece.append(section, tables)
        self._pieces.append(_checked(piece))

    def text(self) -> str:
        """The TOML text of the cell."""
        return "".join(self._pieces)


def _checked(doc: TOMLDocument) -> str:
    """``doc`` as text; ValueError unless the text reads back as ``doc``."""
    text = tomlkit.dumps(doc)
    if tomllib.loads(text) != doc.unwrap():
        raise ValueError("a table written does not read back as built")
    return text
