"""Reading the page's screenshots: pixels of a colour in a box, and where two pictures differ."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image
from playwright.sync_api import Page

Picture = npt.NDArray[np.float64]
"""Height x width x 3, sRGB in 0..1."""
DIFFERS = 0.12
"""A pixel differs where one channel changed by more than this (antialiased fringes do less)."""


def shot(page: Page) -> Picture:
    """The page as it looks now (viewport, CSS px at device pixel ratio 1)."""
    image = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
    return np.asarray(image, dtype=np.float64) / 255.0


def linear(srgb: Picture) -> Picture:
    """sRGB to linear light (IEC 61966-2-1), where shading multiplies all three channels alike."""
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def crop(picture: Picture, box: dict[str, float]) -> Picture:
    """The part of ``picture`` inside ``box`` ({left, top, right, bottom}, px), clipped to it."""
    height, width = picture.shape[:2]
    left, right = max(0, int(box["left"])), min(width, int(np.ceil(box["right"])))
    top, bottom = max(0, int(box["top"])), min(height, int(np.ceil(box["bottom"])))
    return picture[top:bottom, left:right]


def of_colour(picture: Picture, css_hex: str, tolerance: float = 0.04) -> int:
    """Pixels of ``css_hex``'s hue, lit or shaded: its share of each channel in linear light."""
    target = linear(np.array([int(css_hex[k : k + 2], 16) / 255.0 for k in (1, 3, 5)]))
    lin = linear(picture)
    total = lin.sum(axis=-1)
    lit = total > 0.03  # too dark to tell a hue
    share = lin / np.maximum(total, 1e-9)[..., None]
    close = np.abs(share - target / target.sum()).max(axis=-1) < tolerance
    return int(np.count_nonzero(close & lit))


def changed(before: Picture, after: Picture) -> npt.NDArray[np.bool_]:
    """Where ``after`` differs from ``before`` (same size)."""
    mask: npt.NDArray[np.bool_] = np.abs(after - before).max(axis=-1) > DIFFERS
    return mask


def bounding_box(mask: npt.NDArray[np.bool_]) -> dict[str, Any] | None:
    """{left, top, right, bottom} (px, right and bottom exclusive) of the true pixels, or None."""
    rows = np.flatnonzero(mask.any(axis=1))
    columns = np.flatnonzero(mask.any(axis=0))
    if len(rows) == 0:
        return None
    return {
        "left": int(columns[0]),
        "top": int(rows[0]),
        "right": int(columns[-1]) + 1,
        "bottom": int(rows[-1]) + 1,
    }
