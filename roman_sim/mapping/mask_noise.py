"""Mask perturbations used by the simulated segmenter (random ones driven by a given Generator)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage


def neighbour_pairs(ids: NDArray[np.int32], max_gap_px: int) -> dict[tuple[int, int], int]:
    """Pairs of object ids (a < b) that come within ``max_gap_px`` background pixels of each other.

    Returns each pair's smallest gap found along image rows and columns (0: the objects
    touch, mostly where one occludes the other). Depth plays no part: the sensor leaves no
    valid depth on either side of an occlusion edge.

    Args:
        ids: (H, W) object ids, -1 background.
        max_gap_px: largest gap (pixels) to look across.
    """
    out: dict[tuple[int, int], int] = {}
    if ids.size == 0:
        return out
    n = int(ids.max()) + 1
    for gap in range(max(int(max_gap_px), 0), -1, -1):  # smallest gap last, so it wins
        step = gap + 1
        for a, b in ((ids[:, :-step], ids[:, step:]), (ids[:-step, :], ids[step:, :])):
            if a.size == 0:
                continue
            sel = (a != b) & (a >= 0) & (b >= 0)
            if not np.any(sel):
                continue
            lo, hi = np.minimum(a[sel], b[sel]).astype(np.int64), np.maximum(a[sel], b[sel]).astype(np.int64)
            keys = np.unique(lo * n + hi)
            for k in keys.tolist():
                out[(k // n, k % n)] = gap
    return dict(sorted(out.items()))


def split_mask(pix: NDArray[np.bool_], quantile: float) -> list[NDArray[np.bool_]]:
    """Split a mask in two across its longer image axis, the first part holding ``quantile`` of its pixels."""
    rows, cols = np.nonzero(pix)
    axis_vals = rows if np.ptp(rows) >= np.ptp(cols) else cols
    cut = np.quantile(axis_vals, quantile)
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
