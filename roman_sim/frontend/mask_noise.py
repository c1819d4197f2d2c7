"""Mask perturbations used by the simulated segmenter (random ones driven by a given Generator)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage


def neighbour_pairs(ids: NDArray[np.int32], max_gap_px: int) -> dict[tuple[int, int], int]:
    """Pairs of object ids (a < b) next to each other along an image row or column.

    Two objects are neighbours where a run of one is followed, along a row or a column, by a
    run of the other directly (gap 0: they touch, mostly where one occludes the other) or
    after a run of at most ``max_gap_px`` background pixels. Returns each pair's smallest gap.
    Depth plays no part: the sensor leaves no valid depth on either side of an occlusion edge.
    Runs are found with whole-image operations, so the cost follows the number of runs.

    Args:
        ids: (H, W) object ids, -1 background.
        max_gap_px: largest background gap (pixels) to look across (0: touching only).
    """
    if ids.size == 0:
        return {}
    n = int(ids.max()) + 2
    keys, gaps = [], []
    for img in (ids, np.ascontiguousarray(ids.T)):
        h, w = img.shape
        flat = img.ravel()
        # run starts, row by row: where the id changes, and every row's first pixel
        change = flat[1:] != flat[:-1]
        change[w - 1 :: w] = True
        starts = np.concatenate(([0], np.flatnonzero(change) + 1))
        r, c = starts // w, starts % w
        val = flat[starts].astype(np.int64)
        last = np.append(r[1:] != r[:-1], True)  # the run ends its row
        length = np.where(last, w - c, np.append(c[1:], w) - c)
        same = ~last[:-1]
        touch = same & (val[:-1] >= 0) & (val[1:] >= 0)
        keys.append(_pair_keys(val[:-1][touch], val[1:][touch], n))
        gaps.append(np.zeros(int(touch.sum()), np.int64))
        if max_gap_px > 0 and len(val) > 2:
            across = same[:-1] & same[1:] & (val[1:-1] < 0) & (length[1:-1] <= max_gap_px)
            across &= (val[:-2] >= 0) & (val[2:] >= 0) & (val[:-2] != val[2:])
            keys.append(_pair_keys(val[:-2][across], val[2:][across], n))
            gaps.append(length[1:-1][across])
    k, g = np.concatenate(keys), np.concatenate(gaps)
    order = np.lexsort((g, k))
    k, g = k[order], g[order]
    first = np.ones(len(k), dtype=bool)
    first[1:] = k[1:] != k[:-1]
    return {(int(x // n), int(x % n)): int(y) for x, y in zip(k[first].tolist(), g[first].tolist())}


def _pair_keys(a: NDArray[np.int64], b: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """One integer per unordered pair (min, max) of ids below ``n``."""
    return np.minimum(a, b) * n + np.maximum(a, b)


def split_mask(pix: NDArray[np.bool_], quantile: float) -> list[NDArray[np.bool_]]:
    """Split a mask in two across its longer image axis, the first part holding ``quantile`` of its pixels."""
    rows, cols = np.nonzero(pix)
    axis_vals = rows if np.ptp(rows) >= np.ptp(cols) else cols
    cut = np.quantile(axis_vals, quantile)
    first = np.zeros_like(pix)
    sel = axis_vals <= cut
    first[rows[sel], cols[sel]] = True
    return [first, pix & ~first]


def boundary_band(pix: NDArray[np.bool_], width: int) -> NDArray[np.bool_]:
    """Pixels within ``width`` (chessboard distance) of the boundary of ``pix`` (outside counts as empty).

    Where the maximum and the minimum of the (2 width + 1)-square window differ; OpenCV's
    dilation and erosion give the bits of ``boundary_band_reference`` (scipy's filters).
    """
    import cv2  # imported on use: loading a configuration should not import OpenCV

    u = np.ascontiguousarray(pix).view(np.uint8)
    square = np.ones((2 * width + 1, 2 * width + 1), dtype=np.uint8)
    hi = cv2.dilate(u, square, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    lo = cv2.erode(u, square, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return hi != lo


def boundary_band_reference(pix: NDArray[np.bool_], width: int) -> NDArray[np.bool_]:
    """``boundary_band`` by scipy's maximum and minimum filters."""
    u = pix.view(np.uint8)
    size = 2 * width + 1  # square window: separable min/max filters are cheap
    return ndimage.maximum_filter(u, size=size, mode="constant") != ndimage.minimum_filter(
        u, size=size, mode="constant"
    )


def noisy_boundary(pix: NDArray[np.bool_], width: int, rng: np.random.Generator) -> NDArray[np.bool_]:
    """Flip random pixels within ``width`` (chessboard distance) of the boundary, each with p = 0.5.

    ``pix`` should have ``width`` pixels of margin around the mask (dilation stays inside).
    """
    if not np.any(pix):
        return pix
    band = boundary_band(pix, width)
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
