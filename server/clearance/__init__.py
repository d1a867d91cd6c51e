"""Clearance between robots: how close the links of different robots come, from their meshes.

``shapes`` turns each link's GLB into a collision shape; ``checker`` finds the
closest pair of links for every pair of robots near each other (python-fcl
through trimesh); ``service`` runs it at 10 Hz on the newest joint values and
tells the viewers.
"""

from __future__ import annotations

from .checker import ClearanceChecker, Near
from .service import CLEARANCE_KEY, ClearanceService
from .shapes import link_shapes

__all__ = ["CLEARANCE_KEY", "ClearanceChecker", "ClearanceService", "Near", "link_shapes"]
