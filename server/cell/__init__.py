"""The cell: which robots exist, where they stand, and which data-layer nodes drive them."""

from . import transformation
from .load import Cell, CellError, Source, load_cell
from .robot import Joint, Kinematics, Robot

__all__ = [
    "Cell",
    "CellError",
    "Joint",
    "Kinematics",
    "Robot",
    "Source",
    "load_cell",
    "transformation",
]
