"""OPC UA node keys as a cell names them: a NodeId, or a browse path spelled with namespace URIs.

A node key is one of

* a NodeId in OPC UA's text form (Part 6, 5.3.1.10): ``ns=3;s=Robot1.Axis1.Pos``,
  ``nsu=http://example.com/robots/;i=6012``, ``i=2258``, ``ns=2;g=<GUID>``,
  ``ns=2;b=<base64>``. ``nsu=`` (the namespace's URI) is what ``discover`` writes:
  a server may number its namespaces differently after an update or a restart,
  the URI stays;
* a browse path from the Objects folder, ``/``-separated browse names, each
  ``{namespace URI}Name`` (or plain ``Name`` in the OPC UA namespace), e.g.
  ``{http://opcfoundation.org/UA/DI/}DeviceSet/{urn:acme}Cell1/...``. A ``/``, ``{``,
  ``}`` or ``&`` inside a name is escaped with ``&`` (as OPC UA's relative paths do).

Keys are parsed here without a server; ``server.opcua.resolve`` finds their NodeIds
in a session.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from asyncua import ua
from asyncua.ua.uaerrors import UaStringParsingError

NODE_ID = re.compile(r"^(ns|nsu|i|s|g|b)=")
"""What starts a NodeId key (``ns=``, ``nsu=``, ``i=``, ...); anything else is a browse path."""
_ESCAPED = "/{}&"


@dataclass(frozen=True)
class NodeIdKey:
    """A NodeId, its namespace named by URI (``uri``) or by index (``node.NamespaceIndex``)."""

    node: ua.NodeId
    uri: str | None = None


@dataclass(frozen=True)
class BrowsePathKey:
    """A path of browse names ``(namespace URI, name)`` from the Objects folder."""

    names: tuple[tuple[str, str], ...]

    def text(self, upto: int | None = None) -> str:
        """The path (or its first ``upto`` names) spelled as a node key."""
        return "/".join(_spell(uri, name) for uri, name in self.names[:upto])


NodeKey = NodeIdKey | BrowsePathKey
OPC_UA_URI = "http://opcfoundation.org/UA/"
"""Namespace 0's URI: a browse name without ``{...}`` is in it."""


def parse_node(key: str) -> NodeKey:
    """The node a key names; raises ValueError saying what is wrong with it."""
    text = key.strip()
    if not text:
        raise ValueError("an OPC UA node key must not be empty")
    if NODE_ID.match(text):
        return _node_id(text)
    return BrowsePathKey(tuple(_names(text)))


def check_node(key: str) -> None:
    """Raise ValueError for a key that is no OPC UA NodeId or browse path."""
    parse_node(key)


def node_id_key(node: ua.NodeId, uri: str) -> str:
    """The key naming ``node`` by its namespace's URI (``i=...`` alone in namespace 0)."""
    plain = ua.NodeId(node.Identifier, ua.Int16(0), node.NodeIdType).to_string()
    if node.NamespaceIndex == 0:
        return plain
    return f"nsu={uri};{plain}"


def _node_id(text: str) -> NodeIdKey:
    try:
        node = ua.NodeId.from_string(text)
    except (UaStringParsingError, ValueError) as exc:
        cause = exc.args[-1] if exc.args else exc
        raise ValueError(f"not a valid OPC UA NodeId ({cause})") from None
    uri = node.NamespaceUri if isinstance(node, ua.ExpandedNodeId) else None
    if isinstance(node, ua.ExpandedNodeId) and node.ServerIndex:
        raise ValueError("a NodeId on another server (srv=) cannot be read")
    if uri is not None and not uri.strip():
        raise ValueError("nsu= needs the namespace's URI")
    return NodeIdKey(ua.NodeId(node.Identifier, node.NamespaceIndex, node.NodeIdType), uri)


def _names(text: str) -> list[tuple[str, str]]:
    """The ``(uri, name)`` pairs of a browse path; raises ValueError."""
    names: list[tuple[str, str]] = []
    uri, name, in_uri, i = OPC_UA_URI, "", False, 0
    at_start = True
    while i < len(text):
        char = text[i]
        if char == "&":
            if i + 1 >= len(text) or text[i + 1] not in _ESCAPED:
                raise ValueError(f"'&' at {i} must escape one of {_ESCAPED!r}")
            name, i = name + text[i + 1], i + 2
            at_start = False
            continue
        if in_uri:
            if char == "}":
                in_uri, at_start = False, False
                if not uri:
                    raise ValueError(f"an empty namespace URI {{}} at {i}")
            else:
                uri += char
        elif char == "{" and at_start:
            in_uri, uri = True, ""
        elif char in "{}":
            raise ValueError(f"{char!r} at {i}: a namespace URI {{...}} only starts a name")
        elif char == "/":
            names.append(_named(uri, name, len(names)))
            uri, name, at_start = OPC_UA_URI, "", True
        else:
            name += char
            at_start = False
        i += 1
    if in_uri:
        raise ValueError("a namespace URI {... is not closed")
    names.append(_named(uri, name, len(names)))
    return names


def _named(uri: str, name: str, index: int) -> tuple[str, str]:
    if not name:
        raise ValueError(f"browse name {index + 1} of the path is empty")
    return uri, name


def _spell(uri: str, name: str) -> str:
    escaped = "".join(f"&{c}" if c in _ESCAPED else c for c in name)
    return escaped if uri == OPC_UA_URI else f"{{{uri}}}{escaped}"
