"""Operating points on hand-made pair sets: thresholds, counts, precision and Wilson intervals by hand."""

from __future__ import annotations

import json
import math

import pytest

from roman_sim.core.records import from_json, to_json
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics
from roman_sim.evaluation.operating_points import POINT_NAMES, strip_absent_points
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.report.tables import bin_rows, metrics_rows, operating_point_rows, point_cell

Z95 = 1.959963984540054


def wilson_by_hand(k: int, n: int) -> tuple[float, float]:
    """The Wilson score interval at 95 %, from its formula."""
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return centre - half, centre + half


@pytest.fixture
def six(make_score):
    # (relevant, n_assoc, correct): TP(k) = 2 for k <= 5, 1 for k <= 10; FP(k) = 4, 3, 3, 2, then 1 up to k = 8
    spec = [(True, 10, True), (True, 5, True), (True, 3, False), (True, 0, False), (False, 8, False), (False, 2, False)]
    headings = [10.0, 70.0, 150.0, 170.0, 20.0, 100.0]
    return [make_score(str(i), r, n, c, heading=headings[i]) for i, (r, n, c) in enumerate(spec)]


def test_points_by_hand(six):
    pts = compute_metrics(six, acceptance_k=4).stats("m").operating_points
    best = pts["max_recall"]
    # TP stays 2 up to k = 5 (the highest such k), where only the n=8 pair is a false positive
    assert (best.k, best.hits, best.n_relevant, best.false_positives) == (5, 2, 4, 1)
    assert best.recall == 0.5 and best.precision == pytest.approx(2 / 3)
    assert best.recall_ci == pytest.approx(wilson_by_hand(2, 4), abs=1e-9)
    assert best.precision_ci == pytest.approx(wilson_by_hand(2, 3), abs=1e-9)
    for name in ("precision_90", "precision_100"):  # first reached at k = 9: the n=10 pair alone
        p = pts[name]
        assert (p.k, p.reached, p.hits, p.false_positives, p.recall, p.precision) == (9, True, 1, 0, 0.25, 1.0)
    acc = pts["acceptance"]
    assert (acc.k, acc.hits, acc.false_positives, acc.recall) == (4, 2, 1, 0.5)
    assert compute_metrics(six).stats("m").operating_points["acceptance"] is None  # no threshold given, no point


def test_precision_of_exactly_0_9_counts_as_reached(make_score):
    # 27 correct and 3 wrong positives: 27/30 is 0.9 exactly (0.9 * 30 is not 27 in floats)
    scores = [make_score(str(i), True, 5, i < 27) for i in range(30)]
    p = compute_metrics(scores).stats("m").operating_points["precision_90"]
    assert (p.reached, p.k, p.hits, p.false_positives) == (True, 0, 27, 3)
    assert not compute_metrics(scores).stats("m").operating_points["precision_100"].reached


def test_a_precision_never_reached_is_recall_zero_without_threshold(make_score):
    scores = [make_score("0", True, 5, True), make_score("1", False, 5, False), make_score("2", False, 7, False)]
    pts = compute_metrics(scores).stats("m").operating_points
    for name in ("precision_90", "precision_100"):
        p = pts[name]
        assert (p.reached, p.k, p.hits, p.recall, p.precision) == (False, None, 0, 0.0, None)
    assert point_cell(pts["precision_90"], 1) == "not reached (0/1)"
    assert pts["max_recall"].k == 5 and pts["max_recall"].precision == pytest.approx(1 / 3)  # the n=7 pair is wrong too


def test_undefined_points_are_none(make_score):
    scores = [make_score("0", False, 5, False), make_score("1", False, 0, False)]
    pts = compute_metrics(scores, acceptance_k=2).stats("m").operating_points
    assert pts["max_recall"].recall is None and pts["max_recall"].recall_ci is None
    assert pts["acceptance"].recall is None and pts["acceptance"].precision == 0.0
    assert point_cell(pts["max_recall"], 1) == "n/a"


def test_acceptance_threshold_beyond_the_sweep(six):
    acc = compute_metrics(six, acceptance_k=50).stats("m").operating_points["acceptance"]
    assert (acc.k, acc.hits, acc.false_positives, acc.recall, acc.precision) == (50, 0, 0, 0.0, None)


def test_heading_bins_get_their_own_points(six):
    m = compute_metrics(six, acceptance_k=4)
    p = m.stats("m", "0-60").operating_points  # pairs 0 (n=10, right) and 4 (n=8, wrong, irrelevant)
    assert (p["max_recall"].k, p["max_recall"].hits, p["max_recall"].n_relevant) == (10, 1, 1)
    assert (p["precision_90"].k, p["acceptance"].false_positives) == (9, 1)
    fine = m.method("m").set("inter").heading_bins_fine[0].stats.operating_points  # 0-30: the same two pairs
    assert fine["max_recall"].k == 10


def test_json_round_trip_and_older_files(six, tmp_path):
    m = compute_metrics(six, acceptance_k=4)
    d = json.loads(json.dumps(to_json(m)))
    assert d["acceptance_k"] == 4 and list(d["methods"]["m"]["inter"]["operating_points"]) == list(POINT_NAMES)
    assert to_json(from_json(EvaluationMetrics, d, "test")) == d
    old = json.loads(json.dumps(d))  # a file written before the operating points existed
    strip_absent_points({}, old)
    assert "acceptance_k" not in old and "operating_points" not in json.dumps(old)
    back = from_json(EvaluationMetrics, old, "test")
    assert back.acceptance_k is None and back.stats("m").operating_points == {}
    assert operating_point_rows(back, "inter")[0]["max recall"] == "n/a"
    assert not strip_absent_points(d, json.loads(json.dumps(d)))  # a current file is compared whole


def test_tables_show_thresholds_and_precision(six):
    m = compute_metrics(six, EvalConfig(min_relevant=1), acceptance_k=4)
    rows = operating_point_rows(m, "inter")
    assert [r["heading"] for r in rows] == ["all", "0-60 deg", "60-120 deg", "120-180 deg"]
    lo, hi = wilson_by_hand(2, 4)
    assert rows[0]["max recall"] == f"0.50 (2/4) [{lo:.2f}, {hi:.2f}] at k=5, P=0.67 (2/3)"
    assert rows[0]["recall at P>=0.9"].startswith("0.25 (1/4)") and rows[0]["recall at P>=0.9"].endswith(
        "at k=9, P=1.00 (1/1)"
    )
    assert rows[0]["recall at acceptance (k=4)"].endswith("at k=4, P=0.67 (2/3)")
    s = metrics_rows(m, "inter")[0]
    assert s["P at max recall"] == "0.67 (2/3) at k=5" and s["recall@accept (k=4)"].startswith("0.50 (2/4)")


def test_bin_tables_give_each_operating_point(six):
    rows = bin_rows(compute_metrics(six, EvalConfig(min_relevant=1), acceptance_k=4), "inter", "heading_bins_fine")
    assert [r["figure"] for r in rows] == ["max recall", "recall at P>=0.9", "recall at acceptance (k=4)"]
    assert rows[0]["0-30"] == "1.00 (1/1)" and rows[1]["0-30"] == "1.00 (1/1)" and rows[2]["0-30"] == "1.00 (1/1)"
    assert rows[0]["150-180"] == "0.00 (0/2)" and rows[1]["150-180"] == "not reached (0/2)"  # both pairs wrong
    assert rows[0]["90-120"] == "n/a"  # only an irrelevant pair there
