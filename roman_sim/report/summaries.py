"""Compact views of a run's results for tables, sweeps, the reference summary and regression tests."""

from __future__ import annotations

from typing import Any

from roman_sim.evaluation.atetable import ALL, COMMON, AteTable
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics, MapStats


def _stats(s: CurveStats) -> dict[str, Any]:
    """A recall with its count, interval and small-set flag."""
    return {
        "max_recall": s.max_recall,
        "max_hits": s.max_hits,
        "n_relevant": s.n_relevant,
        "recall_ci": None if s.recall_ci is None else list(s.recall_ci),
        "few": s.few,
    }


def _set(metrics: EvaluationMetrics, method: str, kind: str) -> dict[str, Any]:
    ps = metrics.method(method).set(kind)
    o = ps.overall
    return {
        **_stats(o),
        "n_pairs": o.n_pairs,
        "recall_at_precision_1": o.recall_at_precision_1,
        "hits_at_precision_1": o.hits_at_precision_1,
        "best_f1": o.best_f1,
        "auc": o.auc,
        "assoc_precision": o.assoc_precision,
        "assoc_recall": o.assoc_recall,
        "bins": {b.label: _stats(b.stats) for b in ps.heading_bins},
    }


def _weighted_mean(classes: dict[str, Any], names: tuple[str, ...]) -> float | None:
    """Pair-weighted mean cosine of the descriptor classes ``names`` (None without pairs)."""
    got = [(classes[n]["pairs"], classes[n]["mean"]) for n in names if n in classes and classes[n]["pairs"]]
    total = sum(n for n, _ in got)
    return sum(n * m for n, m in got) / total if total else None


def frontend_summary(grades: dict[str, Any] | None) -> dict[str, Any] | None:
    """The front end's grades in short (from metrics.json's ``frontend`` section; None when not graded).

    Segmentation precision, recall, mean IoU, over- / under-segmented and spurious counts over
    the graded frames; descriptor cosine means for the same instance, the same family and other
    families (pairs of the same group and of other groups, weighted by their pair counts).
    """
    if not grades:
        return None
    s = grades["segmentation"]
    classes = (grades.get("descriptors") or {}).get("classes") or {}
    return {
        "segmenter": grades["segmenter"],
        "encoder": grades.get("encoder"),
        "frames": s["frames"],
        "objects": s["objects"],
        "masks": s["masks"],
        "precision": s.get("precision"),
        "recall": s.get("recall"),
        "mean_iou": s.get("mean_iou"),
        "over_segmented": s["over_segmented"],
        "under_segmented": s["under_segmented"],
        "spurious": s["spurious"],
        "cosine_same_instance": _weighted_mean(classes, ("same_instance",)),
        "cosine_same_family": _weighted_mean(classes, ("same_family",)),
        "cosine_other_family": _weighted_mean(classes, ("same_group", "other_group")),
    }


def compact_summary(
    metrics: EvaluationMetrics,
    ate: AteTable | None,
    map_stats: MapStats | None,
    runtimes: dict[str, float | None] | None = None,
) -> dict[str, Any]:
    """JSON-ready summary of a run.

    ``methods[name]`` holds, per pair set (``inter`` cross-robot, ``intra`` same-robot),
    the max recall with its hits / relevant count, Wilson interval and small-set flag, recall
    at precision 1, F1, AUC, association precision / recall and the coarse heading bins; plus
    the median runtime when given. ``ate[variant]`` holds the robots it placed and the SE(3)
    ATE over the common robots and over all robots; ``map`` the map size; ``frontend`` the
    front end's grades against truth when the run graded it (``frontend_summary``). Undefined
    values are None.
    """
    out: dict[str, Any] = {
        "headline": metrics.headline,
        "pairs": metrics.pairs,
        "n_skipped": metrics.n_skipped,
        "methods": {},
        "ate": {},
        "ate_robots": {},
        "map": map_stats.to_json() if map_stats else {},
        "frontend": frontend_summary(metrics.frontend),
    }
    for name in metrics.methods:
        out["methods"][name] = {
            "inter": _set(metrics, name, "inter"),
            "intra": _set(metrics, name, "intra"),
            "runtime_median_s": (runtimes or {}).get(name),
        }
    if ate is not None and ate.variants:
        out["ate_robots"] = {"robots": list(ate.robots), "common": list(ate.common)}
        for variant, row in ate.variants.items():
            out["ate"][variant] = {
                "connected": len(row.connected),
                "common": ate.rmse(variant, "se3", COMMON),
                "all": ate.rmse(variant, "se3", ALL),
            }
    return out
