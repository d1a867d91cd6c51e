"""Words for people: counts with the right number."""

from __future__ import annotations


def plural(n: int, word: str, words: str | None = None) -> str:
    """``1 joint``, ``2 joints`` (``words``: the plural where it is not ``word + "s"``)."""
    return f"{n} {word if n == 1 else words or word + 's'}"
