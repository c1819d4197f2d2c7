"""CLIPPER's rounding in numpy: top entries of ``u`` made a clique, extended, then improved locally.

The numpy path of ``roman_sim.align.clipper`` (``roman_sim.align.clipper_jit_rounding`` is
its compiled twin, tested to give the same bits). The top ``round(F)`` entries of ``u`` are
made a clique greedily (descending ``u``), extended by any node adjacent to every selected
node whose addition raises the clique density ``1^T M_S 1 / |S|``, and finally improved by
single additions / one-for-one swaps while the density rises.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray


def _sub_sum(A: sp.csr_matrix, idx: NDArray[np.int64] | list[int]) -> float:
    """``A[idx][:, idx].sum()`` without fancy indexing (``idx`` unique).

    scipy sums the submatrix's entries in canonical order (rows in ``idx`` order, columns by
    their position in ``idx``); gathering them in that order gives the same bits.
    """
    idx = np.asarray(idx, dtype=np.int64)
    pos = np.full(A.shape[1], -1, dtype=np.int64)
    pos[idx] = np.arange(len(idx))
    parts = []
    for i in idx:
        lo, hi = A.indptr[i], A.indptr[i + 1]
        p = pos[A.indices[lo:hi]]
        keep = p >= 0
        parts.append(A.data[lo:hi][keep][np.argsort(p[keep], kind="stable")])
    data = np.concatenate(parts) if parts else np.zeros(0)
    return float(np.sum(data)) if len(data) else 0.0


def clique_density(A: sp.csr_matrix, sel: NDArray[np.int64]) -> float:
    """``1^T M_S 1 / |S|`` with unit diagonal (``A`` without diagonal)."""
    if len(sel) == 0:
        return 0.0
    return float((_sub_sum(A, sel) + len(sel)) / len(sel))


def round_solution(A: sp.csr_matrix, u: NDArray[np.float64], F: float, eps: float = 1e-9) -> NDArray[np.int64]:
    """Top ``round(F)`` entries of ``u`` made a clique, then greedily extended (see module doc)."""
    order = np.argsort(-u, kind="stable")
    order = order[u[order] > eps]
    k = max(1, int(round(F)))
    chosen: list[int] = []
    mask = np.zeros(A.shape[0], dtype=bool)
    for i in order:
        if len(chosen) >= k:
            break
        if _row_weights(A, int(i), mask, len(chosen)) is not None:
            chosen.append(int(i))
            mask[int(i)] = True
    if not chosen:
        return np.zeros(0, dtype=np.int64)
    return _local_search(A, _extend(A, order, chosen, mask))


def _row_weights(A: sp.csr_matrix, i: int, chosen_mask: NDArray[np.bool_], n_chosen: int) -> NDArray[np.float64] | None:
    """Weights from node ``i`` to the chosen nodes (``chosen_mask``), or None if one is not a neighbour."""
    lo, hi = A.indptr[i], A.indptr[i + 1]
    hit = chosen_mask[A.indices[lo:hi]]
    if int(hit.sum()) != n_chosen:
        return None
    return A.data[lo:hi][hit]


def _extend(
    A: sp.csr_matrix, order: NDArray[np.int64], chosen: list[int], mask: NDArray[np.bool_]
) -> NDArray[np.int64]:
    """Add nodes adjacent to all chosen ones while the clique density increases (``mask`` marks them)."""
    total = _sub_sum(A, chosen) + len(chosen)
    for i in order:
        i = int(i)
        if mask[i]:
            continue
        w = _row_weights(A, i, mask, len(chosen))
        if w is None:
            continue
        gain = 2.0 * float(w.sum()) + 1.0
        if (total + gain) / (len(chosen) + 1) > total / len(chosen):
            chosen.append(i)
            mask[i] = True
            total += gain
    return np.sort(np.asarray(chosen, dtype=np.int64))


def _dense_rows(A: sp.csr_matrix, rows: NDArray[np.int64]) -> NDArray[np.float64]:
    """``A[rows].toarray()`` without scipy's fancy-indexing overhead (a handful of rows per call)."""
    out = np.zeros((len(rows), A.shape[1]))
    for r, i in enumerate(rows):
        lo, hi = A.indptr[i], A.indptr[i + 1]
        out[r, A.indices[lo:hi]] = A.data[lo:hi]
    return out


def _local_search(A: sp.csr_matrix, sel: NDArray[np.int64], max_rounds: int = 50) -> NDArray[np.int64]:
    """Improve the clique density by single additions or one-for-one swaps, best move first.

    Every move keeps ``sel`` a clique of ``A > 0`` and strictly raises the density, so the
    loop ends; it repairs most cases where the ascent stopped next to a denser clique.
    """
    sel = np.asarray(sel, dtype=np.int64)
    for _ in range(max_rounds):
        k = len(sel)
        W = np.ascontiguousarray(_dense_rows(A, sel).T)  # A is symmetric: its columns sel are its rows sel
        cnt, wsum = (W > 0).sum(axis=1), W.sum(axis=1)
        inside = np.zeros(A.shape[0], dtype=bool)
        inside[sel] = True
        total = float(wsum[sel].sum())
        base = (total + k) / k
        add = np.where((cnt == k) & ~inside, (total + 2 * wsum + k + 1) / (k + 1), -np.inf)
        swap = np.full(A.shape[0], -np.inf)
        cand = np.flatnonzero((cnt == k - 1) & ~inside)
        if len(cand):
            missing = np.argmin(W[cand] > 0, axis=1)
            r_out = wsum[sel[missing]]
            swap[cand] = (total - 2 * r_out + 2 * wsum[cand] + k) / k
        best_add, best_swap = int(np.argmax(add)), int(np.argmax(swap))
        if max(add[best_add], swap[best_swap]) <= base + 1e-12:
            break
        if add[best_add] >= swap[best_swap]:
            sel = np.sort(np.append(sel, best_add))
        else:
            drop = sel[np.argmin(W[best_swap] > 0)]
            sel = np.sort(np.append(sel[sel != drop], best_swap))
    return sel
