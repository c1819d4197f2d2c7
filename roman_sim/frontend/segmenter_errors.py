"""Failures of the simulated segmenter that depend on geometry: merges by image and depth gap,
splits and partial masks by viewing sector.

Two objects ``gap`` pixels apart in the image (at 640 px width; 0 where they touch) whose
median depths differ by ``dz`` merge in a frame with probability
``undersegment_prob * exp(-gap / merge_gap_px) * exp(-dz / merge_depth_m)``; pairs beyond
three e-folds of the gap are not looked at.

Each object draws, once per world, the sectors of horizontal viewing direction (bearing
from the camera to the object, world frame) in which it splits in two or shows only in
part, where it is cut, and which part a partial mask keeps. A frame then applies the
failures whose sector holds the object's bearing, with no draw of its own: one object is
two masks from some directions and one mask from others, the same for every robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.sensors import Intrinsics
from roman_sim.frontend.mask_noise import split_mask
from roman_sim.mapping.mask import REFERENCE_WIDTH_PX


class ErrorRates(Protocol):
    """The ``SegmenterConfig`` fields these failures read."""

    undersegment_prob: float
    merge_gap_px: float
    merge_depth_m: float
    view_split_frac: float
    partial_frac: float
    partial_keep: float


@dataclass(frozen=True)
class ObjectTraits:
    """One object's seeded failure traits.

    Attributes:
        split_from_rad: start of the split sector (rad); the sector spans ``view_split_frac`` of the circle.
        split_at: share of the mask's pixels in the first part of a split.
        partial_from_rad: start of the partial-mask sector (rad).
        keep: share of the mask's pixels a partial mask keeps.
        keep_first: a partial mask keeps the first part (top or left) rather than the last.
    """

    split_from_rad: float
    split_at: float
    partial_from_rad: float
    keep: float
    keep_first: bool

    @classmethod
    def draw(cls, rng: np.random.Generator, cfg: ErrorRates) -> ObjectTraits:
        """Traits from the object's own generator."""
        u = rng.random(5)
        keep = float(np.clip(cfg.partial_keep + 0.3 * (u[3] - 0.5), 0.1, 0.95))
        return cls(
            2 * math.pi * float(u[0]), 0.3 + 0.4 * float(u[1]), 2 * math.pi * float(u[2]), keep, bool(u[4] < 0.5)
        )


def in_sector(bearing_rad: float, start_rad: float, frac: float) -> bool:
    """Whether ``bearing_rad`` lies in the sector starting at ``start_rad`` spanning ``frac`` of the circle."""
    return frac > 0 and (bearing_rad - start_rad) % (2 * math.pi) < 2 * math.pi * frac


def object_bearing(R_world_cam: NDArray[np.float64], intr: Intrinsics, window: tuple[slice, slice]) -> float:
    """Horizontal bearing (rad, world frame) from the camera to the centre of an object's image window."""
    u = 0.5 * (window[1].start + window[1].stop - 1)
    v = 0.5 * (window[0].start + window[0].stop - 1)
    d = R_world_cam @ np.array([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, 1.0])
    return float(math.atan2(d[1], d[0]))


def view_parts(
    pix: NDArray[np.bool_], traits: ObjectTraits, bearing_rad: float, cfg: ErrorRates, large: bool
) -> list[NDArray[np.bool_]]:
    """The masks one object shows as from ``bearing_rad``: partial, then split when large."""
    parts = [pix]
    if in_sector(bearing_rad, traits.partial_from_rad, cfg.partial_frac):
        first, last = split_mask(pix, traits.keep if traits.keep_first else 1.0 - traits.keep)
        parts = [first if traits.keep_first else last]
    if large and in_sector(bearing_rad, traits.split_from_rad, cfg.view_split_frac):
        parts = [q for p in parts if p.any() for q in split_mask(p, traits.split_at)]
    return parts


def merge_probability(cfg: ErrorRates, gap_px: float, depth_gap_m: float, width: int) -> float:
    """Probability that two objects ``gap_px`` image pixels and ``depth_gap_m`` apart merge in one frame."""
    if cfg.undersegment_prob <= 0:
        return 0.0
    gap_ref = gap_px * REFERENCE_WIDTH_PX / max(width, 1)
    if cfg.merge_gap_px <= 0:
        image = 1.0 if gap_px <= 0 else 0.0
    else:
        image = math.exp(-gap_ref / cfg.merge_gap_px)
    return float(cfg.undersegment_prob * image * math.exp(-abs(depth_gap_m) / cfg.merge_depth_m))


def max_merge_gap_px(cfg: ErrorRates, width: int) -> int:
    """Largest image gap (pixels) looked across for merges: three e-folds of ``merge_gap_px``."""
    if cfg.undersegment_prob <= 0:
        return -1
    return int(math.ceil(3.0 * cfg.merge_gap_px * width / REFERENCE_WIDTH_PX))
