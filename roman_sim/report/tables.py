"""Table cells and rows of the evaluation, shared by ``report.md``, the CLI and the reference summary.

Every recall cell carries its count and interval: ``0.77 (33/43) [0.62, 0.87]``; a set
with fewer than ``min_relevant`` relevant pairs shows only its count, ``n<5: 1/2``, never a
bare rate; a set without relevant pairs shows ``n/a``. Operating-point cells add the
threshold and the precision there with its count, ``0.42 (22/52) [0.29, 0.56] at k=6,
P=0.92 (22/24)``, or say ``not reached``. ATE cells of a robot a variant did not place read
``not connected``.
"""

from __future__ import annotations

import math
from typing import Any

from roman_sim.evaluation.atetable import ALL, COMMON, AteTable
from roman_sim.evaluation.operating_points import POINT_LABELS, OperatingPoint
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics

NA = "n/a"
NOT_CONNECTED = "not connected"


def fmt(v: Any, digits: int = 3) -> str:
    """A table cell: numbers rounded, None/NaN as ``n/a``."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return NA
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def rate_cell(
    rate: float | None,
    k: int,
    n: int,
    ci: tuple[float, float] | None,
    min_n: int = 1,
    digits: int = 2,
    interval: bool = True,
) -> str:
    """``rate (k/n) [lo, hi]``; ``n<min_n: k/n`` for small sets; ``n/a`` when ``n == 0``."""
    if n == 0 or rate is None:
        return NA
    if n < min_n:
        return f"n<{min_n}: {k}/{n}"
    out = f"{rate:.{digits}f} ({k}/{n})"
    if interval and ci is not None:
        out += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    return out


def recall_cell(s: CurveStats, min_n: int, interval: bool = True) -> str:
    """The max-recall cell of ``s``."""
    return rate_cell(s.max_recall, s.max_hits, s.n_relevant, s.recall_ci, min_n, interval=interval)


def _precision_cell(p: OperatingPoint | None) -> str:
    """``0.41 (36/87) at k=3``: the precision of an operating point with its count."""
    if p is None or not p.reached or p.precision is None:
        return NA
    return f"{p.precision:.2f} ({p.hits}/{p.hits + p.false_positives}) at k={p.k}"


def _point_rate(p: OperatingPoint | None, min_n: int, interval: bool) -> str:
    """The recall cell of an operating point (``not reached (0/n)`` when no threshold met it)."""
    if p is None:
        return NA
    if not p.reached and p.n_relevant:
        return f"not reached (0/{p.n_relevant})"
    return rate_cell(p.recall, p.hits, p.n_relevant, p.recall_ci, min_n, interval=interval)


def metrics_rows(metrics: EvaluationMetrics, kind: str, interval: bool = True) -> list[dict[str, str]]:
    """One row per method on pair set ``kind``: counts, max recall, R@P=1, the precision at max recall,
    recall at P>=0.9 and at the acceptance threshold, best F1, AUC, coarse bins."""
    min_n = metrics.config.min_relevant
    acc = "recall@accept" + (f" (k={metrics.acceptance_k})" if metrics.acceptance_k is not None else "")
    rows = []
    for name, m in metrics.methods.items():
        ps = m.set(kind)
        o = ps.overall
        pts = o.operating_points
        f1 = fmt(o.best_f1) + (f" (k={o.best_f1_k})" if o.best_f1_k is not None else "")
        row = {
            "method": name,
            "pairs": fmt(o.n_pairs),
            "relevant": fmt(o.n_relevant),
            "max recall": recall_cell(o, min_n, interval),
            "recall@P=1": rate_cell(
                o.recall_at_precision_1,
                o.hits_at_precision_1,
                o.n_relevant,
                o.recall_at_precision_1_ci,
                min_n,
                interval=interval,
            ),
            "P at max recall": _precision_cell(pts.get("max_recall")),
            "recall@P>=0.9": _point_rate(pts.get("precision_90"), min_n, interval),
            acc: _point_rate(pts.get("acceptance"), min_n, interval),
            "best F1": f1,
            "AUC": fmt(o.auc),
        }
        for b in ps.heading_bins:
            row[f"{b.label} deg"] = recall_cell(b.stats, min_n, interval)
        rows.append(row)
    return rows


def bin_rows(
    metrics: EvaluationMetrics,
    kind: str,
    table: str,
    points: tuple[str, ...] = ("max_recall", "precision_90", "acceptance"),
) -> list[dict[str, str]]:
    """Recall per bin (``heading_bins_fine`` or ``ambiguity_bins``) per method, with counts: one row per
    operating point of ``points`` (max recall, at precision >= 0.9, at the acceptance threshold)."""
    min_n = metrics.config.min_relevant
    rows = []
    for name, m in metrics.methods.items():
        bins = getattr(m.set(kind), table)
        for point in points:
            label = POINT_LABELS[point] + (f" (k={metrics.acceptance_k})" if point == "acceptance" else "")
            if point == "max_recall":
                cells = {b.label: recall_cell(b.stats, min_n, interval=False) for b in bins}
            elif not any(b.stats.operating_points.get(point) for b in bins):
                continue  # a file written before the operating points, or no acceptance threshold
            else:
                cells = {b.label: _point_rate(b.stats.operating_points.get(point), min_n, False) for b in bins}
            rows.append({"method": name, "figure": label, **cells})
    return rows


def association_rows(metrics: EvaluationMetrics, kind: str) -> list[dict[str, str]]:
    """Association precision and recall per coarse heading bin per method (counts in brackets)."""
    rows = []
    for name, m in metrics.methods.items():
        ps = m.set(kind)
        row = {"method": name}
        for label, s in [("all", ps.overall)] + [(f"{b.label} deg", b.stats) for b in ps.heading_bins]:
            p = rate_cell(s.assoc_precision, s.assoc_correct, s.assoc_selected, None, interval=False)
            r = rate_cell(s.assoc_recall, s.assoc_recovered, s.assoc_available, None, interval=False)
            row[f"{label}: precision"] = p
            row[f"{label}: recall"] = r
        rows.append(row)
    return rows


def ate_rows(ate: AteTable, alignment: str = "se3") -> list[dict[str, str]]:
    """Rows ``trajectory, robots placed, common, all, per robot`` of one alignment, in variant order."""
    n = len(ate.robots)
    common = f"over {', '.join(ate.common)}" if ate.common else "over no robot"
    rows = []
    for name, v in ate.variants.items():
        cells = v.rmse.get(alignment, {})
        row = {
            "trajectory": name,
            "robots placed": f"{len(v.connected)}/{n}",
            f"ATE {common} (common)": fmt(cells.get(COMMON)),
            f"ATE over all {n} robots": fmt(cells.get(ALL)) if len(v.connected) == n else NOT_CONNECTED,
        }
        for r in ate.robots:
            row[r] = fmt(cells.get(r)) if r in v.connected else NOT_CONNECTED
        rows.append(row)
    return rows


def markdown_table(rows: list[dict[str, str]]) -> list[str]:
    """Markdown lines of a table whose rows share their keys (the first row's give the header)."""
    if not rows:
        return []
    cols = list(rows[0])
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    out += ["| " + " | ".join(r.get(c, NA) for c in cols) + " |" for r in rows]
    return out


def point_cell(p: OperatingPoint | None, min_n: int, interval: bool = True) -> str:
    """``0.42 (22/52) [0.29, 0.56] at k=6, P=0.92 (22/24)``; ``not reached`` / ``n/a`` where undefined."""
    if p is None or p.n_relevant == 0:
        return NA
    if not p.reached:
        return f"not reached (0/{p.n_relevant})"
    out = rate_cell(p.recall, p.hits, p.n_relevant, p.recall_ci, min_n, interval=interval)
    pos = p.hits + p.false_positives
    precision = f"P={p.precision:.2f} ({p.hits}/{pos})" if p.precision is not None else "no positive"
    return f"{out} at k={p.k}, {precision}"


def operating_point_rows(metrics: EvaluationMetrics, kind: str, table: str = "heading_bins") -> list[dict[str, str]]:
    """Per method, overall and per bin of ``table`` (``heading_bins`` or ``heading_bins_fine``): the
    operating points (max recall with its precision, recall at P>=0.9 and P=1, recall at the pose
    graph's acceptance threshold), each with its threshold, counts and Wilson interval."""
    min_n = metrics.config.min_relevant
    acc = "recall at acceptance" + (f" (k={metrics.acceptance_k})" if metrics.acceptance_k is not None else "")
    rows = []
    for name, m in metrics.methods.items():
        ps = m.set(kind)
        for label, s in [("all", ps.overall)] + [(f"{b.label} deg", b.stats) for b in getattr(ps, table)]:
            pts = s.operating_points
            rows.append(
                {
                    "method": name,
                    "heading": label,
                    "relevant": fmt(s.n_relevant),
                    POINT_LABELS["max_recall"]: point_cell(pts.get("max_recall"), min_n),
                    POINT_LABELS["precision_90"]: point_cell(pts.get("precision_90"), min_n),
                    POINT_LABELS["precision_100"]: point_cell(pts.get("precision_100"), min_n),
                    acc: point_cell(pts.get("acceptance"), min_n),
                }
            )
    return rows
