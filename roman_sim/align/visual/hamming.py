"""Hamming distances and bit majorities of packed binary descriptors (n, 32) uint8.

Vectorised with numpy: descriptors are viewed as four uint64 words, XORed and counted
with ``np.bitwise_count`` (numpy >= 2.0) or, on older numpy, a 256-entry popcount table
over the bytes. Both give the same integers.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

_POPCOUNT8 = np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1).sum(axis=1).astype(np.uint8)
_HAS_BITWISE_COUNT = hasattr(np, "bitwise_count")


def _as_words(d: NDArray[np.uint8]) -> NDArray[np.uint64]:
    d = np.ascontiguousarray(d, dtype=np.uint8)
    if d.shape[-1] % 8:
        raise ValueError(f"descriptor length {d.shape[-1]} bytes is not a multiple of 8")
    return d.view(np.uint64)


def popcount(x: NDArray[np.uint64]) -> NDArray[np.int32]:
    """Set bits of each uint64 element."""
    if _HAS_BITWISE_COUNT:
        return np.bitwise_count(x).astype(np.int32)
    b = x.view(np.uint8).reshape(*x.shape, 8)
    return _POPCOUNT8[b].sum(axis=-1, dtype=np.int32)


def hamming(a: NDArray[np.uint8], b: NDArray[np.uint8]) -> NDArray[np.int32]:
    """Hamming distance between broadcastable descriptor arrays ``(..., 32)`` -> ``(...)``."""
    x = np.bitwise_xor(_as_words(a), _as_words(b))
    return popcount(x).sum(axis=-1, dtype=np.int32)


def hamming_matrix(a: NDArray[np.uint8], b: NDArray[np.uint8], block: int = 8192) -> NDArray[np.int32]:
    """All-pairs distances (n, m) of descriptors a (n, 32) and b (m, 32), in row blocks."""
    wa, wb = _as_words(a), _as_words(b)
    out = np.empty((len(wa), len(wb)), dtype=np.int32)
    for s in range(0, len(wa), block):
        x = np.bitwise_xor(wa[s : s + block, None, :], wb[None, :, :])
        out[s : s + block] = popcount(x).sum(axis=-1, dtype=np.int32)
    return out


def majority(d: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Bitwise majority (DBoW2's mean of binary descriptors) of (m, 32) -> (32,).

    A bit is set when at least half of the descriptors set it (``2 * count >= m``), as
    DBoW2's ``FORB::meanValue`` does.
    """
    bits = np.unpackbits(np.asarray(d, dtype=np.uint8), axis=1)
    counts = bits.sum(axis=0, dtype=np.int64)
    return np.packbits((2 * counts >= len(d)).astype(np.uint8))


def majority_by_label(
    d: NDArray[np.uint8], labels: NDArray[np.int64], k: int
) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
    """Bitwise majority of the descriptors of each label 0..k-1 -> (k, 32) and a (k,) non-empty mask."""
    order = np.argsort(labels, kind="stable")
    lab = labels[order]
    bits = np.unpackbits(np.asarray(d, dtype=np.uint8)[order], axis=1).astype(np.int32)
    present, starts, counts = np.unique(lab, return_index=True, return_counts=True)
    sums = np.add.reduceat(bits, starts, axis=0)
    out = np.zeros((k, d.shape[1]), dtype=np.uint8)
    out[present] = np.packbits((2 * sums >= counts[:, None]).astype(np.uint8), axis=1)
    nonempty = np.zeros(k, dtype=bool)
    nonempty[present] = True
    return out, nonempty
