"""Depth sensor noise: range-squared Gaussian noise, quantisation, edge dropout, max range.

Kept separate from rendering so that noise-free depth stays available (tests, truth).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import maximum_filter, minimum_filter

from roman_sim.sim.camera import DepthNoiseConfig


def depth_edges(depth: NDArray[np.float32], jump_m: float) -> NDArray[np.bool_]:
    """Pixels whose 3x3 neighbourhood (valid pixels only) spans more than ``jump_m``.

    Invalid neighbours (0) count as a jump, so pixels next to sky are edges too.
    """
    d = np.asarray(depth, dtype=np.float32)
    hi = maximum_filter(d, size=3, mode="nearest")
    lo = minimum_filter(np.where(d > 0, d, np.float32(np.inf)), size=3, mode="nearest")
    has_hole = minimum_filter(d, size=3, mode="nearest") <= 0
    return (d > 0) & (((hi - lo) > jump_m) | has_hole)


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
    out = d.astype(np.float64)
    if cfg.enabled:
        std = cfg.std_at_ref_m * (out / cfg.ref_range_m) ** 2
        out = out + rng.standard_normal(out.shape) * std
        if cfg.quantum_m > 0:
            out = np.round(out / cfg.quantum_m) * cfg.quantum_m
        valid &= ~depth_edges(d, cfg.edge_jump_m)
    valid &= (out > 0) & (d <= max_depth_m)
    return np.where(valid, out, 0.0).astype(np.float32)
