"""report.md holds the tables, links the plots and says what could not be computed."""

from __future__ import annotations

import pytest

from roman_sim.evaluation.metrics import summary
from roman_sim.evaluation.plots import write_metric_plots
from roman_sim.evaluation.report import ate_rows, format_summary_rows, write_report
from roman_sim.evaluation.types import AteTable, MapStats


@pytest.fixture
def metrics(make_score):
    scores = [make_score("0", True, 9, True, method="roman", heading=10.0, runtime=0.5),
              make_score("1", True, 4, False, method="roman", heading=150.0, runtime=1.5),
              make_score("2", False, 2, False, method="roman", heading=90.0, runtime=1.0)]
    return summary(scores)


def test_summary_rows_hand_values(metrics):
    rows = format_summary_rows(metrics)
    assert len(rows) == 1
    r = rows[0]
    assert list(r)[:3] == ["method", "pairs", "relevant"]
    assert (r["method"], r["pairs"], r["relevant"]) == ("roman", "3", "2")
    assert r["max recall"] == "0.500" and r["recall@P=1"] == "0.500"
    assert r["recall 0-60 deg"] == "1.000" and r["recall 120-180 deg"] == "0.000"
    assert r["recall 60-120 deg"] == "n/a"  # no relevant pair there: undefined, not 0
    assert not any("runtime" in c for c in r)  # wall-clock figures live in timings.json
    # k = 5..9: only the correct pair is positive -> P = 1, R = 0.5, F1 = 2/3
    assert r["best F1"] == "0.667 (k=5)"


def test_report_has_tables_plots_and_statements(metrics, tmp_path):
    plots = [p.relative_to(tmp_path).as_posix() for p in write_metric_plots(metrics, tmp_path / "plots")]
    ate = AteTable({"odometry": {"se3": {"all": 4.25, "r1": None}},
                    "roman": {"se3": {"all": 1.5, "r1": 1.25}}, "oracle": {"se3": {"all": None, "r1": None}}})
    maps = MapStats(robots=2, segments=120, submaps=8, segments_per_submap=15.0, kb_per_submap=12.5,
                    kb_per_submap_max=20.0, trajectory_km=0.5, mb_per_km=0.9)
    p = write_report(tmp_path, "smoke", metrics, ate, maps, notes=["robot r2 never connected"], plots=plots)
    text = p.read_text()
    assert p.name == "report.md" and text.startswith("# Evaluation report: smoke")
    assert "| method | pairs | relevant | max recall |" in text
    assert "| roman | 3 | 2 | 0.500 | 0.500 | 0.667 (k=5) |" in text
    assert "| trajectory | se3/all | se3/r1 |" in text
    assert "| odometry | 4.250 | n/a |" in text and "| roman | 1.500 | 1.250 |" in text
    assert "| oracle | n/a | n/a |" in text
    assert "| KB per submap | 12.500 |" in text
    assert "robot r2 never connected" in text and "could not be computed" in text
    assert "![Precision-recall over association count k](plots/precision_recall.png)" in text


def test_report_without_relevant_pairs_or_extras(make_score, tmp_path):
    m = summary([make_score("0", False, 3, False)])
    text = write_report(tmp_path, "empty", m).read_text()
    assert "no relevant pairs" in text
    assert "| m | 1 | 0 | n/a | n/a |" in text
    assert "No trajectory error was computed" in text and "No map statistics" in text
    assert "No plots were written" in text
    assert "No method was evaluated" in write_report(tmp_path, "none", summary([])).read_text()


def test_ate_rows_in_variant_order():
    rows = ate_rows(AteTable({"odometry": {"se3": {"all": 3.0}}, "roman": {"se3": {"all": None}}}))
    assert rows == [{"trajectory": "odometry", "se3/all": "3.000"}, {"trajectory": "roman", "se3/all": "n/a"}]


def test_map_stats_keyframe_figures_are_optional():
    base = dict(robots=2, segments=120, submaps=8, segments_per_submap=15.0, kb_per_submap=12.5,
                kb_per_submap_max=20.0, trajectory_km=0.4, mb_per_km=0.25)
    old = MapStats(**base)
    assert "keyframe_kb_per_submap" not in old.to_json()
    assert MapStats.from_json(old.to_json()) == old  # files written before keyframes existed
    new = MapStats(**base, keyframes_per_submap=9.0, keyframe_kb_per_submap=30.0, keyframe_kb_per_submap_max=60.0,
                   keyframe_mb_per_km=3.0)
    assert MapStats.from_json(new.to_json()) == new and new.to_json()["keyframe_mb_per_km"] == 3.0
