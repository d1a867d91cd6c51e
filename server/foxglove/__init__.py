"""The live Foxglove endpoint (``--foxglove PORT``) and the token guard in front of it."""

from .guard import TokenGuard, token_of
from .live import FoxgloveEndpoint

__all__ = ["FoxgloveEndpoint", "TokenGuard", "token_of"]
