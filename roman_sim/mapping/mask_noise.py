"""Mask perturbations used by the simulated segmenter (all driven by a given Generator)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage


def adjacent_pairs(ids: NDArray[np.int32], depth: NDArray[np.float32], touch_depth_m: float) -> list[tuple[int, int]]:
    """Sorted pairs of object ids that touch in the image at similar depth (touching in 3D).

    Args:
        ids: (H, W) object ids, -1 background.
        depth: (H, W) depth, 0 invalid.
        touch_depth_m: largest depth step across the shared border.
    """
    pairs = set()
    for a, b, da, db in (
        (ids[:, :-1], ids[:, 1:], depth[:, :-1], depth[:, 1:]),
        (ids[:-1, :], ids[1:, :], depth[:-1, :], depth[1:, :]),
    ):
        sel = (a != b) & (a >= 0) & (b >= 0) & (da > 0) & (db > 0) & (np.abs(da - db) <= touch_depth_m)
        if np.any(sel):
            lo, hi = np.minimum(a[sel], b[sel]), np.maximum(a[sel], b[sel])
            pairs.update(zip(lo.tolist(), hi.tolist()))
    return sorted(pairs)


def split_mask(pix: NDArray[np.bool_], rng: np.random.Generator) -> list[NDArray[np.bool_]]:
    """Split a mask in two across its longer image axis at a random cut (30-70 %)."""
    rows, cols = np.nonzero(pix)
    axis_vals = rows if np.ptp(rows) >= np.ptp(cols) else cols
    cut = np.quantile(axis_vals, rng.uniform(0.3, 0.7))
    first = np.zeros_like(pix)
    sel = axis_vals <= cut
    first[rows[sel], cols[sel]] = True
    return [first, pix & ~first]


def noisy_boundary(pix: NDArray[np.bool_], width: int, rng: np.random.Generator) -> NDArray[np.bool_]:
    """Flip random pixels within ``width`` of the boundary (half in, half out)."""
    if not np.any(pix):
        return pix
    rows, cols = np.nonzero(pix)
    r0, r1 = max(rows.min() - width, 0), rows.max() + width + 1
    c0, c1 = max(cols.min() - width, 0), cols.max() + width + 1
    crop = pix[r0:r1, c0:c1]
    inner = ndimage.binary_erosion(crop, iterations=width)
    outer = ndimage.binary_dilation(crop, iterations=width)
    band = outer & ~inner
    flip = band & (rng.random(crop.shape) < 0.5)
    out = pix.copy()
    out[r0:r1, c0:c1] = crop ^ flip
    return out


def spurious_blob(ids: NDArray[np.int32], depth: NDArray[np.float32], radius_frac: float,
                  rng: np.random.Generator) -> tuple[NDArray[np.bool_], tuple[int, ...]] | None:
    """An elliptic mask on background (terrain) pixels with valid depth, or None."""
    bg = (ids < 0) & (depth > 0)
    cand = np.flatnonzero(bg)
    if len(cand) == 0:
        return None
    h, w = ids.shape
    r, c = divmod(int(cand[rng.integers(len(cand))]), w)
    ry, rx = (rng.uniform(0.5, 1.5, 2) * radius_frac * min(h, w)).tolist()
    yy, xx = np.ogrid[:h, :w]
    blob = ((yy - r) / ry) ** 2 + ((xx - c) / rx) ** 2 <= 1.0
    return blob & bg, ()
