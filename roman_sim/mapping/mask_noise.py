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
    pairs: set[tuple[int, int]] = set()
    h, w = ids.shape
    flat_i, flat_d = ids.ravel(), depth.ravel()
    for step, valid in ((1, np.arange(w) < w - 1), (w, None)):
        a, b = flat_i[:-step], flat_i[step:]
        idx = np.flatnonzero(a != b)  # object borders are a small fraction of the image
        if valid is not None:
            idx = idx[valid[idx % w]]  # no wrap-around from one row to the next
        ia, ib = a[idx], b[idx]
        da, db = flat_d[idx], flat_d[idx + step]
        sel = (ia >= 0) & (ib >= 0) & (da > 0) & (db > 0) & (np.abs(da - db) <= touch_depth_m)
        if np.any(sel):
            lo, hi = np.minimum(ia[sel], ib[sel]), np.maximum(ia[sel], ib[sel])
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
    """Flip random pixels within ``width`` (chessboard distance) of the boundary, each with p = 0.5.

    ``pix`` should have ``width`` pixels of margin around the mask (dilation stays inside).
    """
    if not np.any(pix):
        return pix
    u = pix.view(np.uint8)
    size = 2 * width + 1  # square window: separable min/max filters are cheap
    band = ndimage.maximum_filter(u, size=size, mode="constant") != ndimage.minimum_filter(
        u, size=size, mode="constant"
    )
    idx = np.flatnonzero(band)
    out = pix.copy()
    flat = out.reshape(-1)
    flip = idx[rng.random(len(idx)) < 0.5]
    flat[flip] = ~flat[flip]
    return out


def spurious_blob(
    ids: NDArray[np.int32], depth: NDArray[np.float32], radius_frac: float, rng: np.random.Generator
) -> tuple[NDArray[np.bool_], tuple[int, int]] | None:
    """An elliptic crop mask on background (terrain) pixels with valid depth and its (row, col) origin."""
    h, w = ids.shape
    r, c = int(rng.integers(h)), int(rng.integers(w))
    if ids[r, c] >= 0 or depth[r, c] <= 0:
        return None  # the seed pixel is not terrain: no spurious mask this time
    ry, rx = (rng.uniform(0.5, 1.5, 2) * radius_frac * min(h, w)).tolist()
    r0, r1 = max(int(r - ry), 0), min(int(r + ry) + 1, h)
    c0, c1 = max(int(c - rx), 0), min(int(c + rx) + 1, w)
    yy, xx = np.ogrid[r0:r1, c0:c1]
    blob = ((yy - r) / ry) ** 2 + ((xx - c) / rx) ** 2 <= 1.0
    return blob & (ids[r0:r1, c0:c1] < 0) & (depth[r0:r1, c0:c1] > 0), (r0, c0)
