"""Commissioning a cell from the page: samples, calibrated frames, descriptions, saved edits.

``changes`` turns what the page asks (SI units) into edits of the cell file's
text (``server.cell.edit``); ``session`` runs them unsaved, saves them with a
backup, and undoes a save; ``placement`` places a robot from numbers or from
a calibrated frame (``server.kinematics.calibration``); ``descriptions`` finds
the robot descriptions on this machine.
"""

from .changes import Changes, maker
from .descriptions import Catalog, preview
from .errors import CommissioningError
from .placement import tcp_now
from .session import ENABLE, CellEditor

__all__ = [
    "ENABLE",
    "Catalog",
    "CellEditor",
    "Changes",
    "CommissioningError",
    "maker",
    "preview",
    "tcp_now",
]
