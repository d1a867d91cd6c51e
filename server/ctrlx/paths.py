"""Data-layer node addresses as URL paths, and the addresses a request must never name."""

from __future__ import annotations

from urllib.parse import quote

DOT_SEGMENTS = frozenset({".", ".."})
MAX_NAME_CHARS = 256
"""Longer names are refused where a device supplies them (a motion app's are far shorter)."""


def encode_node_path(node: str) -> str:
    """Percent-encode each segment of a node address; ``/`` separators stay.

    Spaces, ``^``, ``%``, ``#`` and ``?`` inside a segment are encoded, so a
    node such as ``plc/app/Application/sym/PLC_PRG/a^b`` survives the trip.
    """
    return "/".join(quote(segment, safe="") for segment in node.strip("/").split("/"))


def node_problem(node: str) -> str | None:
    """Why ``node`` may not be requested, or None.

    A ``.`` or ``..`` segment is resolved by the URL itself (yarl, like every
    browser, removes it before sending): ``motion/axs/../../../x`` would leave
    the nodes API and reach another path of the device, with our token. Percent
    signs are encoded by ``encode_node_path``, so ``%2e%2e`` stays a name.
    """
    if any(segment in DOT_SEGMENTS for segment in node.strip("/").split("/")):
        return "a '.' or '..' segment would leave the data layer's nodes"
    return None


def name_problem(name: str) -> str | None:
    """Why a name a device lists (an axis, a kinematics) is not one node segment, or None.

    Stricter than ``node_problem``: the name becomes part of node addresses
    written into a cell, so it must be one plain segment, nothing a proxy or a
    person could read another way.
    """
    if not name.strip():
        return "the name is empty"
    if len(name) > MAX_NAME_CHARS:
        return f"the name is {len(name)} characters long (at most {MAX_NAME_CHARS})"
    if name in DOT_SEGMENTS or any(c in name for c in "/\\%"):
        return "the name holds '/', '\\', '%' or is '.' or '..': it would name other nodes"
    if not name.isprintable():
        return "the name holds control characters"
    return None
