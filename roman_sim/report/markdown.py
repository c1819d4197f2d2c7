"""``report.md``: the evaluation of one run, with links to its plots.

The header states what was scored and how: the pairs (and a distance cap with the number of
pairs it skipped), the relevance criterion, the success thresholds and the headline pair
set. Cross-robot and same-robot pairs get their own sections. Every recall carries its
count and Wilson interval (``tables``). The ATE section explains how robots a variant could
not place are counted. Anything that could not be computed is written as "n/a" and
explained in the notes, never as 0. Wall-clock runtimes are not in the report (it is
byte-identical between runs of one seed); they are in the run's ``timings.json``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from roman_sim.core.records import to_json_object
from roman_sim.evaluation.atetable import AteTable
from roman_sim.evaluation.metrics import NO_SEGMENTS_NOTE
from roman_sim.evaluation.overlap import RevisitFigures, counts_by_pair, overlap_graph
from roman_sim.evaluation.types import PAIR_SET_LABELS, EvaluationMetrics, MapStats
from roman_sim.report.grades import frontend_report_lines
from roman_sim.report.lead import lead_paragraph
from roman_sim.report.tables import (
    NA,
    association_rows,
    ate_rows,
    bin_rows,
    fmt,
    markdown_table,
    metrics_rows,
    operating_point_rows,
)

log = logging.getLogger(__name__)

REPORT_MD = "report.md"

#: Captions of the plots the report links when they exist in ``plots/``.
PLOT_CAPTIONS = {
    "precision_recall.png": "Precision-recall over association count k",
    "precision_recall_heading.png": "Precision-recall per heading bin",
    "recall_heading.png": "Max recall per heading bin, with counts and 95 % intervals",
    "recall_heading_fine.png": "Max recall per heading bin (fine bins)",
    "recall_ambiguity.png": "Max recall against place ambiguity",
    "recall_operating_points.png": "Recall at max recall, precision >= 0.9, precision 1 and the acceptance threshold",
    "association_heading.png": "Association precision and recall per heading bin",
    "segments_on_image.png": "Segment masks over a camera image",
    "map_view.png": "Segment maps (map view)",
    "trajectories.png": "Trajectories: truth, odometry and the pose graph",
    "frontend.png": "Front end against truth: descriptor cosines, cosine against view difference, objects missed",
}

#: The plots shown right after the opening paragraph, in this order (the others follow the tables).
HEADLINE_PLOTS = ("recall_heading.png", "recall_operating_points.png", "precision_recall.png", "trajectories.png")

MAP_LABELS = {
    "segments": "segments",
    "submaps": "submaps",
    "kb_per_submap": "KB per submap",
    "mb_per_km": "MB per km",
    "keyframes_per_submap": "visual keyframes per submap",
    "keyframe_kb_per_submap": "visual KB per submap",
    "keyframe_kb_per_submap_max": "largest visual packet (KB)",
    "keyframe_mb_per_km": "visual MB per km",
}

#: How the ATE table treats robots a variant could not place (the report's policy text).
ATE_POLICY = (
    "Every row covers the same robots. A pose graph places a robot in the common frame (the first robot's "
    "odometry frame) only through inter-robot loop closures; a robot it never connects has no position there, "
    "and any placement the evaluation could give it (its true start pose, or the origin) would be borrowed from "
    "the truth or arbitrary, so its error would measure that choice rather than the method. Each row therefore "
    "states how many robots it placed; the common column is the ATE of the concatenated trajectories of the robots "
    "every row placed; the all-robots column is given only for rows that placed every robot; a robot a row did not "
    "place reads 'not connected'. `odometry` places each robot with its true start pose, which no real system "
    "has; `odometry_no_prior` knows no start pose and aligns each robot by its own fit (the most its odometry can be "
    "made to agree with the truth); pose-graph rows are aligned by one fit of all their robots together."
)


def _header(metrics: EvaluationMetrics) -> list[str]:
    cfg = metrics.config
    p = metrics.pairs
    scored = (
        f"{metrics.n_pairs} pairs scored (every cross-robot pair and every same-robot pair at least "
        f"{cfg.intra_min_gap} submaps apart)"
    )
    if cfg.max_pair_dist_m is None:
        cap = "no distance cap: every such pair was aligned and scored."
    else:
        cap = (
            f"distance cap {cfg.max_pair_dist_m:g} m on the true centre distance (relevant pairs kept): "
            f"{metrics.n_skipped} of {metrics.n_candidates} candidate pairs skipped, neither aligned nor scored."
        )
    head = PAIR_SET_LABELS[metrics.headline]
    return [
        f"- Pairs: {scored}; {cap}",
        f"- Cross-robot pairs: {p['inter'].n_pairs} ({p['inter'].n_relevant} relevant); same-robot pairs: "
        f"{p['intra'].n_pairs} ({p['intra'].n_relevant} relevant). Headline figures: {head} pairs.",
        f"- Relevant (should align): {cfg.describe_relevance()}. Correct: {cfg.describe_success()}. Positive at "
        f"threshold k: at least k associations, k = {cfg.k_min}..{cfg.k_max}.",
        f"- Recall cells: max recall over k (hits/relevant) [{cfg.interval_level:.0%} Wilson interval]; "
        f"'n<{cfg.min_relevant}: h/n' marks a set with fewer than {cfg.min_relevant} relevant pairs (too few to give a "
        f"rate); {NA}: no relevant pair.",
        "- Operating points: max recall with the precision at the highest k that keeps it; recall at the smallest "
        "k whose precision is >= 0.9 and = 1 (`not reached` when no k is); recall at the pose graph's acceptance "
        f"threshold k = {NA if metrics.acceptance_k is None else metrics.acceptance_k}. Precision = TP / (TP + FP) "
        "with its count.",
        "",
    ]


def _section_pairs(metrics: EvaluationMetrics, kind: str) -> list[str]:
    label = PAIR_SET_LABELS[kind]
    title = f"## Alignment, {label} pairs" + (" (headline)" if kind == metrics.headline else "")
    if not metrics.pairs[kind].n_pairs:
        return [title, "", f"No {label} pairs in this run.", ""]
    if NO_SEGMENTS_NOTE in metrics.notes:  # nothing was there to align: no figure is defined, not even 0 of n
        return [title, "", f"Undefined: {NO_SEGMENTS_NOTE}.", ""]
    lines = [title, "", *markdown_table(metrics_rows(metrics, kind)), ""]
    min_n = metrics.config.min_relevant
    points = operating_point_rows(metrics, kind)
    lines += [f"### Operating points per heading bin, {label}", "", *_folded(points, min_n)]
    lines += [
        f"### Recall per heading bin, {label}, fine bins",
        "",
        *markdown_table(bin_rows(metrics, kind, "heading_bins_fine")),
        "",
    ]
    lines += [
        f"### Recall against place ambiguity, {label}",
        "",
        *markdown_table(bin_rows(metrics, kind, "ambiguity_bins")),
        "",
    ]
    lines += [
        f"### Association truth, {label}",
        "",
        "Precision: selected associations joining segments of the same true object (correct/selected); "
        "recall: true correspondences recovered one-to-one (recovered/available).",
        "",
        *markdown_table(association_rows(metrics, kind)),
        "",
    ]
    return lines


def _folded(rows: list[dict[str, str]], min_n: int) -> list[str]:
    """A table whose rows with fewer than ``min_n`` relevant pairs are folded into a ``<details>`` block."""
    few = [r for r in rows if r["relevant"].isdigit() and int(r["relevant"]) < min_n]
    lines = [*markdown_table([r for r in rows if r not in few]), ""]
    if few:
        lines += [
            f"<details><summary>{len(few)} rows with fewer than {min_n} relevant pairs</summary>",
            "",
            *markdown_table(few),
            "",
            "</details>",
            "",
        ]
    return lines


def _section_robot_pairs(metrics: EvaluationMetrics) -> list[str]:
    """Relevant cross-robot pairs per robot pair, and whether the robots' overlap graph is connected."""
    title = "## Robots that meet: relevant cross-robot pairs per robot pair"
    if metrics.robot_pairs is None:
        return [title, "", "Not recorded in this run's metrics (written before they were).", ""]
    if not metrics.robot_pairs:
        return [title, "", "No cross-robot pairs in this run.", ""]
    counts = counts_by_pair(metrics.robot_pairs)
    robots = list(dict.fromkeys(r for pair in counts for r in pair))
    graph = overlap_graph(counts, robots)
    shared = metrics.revisits or {}
    rows = [
        {
            "robots": f"{a}, {b}",
            "pairs scored": str(entry.n_pairs),
            "relevant": str(entry.n_relevant),
            f"overlap edge (>= {graph.min_pairs})": "yes" if entry.n_relevant >= graph.min_pairs else "no",
            **_shared_cells(shared.get(key)),
        }
        for (a, b), (key, entry) in zip(counts, metrics.robot_pairs.items())
    ]
    cfg = metrics.config
    text = f"Relevant: {cfg.describe_relevance()}. {graph.describe()}."
    if "all" in shared:
        text += (
            " Median overlap and shared objects: over the relevant pairs, the true objects with a segment in "
            "both submaps (over the smaller submap's objects, and their number); all relevant cross-robot "
            "pairs: " + ", ".join(f"{k} {v}" for k, v in _shared_cells(shared["all"]).items()) + "."
        )
    return [title, "", text, "", *markdown_table(rows), ""]


def _shared_cells(fig: RevisitFigures | None) -> dict[str, str]:
    """The median overlap and shared objects of one robot pair's relevant pairs, as table cells."""
    if fig is None:
        return {"median overlap": "n/a", "median shared objects": "n/a"}
    ov, sh = fig.median_overlap, fig.median_shared_objects
    return {
        "median overlap": "n/a" if ov is None else f"{ov:.2f}",
        "median shared objects": "n/a" if sh is None else f"{sh:.1f}",
    }


def _section_ate(ate: AteTable | None) -> list[str]:
    if ate is None or not ate.variants:
        return ["## Trajectory error (ATE RMSE, m)", "", "No trajectory error was computed for this run.", ""]
    lines = [
        "## Trajectory error (ATE RMSE, m)",
        "",
        ATE_POLICY,
        "",
        "SE(3) alignment:",
        "",
        *markdown_table(ate_rows(ate, "se3")),
        "",
        "4-DoF alignment (yaw and translation):",
        "",
        *markdown_table(ate_rows(ate, "4dof")),
        "",
    ]
    return lines


def _caption(name: str) -> str:
    if name.startswith("alignment_"):
        return f"{name[len('alignment_') : -len('.png')]}: a correct alignment and the worst false positive"
    return PLOT_CAPTIONS.get(name, Path(name).stem.replace("_", " "))


def _not_drawn(notes: list[str], names: set[str] | None) -> list[str]:
    """The notes saying a plot was not drawn (of ``names`` only, when given)."""
    return [n for n in notes if " not drawn" in n and (names is None or any(f"plot {x} " in n for x in names))]


def _section_plots(title: str, plots: list[str], skipped: list[str]) -> list[str]:
    if not plots and not skipped:
        return []
    lines = [title, ""]
    for p in plots:
        lines += [f"![{_caption(Path(p).name)}]({p})", ""]
    lines += [f"- {n}" for n in skipped] + ([""] if skipped else [])
    return lines


def report_markdown(
    scenario_name: str,
    metrics: EvaluationMetrics,
    ate_table: AteTable | None = None,
    map_stats: MapStats | None = None,
    notes: list[str] | None = None,
    plots: list[str] | None = None,
) -> str:
    """The text of ``report.md``.

    Args:
        scenario_name: shown in the title.
        metrics: the evaluation's metrics.
        ate_table: ATE RMSE per trajectory variant (odometry, the method, oracle, ...).
        map_stats: map and packet sizes.
        notes: statements to show (no loop closures, a robot never connected, ...).
        plots: plot files to show, relative to the run folder (e.g. ``plots/recall_heading.png``).
    """
    all_notes = list(dict.fromkeys(list(metrics.notes) + list(notes or [])))
    by_name = {Path(p).name: p for p in sorted(plots or [])}
    head = [by_name[n] for n in HEADLINE_PLOTS if n in by_name]
    lines = [f"# Evaluation report: {scenario_name}", "", *lead_paragraph(metrics, ate_table)]
    lines += _section_plots("## Headline plots", head, _not_drawn(all_notes, set(HEADLINE_PLOTS)))
    lines += ["## What was scored", "", *_header(metrics)]
    if all_notes:
        lines += ["## Notes", "", *[f"- {n}" for n in all_notes], ""]
    lines += _section_robot_pairs(metrics)
    kinds = [metrics.headline] + [k for k in ("inter", "intra") if k != metrics.headline]
    if not metrics.methods:
        lines += ["## Alignment", "", "No method was evaluated.", ""]
    else:
        min_n = metrics.config.min_relevant
        for kind in kinds:
            section = _section_pairs(metrics, kind)
            n_rel = metrics.pairs[kind].n_relevant
            if kind != metrics.headline and metrics.pairs[kind].n_pairs and n_rel < min_n:
                summary = f"{section[0][3:]}: {n_rel} relevant, fewer than {min_n} (tables folded)"
                section = [f"<details><summary>{summary}</summary>", "", *section, "</details>", ""]
            lines += section
    lines += _section_ate(ate_table)
    map_rows = [
        {"quantity": MAP_LABELS.get(k, k), "value": fmt(v)}
        for k, v in (to_json_object(map_stats) if map_stats else {}).items()
    ]
    lines += ["## Map size", "", *(markdown_table(map_rows) or ["No map statistics were given."]), ""]
    if metrics.frontend is not None:
        lines += frontend_report_lines(metrics.frontend)
    lines += ["Runtimes per pair and per stage: timings.json.", ""]
    rest = [p for n, p in by_name.items() if p not in head]
    others = _not_drawn(all_notes, None)
    others = [n for n in others if n not in _not_drawn(all_notes, set(HEADLINE_PLOTS))]
    if not plots and not others:
        lines += ["## Plots", "", "No plots were written.", ""]
    lines += _section_plots("## More plots", rest, others)
    return "\n".join(lines)
