"""Answers from a device we do not trust: bounded in size, JSON read leniently, summarised."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import aiohttp
import orjson

from .problem import DataLayerError

MAX_BODY_BYTES = 4 * 1024 * 1024
"""Cap on one response body (event streams excepted, they have their own caps).

The largest legitimate answers are bulk reads and browses at ~150 bytes per
node, so 4 MiB still holds a bulk read of ~25 000 nodes or a big PLC symbol
table, while a broken device (an endless or huge body) costs at most 4 MiB
per request instead of all our memory.
"""


class NotJson:
    """Marks a non-empty body that is not JSON; its text is never kept (it may hold secrets)."""

    def __repr__(self) -> str:
        return "NOT_JSON"


NOT_JSON = NotJson()


class BodyTooLarge(DataLayerError):
    """A response body went past MAX_BODY_BYTES; the connection was dropped."""


@dataclass(frozen=True)
class Answer:
    """One HTTP answer: status, what kind of body it had, and its decoded JSON."""

    status: int
    reason: str
    content_type: str
    size: int
    data: Any
    """Decoded JSON; None for an empty body; NOT_JSON for anything else."""
    location: str | None = None

    def describe(self) -> str:
        """What came back, without a byte of its content: ``text/html, 1534 bytes``."""
        kind = self.content_type or "no content type"
        return f"{kind}, {self.size} bytes" + (", not JSON" if self.data is NOT_JSON else "")


def loads(raw: bytes | str) -> Any:
    """Parse JSON, accepting the NaN and Infinity literals some devices send.

    orjson (fast, strict) first; only a body it refuses is parsed again by the
    standard library's C parser, which takes NaN/Infinity/-Infinity, so the
    common case keeps orjson's speed. Raises ValueError if neither can read it.
    """
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError:
        pass
    try:
        return json.loads(raw)
    except ValueError:  # JSONDecodeError and UnicodeDecodeError both are
        raise ValueError("not valid JSON") from None


def decode(content_type: str, raw: bytes) -> Any:
    """JSON of a body: None if empty, NOT_JSON if it is not JSON.

    Parsed whatever the declared type when it looks like JSON: some firmware
    labels its JSON ``text/plain``.
    """
    if not raw.strip():
        return None
    looks_json = raw.lstrip()[:1] in (b"{", b"[")
    if looks_json or content_type == "application/json" or content_type.endswith("+json"):
        try:
            return loads(raw)
        except ValueError:
            return NOT_JSON
    return NOT_JSON


async def read_bounded(
    resp: aiohttp.ClientResponse, what: str, limit: int = MAX_BODY_BYTES
) -> bytes:
    """The body of ``resp``, or BodyTooLarge (connection closed) once it passes ``limit``."""
    if resp.content_length is not None and resp.content_length > limit:
        resp.close()
        raise BodyTooLarge(f"{what}: answer of {resp.content_length} bytes is over {_mib(limit)}")
    chunks: list[bytes] = []
    size = 0
    async for chunk in resp.content.iter_any():
        size += len(chunk)
        if size > limit:
            resp.close()  # the rest is never read: drop the connection, not drain it
            # The traceback keeps this frame alive until a garbage collection: not 4 MiB with it.
            chunks.clear()
            raise BodyTooLarge(f"{what}: answer is larger than {_mib(limit)}; dropped")
        chunks.append(chunk)
    return b"".join(chunks)


def _mib(n: int) -> str:
    return f"{n / 1024 / 1024:g} MiB" if n >= 1024 * 1024 else f"{n / 1024:g} KiB"
