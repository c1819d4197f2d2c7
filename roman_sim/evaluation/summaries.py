"""Compact views of a run's results for tables, sweeps and regression tests."""

from __future__ import annotations

from typing import Any

from roman_sim.evaluation.types import AteTable, EvaluationMetrics, MapStats


def compact_summary(metrics: EvaluationMetrics, ate: AteTable | None, map_stats: MapStats | None,
                    runtimes: dict[str, float | None] | None = None) -> dict[str, Any]:
    """Per method: max recall, recall at precision 1, F1, AUC, coarse-bin recall and (when
    given) median runtime; plus the concatenated SE(3) ATE of each pose-graph variant and
    the map size. JSON-ready; undefined values are None."""
    out: dict[str, Any] = {"methods": {}, "ate_rmse_m": {}, "map": map_stats.to_json() if map_stats else {}}
    for name, m in metrics.methods.items():
        o = m.overall
        row: dict[str, Any] = {"max_recall": o.max_recall, "max_hits": o.max_hits,
                               "recall_at_precision_1": o.recall_at_precision_1, "best_f1": o.best_f1,
                               "auc": o.auc, "n_relevant": o.n_relevant}
        row["runtime_median_s"] = (runtimes or {}).get(name)
        for b in m.heading_bins:
            row[f"recall_{b.label}"] = b.stats.max_recall
        out["methods"][name] = row
    for variant in (ate.variants if ate else {}):
        out["ate_rmse_m"][variant] = ate.rmse(variant) if ate else None
    return out
