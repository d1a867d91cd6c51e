"""Hub messages packed into one Redis message, and back, without touching their bytes.

A worker publishes what its acquisitions gave the hub since its last
publish as one batch: a Redis message per batch rather than per frame keeps
Redis and both ends of the connection to a few hundred messages a second
whatever the number of sources (see docs/benchmarks.md, bench/cluster.py).

Each item: a 16-byte header (little-endian: payload kind u8, protocol u8
(0: every protocol), key length u16, payload length u32, t_source f64 (NaN:
none)), the key (UTF-8), then the payload: bytes as they are, a text as
UTF-8, several texts each ended by a newline (JSON texts never contain one).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Iterator

from ..stream import Message
from ..stream.hub import Payload

ITEM = struct.Struct("<BBHId")
_TEXT, _BYTES, _TEXTS = 0, 1, 2

Item = tuple[str, Message, int | None]
"""What the acquisition gave ``Hub.publish``: key, message, protocol."""


def pack(items: Iterable[Item]) -> bytes:
    """One batch of hub messages as bytes."""
    parts: list[bytes] = []
    for key, message, protocol in items:
        payload = message.payload
        if isinstance(payload, bytes):
            kind, data = _BYTES, payload
        elif isinstance(payload, str):
            kind, data = _TEXT, payload.encode()
        else:
            kind, data = _TEXTS, "".join(f"{text}\n" for text in payload).encode()
        name = key.encode()
        t = math.nan if message.t_source is None else message.t_source
        parts += (ITEM.pack(kind, protocol or 0, len(name), len(data), t), name, data)
    return b"".join(parts)


def unpack(batch: bytes) -> Iterator[Item]:
    """The hub messages of a batch, in the order they were published; ValueError if garbled."""
    at, end, view = 0, len(batch), memoryview(batch)
    while at < end:
        if end - at < ITEM.size:
            raise ValueError(f"{end - at} bytes left: not a whole item header")
        kind, protocol, key_size, size, t = ITEM.unpack_from(batch, at)
        at += ITEM.size
        if at + key_size + size > end:
            raise ValueError("an item runs past the end of the batch")
        key = str(view[at : at + key_size], "utf-8")
        at += key_size
        data = batch[at : at + size]
        at += size
        payload: Payload
        if kind == _BYTES:
            payload = data
        elif kind == _TEXT:
            payload = data.decode()
        elif kind == _TEXTS:
            payload = tuple(data.decode().split("\n")[:-1])
        else:
            raise ValueError(f"unknown payload kind {kind}")
        yield key, Message(payload, None if math.isnan(t) else t), protocol or None
