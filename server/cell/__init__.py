"""The cell: which robots exist, where they stand, and which data-layer nodes drive them."""

from . import transformation
from .default import default_cell
from .robot import Joint, Kinematics, Robot

__all__ = ["Joint", "Kinematics", "Robot", "default_cell", "transformation"]
