"""Denavit-Hartenberg chains: the forward kernels (``_fk``), ``DHChain`` (``chain``)
and the KUKA LBR iiwa with its geometric inverse (``iiwa``). Modules import in that order.
"""

from .chain import DHChain
from .iiwa import IiwaSolutions, LBRiiwa, iiwa7

__all__ = ["DHChain", "IiwaSolutions", "LBRiiwa", "iiwa7"]
