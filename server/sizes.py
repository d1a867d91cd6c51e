"""How large one robot may be: what the cell schema, the URDF reader and the page are sized for.

Published humanoids and dual-arm mobile manipulators have 40 to 110 movable
joints and a few hundred links; the bounds leave room above them while keeping
one frame of one robot within a WebSocket message the page handles at 50 Hz
(2 048 links are 57 KB of poses). The wire's counts are u16 (docs/protocol.md).
"""

from __future__ import annotations

MAX_JOINTS = 256
"""Movable, non-mimic joints per robot."""
MAX_LINKS = 2048
"""Links per robot."""
MAX_NAME_CHARS = 256
"""Characters in a link or joint name (they travel in every hello and on the page)."""
MAX_DESCRIPTION_MB = 64
"""A URDF file read as it is (xacro output is bounded by the worker's ``output_mb``)."""
