"""Metrics on hand-made pair sets with hand-computed precision, recall, F1 and AUC."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.core.geometry import make_T, pose_4dof, rot_x
from roman_sim.core.records import to_json
from roman_sim.evaluation.bins import bin_index, fine_edges, runtime_stats
from roman_sim.evaluation.metrics import EvalConfig, auc, compute_metrics, pr_curve, score_pair


@pytest.fixture
def six(make_score):
    # (relevant, n_assoc, correct): 4 relevant pairs, 2 irrelevant (both wrong)
    spec = [(True, 10, True), (True, 5, True), (True, 3, False), (True, 0, False), (False, 8, False), (False, 2, False)]
    return [make_score(str(i), r, n, c) for i, (r, n, c) in enumerate(spec)]


def test_pr_curve_hand_counts(six):
    c = pr_curve(six, [0, 3, 6, 9, 11])
    assert c.n_relevant == 4
    assert c.tp.tolist() == [2, 2, 1, 1, 0]
    assert c.fp.tolist() == [4, 2, 1, 0, 0]
    np.testing.assert_allclose(c.precision[:4], [1 / 3, 0.5, 0.5, 1.0])
    np.testing.assert_allclose(c.recall, [0.5, 0.5, 0.25, 0.25, 0.0])
    np.testing.assert_allclose(c.f1[:4], [0.4, 0.5, 1 / 3, 0.4])
    # no positives at k=11: precision and F1 undefined, not zero
    assert math.isnan(c.precision[4]) and math.isnan(c.f1[4])
    # recall points 0.25 (best precision 1) and 0.5 (best 0.5), started at (0, 1)
    assert auc(c) == pytest.approx(0.25 + 0.25 * 0.75)


def test_summary_headlines_over_full_sweep(six):
    s = to_json(compute_metrics(six))["methods"]["m"]["inter"]
    assert s["n_pairs"] == 6 and s["n_relevant"] == 4
    assert s["max_recall"] == pytest.approx(0.5) and s["max_hits"] == 2
    assert s["recall_at_precision_1"] == pytest.approx(0.25)
    # k = 4..5: positives {10, 5, 8}: P = 2/3, R = 1/2
    assert s["best_f1"] == pytest.approx(4 / 7) and s["best_f1_k"] == 4
    assert s["auc"] == pytest.approx(0.25 + 0.25 * (1 + 2 / 3) / 2)
    assert s["pr_curve"]["precision"][-1] is None
    assert compute_metrics(six).methods["m"].n_failed == 1


def test_recall_at_precision_one_is_zero_when_never_reached(make_score):
    scores = [make_score("0", True, 5, True), make_score("1", False, 5, False)]
    s = to_json(compute_metrics(scores))["methods"]["m"]["inter"]
    assert s["recall_at_precision_1"] == 0.0 and s["max_recall"] == 1.0


def test_undefined_metrics_are_none_not_zero(make_score):
    scores = [make_score("0", False, 5, False), make_score("1", False, 0, False)]
    out = to_json(compute_metrics(scores))
    s = out["methods"]["m"]["inter"]
    for key in ("max_recall", "recall_at_precision_1", "auc", "best_f1"):
        assert s[key] is None, key
    assert any("no relevant cross-robot pairs" in n for n in out["notes"])
    assert all(v is None for v in s["pr_curve"]["recall"])
    empty = to_json(compute_metrics([]))
    assert empty["methods"] == {} and empty["notes"]


def test_heading_bins_at_boundaries(make_score):
    heads = [0.0, 59.999, 60.0, 120.0, 180.0, 90.0]
    scores = [make_score(str(i), True, 5, i % 2 == 0, heading=h) for i, h in enumerate(heads)]
    s = to_json(compute_metrics(scores))["methods"]["m"]["inter"]
    coarse = {b["label"]: (b["n_pairs"], b["max_recall"]) for b in s["heading_bins"]}
    # 0, 59.999 -> 0-60; 60, 90 -> 60-120; 120, 180 -> 120-180
    assert coarse == {"0-60": (2, 0.5), "60-120": (2, 0.5), "120-180": (2, 0.5)}
    fine = [b["n_pairs"] for b in s["heading_bins_fine"]]
    assert fine == [1, 1, 1, 1, 1, 1]
    assert s["heading_bins_fine"][1]["max_recall"] == 0.0  # 59.999 is wrong
    assert bin_index([-1.0, float("nan"), 181.0], [0, 60, 120, 180]).tolist() == [-1, -1, -1]


def test_ambiguity_bins_skip_unknown_and_empty_bins_are_none(make_score):
    scores = [
        make_score("0", True, 5, True, ambiguity=0.1),
        make_score("1", True, 5, False, ambiguity=1.0),
        make_score("2", True, 5, True),
    ]
    s = to_json(compute_metrics(scores))["methods"]["m"]["inter"]
    bins = s["ambiguity_bins"]
    assert [b["n_pairs"] for b in bins] == [1, 0, 0, 1]
    assert bins[0]["max_recall"] == 1.0 and bins[3]["max_recall"] == 0.0
    assert bins[1]["max_recall"] is None
    assert s["n_ambiguity_unknown"] == 1


def test_runtime_stats_hand_values():
    rt = runtime_stats([1, 2, 3, 4, 10, float("nan")])
    assert rt["n"] == 5 and (rt["median"], rt["mean"], rt["p90"]) == pytest.approx((3.0, 4.0, 7.6))
    assert runtime_stats([])["median"] is None


def test_summary_holds_no_wall_clock(make_score):
    """Runtimes differ between runs of one seed: they are not part of the metrics."""
    a = [make_score(str(i), True, 5, True, runtime=r) for i, r in enumerate([1, 2, 3])]
    b = [make_score(str(i), True, 5, True, runtime=r) for i, r in enumerate([7, 8, 9])]
    assert to_json(compute_metrics(a)) == to_json(compute_metrics(b))
    assert "runtime" not in json.dumps(to_json(compute_metrics(a)))


def test_score_pair_tolerances(make_truth, result_for):
    t = make_truth("0", True)
    t = type(t)(**{**t.__dict__, "T_a_b_true": pose_4dof(3.0, 0.0, 0.0, np.radians(30))})
    good = t.T_a_b_true @ make_T(rot_x(np.radians(4.0)), [0.0, 0.5, 0.0])
    s = score_pair(t, result_for(good, 7))
    assert s.correct and s.n_assoc == 7
    assert s.rot_err_deg == pytest.approx(4.0) and s.trans_err_m == pytest.approx(0.5)
    bad = t.T_a_b_true @ make_T(rot_x(np.radians(6.0)))
    assert not score_pair(t, result_for(bad, 7)).correct
    far = t.T_a_b_true @ make_T(None, [0.0, 1.2, 0.0])
    assert not score_pair(t, result_for(far, 7)).correct
    assert score_pair(t, result_for(far, 7), EvalConfig(trans_tol_m=1.5)).correct
    none = score_pair(t, result_for(None, 0))
    assert not none.correct and math.isnan(none.rot_err_deg) and none.reason == "failed"
    with pytest.raises(EvaluationError, match="finite 4x4"):
        score_pair(t, result_for(np.full((4, 4), np.nan), 3))


def test_mixed_methods_and_config_errors(make_score):
    with pytest.raises(EvaluationError, match="several methods"):
        pr_curve([make_score("0", True, 1, True, method="x"), make_score("1", True, 1, True, method="y")])
    with pytest.raises(ConfigError, match="heading_bins_deg"):
        validate_model(EvalConfig, {"heading_bins_deg": [0, 90, 60]})
    with pytest.raises(ConfigError, match="k_max"):
        validate_model(EvalConfig, {"k_min": 5, "k_max": 2})
    with pytest.raises(ConfigError, match="unknown key"):
        validate_model(EvalConfig, {"rot_tol": 3})
    assert fine_edges([0, 60, 120, 180], 30) == [0, 30, 60, 90, 120, 150, 180]


def test_summary_counts_distinct_pairs_across_methods(make_score):
    scores = [
        make_score("0", True, 5, True, method="x"),
        make_score("0", True, 5, True, method="y"),
        make_score("1", False, 5, False, method="y"),
    ]
    out = to_json(compute_metrics(scores))
    assert (out["n_pairs"], out["n_relevant"]) == (2, 1)
    only_irrelevant = compute_metrics(
        [make_score("0", True, 5, True, method="x"), make_score("1", False, 5, False, method="y")]
    )
    # y scored no relevant pair: its recall is undefined, not 0
    assert only_irrelevant.figure("y") is None and only_irrelevant.figure("x") == 1.0
