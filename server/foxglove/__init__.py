"""The live Foxglove endpoint (``--foxglove PORT``) and the guard in front of it."""

from .guard import Guard
from .live import FoxgloveEndpoint

__all__ = ["FoxgloveEndpoint", "Guard"]
