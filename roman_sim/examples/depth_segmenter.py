"""A user-supplied front end: a geometry-only segmenter and a mask-shape encoder.

Neither looks at ground truth: the segmenter splits the depth image into connected regions
bounded by depth discontinuities (the mapper's plane filter drops ground patches), the
encoder describes a mask by its bounding-box shape and fill. Use them as

    frontend: {segmenter: examples.depth_segmenter:DepthEdgeSegmenter,
               encoder: examples.depth_segmenter:ShapeEncoder}
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from roman_sim.core.sensors import Frame
from roman_sim.mapping.mask import Mask

if TYPE_CHECKING:
    from roman_sim.mapping.protocols import EncodeContext


class DepthEdgeSegmenter:
    """Connected regions of valid depth separated by jumps larger than ``jump_m``."""

    def __init__(self, jump_m: float = 0.3, min_area_frac: float = 1.0 / 900) -> None:
        self.jump_m = jump_m
        self.min_area_frac = min_area_frac

    def segment(self, frame: Frame) -> list[Mask]:
        d = np.asarray(frame.depth, dtype=np.float64)
        valid = d > 0
        edges = np.zeros_like(valid)
        edges[:, 1:] |= np.abs(np.diff(d, axis=1)) > self.jump_m
        edges[1:, :] |= np.abs(np.diff(d, axis=0)) > self.jump_m
        labels, n = ndimage.label(valid & ~edges)
        min_area = self.min_area_frac * d.size
        sizes = ndimage.sum(np.ones_like(d), labels, index=np.arange(1, n + 1))
        return [Mask(labels == k + 1) for k in np.flatnonzero(sizes >= min_area)]


class ShapeEncoder:
    """An 8-d unit descriptor from the mask's bounding-box shape and fill."""

    def encode(
        self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: EncodeContext
    ) -> NDArray[np.float32]:
        rows, cols = np.nonzero(mask)
        h = rows.max() - rows.min() + 1 if len(rows) else 1
        w = cols.max() - cols.min() + 1 if len(cols) else 1
        v = np.array([h, w, h / w, mask.sum() / (h * w), 1.0, 0.5, 0.25, 0.125], dtype=np.float64)
        return (v / np.linalg.norm(v)).astype(np.float32)
