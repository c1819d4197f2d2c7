"""report.md: header with what was scored and how, per pair set tables with counts, ATE policy."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.records import from_json, to_json
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.atetable import TrajectoryVariant, ate_table
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics
from roman_sim.evaluation.types import MapStats
from roman_sim.report.markdown import report_markdown
from roman_sim.report.plots import write_metric_plots
from roman_sim.report.tables import ate_rows, metrics_rows, rate_cell


@pytest.fixture
def metrics(make_score):
    scores = [
        make_score("0", True, 9, True, method="roman", heading=10.0, runtime=0.5),
        make_score("1", True, 4, False, method="roman", heading=150.0, runtime=1.5),
        make_score("2", False, 2, False, method="roman", heading=90.0, runtime=1.0),
    ]
    return compute_metrics(scores, EvalConfig(min_relevant=1))


def test_cells_carry_counts_and_intervals():
    assert rate_cell(0.5, 1, 2, (0.0945, 0.9055)) == "0.50 (1/2) [0.09, 0.91]"
    assert rate_cell(0.0, 0, 2, (0.0, 0.66), min_n=5) == "n<5: 0/2"  # never a bare 0.00
    assert rate_cell(None, 0, 0, None) == "n/a"


def test_metrics_rows_hand_values(metrics):
    rows = metrics_rows(metrics, "inter")
    assert len(rows) == 1
    r = rows[0]
    assert (r["method"], r["pairs"], r["relevant"]) == ("roman", "3", "2")
    # 1 of 2 relevant: Wilson 95 % of 1/2 is [0.0945, 0.9055]
    assert r["max recall"] == "0.50 (1/2) [0.09, 0.91]" and r["recall@P=1"] == "0.50 (1/2) [0.09, 0.91]"
    assert r["0-60 deg"].startswith("1.00 (1/1)") and r["120-180 deg"].startswith("0.00 (0/1)")
    assert r["60-120 deg"] == "n/a"  # no relevant pair there: undefined, not 0
    assert not any("runtime" in c for c in r)  # wall-clock figures live in timings.json
    # k = 5..9: only the correct pair is positive -> P = 1, R = 0.5, F1 = 2/3
    assert r["best F1"] == "0.667 (k=5)"


def _truth() -> dict[str, Trajectory]:
    t = np.arange(10, dtype=float)
    T = np.tile(np.eye(4), (10, 1, 1))
    T[:, 0, 3] = t
    return {"r1": Trajectory(t, T), "r2": Trajectory(t, T.copy())}


def test_report_has_header_tables_plots_and_statements(metrics, tmp_path):
    plots = [p.relative_to(tmp_path).as_posix() for p in write_metric_plots(metrics, tmp_path / "plots")[0]]
    truth = _truth()
    variants = {"odometry": TrajectoryVariant(""), "roman": TrajectoryVariant("")}
    ate = ate_table(truth, variants, {"odometry": truth, "roman": {"r1": truth["r1"]}})
    maps = MapStats(
        robots=2,
        segments=120,
        submaps=8,
        segments_per_submap=15.0,
        kb_per_submap=12.5,
        kb_per_submap_max=20.0,
        trajectory_km=0.5,
        mb_per_km=0.9,
    )
    text = report_markdown("smoke", metrics, ate, maps, notes=["robot r2 never connected"], plots=plots)
    assert text.startswith("# Evaluation report: smoke")
    assert "no distance cap" in text and "Headline figures: cross-robot pairs" in text
    assert "true submap centres within 10 m" in text and "rotation error <= 5 deg" in text
    assert "## Alignment, cross-robot pairs (headline)" in text and "## Alignment, same-robot pairs" in text
    assert "No same-robot pairs in this run." in text
    assert "| roman | 3 | 2 | 0.50 (1/2) [0.09, 0.91] |" in text
    assert "Every row covers the same robots" in text
    assert "| trajectory | robots placed | ATE over r1 (common) | ATE over all 2 robots | r1 | r2 |" in text
    assert "| odometry | 2/2 | 0.000 | 0.000 | 0.000 | 0.000 |" in text
    assert "| roman | 1/2 | 0.000 | not connected | 0.000 | not connected |" in text
    assert "| KB per submap | 12.500 |" in text
    assert "robot r2 never connected" in text
    assert "![Precision-recall over association count k](plots/precision_recall.png)" in text


def test_report_names_a_distance_cap_and_what_it_skipped(make_score, tmp_path):
    m = compute_metrics([make_score("0", True, 3, True)], EvalConfig(max_pair_dist_m=40.0), n_skipped=7)
    text = report_markdown("capped", m)
    assert "distance cap 40 m on the true centre distance (relevant pairs kept): 7 of 8 candidate pairs skipped" in text


def test_report_without_relevant_pairs_or_extras(make_score, tmp_path):
    m = compute_metrics([make_score("0", False, 3, False)])
    text = report_markdown("empty", m)
    assert "no relevant cross-robot pairs" in text
    assert "| m | 1 | 0 | n/a | n/a |" in text
    assert "No trajectory error was computed" in text and "No map statistics" in text
    assert "No plots were written" in text
    assert "No method was evaluated" in report_markdown("none", compute_metrics([]))


def test_ate_rows_in_variant_order():
    truth = _truth()
    variants = {"odometry": TrajectoryVariant(""), "roman": TrajectoryVariant("")}
    table = ate_table(truth, variants, {"odometry": truth, "roman": {}})
    rows = ate_rows(table)
    assert [r["trajectory"] for r in rows] == ["odometry", "roman"]
    assert rows[1]["robots placed"] == "0/2" and rows[1]["r1"] == "not connected"
    assert table.common == []  # roman placed nobody: no robot is common to every row


def test_map_stats_keyframe_figures_are_optional():
    base = dict(
        robots=2,
        segments=120,
        submaps=8,
        segments_per_submap=15.0,
        kb_per_submap=12.5,
        kb_per_submap_max=20.0,
        trajectory_km=0.4,
        mb_per_km=0.25,
    )
    old = MapStats(**base)
    assert "keyframe_kb_per_submap" not in to_json(old)
    assert from_json(MapStats, to_json(old), "test") == old  # files written before keyframes existed
    new = MapStats(
        **base,
        keyframes_per_submap=9.0,
        keyframe_kb_per_submap=30.0,
        keyframe_kb_per_submap_max=60.0,
        keyframe_mb_per_km=3.0,
    )
    assert from_json(MapStats, to_json(new), "test") == new and to_json(new)["keyframe_mb_per_km"] == 3.0
