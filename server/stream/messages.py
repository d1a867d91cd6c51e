"""The JSON messages that describe the cell rather than a sample: ``hello`` and ``cell``."""

from __future__ import annotations

import orjson

from ..protocol import CellNotice, Hello, RobotInfo

PROTOCOL_VERSIONS = (1, 2)


def hello_message(robots: list[RobotInfo], session: str, protocol: int) -> str:
    """The ``hello`` a viewer of ``protocol`` gets first, and again when the cell changes."""
    hello = Hello(type="hello", protocol=protocol, session=session, robots=robots)
    return orjson.dumps(hello.model_dump()).decode()


def cell_message(path: str | None, error: str | None) -> str:
    """The ``cell`` notice: which file is shown, and why its newest version is not (if so)."""
    return orjson.dumps(CellNotice(type="cell", path=path, error=error).model_dump()).decode()
