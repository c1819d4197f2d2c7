"""Depth sensor noise: range-squared Gaussian noise, quantisation, edge dropout, max range.

Kept separate from rendering so that noise-free depth stays available (tests, truth).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.sim.camera import DepthNoiseConfig


def _filter3(img: NDArray[np.float32], op: np.ufunc) -> NDArray[np.float32]:
    """3x3 max/min filter (edge-replicated) as two separable passes of ``op``.

    Equivalent to ``scipy.ndimage.maximum_filter(img, 3, mode="nearest")`` (for
    ``np.maximum``) but about 6x faster at 640 x 480, which matters once per frame.
    """
    p = np.pad(img, 1, mode="edge")
    rows = op(op(p[:-2], p[1:-1]), p[2:])
    return op(op(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:])


def depth_edges(depth: NDArray[np.float32], jump_m: float) -> NDArray[np.bool_]:
    """Pixels whose 3x3 neighbourhood (valid pixels only) spans more than ``jump_m``.

    Invalid neighbours (0) count as a jump, so pixels next to sky are edges too.
    """
    d = np.asarray(depth, dtype=np.float32)
    hi = _filter3(d, np.maximum)
    # Holes become a very low value, so a hole in the neighbourhood always counts as a jump.
    lo = _filter3(np.where(d > 0, d, np.float32(-1e6)), np.minimum)
    return (d > 0) & ((hi - lo) > jump_m)


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
    valid = (d > 0) & (d <= max_depth_m)
    out = d.copy()
    if cfg.enabled:
        std = np.float32(cfg.std_at_ref_m / cfg.ref_range_m**2) * d * d
        out += rng.standard_normal(d.shape, dtype=np.float32) * std
        if cfg.quantum_m > 0:
            q = np.float32(cfg.quantum_m)
            out = np.round(out / q) * q
        valid &= ~depth_edges(d, cfg.edge_jump_m)
    valid &= (out > 0) & (out <= max_depth_m)  # the measured value must also be in range
    out[~valid] = 0.0
    return out
