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
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy import ndimage

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.core.registry import Registry
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame
from roman_sim.mapping.mask import Mask, ellipse_kernel
from roman_sim.mapping.mask_noise import adjacent_pairs, noisy_boundary, split_mask, spurious_blob

log = logging.getLogger(__name__)


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
SEGMENTERS.register(
    "perfect",
    SegmenterConfig(
        miss_prob=0,
        miss_small_prob=0,
        miss_far_prob=0,
        oversegment_prob=0,
        undersegment_prob=0,
        spurious_rate=0,
        boundary_noise_px=0,
    ),
)


def build_segmenter(cfg: SegmenterConfig | str | Any = "fastsam", seed: int = 0) -> Any:
    """A simulated segmenter from a config or a preset name.

    A front-end entry (``frontend.segmenter``, any registered segmenter) is built by
    ``roman_sim.mapping.frontend.build_segmenter``.
    """
    if not isinstance(cfg, (str, SegmenterConfig)):
        raise MappingError(
            f"build_segmenter: expected a preset name or a SegmenterConfig, got {type(cfg).__name__} "
            "(a front-end entry is built by roman_sim.mapping.frontend.build_segmenter)"
        )
    if isinstance(cfg, str):
        cfg = SEGMENTERS.get(cfg).model_copy()
    return SimulatedSegmenter(cfg, seed)


@dataclass
class _Crop:
    """A mask inside an image window starting at (r0, c0), with its true object ids."""

    pix: NDArray[np.bool_]
    r0: int
    c0: int
    ids: tuple[int, ...]


class SimulatedSegmenter:
    """Instance masks from truth ids, degraded by ``SegmenterConfig``; seeded per robot.

    All work happens in padded bounding-box windows, so the cost grows with the masked
    area, not with the number of objects in the image.
    """

    needs_rgb = False
    reads_truth = True

    def __init__(self, cfg: SegmenterConfig, seed: int = 0) -> None:
        if cfg.max_area_div >= cfg.min_area_div:
            raise MappingError("segmenter: max_area_div must be smaller than min_area_div")
        self.cfg = cfg
        self.seed = seed
        self._kernel = ellipse_kernel(cfg.erosion_px) if cfg.erosion_px else None
        self._pad = cfg.erosion_px + cfg.boundary_noise_px + 1

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of ``frame`` (deterministic in seed, robot and frame index)."""
        if frame.truth is None or frame.truth.object_ids is None:
            raise MappingError(
                "the simulated segmenter cuts masks from the true instance image: "
                f"frame {frame.index} of robot {frame.robot} has no instance labels "
                "(use an image segmenter for real or truth-free frames)"
            )
        ids = np.asarray(frame.truth.object_ids)
        depth = np.asarray(frame.depth)
        if ids.ndim != 2 or ids.shape != depth.shape:
            raise MappingError(
                f"frame {frame.index}: object_ids {ids.shape} and depth {depth.shape} must be equal 2D shapes"
            )
        if ids.size == 0:
            log.debug("frame %d: empty image, no masks", frame.index)
            return []
        rng = child_rng(self.seed, "segmenter", frame.robot, int(frame.index))
        crops = self._object_masks(ids, depth, rng)
        for _ in range(rng.poisson(self.cfg.spurious_rate)):
            blob = spurious_blob(ids, depth, self.cfg.spurious_radius_frac, rng)
            if blob is not None:
                crops.append(self._padded(blob[0], *blob[1], (), ids.shape))
        out = []
        for crop in crops:
            if self.cfg.boundary_noise_px:
                crop.pix = noisy_boundary(crop.pix, self.cfg.boundary_noise_px, rng)
            m = self._filter_and_erode(crop, ids.shape)
            if m is not None:
                out.append(m)
        return out

    def _padded(self, pix: NDArray[np.bool_], r0: int, c0: int, oids: tuple[int, ...], shape: tuple[int, int]) -> _Crop:
        """Crop grown by the margin that boundary noise and erosion need."""
        p = self._pad
        R0, C0 = max(r0 - p, 0), max(c0 - p, 0)
        R1, C1 = min(r0 + pix.shape[0] + p, shape[0]), min(c0 + pix.shape[1] + p, shape[1])
        out = np.zeros((R1 - R0, C1 - C0), dtype=bool)
        out[r0 - R0 : r0 - R0 + pix.shape[0], c0 - C0 : c0 - C0 + pix.shape[1]] = pix
        return _Crop(out, R0, C0, oids)

    def _groups(
        self, ids: NDArray[np.int32], depth: NDArray[np.float32], present: list[int], rng: np.random.Generator
    ) -> list[tuple[int, ...]]:
        """Object groups after under-segmentation of touching objects."""
        groups = {i: {i} for i in present}
        for a, b in adjacent_pairs(ids, depth, self.cfg.touch_depth_m):
            if rng.random() < self.cfg.undersegment_prob:
                merged = groups[a] | groups[b]
                for k in merged:
                    groups[k] = merged
        return sorted({tuple(sorted(g)) for g in groups.values()})

    def _object_masks(
        self, ids: NDArray[np.int32], depth: NDArray[np.float32], rng: np.random.Generator
    ) -> list[_Crop]:
        c = self.cfg
        A = ids.size
        lab = ids.astype(np.int64) + 1
        counts = np.bincount(lab.ravel())
        slices = ndimage.find_objects(lab)
        present = [int(i) - 1 for i in np.flatnonzero(counts[1:]) + 1]
        out = []
        for members in self._groups(ids, depth, present, rng):
            area = int(sum(counts[m + 1] for m in members))
            if area < A / c.min_area_div**2 / 2:
                continue  # far below the area filter even after boundary noise
            sl = tuple(
                slice(min(slices[m][d].start for m in members), max(slices[m][d].stop for m in members))
                for d in range(2)
            )
            pix = ids[sl] == members[0] if len(members) == 1 else np.isin(ids[sl], members)
            d = depth[sl][pix]
            dist = float(np.median(d[d > 0])) if np.any(d > 0) else c.far_end_m
            small = max(0.0, 1.0 - area / (c.small_area_frac * A))
            far = np.clip((dist - c.far_start_m) / max(c.far_end_m - c.far_start_m, 1e-9), 0, 1)
            if rng.random() < min(1.0, c.miss_prob + c.miss_small_prob * small + c.miss_far_prob * far):
                continue
            split = area > c.oversegment_min_area_frac * A and rng.random() < c.oversegment_prob
            parts = split_mask(pix, rng) if split else [pix]
            out += [self._padded(p, sl[0].start, sl[1].start, members, ids.shape) for p in parts]
        return out

    def _filter_and_erode(self, crop: _Crop, shape: tuple[int, int]) -> Mask | None:
        A = shape[0] * shape[1]
        pix = crop.pix
        area = int(pix.sum())
        if not (A / self.cfg.min_area_div**2 <= area <= A / self.cfg.max_area_div**2):
            return None
        if self._kernel is not None:
            pix = ndimage.binary_erosion(pix, structure=self._kernel, border_value=0)
        full = np.zeros(shape, dtype=bool)
        full[crop.r0 : crop.r0 + pix.shape[0], crop.c0 : crop.c0 + pix.shape[1]] = pix
        rows, cols = np.nonzero(pix)
        if len(rows) == 0:
            return None
        bbox = (
            crop.r0 + int(rows.min()),
            crop.r0 + int(rows.max()) + 1,
            crop.c0 + int(cols.min()),
            crop.c0 + int(cols.max()) + 1,
        )
        return Mask(full, tuple(crop.ids), bbox)
