"""The ``GET /api/history`` window on the wire: compact binary (default) or JSON.

Binary, little-endian (docs/protocol.md): the magic ``LVH1``, a u32 header
length, a JSON header padded with spaces to a multiple of 8 bytes, then the
arrays the header points to, each at an offset (from the start of the body)
that is a multiple of 8, so a page can view them in place as typed arrays.
Poses and joints are f32, as in protocol 2's frames; times are f64.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import orjson

from .ring import Rows
from .window import Poses, RobotWindow

MAGIC = b"LVH1"
_OPTS = orjson.OPT_SERIALIZE_NUMPY


class _Body:
    """Arrays laid out one after another, 8-byte aligned."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0

    def add(self, array: npt.NDArray[Any], kind: str) -> dict[str, Any]:
        data = np.ascontiguousarray(array, dtype=kind).tobytes()
        entry = {"offset": self.size, "type": _TYPES[kind], "shape": list(array.shape)}
        pad = -len(data) % 8
        self.parts += [data, b"\0" * pad]
        self.size += len(data) + pad
        return entry


_TYPES = {"<f8": "f64", "<f4": "f32", "<u4": "u32", "u1": "u8"}


def encode_binary(
    source: str, t_from: float, t_to: float, rows: Rows, windows: list[RobotWindow], poses: Poses
) -> bytes:
    """The binary window of ``source``."""
    body = _Body()
    header: dict[str, Any] = {
        "source": source,
        "from": t_from,
        "to": t_to,
        "count": len(rows),
        "poses": poses,
        "t": body.add(rows.t, "<f8"),
        "seq": body.add(rows.seq & 0xFFFFFFFF, "<u4"),
        "robots": [],
    }
    for window in windows:
        robot: dict[str, Any] = {
            "name": window.robot.name,
            "index": window.index,
            "ok": body.add(window.ok, "u1"),
            "joints": body.add(window.joints, "<f4"),
            "tcp": None if window.tcp is None else body.add(window.tcp, "<f4"),
            "links": None if window.links is None else body.add(window.links, "<f4"),
            "errors": window.errors,
        }
        header["robots"].append(robot)
    text = orjson.dumps(header)
    text += b" " * (-len(text) % 8)
    return b"".join([MAGIC, len(text).to_bytes(4, "little"), text, *body.parts])


def encode_json(
    source: str, t_from: float, t_to: float, rows: Rows, windows: list[RobotWindow], poses: Poses
) -> bytes:
    """The same window as one JSON object (larger; for scripts and people)."""
    robots = []
    for window in windows:
        joints = window.joints.astype(object)
        joints[~np.isfinite(window.joints)] = None
        robots.append(
            {
                "name": window.robot.name,
                "index": window.index,
                "ok": window.ok,
                "joints": joints.tolist(),
                "tcp": window.tcp,
                "links": window.links,
                "errors": window.errors,
            }
        )
    message = {
        "source": source,
        "from": t_from,
        "to": t_to,
        "count": len(rows),
        "poses": poses,
        "t": rows.t,
        "seq": rows.seq,
        "robots": robots,
    }
    return orjson.dumps(message, option=_OPTS)


def decode_binary(data: bytes) -> dict[str, Any]:
    """The header of a binary window with every array in place of its entry (tests, tools)."""
    if data[:4] != MAGIC:
        raise ValueError("not a linkview history window")
    size = int.from_bytes(data[4:8], "little")
    header: dict[str, Any] = orjson.loads(data[8 : 8 + size])
    body = 8 + size
    kinds = {v: k for k, v in _TYPES.items()}

    def load(entry: dict[str, Any] | None) -> npt.NDArray[Any] | None:
        if entry is None:
            return None
        dtype = np.dtype(kinds[entry["type"]])
        count = int(np.prod(entry["shape"]))
        array = np.frombuffer(data, dtype, count, body + entry["offset"])
        return array.reshape(entry["shape"])

    header["t"], header["seq"] = load(header["t"]), load(header["seq"])
    for robot in header["robots"]:
        for key in ("ok", "joints", "tcp", "links"):
            robot[key] = load(robot[key])
        robot["ok"] = robot["ok"].astype(bool)
    return header
