"""Open-set segmentation: the ``Segmenter`` protocol and a simulated, seeded segmenter.

The simulated segmenter starts from the rendered instance ids (truth) and degrades them
like an open-set model (FastSAM) would: missed detections (likelier for small and distant
objects), over-segmentation of large objects, under-segmentation of touching objects,
spurious masks on terrain and noisy boundaries; then the reference area filter
[A/30^2, A/3^2] and erosion (elliptical kernel 2*3+1). Presets live in ``SEGMENTERS``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy import ndimage

from roman_sim.config import StrictModel
from roman_sim.errors import MappingError
from roman_sim.mapping.mask_noise import adjacent_pairs, noisy_boundary, spurious_blob, split_mask
from roman_sim.registry import Registry
from roman_sim.seeding import child_rng
from roman_sim.sim.frame import Frame

log = logging.getLogger(__name__)


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


@runtime_checkable
class Segmenter(Protocol):
    """Anything that turns a frame into masks (a real model may ignore ``object_ids``)."""

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of one frame."""
        ...


class SegmenterConfig(StrictModel):
    """Error model of the simulated segmenter (probabilities per object per frame)."""

    min_area_div: float = Field(30.0, gt=1)
    max_area_div: float = Field(3.0, gt=0)
    erosion_px: int = Field(3, ge=0, le=20)
    miss_prob: float = Field(0.05, ge=0, le=1)
    miss_small_prob: float = Field(0.3, ge=0, le=1)
    small_area_frac: float = Field(0.01, gt=0, le=1)
    miss_far_prob: float = Field(0.3, ge=0, le=1)
    far_start_m: float = Field(4.0, ge=0)
    far_end_m: float = Field(7.5, gt=0)
    oversegment_prob: float = Field(0.15, ge=0, le=1)
    oversegment_min_area_frac: float = Field(0.03, ge=0, le=1)
    undersegment_prob: float = Field(0.3, ge=0, le=1)
    touch_depth_m: float = Field(0.3, ge=0)
    spurious_rate: float = Field(0.5, ge=0, le=20)
    spurious_radius_frac: float = Field(0.08, gt=0, le=0.5)
    boundary_noise_px: int = Field(2, ge=0, le=10)


SEGMENTERS: Registry[SegmenterConfig] = Registry("segmenter preset")
SEGMENTERS.register("fastsam", SegmenterConfig())
SEGMENTERS.register("perfect", SegmenterConfig(
    miss_prob=0, miss_small_prob=0, miss_far_prob=0, oversegment_prob=0,
    undersegment_prob=0, spurious_rate=0, boundary_noise_px=0))


def build_segmenter(cfg: SegmenterConfig | str = "fastsam", seed: int = 0) -> "SimulatedSegmenter":
    """A simulated segmenter from a config or a preset name."""
    if isinstance(cfg, str):
        cfg = SEGMENTERS.get(cfg).model_copy()
    return SimulatedSegmenter(cfg, seed)


def ellipse_kernel(radius: int) -> NDArray[np.bool_]:
    """Elliptical (disk) structuring element of size 2*radius+1."""
    yy, xx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    return (xx**2 + yy**2) <= radius**2 + radius * 0.5


class SimulatedSegmenter:
    """Instance masks from truth ids, degraded by ``SegmenterConfig``; seeded per robot."""

    def __init__(self, cfg: SegmenterConfig, seed: int = 0) -> None:
        if cfg.max_area_div >= cfg.min_area_div:
            raise MappingError("segmenter: max_area_div must be smaller than min_area_div")
        self.cfg = cfg
        self.seed = seed
        self._kernel = ellipse_kernel(cfg.erosion_px) if cfg.erosion_px else None

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of ``frame`` (deterministic in seed, robot and frame index)."""
        ids = np.asarray(frame.object_ids)
        depth = np.asarray(frame.depth)
        if ids.ndim != 2 or ids.shape != depth.shape:
            raise MappingError(f"frame {frame.index}: object_ids {ids.shape} and depth {depth.shape} must be equal 2D shapes")
        rng = child_rng(self.seed, "segmenter", frame.robot, int(frame.index))
        raw = self._object_masks(ids, depth, rng)
        raw += [m for m in (spurious_blob(ids, depth, self.cfg.spurious_radius_frac, rng)
                            for _ in range(rng.poisson(self.cfg.spurious_rate))) if m is not None]
        out = []
        for pix, oids in raw:
            if self.cfg.boundary_noise_px:
                pix = noisy_boundary(pix, self.cfg.boundary_noise_px, rng)
            m = self._filter_and_erode(pix, oids)
            if m is not None:
                out.append(m)
        return out

    def _object_masks(self, ids: NDArray[np.int32], depth: NDArray[np.float32],
                      rng: np.random.Generator) -> list[tuple[NDArray[np.bool_], tuple[int, ...]]]:
        c = self.cfg
        A = ids.size
        present = [int(i) for i in np.unique(ids) if i >= 0]
        groups = {i: {i} for i in present}
        for a, b in adjacent_pairs(ids, depth, c.touch_depth_m):
            if rng.random() < c.undersegment_prob:
                merged = groups[a] | groups[b]
                for k in merged:
                    groups[k] = merged
        out = []
        for members in {tuple(sorted(g)) for g in groups.values()}:
            pix = np.isin(ids, members)
            area = int(pix.sum())
            d = depth[pix]
            dist = float(np.median(d[d > 0])) if np.any(d > 0) else c.far_end_m
            small = max(0.0, 1.0 - area / (c.small_area_frac * A))
            far = np.clip((dist - c.far_start_m) / max(c.far_end_m - c.far_start_m, 1e-9), 0, 1)
            if rng.random() < min(1.0, c.miss_prob + c.miss_small_prob * small + c.miss_far_prob * far):
                continue
            if area > c.oversegment_min_area_frac * A and rng.random() < c.oversegment_prob:
                out += [(p, members) for p in split_mask(pix, rng)]
            else:
                out.append((pix, members))
        return sorted(out, key=lambda m: (m[1], -int(m[0].sum())))

    def _filter_and_erode(self, pix: NDArray[np.bool_], oids: tuple[int, ...]) -> Mask | None:
        A = pix.size
        area = int(pix.sum())
        if not (A / self.cfg.min_area_div**2 <= area <= A / self.cfg.max_area_div**2):
            return None
        if self._kernel is not None:
            r = self.cfg.erosion_px
            r0, r1, c0, c1 = mask_bbox(pix)
            sl = (slice(max(r0 - r, 0), r1 + r), slice(max(c0 - r, 0), c1 + r))
            eroded = np.zeros_like(pix)
            eroded[sl] = ndimage.binary_erosion(pix[sl], structure=self._kernel, border_value=0)
            pix = eroded
        m = Mask(pix, tuple(oids))
        return m if m.area > 0 else None
