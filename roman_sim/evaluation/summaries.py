"""Compact views of a run's ``metrics.json`` for tables, sweeps and regression tests."""

from __future__ import annotations

from typing import Any

from roman_sim.core.errors import EvaluationError


def method_metrics(metrics: dict[str, Any], method: str) -> dict[str, Any]:
    """The summary of ``method``; unknown methods raise ``EvaluationError`` listing the known ones."""
    methods = metrics.get("methods", {})
    if method not in methods:
        raise EvaluationError(f"method {method!r} not in this run (methods: {', '.join(sorted(methods)) or 'none'})")
    return methods[method]


def method_recall(metrics: dict[str, Any], method: str, heading_bin: str | None = None,
                  key: str = "max_recall") -> float | None:
    """``key`` (default max recall) of ``method`` overall or in a heading bin (``"120-180"``).

    Bins are looked up among the coarse bins, then the fine ones. None when undefined.
    """
    m = method_metrics(metrics, method)
    if heading_bin is None:
        return m.get(key)
    for table in ("heading_bins", "heading_bins_fine"):
        for row in m.get(table, []):
            if row["label"] == heading_bin:
                return row.get(key)
    labels = [r["label"] for r in m.get("heading_bins", []) + m.get("heading_bins_fine", [])]
    raise EvaluationError(f"heading bin {heading_bin!r} unknown (bins: {', '.join(labels)})")


def compact_summary(metrics: dict[str, Any], ate: dict[str, Any], map_stats: dict[str, Any]) -> dict[str, Any]:
    """Per method: max recall, recall at precision 1, F1, AUC, coarse-bin recall, median runtime;
    plus the concatenated SE(3) ATE of each pose-graph variant and the map size."""
    out: dict[str, Any] = {"methods": {}, "ate_rmse_m": {}, "map": dict(map_stats)}
    for name, m in sorted(metrics.get("methods", {}).items()):
        row = {k: m.get(k) for k in ("max_recall", "recall_at_precision_1", "best_f1", "auc", "n_relevant")}
        row["runtime_median_s"] = (m.get("runtime_s") or {}).get("median")
        for b in m.get("heading_bins", []):
            row[f"recall_{b['label']}"] = b.get("max_recall")
        out["methods"][name] = row
    for variant, v in sorted(ate.items()):
        out["ate_rmse_m"][variant] = ((v or {}).get("se3") or {}).get("all")
    return out
