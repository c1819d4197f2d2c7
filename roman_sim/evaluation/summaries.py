"""Compact views of a run's results for tables, sweeps, the reference summary and regression tests."""

from __future__ import annotations

from typing import Any

from roman_sim.evaluation.atetable import ALL, COMMON, AteTable
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics, MapStats


def _stats(s: CurveStats) -> dict[str, Any]:
    """A recall with its count, interval and small-set flag."""
    return {"max_recall": s.max_recall, "max_hits": s.max_hits, "n_relevant": s.n_relevant,
            "recall_ci": None if s.recall_ci is None else list(s.recall_ci), "few": s.few}


def _set(metrics: EvaluationMetrics, method: str, kind: str) -> dict[str, Any]:
    ps = metrics.method(method).set(kind)
    o = ps.overall
    return {**_stats(o), "n_pairs": o.n_pairs, "recall_at_precision_1": o.recall_at_precision_1,
            "hits_at_precision_1": o.hits_at_precision_1, "best_f1": o.best_f1, "auc": o.auc,
            "assoc_precision": o.assoc_precision, "assoc_recall": o.assoc_recall,
            "bins": {b.label: _stats(b.stats) for b in ps.heading_bins}}


def compact_summary(metrics: EvaluationMetrics, ate: AteTable | None, map_stats: MapStats | None,
                    runtimes: dict[str, float | None] | None = None) -> dict[str, Any]:
    """JSON-ready summary of a run.

    ``methods[name]`` holds, per pair set (``inter`` cross-robot, ``intra`` same-robot),
    the max recall with its hits / relevant count, Wilson interval and small-set flag, recall
    at precision 1, F1, AUC, association precision / recall and the coarse heading bins; plus
    the median runtime when given. ``ate[variant]`` holds the robots it placed and the SE(3)
    ATE over the common robots and over all robots; ``map`` the map size. Undefined values
    are None.
    """
    out: dict[str, Any] = {"headline": metrics.headline, "pairs": metrics.pairs, "n_skipped": metrics.n_skipped,
                           "methods": {}, "ate": {}, "ate_robots": {}, "map": map_stats.to_json() if map_stats else {}}
    for name in metrics.methods:
        out["methods"][name] = {"inter": _set(metrics, name, "inter"), "intra": _set(metrics, name, "intra"),
                                "runtime_median_s": (runtimes or {}).get(name)}
    if ate is not None and ate.variants:
        out["ate_robots"] = {"robots": list(ate.robots), "common": list(ate.common)}
        for variant, row in ate.variants.items():
            out["ate"][variant] = {"connected": len(row.connected), "common": ate.rmse(variant, "se3", COMMON),
                                   "all": ate.rmse(variant, "se3", ALL)}
    return out
