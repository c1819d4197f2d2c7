"""Depth sensor noise: range-squared Gaussian noise, quantisation, edge dropout, max range.

Kept separate from rendering so that noise-free depth stays available (tests, truth).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.sim.camera import DepthNoiseConfig

_SQUARE3 = np.ones((3, 3), dtype=np.uint8)


def _filter3(img: NDArray[np.float32], op: np.ufunc) -> NDArray[np.float32]:
    """3x3 max/min filter (edge-replicated) as two separable passes of ``op``.

    Equivalent to ``scipy.ndimage.maximum_filter(img, 3, mode="nearest")`` (for
    ``np.maximum``); ``_extreme3`` gives the same bits faster.
    """
    p = np.pad(img, 1, mode="edge")
    rows = op(op(p[:-2], p[1:-1]), p[2:])
    return op(op(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:])


def _extreme3(img: NDArray[np.float32], op: np.ufunc) -> NDArray[np.float32]:
    """``_filter3`` by OpenCV's dilation (max) or erosion (min) with a 3x3 square, edges replicated.

    A maximum or minimum is exact, so the bits are ``_filter3``'s; OpenCV takes no NaN into
    account, so an image holding NaN goes through ``_filter3``.
    """
    if img.ndim != 2 or img.dtype != np.float32 or np.isnan(img).any():
        return _filter3(img, op)
    import cv2  # imported on use: loading the pipeline should not import OpenCV

    morph = cv2.dilate if op is np.maximum else cv2.erode
    return np.asarray(morph(img, _SQUARE3, borderType=cv2.BORDER_REPLICATE), dtype=np.float32)


def depth_edges(depth: NDArray[np.float32], jump_m: float) -> NDArray[np.bool_]:
    """Pixels whose 3x3 neighbourhood (valid pixels only) spans more than ``jump_m``.

    Invalid neighbours (0) count as a jump, so pixels next to sky are edges too.
    """
    d = np.asarray(depth, dtype=np.float32)
    valid = d > 0
    hi = _extreme3(d, np.maximum)
    # Holes become a very low value, so a hole in the neighbourhood always counts as a jump.
    lo = _extreme3(np.where(valid, d, np.float32(-1e6)), np.minimum)
    hi -= lo
    return valid & (hi > jump_m)


def apply_depth_noise(
    depth: NDArray[np.float32],
    cfg: DepthNoiseConfig,
    max_depth_m: float,
    rng: np.random.Generator,
) -> NDArray[np.float32]:
    """Noisy copy of a noise-free depth image (0 = invalid stays invalid).

    Args:
        depth: (H, W) float32 noise-free depth in metres.
        cfg: noise parameters; ``cfg.enabled = False`` only applies the max range.
        max_depth_m: readings beyond this are set to 0 (invalid).
        rng: seeded generator (one per robot, from ``seeding.child_rng``).

    Returns: (H, W) float32 depth.
    """
    d = np.asarray(depth, dtype=np.float32)
    valid = d > 0
    valid &= d <= max_depth_m
    out = d.copy()
    if cfg.enabled:
        # the expressions of the plain form, evaluated in place: (k d) d, d + n std, round(x / q) q
        noise = rng.standard_normal(d.shape, dtype=np.float32)
        std = np.float32(cfg.std_at_ref_m / cfg.ref_range_m**2) * d
        std *= d
        noise *= std
        out += noise
        if cfg.quantum_m > 0:
            q = np.float32(cfg.quantum_m)
            out /= q
            np.round(out, out=out)
            out *= q
        valid &= ~depth_edges(d, cfg.edge_jump_m)
    valid &= out > 0  # the measured value must also be in range
    valid &= out <= max_depth_m
    np.logical_not(valid, out=valid)
    out[valid] = 0.0
    return out
