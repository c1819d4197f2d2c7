"""Open-set segmentation: the ``Segmenter`` protocol and a simulated, seeded segmenter.

The simulated segmenter starts from the rendered instance ids (truth) and degrades them
like an open-set model (FastSAM) would:

- missed detections, likelier for small and distant objects;
- under-segmentation: two instances that come close in the image merge into one mask with
  probability ``undersegment_prob * exp(-gap / merge_gap_px) * exp(-depth gap / merge_depth_m)``
  (gap in pixels at 640 px width between the two masks, 0 where they touch; depth gap between
  their median depths), drawn per pair and frame; merged groups are transitive;
- view-dependent splits: every object has its own sector of viewing directions, a share
  ``view_split_frac`` of the full circle, from which a large object shows as two masks (cut
  at its own place); from elsewhere it shows as one. ``oversegment_prob`` adds splits drawn
  independently per frame;
- partial masks: from its own sector (share ``partial_frac``) an object's mask covers only
  part of it (about ``partial_keep`` of its pixels, the same side each time), which moves
  the observed centroid with the view;
- spurious masks on terrain and noisy boundaries;

then ROMAN's area filter [A/30^2, A/3^2] and erosion (elliptical kernel of radius
``erosion_px``). Pixel sizes (``erosion_px``, ``boundary_noise_px``, ``merge_gap_px``) are
given at 640 px image width and follow the image width (``roman_sim.mapping.mask.scaled_px``).
Per-object traits (sectors, cuts) are seeded by the world seed and the object, so every robot
sees an object fail the same way from the same side; per-frame draws by the robot and frame.
Presets live in ``SEGMENTERS``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.core.registry import Registry
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame
from roman_sim.frontend.frame_objects import FrameObjects, frame_objects, median_depth
from roman_sim.frontend.mask_noise import noisy_boundary, split_mask, spurious_blob
from roman_sim.frontend.segmenter_errors import (
    ObjectTraits,
    max_merge_gap_px,
    merge_probability,
    object_bearing,
    view_parts,
)
from roman_sim.mapping.mask import Mask, ellipse_kernel, erode_mask, scaled_px

log = logging.getLogger(__name__)


class SegmenterConfig(StrictModel):
    """Error model of the simulated segmenter (probabilities per object per frame; pixels at 640 px width)."""

    min_area_div: float = Field(30.0, gt=1)
    max_area_div: float = Field(3.0, gt=0)
    erosion_px: int = Field(3, ge=0, le=20, description="erosion radius at 640 px width")
    miss_prob: float = Field(0.05, ge=0, le=1)
    miss_small_prob: float = Field(0.3, ge=0, le=1)
    small_area_frac: float = Field(0.01, gt=0, le=1)
    miss_far_prob: float = Field(0.3, ge=0, le=1)
    far_start_m: float = Field(4.0, ge=0)
    far_end_m: float = Field(7.5, gt=0)
    oversegment_prob: float = Field(0.05, ge=0, le=1, description="split per frame, independent of the view")
    oversegment_min_area_frac: float = Field(0.03, ge=0, le=1)
    view_split_frac: float = Field(0.15, ge=0, le=1, description="share of viewing directions that split an object")
    partial_frac: float = Field(0.1, ge=0, le=1, description="share of viewing directions that see part of an object")
    partial_keep: float = Field(0.6, ge=0.2, le=0.95, description="mean share of the object a partial mask covers")
    undersegment_prob: float = Field(0.3, ge=0, le=1, description="merge probability of touching objects, same depth")
    merge_gap_px: float = Field(2.0, ge=0, le=50, description="image gap (px at 640) at which merges fall by e")
    merge_depth_m: float = Field(1.5, gt=0, le=100, description="depth gap at which merges fall by e")
    spurious_rate: float = Field(0.5, ge=0, le=20)
    spurious_radius_frac: float = Field(0.08, gt=0, le=0.5)
    boundary_noise_px: int = Field(2, ge=0, le=40, description="boundary noise width at 640 px width")


SEGMENTERS: Registry[SegmenterConfig] = Registry("segmenter preset")
SEGMENTERS.register("fastsam", SegmenterConfig())
SEGMENTERS.register(
    "perfect",
    SegmenterConfig(
        miss_prob=0,
        miss_small_prob=0,
        miss_far_prob=0,
        oversegment_prob=0,
        view_split_frac=0,
        partial_frac=0,
        undersegment_prob=0,
        spurious_rate=0,
        boundary_noise_px=0,
    ),
)


def simulated_segmenter(cfg: SegmenterConfig | str | Any = "fastsam", seed: int = 0) -> Any:
    """A simulated segmenter from a config or a preset name.

    A front-end entry (``frontend.segmenter``, any registered segmenter) is built by
    ``roman_sim.frontend.components.build_segmenter``.
    """
    if not isinstance(cfg, (str, SegmenterConfig)):
        raise MappingError(
            f"simulated_segmenter: expected a preset name or a SegmenterConfig, got {type(cfg).__name__} "
            "(a front-end entry is built by roman_sim.frontend.components.build_segmenter)"
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


@dataclass
class _Scale:
    """Pixel sizes of one image width: erosion radius and kernel, boundary noise, window pad."""

    erosion: int
    kernel: NDArray[np.bool_] | None
    noise: int
    pad: int


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
        self._scales: dict[int, _Scale] = {}
        self._traits: dict[int, ObjectTraits] = {}
        self.last_merges: list[tuple[int, int]] = []

    def scale(self, width: int) -> _Scale:
        """Pixel sizes for images ``width`` pixels wide."""
        if width not in self._scales:
            r = scaled_px(self.cfg.erosion_px, width)
            noise = scaled_px(self.cfg.boundary_noise_px, width)
            self._scales[width] = _Scale(r, ellipse_kernel(r) if r else None, noise, r + noise + 1)
        return self._scales[width]

    def traits(self, oid: int) -> ObjectTraits:
        """Object ``oid``'s seeded failure traits (shared by every robot)."""
        if oid not in self._traits:
            self._traits[oid] = ObjectTraits.draw(child_rng(self.seed, "segmenter", "object", oid), self.cfg)
        return self._traits[oid]

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
        self.last_merges = []
        if ids.size == 0:
            log.debug("frame %d: empty image, no masks", frame.index)
            return []
        rng = child_rng(self.seed, "segmenter", frame.robot, int(frame.index))
        sc = self.scale(ids.shape[1])
        crops = self._object_masks(frame, ids, depth, rng, sc)
        for _ in range(rng.poisson(self.cfg.spurious_rate)):
            blob = spurious_blob(ids, depth, self.cfg.spurious_radius_frac, rng)
            if blob is not None:
                crops.append(self._padded(blob[0], *blob[1], (), ids.shape, sc.pad))
        out = []
        for crop in crops:
            if sc.noise:
                crop.pix = noisy_boundary(crop.pix, sc.noise, rng)
            m = self._filter_and_erode(crop, ids.shape, sc)
            if m is not None:
                out.append(m)
        return out

    def _padded(
        self, pix: NDArray[np.bool_], r0: int, c0: int, oids: tuple[int, ...], shape: tuple[int, int], p: int
    ) -> _Crop:
        """Crop grown by the margin ``p`` that boundary noise and erosion need."""
        R0, C0 = max(r0 - p, 0), max(c0 - p, 0)
        R1, C1 = min(r0 + pix.shape[0] + p, shape[0]), min(c0 + pix.shape[1] + p, shape[1])
        out = np.zeros((R1 - R0, C1 - C0), dtype=bool)
        out[r0 - R0 : r0 - R0 + pix.shape[0], c0 - C0 : c0 - C0 + pix.shape[1]] = pix
        return _Crop(out, R0, C0, oids)

    def merge_candidates(self, frame: Frame) -> list[tuple[int, int, float]]:
        """(a, b, merge probability) of every pair of objects in ``frame`` that may merge."""
        ids = np.asarray(frame.truth.object_ids) if frame.truth is not None else None
        if ids is None or ids.size == 0:
            return []
        return self._candidates(ids, frame_objects(ids, np.asarray(frame.depth)))

    def _candidates(self, ids: NDArray[np.int32], objs: FrameObjects) -> list[tuple[int, int, float]]:
        max_gap = max_merge_gap_px(self.cfg, ids.shape[1])
        if max_gap < 0:
            return []
        gaps = objs.neighbour_pairs(max_gap)
        out = []
        far = self.cfg.far_end_m  # an object without valid depth lies beyond the range: count it there
        for (a, b), gap in gaps.items():
            da, db = (min(objs.depth_of(k), far) for k in (a, b))
            p = merge_probability(self.cfg, gap, abs(da - db), ids.shape[1])
            if p > 0:
                out.append((a, b, p))
        return out

    def _groups(self, ids: NDArray[np.int32], objs: FrameObjects, rng: np.random.Generator) -> list[tuple[int, ...]]:
        """Object groups after under-segmentation (``last_merges`` keeps the merged pairs)."""
        groups = {i: {i} for i in objs.present}
        for a, b, p in self._candidates(ids, objs):
            if rng.random() < p:
                self.last_merges.append((a, b))
                merged = groups[a] | groups[b]
                for k in merged:
                    groups[k] = merged
        return sorted({tuple(sorted(g)) for g in groups.values()})

    def _object_masks(
        self, frame: Frame, ids: NDArray[np.int32], depth: NDArray[np.float32], rng: np.random.Generator, sc: _Scale
    ) -> list[_Crop]:
        c = self.cfg
        A = ids.size
        objs = frame_objects(ids, depth)
        counts, box = objs.counts, objs.box
        R_world_cam = None
        if (c.view_split_frac > 0 or c.partial_frac > 0) and frame.truth is not None:
            R_world_cam = (np.asarray(frame.truth.T_world_body) @ np.asarray(frame.T_body_cam))[:3, :3]
        out = []
        for members in self._groups(ids, objs, rng):
            area = int(sum(counts[m + 1] for m in members))
            if area < A / c.min_area_div**2 / 2:
                continue  # far below the area filter even after boundary noise
            rows_sl, cols_sl = (
                slice(min(box(m)[d].start for m in members), max(box(m)[d].stop for m in members)) for d in range(2)
            )
            sl = (rows_sl, cols_sl)
            pix = ids[sl] == members[0] if len(members) == 1 else np.isin(ids[sl], members)
            dist = objs.depth_of(members[0]) if len(members) == 1 else median_depth(depth[sl], pix)
            dist = dist if np.isfinite(dist) else c.far_end_m
            small = max(0.0, 1.0 - area / (c.small_area_frac * A))
            far = min(max((dist - c.far_start_m) / max(c.far_end_m - c.far_start_m, 1e-9), 0.0), 1.0)  # np.clip's value
            if rng.random() < min(1.0, c.miss_prob + c.miss_small_prob * small + c.miss_far_prob * far):
                continue
            large = area > c.oversegment_min_area_frac * A
            parts = [pix]
            if R_world_cam is not None and len(members) == 1:
                bearing = object_bearing(R_world_cam, frame.intrinsics, sl)
                parts = view_parts(pix, self.traits(members[0]), bearing, c, large)
            if large and rng.random() < c.oversegment_prob:
                parts = [q for p in parts if p.any() for q in split_mask(p, rng.uniform(0.3, 0.7))]
            out += [self._padded(p, sl[0].start, sl[1].start, members, ids.shape, sc.pad) for p in parts if p.any()]
        return out

    def _filter_and_erode(self, crop: _Crop, shape: tuple[int, int], sc: _Scale) -> Mask | None:
        A = shape[0] * shape[1]
        pix = crop.pix
        area = int(pix.sum())
        if not (A / self.cfg.min_area_div**2 <= area <= A / self.cfg.max_area_div**2):
            return None
        if sc.kernel is not None:
            pix = erode_mask(pix, sc.kernel)
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
