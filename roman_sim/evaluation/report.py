"""``report.md``: the evaluation tables of one run, with links to its plots.

Takes the ``metrics.summary`` dict, and optionally an ATE table and map statistics as
plain dicts (computed elsewhere). Anything that could not be computed is written as
"n/a" and explained in the notes, never as 0.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_text

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
}

MAP_LABELS = {
    "segments": "segments", "submaps": "submaps", "kb_per_submap": "KB per submap",
    "mb_per_km": "MB per km",
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


def format_summary_rows(metrics: dict[str, Any]) -> list[dict[str, str]]:
    """One row per method: column header -> cell text (same columns, in order, for each row).

    Columns: method, pairs, relevant, max recall, recall@P=1, best F1 (k), AUC, max recall
    per coarse heading bin, median runtime.
    """
    rows = []
    for name, m in metrics.get("methods", {}).items():
        f1 = fmt(m.get("best_f1"))
        if m.get("best_f1_k") is not None:
            f1 += f" (k={m['best_f1_k']})"
        row = {
            "method": name, "pairs": fmt(m.get("n_pairs")), "relevant": fmt(m.get("n_relevant")),
            "max recall": fmt(m.get("max_recall")), "recall@P=1": fmt(m.get("recall_at_precision_1")),
            "best F1": f1, "AUC": fmt(m.get("auc")),
        }
        for b in m.get("heading_bins", []):
            row[f"recall {b['label']} deg"] = fmt(b.get("max_recall"))
        row["median runtime (s)"] = fmt((m.get("runtime_s") or {}).get("median"), 4)
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


def _bin_rows(metrics: dict[str, Any], table: str) -> list[dict[str, str]]:
    rows = []
    for name, m in metrics.get("methods", {}).items():
        row = {"method": name}
        for b in m.get(table, []):
            row[b["label"]] = f"{fmt(b.get('max_recall'), 2)} ({b.get('n_relevant', 0)})"
        rows.append(row)
    return rows


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    """Nested ATE dicts to ``{"se3/all": rmse, ...}``; a dict with ``rmse_m`` is a leaf."""
    if hasattr(value, "to_dict"):  # e.g. an ``AteResult``
        value = value.to_dict()
    if isinstance(value, dict) and "rmse_m" not in value:
        out: dict[str, Any] = {}
        for k, v in value.items():
            out.update(_flatten(v, f"{prefix}/{k}" if prefix else str(k)))
        return out
    leaf = value.get("rmse_m") if isinstance(value, dict) else value
    return {prefix or "ATE RMSE (m)": leaf}


def ate_rows(ate_table: dict[str, Any]) -> list[dict[str, str]]:
    """Rows ``variant -> cells`` of an ATE table (values in metres; nested dicts flattened)."""
    flat = {variant: _flatten(v) for variant, v in ate_table.items()}
    cols: list[str] = []
    for cells in flat.values():
        cols += [c for c in cells if c not in cols]
    return [{"trajectory": variant, **{c: fmt(cells.get(c)) for c in cols}} for variant, cells in flat.items()]


def _notes(metrics: dict[str, Any], ate_table: dict[str, Any] | None, notes: list[str]) -> list[str]:
    out = list(metrics.get("notes", [])) + list(notes)
    if ate_table is not None and any(fmt(v) == NA for v in _flatten(ate_table).values()):
        out.append("some trajectory errors could not be computed (n/a in the ATE table)")
    return out


def _section_alignment(metrics: dict[str, Any]) -> list[str]:
    lines = ["## Alignment", "",
             f"Pairs: {metrics.get('n_pairs', 0)}, relevant: {metrics.get('n_relevant', 0)}.", ""]
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


def _section_plots(out_dir: Path) -> list[str]:
    plots = sorted((out_dir / "plots").glob("*.png")) if (out_dir / "plots").is_dir() else []
    if not plots:
        return ["## Plots", "", "No plots were written.", ""]
    lines = ["## Plots", ""]
    for p in plots:
        caption = PLOT_CAPTIONS.get(p.name, p.stem.replace("_", " "))
        lines += [f"![{caption}](plots/{p.name})", ""]
    return lines


def write_report(
    out_dir: str | Path,
    scenario_name: str,
    metrics: dict[str, Any],
    ate_table: dict[str, Any] | None = None,
    map_stats: dict[str, Any] | None = None,
    notes: list[str] | None = None,
) -> Path:
    """Write ``out_dir/report.md`` and return its path.

    Args:
        out_dir: the run folder (plots are looked up in ``out_dir/plots``).
        scenario_name: shown in the title.
        metrics: ``metrics.summary`` output (or ``metrics.json`` read back).
        ate_table: ``{variant: value}`` with variant e.g. odometry / roman / oracle and value
            an RMSE in metres, None, or a (nested) dict of those, of ``{"rmse_m": ...}`` or of
            objects with ``to_dict()`` giving one.
        map_stats: e.g. ``{"segments", "submaps", "kb_per_submap", "mb_per_km"}``.
        notes: statements to show (no loop closures, a robot never connected, ...).
    """
    out = Path(out_dir)
    lines = [f"# Evaluation report: {scenario_name}", ""]
    all_notes = _notes(metrics, ate_table, notes or [])
    if all_notes:
        lines += ["## Notes", "", *[f"- {n}" for n in all_notes], ""]
    lines += _section_alignment(metrics)
    lines += [f"Values shown as {NA} could not be computed. Bin cells: max recall (relevant pairs).", ""]
    lines += _section_table("Trajectory error (ATE RMSE, m)", ate_rows(ate_table) if ate_table else None,
                            "No trajectory error was computed for this run.")
    map_rows = [{"quantity": MAP_LABELS.get(k, k), "value": fmt(v)} for k, v in (map_stats or {}).items()]
    lines += _section_table("Map size", map_rows, "No map statistics were given.")
    lines += _section_plots(out)
    path = out / REPORT_MD
    write_text(path, "\n".join(lines))
    log.info("wrote %s", path)
    return path
