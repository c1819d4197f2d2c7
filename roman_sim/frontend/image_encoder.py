"""An encoder that sees only pixels: colour and texture statistics under the mask.

ROMAN takes each mask's bounding-box crop of the image; this encoder describes the pixels
of the crop that lie under the mask by three histograms:

- colour: joint CIELAB histogram (``l_bins`` x ``ab_bins`` x ``ab_bins``, OpenCV's 8-bit Lab);
- gradient orientation: unsigned orientation of the grey-level gradient in ``orient_bins``
  bins, weighted by gradient magnitude (texture direction: bark, trunks, foliage);
- local binary patterns (uniform, 8 neighbours, radius 1, as scikit-image's
  ``local_binary_pattern(grey, 8, 1, "uniform")`` defines them): micro-texture.

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
from roman_sim.mapping.mask import Mask


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
        import cv2  # OpenCV is imported on use, not when a configuration loads

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
        self.lbp = uniform_lbp(grey)


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

    def encode_batch(
        self, rgb: NDArray[np.uint8] | None, masks: list[Mask], contexts: list[Any]
    ) -> NDArray[np.float32]:
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
        win = np.s_[at[0] : at[0] + h, at[1] : at[1] + w]
        if not np.any(pix):
            raise MappingError("image encoder: empty mask")
        hists = (
            np.bincount(codes.colour[win][pix], minlength=self.sizes[0]).astype(np.float64),
            np.bincount(codes.orient[win][pix], weights=codes.weight[win][pix], minlength=self.sizes[1]).astype(
                np.float64
            ),
            np.bincount(codes.lbp[win][pix], minlength=self.sizes[2]).astype(np.float64),
        )
        blocks = [_block(hh, wt, self.cfg.centre) for hh, wt in zip(hists, self.weights)]
        v = np.concatenate(blocks)
        n = np.linalg.norm(v)
        if n == 0:
            v = np.concatenate([np.full(s, wt / np.sqrt(s)) for s, wt in zip(self.sizes, self.weights)])
            n = np.linalg.norm(v)
        return (v / n).astype(np.float32)


def _uniform_lbp_table() -> NDArray[np.int32]:
    """Uniform LBP code of each 8-bit neighbour pattern (bit i: neighbour i >= centre).

    As scikit-image counts them: the 0/1 changes between neighbours 0..7 taken in order
    (7 transitions, not wrapping around); at most 2 changes give the number of ones, else 9.
    """
    lut = np.zeros(256, dtype=np.int32)
    for code in range(256):
        bits = [(code >> i) & 1 for i in range(8)]
        changes = sum(bits[i] != bits[i + 1] for i in range(7))
        lut[code] = sum(bits) if changes <= 2 else 9
    return lut


_LBP_TABLE = _uniform_lbp_table()
_LBP_ANGLES = 2 * np.pi * np.arange(8, dtype=np.float64) / 8
_LBP_DR = np.round(-np.sin(_LBP_ANGLES), 5)  # neighbour i at (r + dr[i], c + dc[i])
_LBP_DC = np.round(np.cos(_LBP_ANGLES), 5)


def uniform_lbp(grey: NDArray[Any]) -> NDArray[np.int32]:
    """(H, W) uniform local binary patterns of a grey image (8 neighbours, radius 1).

    The same codes as ``skimage.feature.local_binary_pattern(grey, 8, 1, "uniform")``, bit
    for bit: each neighbour is bilinearly interpolated (zero outside the image) with the
    same double-precision weights, from the same rounded offsets. scikit-image computes
    those weights pixel by pixel; here each neighbour is a few whole-image operations,
    about 3x faster, which matters because the encoder runs on every frame.
    """
    img = np.asarray(grey).astype(np.float64)
    H, W = img.shape
    if img.size == 0:
        return np.zeros((H, W), dtype=np.int32)
    pad = np.zeros((H + 2, W + 2))
    pad[1:-1, 1:-1] = img
    rows = np.arange(H, dtype=np.float64)[:, None]
    cols = np.arange(W, dtype=np.float64)[None, :]
    code = np.zeros((H, W), dtype=np.uint8)
    top, bottom, tmp = np.empty((H, W)), np.empty((H, W)), np.empty((H, W))
    for i in range(8):
        rr, cc = rows + _LBP_DR[i], cols + _LBP_DC[i]
        r0, c0 = np.floor(rr), np.floor(cc)
        dr, dc = rr - r0, cc - c0
        # the neighbour's cell offset is the same at every pixel (read at pixel 0, 0)
        a, b = 1 + int(r0[0, 0]), 1 + int(c0[0, 0])
        tl = pad[a : a + H, b : b + W]
        if not dr.any() and not dc.any():
            bit = tl >= img  # on the pixel grid the interpolation returns the pixel itself
        else:
            tr = pad[a : a + H, b + 1 : b + 1 + W]
            bl, br = pad[a + 1 : a + 1 + H, b : b + W], pad[a + 1 : a + 1 + H, b + 1 : b + 1 + W]
            one_dc = 1 - dc
            np.multiply(one_dc, tl, out=top)
            np.multiply(dc, tr, out=tmp)
            top += tmp
            np.multiply(one_dc, bl, out=bottom)
            np.multiply(dc, br, out=tmp)
            bottom += tmp
            np.multiply(1 - dr, top, out=top)
            np.multiply(dr, bottom, out=bottom)
            top += bottom
            top -= img
            bit = top >= 0
        code |= bit.view(np.uint8) << np.uint8(i)
    return _LBP_TABLE[code]


def _block(hist: NDArray[np.float64], weight: float, centre: float) -> NDArray[np.float64]:
    """Square-rooted, centred, unit block of one histogram times ``weight`` (zeros when empty)."""
    total = hist.sum()
    if weight == 0 or total <= 0:
        return np.zeros(len(hist))
    v = np.sqrt(hist / total) - centre / np.sqrt(len(hist))
    n = np.linalg.norm(v)
    return weight * v / n if n > 0 else np.zeros(len(hist))
