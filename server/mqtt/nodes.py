"""MQTT node keys: a topic, and where the value is in its payload.

A joint's node is ``TOPIC`` (the payload is the number, as text) or
``TOPIC#POINTER`` (the payload is JSON; the value is at the JSON pointer,
RFC 6901, e.g. ``cell/ur5e/state#/joints/3``). ``#`` cannot be part of a
topic one publishes to (it is the subscription wildcard), so the split is
unambiguous, and ``#/...`` reads as RFC 6901's URI-fragment form.

A Sparkplug B metric is ``spBv1.0/GROUP/EDGE[/DEVICE]#METRIC NAME``: the topic
without its message type (births, data and deaths all count), and the metric's
name as its birth certificate gives it (see sparkplug.py).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from urllib.parse import urlsplit

import orjson

from . import sparkplug

PORTS = {"mqtt": 1883, "mqtts": 8883}


@dataclass(frozen=True)
class Node:
    """Where one value is: ``topic``, and ``pointer`` into its JSON payload (None: plain)."""

    topic: str
    pointer: tuple[str, ...] | None = None
    """Reference tokens of the JSON pointer, unescaped (``~1`` -> ``/``, ``~0`` -> ``~``)."""
    metric: str | None = None
    """A Sparkplug B metric's name (``topic`` is then ``spBv1.0/GROUP/EDGE[/DEVICE]``)."""


class PayloadError(ValueError):
    """A payload that does not hold the value where the cell says: shown as the joint's error."""


def parse_node(text: str) -> Node:
    """The topic and pointer of ``text``; ValueError if it cannot name a published value."""
    topic, hash_, pointer = text.partition("#")
    if not topic or "+" in topic or "\0" in topic:
        raise ValueError(
            f"{text!r}: name a topic one publishes to (no + or # wildcards), optionally "
            "followed by #/json/pointer"
        )
    if len(topic.encode()) > 65535:
        raise ValueError(f"{text[:40]!r}...: an MQTT topic has at most 65535 bytes")
    if topic.startswith(sparkplug.NAMESPACE + "/"):
        return _sparkplug_node(text, topic, pointer)
    if not hash_:
        return Node(topic)
    if pointer and not pointer.startswith("/"):
        raise ValueError(f"{text!r}: a JSON pointer starts with / (e.g. #/joints/3)")
    tokens = tuple(t.replace("~1", "/").replace("~0", "~") for t in pointer.split("/")[1:])
    return Node(topic, tokens)


def _sparkplug_node(text: str, topic: str, metric: str) -> Node:
    parts = topic.split("/")
    if len(parts) not in (3, 4) or not all(parts) or parts[2] in sparkplug.TYPES or not metric:
        raise ValueError(
            f"{text!r}: a Sparkplug B metric is spBv1.0/GROUP/EDGE[/DEVICE]#METRIC NAME "
            "(the topic without NBIRTH, DDATA, ...)"
        )
    return Node(topic, metric=metric)


_USERINFO = re.compile(r"//[^/@]*@")


def mqtt_address(url: str) -> tuple[str, int, bool]:
    """``(host, port, tls)`` of ``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]``."""
    parts = urlsplit(url)
    url = _USERINFO.sub("//", url)  # a password put in the URL is never echoed
    if parts.scheme not in PORTS or not parts.hostname:
        raise ValueError(f"{url!r} is no broker address: write mqtt://HOST[:PORT] or mqtts://...")
    if parts.username or parts.password:
        raise ValueError(f"{url!r}: give the source's user, and the password in password_env")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(f"{url!r}: a broker address is mqtt://HOST[:PORT], nothing more")
    try:
        port = parts.port or PORTS[parts.scheme]
    except ValueError as exc:
        raise ValueError(f"{url!r}: {exc}") from None
    return parts.hostname, port, parts.scheme == "mqtts"


def check_mqtt_url(url: str) -> None:
    """Raises ValueError unless ``url`` is a broker address."""
    mqtt_address(url)


def value_in(node: Node, payload: bytes | bytearray, document: object = None) -> float:
    """The number ``node`` names in ``payload`` (``document``: the payload already parsed).

    Raises PayloadError saying what the payload holds instead.
    """
    if node.pointer is None:
        try:
            value = float(payload.decode().strip())
        except (UnicodeDecodeError, ValueError):
            raise PayloadError(f"{node.topic}: payload {_shown(payload)} is not a number") from None
        return _finite(node, value)
    at: object = document
    for depth, token in enumerate(node.pointer):
        where = "/" + "/".join(node.pointer[: depth + 1])
        if isinstance(at, dict):
            if token not in at:
                raise PayloadError(f"{node.topic}: the JSON payload has no {where}")
            at = at[token]
        elif isinstance(at, list):
            if not token.isdigit() or (token != "0" and token.startswith("0")):
                raise PayloadError(f"{node.topic}: {where}: an array takes an index")
            if int(token) >= len(at):
                raise PayloadError(f"{node.topic}: {where}: the array has {len(at)} items")
            at = at[int(token)]
        else:
            raise PayloadError(f"{node.topic}: {where}: nothing below a {type(at).__name__}")
    if isinstance(at, bool) or not isinstance(at, int | float):
        raise PayloadError(
            f"{node.topic}#{'/' + '/'.join(node.pointer)}: {_shown_json(at)} is not a number"
        )
    return _finite(node, float(at))


def parsed(payload: bytes | bytearray, topic: str) -> object:
    """The JSON document of ``payload``; PayloadError if it is not JSON."""
    try:
        return orjson.loads(payload)
    except orjson.JSONDecodeError:
        raise PayloadError(f"{topic}: payload {_shown(payload)} is not JSON") from None


def _finite(node: Node, value: float) -> float:
    if not math.isfinite(value):
        raise PayloadError(f"{node.topic}: {value} is not a finite number")
    return value


def _shown(payload: bytes | bytearray) -> str:
    """A payload as a log line may show it: short, and never control characters."""
    text = payload[:40].decode(errors="replace")
    text = "".join(c if c.isprintable() else "?" for c in text)
    return repr(text + ("..." if len(payload) > 40 else ""))


def _shown_json(value: object) -> str:
    return _shown(orjson.dumps(value))
