"""The wire contract: every message field the page reads exists in ``server/protocol.py``.

The page names its message variables after the protocol models (``hello``,
``frame``, ``status``, ``robot``, ``joint``, ``link``, ``source``), so a read
such as ``frame.links`` in ``static/js/*.js`` can be checked against
``Frame.model_fields``. Renaming a field on either side without the other
fails here instead of in a browser.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

import pytest
from pydantic import BaseModel

from server.protocol import (
    MESSAGE_TYPES,
    Frame,
    Hello,
    JointInfo,
    LinkInfo,
    RobotInfo,
    SourceStatus,
    Status,
)

JS_DIR = Path(__file__).resolve().parents[2] / "static" / "js"

MODELS: dict[str, type[BaseModel]] = {
    "hello": Hello,
    "frame": Frame,
    "status": Status,
    "robot": RobotInfo,
    "joint": JointInfo,
    "link": LinkInfo,
    "source": SourceStatus,
}

# `frame.links`, `${source.name}`, `hello.robots.forEach` (first field only); not
# `view.frame.x` or `'./robot.js'`, where the name is a property or a file.
READ = re.compile(r"(?<![\w$./'\"])(" + "|".join(MODELS) + r")\s*\??\.\s*([A-Za-z_$][\w$]*)")
COMMENT = re.compile(r"/\*.*?\*/|(?<![:'\"`])//[^\n]*", re.S)
MESSAGE_CASE = re.compile(r"case\s+'(\w+)'\s*:")


def reads(source: str) -> set[tuple[str, str]]:
    """(variable, field) pairs read in JavaScript ``source``, comments ignored."""
    return {(m[1], m[2]) for m in READ.finditer(COMMENT.sub("", source))}


def page_reads() -> dict[tuple[str, str], list[str]]:
    """Every (variable, field) read in ``static/js/*.js`` and the files reading it."""
    found: dict[tuple[str, str], list[str]] = defaultdict(list)
    for path in sorted(JS_DIR.glob("*.js")):
        for pair in reads(path.read_text()):
            found[pair].append(path.name)
    return dict(found)


def test_extractor_sees_reads_and_ignores_the_rest() -> None:
    js = """
        import { RobotView } from './robot.js';   // robot.fake in a comment
        const n = frame.links.length + hello?.robots;
        label.textContent = `${source.name}: ${view.frame.nope}`;
        /* status.nope */ robot . joints;
    """
    assert reads(js) == {
        ("frame", "links"),
        ("hello", "robots"),
        ("source", "name"),
        ("robot", "joints"),
    }


def test_page_reads_enough_fields_to_mean_something() -> None:
    found = page_reads()
    assert len(found) >= 20, sorted(found)
    assert {name for name, _ in found} == set(MODELS), sorted(found)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_field_the_page_reads_exists(name: str) -> None:
    model = MODELS[name]
    unknown = {
        f"{var}.{field} ({', '.join(files)})"
        for (var, field), files in page_reads().items()
        if var == name and field not in model.model_fields
    }
    assert not unknown, f"not fields of {model.__name__}: {sorted(unknown)}"


def test_the_page_handles_exactly_the_protocol_messages() -> None:
    handled = set(MESSAGE_CASE.findall((JS_DIR / "app.js").read_text()))
    assert handled == set(MESSAGE_TYPES)
