"""Small helpers every batch-first family shares."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

BoolArray = npt.NDArray[np.bool_]


def all_along_last(mask: BoolArray) -> BoolArray:
    """``mask.all(axis=-1)``, always as an array (0-d for one configuration)."""
    return np.asarray(np.all(mask, axis=-1), dtype=np.bool_)
