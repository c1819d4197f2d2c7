"""The named confidence scores an aligner gives beside its association count.

A pair is accepted when its score reaches a threshold; the association count
(``associations``) is every method's default. ROMAN and its CLIPPER variants also give:

- ``objective``: CLIPPER's objective ``F = u^T M u`` at the end of its ascent (``u`` unit,
  ``M`` the affinity matrix with unit diagonal): the soft size of the densest consistent set;
- ``density``: ``1^T M_S 1 / |S|`` of the selected set ``S`` (the rounded clique's density);
- ``percent_associations``: the reference ROMAN's own score, the association count over the
  mean segment count of the two submaps (0 when both are empty). The reference counts 0
  associations when its registration failed; here the count is that of ``associations``
  (the selected set, also when too few for a transform), so the two scores rank alike;
- ``margin``: the objective of the best hypothesis minus that of the second-best, where the
  second-best is CLIPPER solved again on the putative associations without the selected
  ones (the densest consistent set that reuses none of the chosen associations); clipped at
  0 (CLIPPER is a local method: a second solve may end above the first);
- ``semantic``: the mean cosine of the semantic descriptors of the associated segments
  (methods that read descriptors, with at least one association).

Baselines give what they have: RANSAC its best hypothesis' ``inliers`` over all
correspondences, the visual method its place-recognition ``bow_score`` and ``matches``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from roman_sim.align.clipper import ClipperParams, solve_clipper


def percent_associations(n_associations: int, n_a: int, n_b: int) -> float:
    """``n_associations / mean(n_a, n_b)`` (0 when both submaps are empty), as the reference computes it."""
    mean = 0.5 * (n_a + n_b)
    return float(n_associations / mean) if mean > 0 else 0.0


def mean_cosine(da: NDArray[np.floating], db: NDArray[np.floating], sel: NDArray[np.int64]) -> float:
    """Mean cosine of the descriptors of the associated segments ``sel`` (k, 2), k >= 1."""
    x = np.asarray(da, dtype=np.float64)[sel[:, 0]]
    y = np.asarray(db, dtype=np.float64)[sel[:, 1]]
    cos = np.einsum("ij,ij->i", x, y) / (np.linalg.norm(x, axis=1) * np.linalg.norm(y, axis=1))
    return float(np.mean(cos))


def rival_objective(M: sp.spmatrix, selected: NDArray[np.int64], params: ClipperParams) -> float:
    """CLIPPER's objective on ``M`` without the ``selected`` associations (0 when none is left)."""
    keep = np.setdiff1d(np.arange(M.shape[0]), np.asarray(selected, dtype=np.int64))
    if len(keep) == 0:
        return 0.0
    sub = sp.csr_matrix(M)[keep][:, keep]
    return float(solve_clipper(sub, params).F)
