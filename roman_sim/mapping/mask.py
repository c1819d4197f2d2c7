"""A segmentation mask and the mask helpers shared by every front end.

Pixel sizes of the front end (erosion radius, boundary noise, merge distances) are given for
an image 640 pixels wide and follow the image in proportion, as ROMAN's area window follows
the image area: ``scaled_px(px, width)`` is ``px * width / 640`` rounded half up, so erosion 3
is 3 px at 640 x 480, 2 px at 320 x 240 (1.5 rounded up) and 1 px at 160 x 120.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass
class Mask:
    """One segmentation mask.

    Attributes:
        pixels: (H, W) bool mask.
        object_ids: evaluation only: true object id(s) under the mask (empty for terrain).
        bbox: (row0, row1, col0, col1) half-open bounding box of ``pixels``.
    """

    pixels: NDArray[np.bool_]
    object_ids: tuple[int, ...] = ()
    bbox: tuple[int, int, int, int] | None = None

    def __post_init__(self) -> None:
        if self.bbox is None:
            self.bbox = mask_bbox(self.pixels)

    @property
    def area(self) -> int:
        """Number of mask pixels."""
        r0, r1, c0, c1 = self.bbox  # type: ignore[misc]
        return int(self.pixels[r0:r1, c0:c1].sum())


def mask_bbox(pixels: NDArray[np.bool_]) -> tuple[int, int, int, int]:
    """Half-open bounding box (row0, row1, col0, col1); (0, 0, 0, 0) when empty."""
    rows, cols = np.flatnonzero(pixels.any(axis=1)), np.flatnonzero(pixels.any(axis=0))
    if len(rows) == 0:
        return (0, 0, 0, 0)
    return (int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1)


def erode_mask(pix: NDArray[np.bool_], kernel: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Binary erosion of ``pix`` by the symmetric ``kernel``, pixels outside the image empty.

    OpenCV's erosion: the bits of ``scipy.ndimage.binary_erosion(pix, kernel, border_value=0)``.
    """
    import cv2  # imported on use: loading a configuration should not import OpenCV

    u = np.ascontiguousarray(pix, dtype=bool).view(np.uint8)
    out = cv2.erode(u, kernel.astype(np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return out.view(bool)


def ellipse_kernel(radius: int) -> NDArray[np.bool_]:
    """Elliptical (disk) structuring element of size 2*radius+1."""
    yy, xx = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    return (xx**2 + yy**2) <= radius**2 + radius * 0.5


#: Image width (pixels) at which the front end's pixel sizes are given.
REFERENCE_WIDTH_PX = 640


def scaled_px(px: float, width: int) -> int:
    """``px`` (given at 640 px width) for an image ``width`` pixels wide, rounded half up."""
    return int(math.floor(px * width / REFERENCE_WIDTH_PX + 0.5))
