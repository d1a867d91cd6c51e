"""A node's EngineeringUnits (OPC UA Part 8: UNECE codes) as the cell's units, and factors.

OPC UA names a unit by its UNECE Recommendation 20 common code packed into an
Int32 (``UnitId``: each character's byte, most significant first, e.g. "MMT" ->
0x4D4D54) in the namespace ``UNECE_URI``. A joint's values travel in the unit
the cell declares (``deg``, ``rad``, ``mm``, ``m``); where the cell leaves the
unit out, the connector converts each node's values from its EngineeringUnits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from asyncua import ua

UNECE_URI = "http://www.opcfoundation.org/UA/units/un/cefact"


def unece_id(code: str) -> int:
    """The ``UnitId`` OPC UA gives the UNECE common code ``code`` (Part 8, 5.6.3)."""
    value = 0
    for char in code.upper():
        value = (value << 8) | ord(char)
    return value


@dataclass(frozen=True)
class KnownUnit:
    """A unit a node may report: the cell unit it converts into, and the factor to it."""

    code: str
    """UNECE common code."""
    name: str
    """What people call it (shown in errors)."""
    symbol: str
    """The symbol a server shows as DisplayName."""
    cell_unit: str
    """The cell unit of the same kind (``deg`` or ``mm`` family)."""
    factor: float
    """Values in this unit times ``factor`` are in ``cell_unit``."""


KNOWN_UNITS: tuple[KnownUnit, ...] = (
    KnownUnit("DD", "degree", "°", "deg", 1.0),
    KnownUnit("C81", "radian", "rad", "rad", 1.0),
    KnownUnit("C25", "milliradian", "mrad", "rad", 1e-3),
    KnownUnit("MMT", "millimetre", "mm", "mm", 1.0),
    KnownUnit("MTR", "metre", "m", "m", 1.0),
    KnownUnit("CMT", "centimetre", "cm", "mm", 10.0),
    KnownUnit("4H", "micrometre", "µm", "mm", 1e-3),
    KnownUnit("INH", "inch", "in", "mm", 25.4),
)
_BY_ID = {unece_id(u.code): u for u in KNOWN_UNITS}
CELL_UNIT = {u.cell_unit: u for u in KNOWN_UNITS if u.factor == 1.0}
"""The UNECE unit of each cell unit (``deg`` -> degree, ...), as a server would declare it."""
_TO_BASE = {"deg": ("angle", 1.0), "rad": ("angle", 180.0 / math.pi)}
_TO_BASE |= {"mm": ("length", 1.0), "m": ("length", 1000.0)}


def unit_of(info: ua.EUInformation) -> KnownUnit | None:
    """The known unit ``info`` declares, None for one linkview does not convert."""
    if info.NamespaceUri not in (UNECE_URI, None, ""):
        return None
    return _BY_ID.get(int(info.UnitId))


def describe(info: ua.EUInformation) -> str:
    """``info`` for people: its display name and UNECE code."""
    shown = info.DisplayName.Text if info.DisplayName and info.DisplayName.Text else "?"
    code = "".join(chr((int(info.UnitId) >> shift) & 0xFF) for shift in (24, 16, 8, 0)).lstrip("\0")
    return f"{shown!r} (UNECE {code!r})" if code.isprintable() and code else repr(shown)


def factor(unit: KnownUnit, cell_unit: str) -> float:
    """What values in ``unit`` are multiplied by to be in ``cell_unit``; ValueError across kinds."""
    have_kind, have = _TO_BASE[unit.cell_unit]
    want_kind, want = _TO_BASE[cell_unit]
    if have_kind != want_kind:
        raise ValueError(f"the node is in {unit.name}s ({have_kind}); the joint takes {cell_unit}")
    return unit.factor * have / want


def eu_information(cell_unit: str) -> ua.EUInformation:
    """The EngineeringUnits a server declares for values in ``cell_unit``."""
    unit = CELL_UNIT[cell_unit]
    return ua.EUInformation(
        NamespaceUri=UNECE_URI,
        UnitId=unece_id(unit.code),
        DisplayName=ua.LocalizedText(unit.symbol),
        Description=ua.LocalizedText(unit.name),
    )
