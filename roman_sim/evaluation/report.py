"""``report.md``: the evaluation tables of one run, with links to its plots.

Takes the ``EvaluationMetrics`` and optionally an ``AteTable`` and ``MapStats``. Anything
that could not be computed is written as "n/a" and explained in the notes, never as 0.
Wall-clock runtimes are not in the report (it is byte-identical between runs of one seed);
they are in the run's ``timings.json``.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_text
from roman_sim.evaluation.frontend_grades import FrontEndGrades, frontend_report_lines
from roman_sim.evaluation.types import AteTable, EvaluationMetrics, MapStats

log = logging.getLogger(__name__)

NA = "n/a"
REPORT_MD = "report.md"

#: Captions of the plots the report links when they exist in ``plots/``.
PLOT_CAPTIONS = {
    "precision_recall.png": "Precision-recall over association count k",
    "recall_heading.png": "Recall per heading difference",
    "recall_heading_fine.png": "Recall per heading difference (30 deg bins)",
    "recall_ambiguity.png": "Recall against place ambiguity",
    "alignment_correct.png": "A correct alignment",
    "alignment_wrong.png": "A wrong alignment",
    "map_view.png": "Segment maps (map view)",
    "trajectories.png": "Trajectories: truth, odometry and the pose graph",
    "frontend.png": "Front end against truth: descriptor cosines, cosine against view difference, objects missed",
}

MAP_LABELS = {
    "segments": "segments", "submaps": "submaps", "kb_per_submap": "KB per submap",
    "mb_per_km": "MB per km",
    "keyframes_per_submap": "visual keyframes per submap", "keyframe_kb_per_submap": "visual KB per submap",
    "keyframe_kb_per_submap_max": "largest visual packet (KB)", "keyframe_mb_per_km": "visual MB per km",
}


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


def format_summary_rows(metrics: EvaluationMetrics) -> list[dict[str, str]]:
    """One row per method: column header -> cell text (same columns, in order, for each row).

    Columns: method, pairs, relevant, max recall, recall@P=1, best F1 (k), AUC, max recall
    per coarse heading bin.
    """
    rows = []
    for name, m in metrics.methods.items():
        o = m.overall
        f1 = fmt(o.best_f1)
        if o.best_f1_k is not None:
            f1 += f" (k={o.best_f1_k})"
        row = {
            "method": name, "pairs": fmt(o.n_pairs), "relevant": fmt(o.n_relevant),
            "max recall": fmt(o.max_recall), "recall@P=1": fmt(o.recall_at_precision_1),
            "best F1": f1, "AUC": fmt(o.auc),
        }
        for b in m.heading_bins:
            row[f"recall {b.label} deg"] = fmt(b.stats.max_recall)
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


def _bin_rows(metrics: EvaluationMetrics, table: str) -> list[dict[str, str]]:
    rows = []
    for name, m in metrics.methods.items():
        row = {"method": name}
        for b in getattr(m, table):
            row[b.label] = f"{fmt(b.stats.max_recall, 2)} ({b.stats.n_relevant})"
        rows.append(row)
    return rows


def ate_rows(ate: AteTable) -> list[dict[str, str]]:
    """Rows ``variant -> cells`` (``se3/all``, ``se3/a``, ...), in the table's variant order."""
    cols: list[str] = []
    cells: dict[str, dict[str, float | None]] = {}
    for variant, per in ate.variants.items():
        cells[variant] = {f"{al}/{robot}": v for al, rob in per.items() for robot, v in rob.items()}
        cols += [c for c in cells[variant] if c not in cols]
    return [{"trajectory": v, **{c: fmt(cells[v].get(c)) for c in cols}} for v in ate.variants]


def _notes(metrics: EvaluationMetrics, ate: AteTable | None, notes: list[str]) -> list[str]:
    out = list(dict.fromkeys(list(metrics.notes) + list(notes)))
    if ate is not None and any(v is None for per in ate.variants.values() for rob in per.values() for v in rob.values()):
        out.append("some trajectory errors could not be computed (n/a in the ATE table)")
    return out


def _section_alignment(metrics: EvaluationMetrics) -> list[str]:
    lines = ["## Alignment", "", f"Pairs: {metrics.n_pairs}, relevant: {metrics.n_relevant}.", ""]
    rows = format_summary_rows(metrics)
    if not rows:
        return lines + ["No method was evaluated.", ""]
    lines += markdown_table(rows) + ["", "### Max recall per heading bin, 30 deg (relevant pairs)", ""]
    lines += markdown_table(_bin_rows(metrics, "heading_bins_fine"))
    lines += ["", "### Max recall against place ambiguity (relevant pairs)", ""]
    return lines + markdown_table(_bin_rows(metrics, "ambiguity_bins")) + [""]


def _section_table(title: str, rows: list[dict[str, str]] | None, missing: str) -> list[str]:
    if not rows:
        return [f"## {title}", "", missing, ""]
    return [f"## {title}", "", *markdown_table(rows), ""]


def _section_plots(plots: list[str]) -> list[str]:
    if not plots:
        return ["## Plots", "", "No plots were written.", ""]
    lines = ["## Plots", ""]
    for p in sorted(plots):
        name = Path(p).name
        caption = PLOT_CAPTIONS.get(name, Path(p).stem.replace("_", " "))
        lines += [f"![{caption}]({p})", ""]
    return lines


def write_report(
    out_dir: str | Path,
    scenario_name: str,
    metrics: EvaluationMetrics,
    ate_table: AteTable | None = None,
    map_stats: MapStats | None = None,
    notes: list[str] | None = None,
    plots: list[str] | None = None,
) -> Path:
    """Write ``out_dir/report.md`` and return its path.

    Args:
        out_dir: the run folder.
        scenario_name: shown in the title.
        metrics: the evaluation's metrics.
        ate_table: ATE RMSE per pose-graph variant (odometry, the method, oracle, ...).
        map_stats: map and packet sizes.
        notes: statements to show (no loop closures, a robot never connected, ...).
        plots: plot files to show, relative to ``out_dir`` (e.g. ``plots/recall_heading.png``).
    """
    out = Path(out_dir)
    lines = [f"# Evaluation report: {scenario_name}", ""]
    all_notes = _notes(metrics, ate_table, notes or [])
    if all_notes:
        lines += ["## Notes", "", *[f"- {n}" for n in all_notes], ""]
    lines += _section_alignment(metrics)
    lines += [f"Values shown as {NA} could not be computed. Bin cells: max recall (relevant pairs). "
              "Runtimes per pair and per stage: timings.json.", ""]
    lines += _section_table("Trajectory error (ATE RMSE, m)", ate_rows(ate_table) if ate_table else None,
                            "No trajectory error was computed for this run.")
    map_rows = [{"quantity": MAP_LABELS.get(k, k), "value": fmt(v)} for k, v in (map_stats.to_json() if map_stats else {}).items()]
    lines += _section_table("Map size", map_rows, "No map statistics were given.")
    if metrics.frontend is not None:
        lines += frontend_report_lines(FrontEndGrades.from_json(metrics.frontend))
    lines += _section_plots(list(plots or []))
    path = out / REPORT_MD
    write_text(path, "\n".join(lines))
    log.info("wrote %s", path)
    return path
