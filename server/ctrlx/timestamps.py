"""Data-layer timestamps: Windows FILETIME (100 ns ticks since 1601-01-01 UTC) and unix time."""

from __future__ import annotations

from typing import Any

FILETIME_UNIX_EPOCH = 116_444_736_000_000_000
"""FILETIME of 1970-01-01 00:00 UTC."""
TICKS_PER_S = 10_000_000
FIRST_FILETIME_S = 315_532_800.0
"""1980-01-01 in unix seconds: an earlier 'FILETIME' is a counter or a unix time."""


def unix_from_filetime(filetime: int) -> float:
    """Unix seconds of a FILETIME."""
    return (filetime - FILETIME_UNIX_EPOCH) / TICKS_PER_S


def filetime_from_unix(t: float) -> int:
    """FILETIME of unix seconds ``t`` (rounded to 100 ns)."""
    return FILETIME_UNIX_EPOCH + round(t * TICKS_PER_S)


def parse_filetime(raw: Any) -> float | None:
    """Unix seconds of a FILETIME given as int or decimal string; None if it is not one.

    Values before 1980 are rejected: a counter or a unix time is no FILETIME.
    """
    if isinstance(raw, str) and raw.isascii() and raw.isdigit():
        raw = int(raw)
    if isinstance(raw, bool) or not isinstance(raw, int):
        return None
    t = unix_from_filetime(raw)
    return t if t >= FIRST_FILETIME_S else None
