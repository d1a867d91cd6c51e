"""The RTDE wire format (Universal Robots' Real-Time Data Exchange guide, protocol version 2).

Every package is a header, big-endian ``uint16`` size (header included) and
``uint8`` type, then its payload. The client asks for protocol version 2
(``V``, reply: ``uint8`` accepted), reads the controller version (``v``, reply:
four ``uint32``: major, minor, bugfix, build), sets up an output recipe (``O``:
``double`` frequency and the field names joined by commas; reply: ``uint8``
recipe id and the field types joined by commas, ``NOT_FOUND`` for a field the
controller lacks), and starts (``S``, reply: ``uint8`` accepted). Data packages
(``U``) then carry the recipe id and the fields in recipe order. Text messages
(``M``) may come at any time. Shared by the client (``server.rtde``) and the
mock (``server.mock_rtde``); nothing here does I/O.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from urllib.parse import urlsplit

PORT = 30004
PROTOCOL_VERSION = 2
MAX_FREQUENCY_HZ = 500.0
"""The controller's real-time loop on e-Series (CB3: 125 Hz)."""

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")

HEADER = struct.Struct(">HB")
VERSION = struct.Struct(">IIII")
FREQUENCY = struct.Struct(">d")
U16 = struct.Struct(">H")

NOT_FOUND = "NOT_FOUND"
IN_USE = "IN_USE"
TYPE_FORMATS = {
    "BOOL": "?",
    "UINT8": "B",
    "UINT32": "I",
    "UINT64": "Q",
    "INT32": "i",
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
}
"""struct format of each RTDE data type."""
TYPE_WIDTH = {"VECTOR3D": 3, "VECTOR6D": 6, "VECTOR6INT32": 6, "VECTOR6UINT32": 6}
"""Values per field of a vector type (the others carry one)."""

ROBOT_MODES = {
    -1: "NO_CONTROLLER",
    0: "DISCONNECTED",
    1: "CONFIRM_SAFETY",
    2: "BOOTING",
    3: "POWER_OFF",
    4: "POWER_ON",
    5: "IDLE",
    6: "BACKDRIVE",
    7: "RUNNING",
    8: "UPDATING_FIRMWARE",
}
SAFETY_MODES = {
    1: "NORMAL",
    2: "REDUCED",
    3: "PROTECTIVE_STOP",
    4: "RECOVERY",
    5: "SAFEGUARD_STOP",
    6: "SYSTEM_EMERGENCY_STOP",
    7: "ROBOT_EMERGENCY_STOP",
    8: "VIOLATION",
    9: "FAULT",
    10: "VALIDATE_JOINT_ID",
    11: "UNDEFINED_SAFETY_MODE",
    12: "AUTOMATIC_MODE_SAFEGUARD_STOP",
    13: "SYSTEM_THREE_POSITION_ENABLING_STOP",
}
HALTING_SAFETY_MODES = {3, 5, 6, 7, 8, 9, 12, 13}
"""Safety modes in which the controller holds the robot still (stops, violation, fault)."""
RUNNING = 7
NORMAL = 1
SAFETY_REDUCED = 2
PROTECTIVE_STOP = 3


def halt_text(safety_mode: int) -> str | None:
    """``protective stop`` for PROTECTIVE_STOP, and so on; None for a mode that lets it move."""
    if safety_mode not in HALTING_SAFETY_MODES:
        return None
    return SAFETY_MODES[safety_mode].lower().replace("_", " ")


class WireError(ValueError):
    """Bytes that are not RTDE as the guide describes it."""


def package(kind: int, payload: bytes = b"") -> bytes:
    """A whole package of type ``kind``."""
    if HEADER.size + len(payload) > 0xFFFF:
        raise WireError(f"package of {len(payload)} bytes is too long for RTDE")
    return HEADER.pack(HEADER.size + len(payload), kind) + payload


def text_message(message: str, source: str = "linkview", level: int = 3) -> bytes:
    """A protocol-2 text message (``level`` 0 exception, 1 error, 2 warning, 3 info)."""
    msg, src = message.encode()[:255], source.encode()[:255]
    return package(TEXT_MESSAGE, bytes([len(msg)]) + msg + bytes([len(src)]) + src + bytes([level]))


def read_text_message(payload: bytes) -> str:
    """The text (and its source) of a protocol-2 text message, for the log."""
    n = payload[0] if payload else 0
    msg = payload[1 : 1 + n].decode(errors="replace")
    rest = payload[1 + n :]
    m = rest[0] if rest else 0
    src = rest[1 : 1 + m].decode(errors="replace")
    text = f"{src}: {msg}" if src else msg
    # The device's words go to the log: one line, no control characters.
    return "".join(c if c.isprintable() else "?" for c in text)


_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


@dataclass(frozen=True)
class Key:
    """One value of a recipe: ``field`` and, for a vector field, its ``index``."""

    field: str
    index: int | None = None

    def __str__(self) -> str:
        return self.field if self.index is None else f"{self.field}[{self.index}]"


def parse_key(text: str) -> Key:
    """A node key as a cell names it: ``actual_q[2]``, ``output_double_register_24``.

    Raises ValueError for anything else (an index beyond a known vector's width too).
    """
    match = _KEY.match(text.strip())
    if match is None:
        raise ValueError(
            f"{text!r} is no RTDE output: write a field, or a vector field and index "
            "(e.g. actual_q[2], output_double_register_24)"
        )
    field, index = match[1], None if match[2] is None else int(match[2])
    width = TYPE_WIDTH.get(KNOWN_TYPES.get(field, ""), 1)
    known = field in KNOWN_TYPES
    if known and width > 1 and index is None:
        raise ValueError(f"{field} has {width} values: name one, e.g. {field}[0]")
    if known and index is not None and (width == 1 or not 0 <= index < width):
        what = "no index: it is one value" if width == 1 else f"an index 0 to {width - 1}"
        raise ValueError(f"{field} takes {what}, not [{index}]")
    return Key(field, index)


def register_key(register: int) -> str:
    """The node key of ``output_double_register_<register>``."""
    return f"output_double_register_{register}"


KNOWN_TYPES: dict[str, str] = {
    "timestamp": "DOUBLE",
    "target_q": "VECTOR6D",
    "target_qd": "VECTOR6D",
    "target_qdd": "VECTOR6D",
    "actual_q": "VECTOR6D",
    "actual_qd": "VECTOR6D",
    "actual_TCP_pose": "VECTOR6D",
    "target_TCP_pose": "VECTOR6D",
    "actual_TCP_speed": "VECTOR6D",
    "joint_temperatures": "VECTOR6D",
    "robot_mode": "INT32",
    "joint_mode": "VECTOR6INT32",
    "safety_mode": "INT32",
    "safety_status": "INT32",
    "robot_status_bits": "UINT32",
    "safety_status_bits": "UINT32",
    "runtime_state": "UINT32",
    "speed_scaling": "DOUBLE",
    "target_speed_fraction": "DOUBLE",
    **{f"output_double_register_{i}": "DOUBLE" for i in range(48)},
    **{f"output_int_register_{i}": "INT32" for i in range(48)},
    **{f"output_bit_register_{i}": "BOOL" for i in range(64, 128)},
}
"""Output fields of the RTDE guide this code knows the type of (for checking a cell's keys
and for the mock); the controller's setup reply is what the client trusts."""


_USERINFO = re.compile(r"//[^/@]*@")


def rtde_address(url: str) -> tuple[str, int]:
    """``(host, port)`` of ``rtde://HOST[:PORT]`` (port 30004 by default); ValueError if not one."""
    parts = urlsplit(url)
    url = _USERINFO.sub("//", url)  # a password put in the URL is never echoed
    if parts.scheme != "rtde" or not parts.hostname:
        raise ValueError(f"{url!r} is no RTDE address: write rtde://HOST or rtde://HOST:PORT")
    if parts.path not in ("", "/") or parts.query or parts.fragment or parts.username:
        raise ValueError(f"{url!r}: an RTDE address is rtde://HOST[:PORT], nothing more (no login)")
    try:
        port = parts.port or PORT
    except ValueError as exc:
        raise ValueError(f"{url!r}: {exc}") from None
    return parts.hostname, port


def check_rtde_url(url: str) -> None:
    """Raises ValueError unless ``url`` is ``rtde://HOST[:PORT]``."""
    rtde_address(url)
