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
from dataclasses import fields
from pathlib import Path

import pytest
from pydantic import BaseModel

from server.protocol import (
    MESSAGE_TYPES,
    Clearance,
    Frame,
    Frames2,
    Hello,
    JointInfo,
    LinkInfo,
    NearLinks,
    RobotFrame2,
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
    "clearance": Clearance,
    "near": NearLinks,
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


# Protocol 2: the decoder's objects carry the fields of the server's decoded dataclasses,
# and the page reads no others (`frames` is a decoded message, `entry` one robot of it).
DECODED = re.compile(r"robots\[\s*r\s*\]\s*=\s*\{([^}]*)\}")
RETURNED = re.compile(r"return\s*\{\s*(seq[^}]*)\}")


def _keys(literal: str) -> set[str]:
    return {part.split(":")[0].strip() for part in literal.split(",") if part.strip()}


def test_protocol2_decoder_returns_the_fields_of_decode_frames() -> None:
    source = (JS_DIR / "protocol2.js").read_text()
    robot = DECODED.search(source)
    message = RETURNED.search(source)
    assert robot and message, "decodeFrames no longer builds its objects where this test looks"
    assert _keys(robot[1]) == {f.name for f in fields(RobotFrame2)}
    assert _keys(message[1]) == {f.name for f in fields(Frames2)}


def test_page_reads_only_decoded_protocol2_fields() -> None:
    source = COMMENT.sub("", (JS_DIR / "app.js").read_text())
    allowed = {
        "frames": {f.name for f in fields(Frames2)},
        "entry": {f.name for f in fields(RobotFrame2)},
    }
    read = re.findall(r"(?<![\w$.])(frames|entry)\.([A-Za-z_$][\w$]*)", source)
    assert read, "app.js no longer reads protocol-2 messages as `frames` and `entry`"
    unknown = {f"{var}.{name}" for var, name in read if name not in allowed[var]}
    assert not unknown, unknown
