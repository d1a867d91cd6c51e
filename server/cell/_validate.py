"""A cell file against its schema: every mistake at once, and the other checks still run.

pydantic reports every schema error of a file, but then yields no model, so the
checks across keys (joint counts, files, sources) would only show in the next
run. Here each source and robot is validated on its own, and one with mistakes
is validated again without the keys at fault (their defaults stand in), so its
other checks still run. Keys are named with the item's name,
``robot[1] "arm".joints[3].unit``, and a wrong choice suggests the near one.
"""

from __future__ import annotations

import copy
import difflib
from dataclasses import dataclass, field
from typing import Any, TypeVar

from pydantic import TypeAdapter, ValidationError

from . import schema

M = TypeVar("M")
SECTIONS = ("source", "robot")
REPAIR_ROUNDS = 5


@dataclass
class Validated:
    """What of a file passed the schema, by index, and what did not."""

    cell: schema.Cell | None
    """The whole file, when it passed as it is."""
    sources: dict[int, schema.Source]
    robots: dict[int, schema.Robot]
    names: dict[str, dict[int, str]]
    """The name each source and robot gives itself, valid or not, by section and index."""
    problems: list[tuple[str, str]] = field(default_factory=list)
    faulty: list[str] = field(default_factory=list)
    """Keys with a schema problem: what later checks find under them is only its echo."""

    def label(self, section: str, index: int) -> str:
        """``robot[1] "arm"``: the item's index and, if it has one, its name."""
        name = self.names.get(section, {}).get(index)
        return f'{section}[{index}] "{name}"' if name else f"{section}[{index}]"

    def echoes(self, key: str) -> bool:
        """True if ``key`` is at or under a key that already has a schema problem."""
        return any(key == f or key.startswith((f"{f}.", f"{f}[")) for f in self.faulty)


def validate(raw: dict[str, Any]) -> Validated:
    """``raw`` (a parsed TOML file) against ``schema.Cell``, item by item where it fails."""
    names = {s: _names(raw.get(s)) for s in SECTIONS}
    try:
        cell = schema.Cell.model_validate(raw)
    except ValidationError as exc:
        errors = exc.errors()
    else:
        return Validated(cell, dict(enumerate(cell.source)), dict(enumerate(cell.robot)), names)
    result = Validated(
        None,
        _lenient(raw.get("source"), TypeAdapter(schema.Source)),
        _lenient(raw.get("robot"), TypeAdapter(schema.Robot)),
        names,
    )
    for error in errors:
        key, reason = _problem(error, result)
        result.problems.append((key, reason))
        result.faulty.append(key)
    return result


def _names(items: object) -> dict[int, str]:
    if not isinstance(items, list):
        return {}
    return {
        i: item["name"]
        for i, item in enumerate(items)
        if isinstance(item, dict) and isinstance(item.get("name"), str) and item["name"]
    }


def _lenient(items: object, model: TypeAdapter[M]) -> dict[int, M]:
    """Each item that passes ``model``, if need be without the keys at fault."""
    if not isinstance(items, list):
        return {}
    passed: dict[int, M] = {}
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            continue
        attempt = copy.deepcopy(item)
        for _ in range(REPAIR_ROUNDS):
            try:
                passed[i] = model.validate_python(attempt)
                break
            except ValidationError as exc:
                if not all(_drop(attempt, e) for e in exc.errors()):
                    break  # a required key is wrong: nothing to check on without it
    return passed


def _drop(item: dict[str, Any], error: Any) -> bool:
    """Remove the key ``error`` is about, so its default stands in; False if it has none."""
    path = _path(error["loc"], within_item=True)
    if error["type"] == "missing" or not path or not isinstance(path[-1], str):
        return False
    parent: Any = item
    for part in path[:-1]:
        try:
            parent = parent[part]
        except (KeyError, IndexError, TypeError):
            return False
    if not isinstance(parent, dict) or path[-1] not in parent:
        return False
    if error["type"].startswith("union_tag"):
        return False  # the kinematics' or source's type: everything below it depends on it
    del parent[path[-1]]
    return True


def _path(loc: tuple[Any, ...], within_item: bool = False) -> list[Any]:
    """``loc`` without the tags pydantic inserts for the discriminated unions (kinematics, source).

    ``within_item``: ``loc`` starts inside one source or robot, not at the file's top.
    """
    source_tag_at = 0 if within_item else 2
    return [part for k, part in enumerate(loc) if not _is_tag(loc, k, source_tag_at)]


def _is_tag(loc: tuple[Any, ...], k: int, source_tag_at: int) -> bool:
    part = loc[k]
    if part in schema.KINEMATICS_TYPES and k > 0 and loc[k - 1] == "kinematics":
        return True
    return part in schema.SOURCE_TYPES and k == source_tag_at and (k == 0 or loc[0] == "source")


def _types(path: list[Any]) -> tuple[str, ...]:
    """The ``type`` choices of the union ``path`` is in: a source's kind or a kinematics family."""
    if len(path) <= 2 and path[:1] == ["source"]:
        return schema.SOURCE_TYPES
    return schema.KINEMATICS_TYPES


def _problem(error: Any, validated: Validated) -> tuple[str, str]:
    path = _path(error["loc"])
    key = ""
    for k, part in enumerate(path):
        if k == 1 and path[0] in SECTIONS and isinstance(part, int):
            key = validated.label(path[0], part)
        elif isinstance(part, int):
            key += f"[{part}]"
        else:
            key += f".{part}" if key else str(part)
    kind, msg = error["type"], error["msg"]
    if kind == "extra_forbidden":
        msg = "unknown key"
    elif kind == "missing":
        msg = "required key is missing"
    elif kind == "union_tag_invalid":
        key += ".type"
        bad = error.get("ctx", {}).get("tag", "")
        types = _types(path)
        msg = f"must be one of {', '.join(types)}, not {bad!r}{_near(bad, types)}"
    elif kind == "union_tag_not_found":
        msg = f"needs a 'type' ({', '.join(_types(path))})"
    elif kind == "literal_error":
        expected = error.get("ctx", {}).get("expected", "")
        options = [c.strip(" '") for c in expected.replace(" or ", ", ").split(",")]
        bad = error["input"]
        msg = f"must be {expected}, not {bad!r}{_near(bad, options)}"
    return key or "(top level)", msg


def _near(value: object, choices: tuple[str, ...] | list[str]) -> str:
    """`` (did you mean 'dh'?)`` for a value close to one of ``choices``; else empty."""
    if not isinstance(value, str):
        return ""
    folded = {c.lower(): c for c in choices}
    close = difflib.get_close_matches(value.lower(), list(folded), n=1, cutoff=0.6)
    return f" (did you mean {folded[close[0]]!r}?)" if close else ""
