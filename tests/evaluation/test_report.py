"""report.md holds the tables, links the plots and says what could not be computed."""

from __future__ import annotations

import pytest

from roman_sim.evaluation.metrics import summary
from roman_sim.evaluation.plots import write_metric_plots
from roman_sim.evaluation.report import ate_rows, format_summary_rows, write_report


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
    assert r["median runtime (s)"] == "1.0000"
    # k = 5..9: only the correct pair is positive -> P = 1, R = 0.5, F1 = 2/3
    assert r["best F1"] == "0.667 (k=5)"


def test_report_has_tables_plots_and_statements(metrics, tmp_path):
    write_metric_plots(metrics, tmp_path / "plots")
    ate = {"odometry": {"se3": {"all": {"rmse_m": 4.25, "n": 10}, "r1": None}},
           "roman": {"se3": {"all": {"rmse_m": 1.5}, "r1": {"rmse_m": 1.25}}}, "oracle": None}
    maps = {"segments": 120, "submaps": 8, "kb_per_submap": 12.5, "mb_per_km": 0.9}
    p = write_report(tmp_path, "smoke", metrics, ate, maps, notes=["robot r2 never connected"])
    text = p.read_text()
    assert p.name == "report.md" and text.startswith("# Evaluation report: smoke")
    assert "| method | pairs | relevant | max recall |" in text
    assert "| roman | 3 | 2 | 0.500 | 0.500 | 0.667 (k=5) |" in text
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


def test_ate_rows_flatten_scalars():
    rows = ate_rows({"odometry": 3.0, "roman": float("nan")})
    assert rows == [{"trajectory": "odometry", "ATE RMSE (m)": "3.000"},
                    {"trajectory": "roman", "ATE RMSE (m)": "n/a"}]


def test_ate_rows_accept_result_objects():
    class Res:
        def to_dict(self):
            return {"rmse_m": 0.5, "n": 3}

    assert ate_rows({"roman": {"all": Res()}}) == [{"trajectory": "roman", "all": "0.500"}]


def test_report_from_run_folder_states_missing_stages(metrics, tmp_path):
    import json

    from roman_sim.core.errors import StorageError
    from roman_sim.evaluation.evaluate import report_from_run
    from roman_sim.evaluation.results import write_metrics_json

    run = tmp_path / "smoke" / "run-1"
    with pytest.raises(StorageError):
        report_from_run(run)
    write_metrics_json(run / "metrics.json", metrics)
    (run / "ate.json").write_text(json.dumps({"odometry": {"all": 2.0}, "notes": ["robot r2 never connected"]}))
    (run / "map_stats.json").write_text("{not json")
    text = report_from_run(run).read_text()
    assert text.startswith("# Evaluation report: smoke")
    assert "| odometry | 2.000 |" in text and "robot r2 never connected" in text
    assert "map size not available (map_stats.json unreadable or corrupt" in text
    assert (run / "plots" / "precision_recall.png").is_file()
    (run / "metrics.json").write_text("[]")
    with pytest.raises(StorageError, match="schema"):
        report_from_run(run)
