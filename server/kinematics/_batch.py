"""Small helpers every batch-first family shares."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


def all_along_last(mask: BoolArray) -> BoolArray:
    """``mask.all(axis=-1)``, always as an array (0-d for one configuration)."""
    return np.asarray(np.all(mask, axis=-1), dtype=np.bool_)


def finite_rows(arr: Array) -> tuple[Array, BoolArray]:
    """``arr`` ``(..., n)`` with non-finite entries taken as 0, and where its rows were all finite.

    Checks the whole array first: a reduction along a short last axis costs
    about 40x more (2.8 ms on 100 000 x 7), and rows are almost always finite.
    """
    finite = np.isfinite(arr)
    if finite.all():
        return arr, np.ones(arr.shape[:-1], dtype=np.bool_)
    return np.where(finite, arr, 0.0), all_along_last(finite)
