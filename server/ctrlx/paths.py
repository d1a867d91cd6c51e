"""Data-layer node addresses as URL paths."""

from __future__ import annotations

from urllib.parse import quote


def encode_node_path(node: str) -> str:
    """Percent-encode each segment of a node address; ``/`` separators stay.

    Spaces, ``^``, ``%``, ``#`` and ``?`` inside a segment are encoded, so a
    node such as ``plc/app/Application/sym/PLC_PRG/a^b`` survives the trip.
    """
    return "/".join(quote(segment, safe="") for segment in node.strip("/").split("/"))
