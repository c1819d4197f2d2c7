"""CLIPPER's rounding compiled with numba: greedy clique, extension, local search, density.

The same decisions and sums, in the same order, as ``round_solution`` and ``clique_density``
of ``roman_sim.align.clipper_rounding`` (see ``roman_sim.align.clipper_jit`` for how the bits are kept).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.clipper_jit import F64, Idx, Ptr, _jit, _pairwise, total

I64 = NDArray[np.int64]
Mask = NDArray[np.bool_]


@_jit
def _hits(indptr: Ptr, indices: Idx, data: F64, i: int, mask: Mask, w: F64) -> int:
    """Neighbours of ``i`` among the masked nodes; their weights go to ``w`` in CSR order."""
    c = 0
    for jj in range(indptr[i], indptr[i + 1]):
        if mask[indices[jj]]:
            w[c] = data[jj]
            c += 1
    return c


@_jit
def sub_sum(indptr: Ptr, indices: Idx, data: F64, idx: I64, n_idx: int) -> float:
    """``A[idx][:, idx].sum()``: rows in ``idx`` order, columns by their position in ``idx``."""
    pos = np.full(indptr.shape[0] - 1, -1, dtype=np.int64)
    for r in range(n_idx):
        pos[idx[r]] = r
    buf = np.empty(n_idx * n_idx)
    row = np.empty(n_idx)
    seen = np.zeros(n_idx, dtype=np.bool_)
    k = 0
    for r in range(n_idx):
        i = idx[r]
        for jj in range(indptr[i], indptr[i + 1]):
            p = pos[indices[jj]]
            if p >= 0:
                row[p] = data[jj]
                seen[p] = True
        for p in range(n_idx):
            if seen[p]:
                buf[k] = row[p]
                k += 1
                seen[p] = False
    return _pairwise(buf, 0, k) if k else 0.0


@_jit
def _greedy(indptr: Ptr, indices: Idx, data: F64, order: I64, k_max: int, mask: Mask) -> I64:
    """Nodes in ``order`` that keep the chosen set a clique, until ``k_max`` are chosen; then the
    extension by any adjacent node that raises the density (``_extend``)."""
    chosen = np.empty(order.shape[0], dtype=np.int64)
    w = np.empty(order.shape[0])
    c = 0
    for i in order:
        if c >= k_max:
            break
        if _hits(indptr, indices, data, i, mask, w) == c:
            chosen[c] = i
            mask[i] = True
            c += 1
    if c == 0:
        return chosen[:0]
    tot = sub_sum(indptr, indices, data, chosen, c) + c
    for i in order:
        if mask[i] or _hits(indptr, indices, data, i, mask, w) != c:
            continue
        gain = 2.0 * _pairwise(w, 0, c) + 1.0
        if (tot + gain) / (c + 1) > tot / c:
            chosen[c] = i
            mask[i] = True
            c += 1
            tot += gain
    return np.sort(chosen[:c])


@_jit
def _dense_columns(indptr: Ptr, indices: Idx, data: F64, sel: I64, n: int) -> F64:
    """(n, k) ``W[j, r] = A[sel[r], j]`` (the symmetric matrix's columns ``sel``)."""
    W = np.zeros((n, sel.shape[0]))
    for r in range(sel.shape[0]):
        for jj in range(indptr[sel[r]], indptr[sel[r] + 1]):
            W[indices[jj], r] = data[jj]
    return W


@_jit
def _first_zero(W: F64, j: int) -> int:
    """``argmin(W[j] > 0)``: the first column of row ``j`` without an edge (0 if none)."""
    for r in range(W.shape[1]):
        if not W[j, r] > 0:
            return r
    return 0


@_jit
def _best_move(W: F64, sel: I64, n: int) -> tuple[float, int, float, int, float]:
    """Base density and the best addition and swap (value, node) of one local-search round."""
    k = sel.shape[0]
    flat = W.ravel()
    wsum, cnt = np.empty(n), np.zeros(n, dtype=np.int64)
    for j in range(n):
        wsum[j] = _pairwise(flat, j * k, k)
        for r in range(k):
            cnt[j] += W[j, r] > 0
    inside = np.zeros(n, dtype=np.bool_)
    ws = np.empty(k)
    for r in range(k):
        inside[sel[r]] = True
        ws[r] = wsum[sel[r]]
    tot = total(ws)
    best_add, add_j, best_swap, swap_j = -np.inf, 0, -np.inf, 0
    for j in range(n):
        if inside[j]:
            continue
        if cnt[j] == k:
            v = (tot + 2 * wsum[j] + k + 1) / (k + 1)
            if v > best_add:
                best_add, add_j = v, j
        elif cnt[j] == k - 1:
            r_out = wsum[sel[_first_zero(W, j)]]
            v = (tot - 2 * r_out + 2 * wsum[j] + k) / k
            if v > best_swap:
                best_swap, swap_j = v, j
    return (tot + k) / k, add_j, best_add, swap_j, best_swap


@_jit
def _local_search(indptr: Ptr, indices: Idx, data: F64, sel: I64, max_rounds: int) -> I64:
    """Single additions or one-for-one swaps, best move first, while the density rises."""
    n = indptr.shape[0] - 1
    for _ in range(max_rounds):
        W = _dense_columns(indptr, indices, data, sel, n)
        base, add_j, best_add, swap_j, best_swap = _best_move(W, sel, n)
        if max(best_add, best_swap) <= base + 1e-12:
            break
        if best_add >= best_swap:
            sel = np.sort(np.append(sel, add_j))
        else:
            drop = sel[_first_zero(W, swap_j)]
            sel = np.sort(np.append(sel[sel != drop], swap_j))
    return sel


@_jit
def round_and_score(indptr: Ptr, indices: Idx, data: F64, u: F64, k_max: int, eps: float) -> tuple[I64, float]:
    """``round_solution`` then ``clique_density``: the selected nodes (sorted) and their density."""
    order = np.argsort(-u, kind="mergesort")
    order = order[u[order] > eps]
    mask = np.zeros(u.shape[0], dtype=np.bool_)
    sel = _greedy(indptr, indices, data, order, k_max, mask)
    if sel.shape[0] == 0:
        return sel, 0.0
    sel = _local_search(indptr, indices, data, sel, 50)
    return sel, (sub_sum(indptr, indices, data, sel, sel.shape[0]) + sel.shape[0]) / sel.shape[0]
