"""A user-supplied aligner: mutual nearest neighbours in descriptor space, then Arun.

Run it next to the built-in methods:
    roman-sim run smoke --aligner examples.mutual_nn_aligner:MutualNNAligner
(from the repository root, so that ``examples`` is importable).
"""

from __future__ import annotations

import time

import numpy as np

from roman_sim.align.base import AlignResult
from roman_sim.core.geometry import arun_4dof
from roman_sim.mapping.types import Submap


class MutualNNAligner:
    """Associates segments whose descriptors are mutual nearest neighbours (cosine)."""

    name = "MutualNNAligner"

    def __init__(self, min_cosine: float = 0.9) -> None:
        self.min_cosine = min_cosine

    def align(self, a: Submap, b: Submap) -> AlignResult:
        t0 = time.perf_counter()
        if len(a) < 3 or len(b) < 3:
            return AlignResult.failure(self.name, "fewer than 3 segments")
        da = np.asarray(a.descriptors, dtype=np.float64)
        db = np.asarray(b.descriptors, dtype=np.float64)
        sim = da @ db.T
        best_b, best_a = sim.argmax(axis=1), sim.argmax(axis=0)
        pairs = np.array(
            [(i, j) for i, j in enumerate(best_b) if best_a[j] == i and sim[i, j] >= self.min_cosine], dtype=np.int64
        ).reshape(-1, 2)
        if len(pairs) < 3:
            return AlignResult.failure(self.name, "fewer than 3 mutual matches", time.perf_counter() - t0)
        T = arun_4dof(b.centers[pairs[:, 1]], a.centers[pairs[:, 0]])
        return AlignResult(self.name, T, pairs, sim[pairs[:, 0], pairs[:, 1]], time.perf_counter() - t0)
