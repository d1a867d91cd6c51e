"""How big a cell the server runs: files, nesting, robots, sources and nodes past these are refused.

Each bound is named in the problem ``check`` and the reload report, so a
person knows which number to change. They are checked in order of cost: the
file's size before it is read, its nesting and its counts before the schema
sees it (a cell of 100 000 robots, 18 MB, once blocked the server for minutes
and then asked for 56 GiB), the nodes once the robots are built. History
memory depends on the server's settings as well: ``server.runtime.startup``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ..text import plural

MAX_FILE_BYTES = 4 << 20
"""4 MiB: a cell of 1 000 seven-axis robots with setpoints is about 400 kB."""
MAX_DEPTH = 16
"""Tables and arrays inside each other; a cell needs 7 (robot, kinematics, axes, pose, xyz)."""
MAX_ROBOTS = 1000
"""Robots of one cell: every viewer gets all of them in one hello, and one frame per sample."""
MAX_SOURCES = 1000
"""Sources of one cell: each is a connection (and, without ``url``, an embedded mock)."""
MAX_NODES_PER_SOURCE = 4096
"""Nodes one source reads (joints and setpoints): one subscription or bulk read each sample."""
MAX_NODES = 16_384
"""Nodes of the whole cell."""


def file_problem(size: int) -> str | None:
    """Why a cell file of ``size`` bytes is not read, or None."""
    if size > MAX_FILE_BYTES:
        return f"is {_mib(size)}; a cell file may be at most {_mib(MAX_FILE_BYTES)}"
    return None


def nesting(value: Any) -> int:
    """How deeply tables and arrays nest in ``value`` (a parsed TOML document), without
    recursion: a hostile file must not overflow the stack of the code that checks it."""
    deepest, pending = 0, [(value, 1)]
    while pending:
        item, depth = pending.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, depth)
            if depth <= MAX_DEPTH:  # deeper is refused anyway: no need to walk it
                children = item.values() if isinstance(item, dict) else item
                pending.extend((child, depth + 1) for child in children)
    return deepest


def shape_problems(raw: dict[str, Any]) -> list[tuple[str, str]]:
    """The bounds a parsed cell file passes before anything is built from it."""
    depth = nesting(raw)
    if depth > MAX_DEPTH:
        return [("(file)", f"nests tables or arrays more than {MAX_DEPTH} deep")]
    problems = []
    for section, bound in (("source", MAX_SOURCES), ("robot", MAX_ROBOTS)):
        items = raw.get(section)
        if isinstance(items, list) and len(items) > bound:
            count = plural(len(items), section)
            problems.append((section, f"{count}; a cell may have at most {bound}"))
    return problems


def node_problems(sources: Iterable[tuple[str, int]], total: int) -> list[tuple[str, str]]:
    """``(key, node count)`` of each source and the cell's total against the node bounds."""
    problems = [
        (key, f"reads {plural(count, 'node')}; a source may read at most {MAX_NODES_PER_SOURCE}")
        for key, count in sources
        if count > MAX_NODES_PER_SOURCE
    ]
    if total > MAX_NODES:
        problems.append(
            ("(cell)", f"reads {plural(total, 'node')}; a cell may read at most {MAX_NODES}")
        )
    return problems


def _mib(size: int) -> str:
    return f"{size / (1 << 20):.1f} MiB"
