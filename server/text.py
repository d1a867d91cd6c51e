"""Words for people: counts with the right number, and text from elsewhere made safe to show."""

from __future__ import annotations


def plural(n: int, word: str, words: str | None = None) -> str:
    """``1 joint``, ``2 joints`` (``words``: the plural where it is not ``word + "s"``)."""
    return f"{n} {word if n == 1 else words or word + 's'}"


def printable(text: str) -> str:
    """``text`` on one line with every control or format character escaped (``\\x1b``, ``\\n``).

    Text a device or a file supplies (names, units, error details) reaches a
    terminal, a log or a TOML comment through this: an ANSI escape cannot
    recolour or rewrite a terminal, a newline cannot end a comment and start a
    key, a right-to-left override cannot reorder what a person reads.
    """
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
