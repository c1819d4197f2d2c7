"""Binning helpers for the evaluation: bin assignment, per-bin tables, runtime statistics.

Bins are half-open ``[lo, hi)`` except the last, which also holds its upper edge, so a
heading difference of exactly 60 deg is in 60-120 and one of 180 deg in 120-180. Values
outside the edges or NaN belong to no bin.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from roman_sim.evaluation.types import BinStats, CurveStats

S = TypeVar("S")


def bin_index(values: Sequence[float] | NDArray[np.float64], edges: Sequence[float]) -> NDArray[np.int64]:
    """Bin of each value (0..len(edges)-2), or -1 outside the edges / NaN."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    e = np.asarray(edges, dtype=np.float64)
    idx = np.searchsorted(e, v, side="right") - 1
    idx = np.where(v == e[-1], len(e) - 2, idx)
    bad = np.isnan(v) | (v < e[0]) | (v > e[-1])
    return np.where(bad, -1, idx).astype(np.int64)


def bin_label(lo: float, hi: float) -> str:
    """``"0-60"`` style label (``%g`` formatting)."""
    return f"{lo:g}-{hi:g}"


def fine_edges(coarse: Sequence[float], step: float) -> list[float]:
    """Edges every ``step`` from the first to the last coarse edge (last edge kept exact)."""
    lo, hi = float(coarse[0]), float(coarse[-1])
    edges = list(np.arange(lo, hi, step, dtype=np.float64))
    if hi - edges[-1] < 1e-9 * max(1.0, hi):
        edges.pop()
    return [float(x) for x in edges] + [hi]


def bin_groups(items: Sequence[S], values: Sequence[float], edges: Sequence[float]) -> list[list[S]]:
    """The items of each bin, in bin order."""
    idx = bin_index(values, edges)
    return [[it for it, j in zip(items, idx) if j == i] for i in range(len(edges) - 1)]


def bin_table(
    items: Sequence[S],
    values: Sequence[float],
    edges: Sequence[float],
    k_values: list[int],
    stats: Callable[[list[S], list[int]], CurveStats],
) -> list[BinStats]:
    """``stats(items in bin, k_values)`` for each bin, labelled with its edges."""
    return [
        BinStats(bin_label(lo, hi), float(lo), float(hi), stats(group, k_values))
        for group, lo, hi in zip(bin_groups(items, values, edges), edges, edges[1:])
    ]


def runtime_stats(runtimes: Sequence[float]) -> dict[str, Any]:
    """Median, mean and 90th percentile (s) of finite runtimes; ``None`` when there are none."""
    r = np.asarray(runtimes, dtype=np.float64)
    r = r[np.isfinite(r)]
    if len(r) == 0:
        return {"n": 0, "median": None, "mean": None, "p90": None}
    return {
        "n": int(len(r)),
        "median": float(np.median(r)),
        "mean": float(np.mean(r)),
        "p90": float(np.percentile(r, 90)),
    }
