"""Sparse bag-of-words vectors and DBoW2's L1 score.

For L1-normalised non-negative vectors, ``s = 1 - 0.5 |v1 - v2|_1`` equals the sum over
shared words of ``min(v1_w, v2_w)``: 1 for identical vectors, 0 for vectors without a
common word.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass
class BowVector:
    """A sparse BoW vector: sorted unique word ids (n,) int32 and their values (n,) float32."""

    words: NDArray[np.int32]
    values: NDArray[np.float32]

    @classmethod
    def empty(cls) -> BowVector:
        """The vector of an image without features (scores 0 against anything)."""
        return cls(np.zeros(0, np.int32), np.zeros(0, np.float32))

    def __len__(self) -> int:
        return len(self.words)


def l1_score(v1: BowVector, v2: BowVector) -> float:
    """DBoW2's L1 score ``1 - 0.5 |v1 - v2|_1`` of two L1-normalised vectors."""
    _, i1, i2 = np.intersect1d(v1.words, v2.words, assume_unique=True, return_indices=True)
    return float(np.minimum(v1.values[i1].astype(np.float64), v2.values[i2]).sum())


def score_matrix(qs: list[BowVector], cs: list[BowVector]) -> NDArray[np.float64]:
    """L1 scores (len(qs), len(cs)) of every query against every candidate (dense over used words)."""
    out = np.zeros((len(qs), len(cs)))
    if not qs or not cs:
        return out
    n = 1 + max([int(v.words.max()) for v in qs + cs if len(v)], default=-1)
    if n == 0:
        return out
    Q, C = np.zeros((len(qs), n)), np.zeros((len(cs), n))
    for M, vs in ((Q, qs), (C, cs)):
        for r, v in enumerate(vs):
            M[r, v.words] = v.values
    for r in range(len(qs)):
        out[r] = np.minimum(Q[r][None, :], C).sum(axis=1)
    return out
