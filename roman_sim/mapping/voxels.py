"""Fast voxel helpers on int64-hashed voxel keys (1D numpy set operations).

A voxel key ``(i, j, k) = floor(p / voxel)`` is packed into one int64 with 21 bits per
axis, so sets of voxels become sorted 1D arrays and IoU is ``np.intersect1d`` /
``np.isin`` work instead of row-wise ``np.unique(axis=0)``. Keys are valid for
|i|, |j|, |k| < 2**20 (about 52 km at 0.05 m); points outside raise ``MappingError``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import MappingError

_BITS = 21
_OFFSET = 1 << (_BITS - 1)
_MASK = (1 << _BITS) - 1

#: Packed-key offsets of the 27 voxels of a 3x3x3 neighbourhood (valid away from the key range ends).
NEIGHBOUR_OFFSETS = np.array(
    [(dx << (2 * _BITS)) + (dy << _BITS) + dz for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)],
    dtype=np.int64,
)


def hash_voxels(points: NDArray[np.float64], voxel: float) -> NDArray[np.int64]:
    """Packed int64 voxel key of every point (N,), not deduplicated."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return np.zeros(0, dtype=np.int64)
    if not np.all(np.isfinite(pts)):
        raise MappingError("points: non-finite coordinates cannot be voxelised")
    k = np.floor(pts / voxel).astype(np.int64) + _OFFSET
    if k.min() < 0 or k.max() > _MASK:
        raise MappingError(f"points: coordinates beyond +-{_OFFSET * voxel:.0f} m cannot be voxelised")
    return (k[:, 0] << (2 * _BITS)) | (k[:, 1] << _BITS) | k[:, 2]


def voxel_set(points: NDArray[np.float64], voxel: float) -> NDArray[np.int64]:
    """Sorted unique packed voxel keys of ``points``."""
    return np.unique(hash_voxels(points, voxel))


def downsample(points: NDArray[np.float64], voxel: float) -> NDArray[np.float64]:
    """One point per occupied voxel (mean of its points), ordered by voxel key."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return pts
    _, inv, counts = np.unique(hash_voxels(pts, voxel), return_inverse=True, return_counts=True)
    out = np.empty((len(counts), 3))
    for d in range(3):
        out[:, d] = np.bincount(inv, weights=pts[:, d], minlength=len(counts))
    return out / counts[:, None]


def downsample_union(
    a: NDArray[np.float64], b: NDArray[np.float64], voxel: float, keys_a: NDArray[np.int64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
    """``downsample(np.vstack([a, b]), voxel)`` of two downsampled clouds, by a merge instead of a sort.

    When the voxel keys of ``a`` and of ``b`` each strictly increase (one point per voxel, in
    ``downsample``'s order), every voxel of the union holds one point of either cloud or one of
    each, and ``downsample`` gives ``(0 + p) / 1`` or ``((0 + p) + q) / 2`` (``np.bincount``'s
    running sums): the same bits are computed here directly. Otherwise (a mean rounded across a
    voxel border) ``downsample`` runs.

    Args:
        a: the first cloud (N, 3).
        b: the second cloud (M, 3).
        voxel: voxel size (m).
        keys_a: ``hash_voxels(a, voxel)`` when the caller has it.

    Returns: the points and, after a merge, their voxel keys (each merged point is the mean of
    two points of one voxel, so it stays in that voxel), else None.
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
    if len(a) == 0 or len(b) == 0:
        return downsample(np.vstack([a, b]), voxel), None
    ka = hash_voxels(a, voxel) if keys_a is None else keys_a
    kb = hash_voxels(b, voxel)
    if not (np.all(ka[1:] > ka[:-1]) and np.all(kb[1:] > kb[:-1])):
        return downsample(np.vstack([a, b]), voxel), None
    pos = np.searchsorted(ka, kb)
    hit = pos < len(ka)
    hit[hit] = ka[pos[hit]] == kb[hit]
    kb_new = kb[~hit]
    at_a = np.arange(len(ka)) + np.searchsorted(kb_new, ka)  # output row of each point of a
    at_b = np.searchsorted(ka, kb_new) + np.arange(len(kb_new))
    out = np.empty((len(ka) + len(kb_new), 3))
    out[at_a] = a + 0.0
    out[at_b] = b[~hit] + 0.0
    both = pos[hit]
    out[at_a[both]] = ((a[both] + 0.0) + b[hit]) / 2.0
    keys = np.empty(len(out), dtype=np.int64)
    keys[at_a], keys[at_b] = ka, kb_new
    return out, keys


def pack_cells(cells: NDArray[np.int64]) -> NDArray[np.int64] | None:
    """Packed int64 keys of integer cells (N, 3) in their lexicographic order, or None when a
    coordinate (or its neighbour) is outside the packing range."""
    c = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    if len(c) and (c.min() <= -_OFFSET or c.max() >= _OFFSET - 1):
        return None
    k = c + _OFFSET
    return (k[:, 0] << (2 * _BITS)) | (k[:, 1] << _BITS) | k[:, 2]


def neighbour_pairs(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index pairs (i, j) of sorted unique packed keys whose cells touch (26-neighbours), i < j."""
    fwd = NEIGHBOUR_OFFSETS[NEIGHBOUR_OFFSETS > 0]  # 13 offsets: each touching pair once
    q = (keys[None, :] + fwd[:, None]).ravel()
    j = np.minimum(np.searchsorted(keys, q), len(keys) - 1)
    found = keys[j] == q
    i = np.tile(np.arange(len(keys)), len(fwd))
    return i[found], j[found]


def iou(a: NDArray[np.int64], b: NDArray[np.int64]) -> float:
    """IoU of two sorted unique key sets (0 when both are empty)."""
    if len(a) == 0 or len(b) == 0:
        return 0.0
    inter = len(np.intersect1d(a, b, assume_unique=True))
    return inter / (len(a) + len(b) - inter)


def iou_matrix(obs: list[NDArray[np.int64]], segs: list[NDArray[np.int64]]) -> NDArray[np.float64]:
    """(len(obs), len(segs)) voxel IoU; one ``np.isin`` per observation.

    Args:
        obs: sorted unique key sets of the observations.
        segs: sorted unique key sets of the segments.
    """
    out = np.zeros((len(obs), len(segs)))
    if not obs or not segs:
        return out
    labels = np.concatenate([np.full(len(s), j, dtype=np.int64) for j, s in enumerate(segs)])
    allkeys = np.concatenate(segs)
    sizes = np.array([len(s) for s in segs], dtype=np.float64)
    for i, o in enumerate(obs):
        if len(o) == 0:
            continue
        inter = np.bincount(labels[np.isin(allkeys, o)], minlength=len(segs)).astype(np.float64)
        out[i] = inter / (len(o) + sizes - inter)
    return out
