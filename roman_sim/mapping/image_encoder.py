"""An encoder that sees only pixels: colour and texture statistics under the mask.

ROMAN takes each mask's bounding-box crop of the image; this encoder describes the pixels
of the crop that lie under the mask by three histograms:

- colour: joint CIELAB histogram (``l_bins`` x ``ab_bins`` x ``ab_bins``, OpenCV's 8-bit Lab);
- gradient orientation: unsigned orientation of the grey-level gradient in ``orient_bins``
  bins, weighted by gradient magnitude (texture direction: bark, trunks, foliage);
- local binary patterns (uniform, 8 neighbours, radius 1; scikit-image): micro-texture.

Each histogram is normalised to sum 1 and square-rooted (so the cosine of two blocks is
their Bhattacharyya coefficient), centred by subtracting ``centre`` times the square root
of the uniform histogram (so unrelated appearances score lower), scaled to unit length and
weighted; the concatenation is unit-normalised. ``encode_batch`` computes the per-pixel
codes once per frame and histograms every mask with ``numpy.bincount``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.mapping.segmenter import Mask


class ImageEncoderConfig(StrictModel):
    """Histogram sizes and block weights of the image encoder."""

    l_bins: int = Field(4, ge=1, le=32)
    ab_bins: int = Field(6, ge=1, le=32)
    orient_bins: int = Field(8, ge=2, le=36)
    min_gradient: float = Field(8.0, ge=0, description="gradient magnitude (grey levels per pixel) that counts")
    colour_weight: float = Field(0.6, ge=0)
    orient_weight: float = Field(0.2, ge=0)
    lbp_weight: float = Field(0.2, ge=0)
    centre: float = Field(0.5, ge=0, le=1, description="share of the uniform histogram subtracted per block")


_LBP_BINS = 10  # uniform patterns of 8 neighbours: 9 uniform codes + 1 for all others


class _Codes:
    """Per-pixel codes of an RGB image: colour bin, orientation bin, gradient weight, LBP code."""

    def __init__(self, rgb: NDArray[np.uint8], cfg: ImageEncoderConfig) -> None:
        import cv2  # OpenCV and scikit-image are imported on use, not when a configuration loads
        from skimage.feature import local_binary_pattern

        lab = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2LAB).astype(np.int32)
        lq = lab[..., 0] * cfg.l_bins // 256
        aq = lab[..., 1] * cfg.ab_bins // 256
        bq = lab[..., 2] * cfg.ab_bins // 256
        self.colour = (lq * cfg.ab_bins + aq) * cfg.ab_bins + bq
        grey = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
        gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3) / 8.0
        gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3) / 8.0
        mag = np.hypot(gx, gy)
        theta = np.mod(np.arctan2(gy, gx), np.pi)
        self.orient = np.minimum((theta / np.pi * cfg.orient_bins).astype(np.int32), cfg.orient_bins - 1)
        self.weight = np.where(mag >= cfg.min_gradient, mag, 0.0).astype(np.float64)
        self.lbp = local_binary_pattern(grey, 8, 1, method="uniform").astype(np.int32)


class ImageEncoder:
    """Truth-free unit descriptors from the pixels under each mask (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: ImageEncoderConfig | None = None) -> None:
        self.cfg = cfg or ImageEncoderConfig()
        c = self.cfg
        self.sizes = (c.l_bins * c.ab_bins * c.ab_bins, c.orient_bins, _LBP_BINS)
        self.weights = np.sqrt(np.array([c.colour_weight, c.orient_weight, c.lbp_weight], dtype=np.float64))
        if not np.any(self.weights > 0):
            raise MappingError("image encoder: at least one of colour_weight, orient_weight, lbp_weight must be > 0")
        self.dim = int(sum(self.sizes))

    def encode(self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: Any) -> NDArray[np.float32]:
        """Unit descriptor of the pixels of ``rgb_crop`` under ``mask`` (both of the crop's size)."""
        if rgb_crop is None:
            raise MappingError("image encoder: the frame has no RGB (set render_rgb: true)")
        crop = np.asarray(rgb_crop)
        m = np.asarray(mask, dtype=bool)
        if m.shape != crop.shape[:2]:
            raise MappingError(f"image encoder: mask {m.shape} and crop {crop.shape[:2]} differ in size")
        codes = _Codes(crop, self.cfg)
        return self._describe(codes, m, (0, 0))

    def encode_batch(self, rgb: NDArray[np.uint8] | None, masks: list[Mask],
                     contexts: list[Any]) -> NDArray[np.float32]:
        """(N, dim) unit descriptors of every mask of one frame (codes computed once)."""
        if rgb is None:
            raise MappingError("image encoder: the frame has no RGB (set render_rgb: true)")
        out = np.zeros((len(masks), self.dim), dtype=np.float32)
        if not masks:
            return out
        r0 = min(m.bbox[0] for m in masks)  # type: ignore[index]
        r1 = max(m.bbox[1] for m in masks)  # type: ignore[index]
        c0 = min(m.bbox[2] for m in masks)  # type: ignore[index]
        c1 = max(m.bbox[3] for m in masks)  # type: ignore[index]
        codes = _Codes(np.asarray(rgb)[r0:r1, c0:c1], self.cfg)
        for k, m in enumerate(masks):
            a0, a1, b0, b1 = m.bbox  # type: ignore[misc]
            out[k] = self._describe(codes, m.pixels[a0:a1, b0:b1], (a0 - r0, b0 - c0))
        return out

    def _describe(self, codes: _Codes, pix: NDArray[np.bool_], at: tuple[int, int]) -> NDArray[np.float32]:
        h, w = pix.shape
        win = np.s_[at[0]:at[0] + h, at[1]:at[1] + w]
        if not np.any(pix):
            raise MappingError("image encoder: empty mask")
        hists = (np.bincount(codes.colour[win][pix], minlength=self.sizes[0]).astype(np.float64),
                 np.bincount(codes.orient[win][pix], weights=codes.weight[win][pix],
                             minlength=self.sizes[1]).astype(np.float64),
                 np.bincount(codes.lbp[win][pix], minlength=self.sizes[2]).astype(np.float64))
        blocks = [_block(hh, wt, self.cfg.centre) for hh, wt in zip(hists, self.weights)]
        v = np.concatenate(blocks)
        n = np.linalg.norm(v)
        if n == 0:
            v = np.concatenate([np.full(s, wt / np.sqrt(s)) for s, wt in zip(self.sizes, self.weights)])
            n = np.linalg.norm(v)
        return (v / n).astype(np.float32)


def _block(hist: NDArray[np.float64], weight: float, centre: float) -> NDArray[np.float64]:
    """Square-rooted, centred, unit block of one histogram times ``weight`` (zeros when empty)."""
    total = hist.sum()
    if weight == 0 or total <= 0:
        return np.zeros(len(hist))
    v = np.sqrt(hist / total) - centre / np.sqrt(len(hist))
    n = np.linalg.norm(v)
    return weight * v / n if n > 0 else np.zeros(len(hist))
