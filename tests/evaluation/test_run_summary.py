"""The compact run summary carries the operating points: filled from the metrics, read back, old files read."""

from __future__ import annotations

import json

import pytest

from roman_sim.core.records import RecordError, dumps_record, from_json, loads_record, to_json
from roman_sim.evaluation.metrics import compute_metrics
from roman_sim.evaluation.operating_points import POINT_NAMES
from roman_sim.evaluation.run_summary import RecallSummary, RunSummary, SetSummary, summarize_run


@pytest.fixture
def six(make_score):
    # (relevant, n_assoc, correct): TP(k) = 2 for k <= 5, 1 for k <= 10; the n=8 pair is the last false positive
    spec = [(True, 10, True), (True, 5, True), (True, 3, False), (True, 0, False), (False, 8, False), (False, 2, False)]
    headings = [10.0, 70.0, 150.0, 170.0, 20.0, 100.0]
    return [make_score(str(i), r, n, c, heading=headings[i]) for i, (r, n, c) in enumerate(spec)]


def _run(scores, acceptance_k: int | None) -> RunSummary:
    return summarize_run(compute_metrics(scores, acceptance_k=acceptance_k), None, None)


def test_points_are_filled_for_the_set_and_every_bin(six):
    inter = _run(six, 4).methods["m"].inter
    assert list(inter.points) == list(POINT_NAMES)
    best = inter.points["max_recall"]
    assert (best.k, best.hits, best.n_relevant, best.false_positives, best.precision) == (5, 2, 4, 1, 2 / 3)
    p90 = inter.points["precision_90"]
    assert (p90.k, p90.reached, p90.hits, p90.false_positives, p90.recall) == (9, True, 1, 0, 0.25)
    acc = inter.points["acceptance"]
    assert (acc.k, acc.hits, acc.false_positives) == (4, 2, 1)
    # 0-60 deg: the n=10 hit and the irrelevant n=8 miss; TP 1 up to k = 10, FP 1 up to k = 8
    b = inter.bins["0-60"].points
    assert (b["max_recall"].k, b["max_recall"].hits, b["max_recall"].false_positives) == (10, 1, 0)
    assert (b["precision_100"].k, b["precision_100"].hits) == (9, 1)
    assert (b["acceptance"].hits, b["acceptance"].false_positives, b["acceptance"].precision) == (1, 1, 0.5)
    # 120-180 deg: two relevant pairs nobody got (3 wrong, 0): no hit at all, max recall at the lowest k
    m = inter.bins["120-180"].points["max_recall"]
    assert (m.k, m.hits, m.false_positives, m.recall, m.precision) == (0, 0, 2, 0.0, 0.0)
    assert not inter.bins["120-180"].points["precision_90"].reached
    # no acceptance threshold: no acceptance point
    assert list(_run(six, None).methods["m"].inter.points) == list(POINT_NAMES[:3])


def test_points_round_trip_through_json(six):
    run = _run(six, 4)
    text = dumps_record(run)
    again = loads_record(text, RunSummary, "run")
    assert again == run
    assert dumps_record(again) == text
    point = json.loads(text)["methods"]["m"]["inter"]["points"]["precision_90"]
    assert set(point) == {
        "k",
        "reached",
        "hits",
        "n_relevant",
        "false_positives",
        "recall",
        "recall_ci",
        "precision",
        "precision_ci",
    }
    assert json.loads(text)["methods"]["m"]["inter"]["bins"]["60-120"]["points"]["max_recall"]["n_relevant"] == 1


def test_a_summary_written_before_the_points_still_reads(six):
    old = to_json(_run(six, 4))

    def strip(node):
        if isinstance(node, dict):
            node.pop("points", None)
            for v in node.values():
                strip(v)

    strip(old)
    run = from_json(RunSummary, old, "run")
    inter = run.methods["m"].inter
    assert inter.points == {} and all(b.points == {} for b in inter.bins.values())
    assert (inter.max_hits, inter.n_relevant) == (2, 4)
    empty = {"max_recall": None, "max_hits": 0, "n_relevant": 0, "recall_ci": None, "few": True}
    assert from_json(RecallSummary, empty, "recall").points == {}
    bad = to_json(_run(six, 4))
    bad["methods"]["m"]["inter"]["points"]["best"] = bad["methods"]["m"]["inter"]["points"]["max_recall"]
    with pytest.raises(RecordError, match=r"^run: field methods.m.inter.points.best: unknown key \(valid: max_recall,"):
        from_json(RunSummary, bad, "run")
    intra = to_json(_run(six, 4))["methods"]["m"]["intra"]
    assert isinstance(from_json(SetSummary, intra, "set"), SetSummary)
