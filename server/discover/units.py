"""From a controller's unit text to the cell's ``unit`` and ``scale`` (docs/cell.md)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Mapping:
    """How a joint entry reads a node: its cell ``unit``, ``scale``, and whether it was guessed."""

    unit: str
    scale: float = 1.0
    guessed: bool = False


_KNOWN: dict[str, tuple[str, float]] = {
    "deg": ("deg", 1.0),
    "°": ("deg", 1.0),
    "degree": ("deg", 1.0),
    "rad": ("rad", 1.0),
    "mrad": ("rad", 1e-3),
    "mm": ("mm", 1.0),
    "m": ("m", 1.0),
    "µm": ("mm", 1e-3),
    "um": ("mm", 1e-3),
    "cm": ("mm", 10.0),
    "in": ("mm", 25.4),
    "inch": ("mm", 25.4),
}
ROTARY_UNITS = {"deg", "rad"}


def mapping(unit: str | None, kind: str | None) -> Mapping:
    """The cell ``unit``/``scale`` for a node in ``unit`` of an axis of ``kind``.

    ``kind`` is ``ROTATIONAL``, ``LINEAR`` or None. A unit that is missing or
    unknown gives the kind's usual unit (``deg``, ``mm``), marked as a guess.
    """
    known = _KNOWN.get((unit or "").strip())
    if known is not None:
        return Mapping(*known)
    return Mapping("mm" if kind == "LINEAR" else "deg", 1.0, guessed=True)


def is_rotary(unit: str | None, kind: str | None) -> bool:
    """Whether an axis turns (by ``kind`` if known, else by its unit)."""
    if kind in ("ROTATIONAL", "LINEAR"):
        return kind == "ROTATIONAL"
    return mapping(unit, kind).unit in ROTARY_UNITS
