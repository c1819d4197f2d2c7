"""Relevant pairs per robot pair, the overlap graph and what relevant pairs share, against hand counts."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.records import from_json, to_json
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics
from roman_sim.evaluation.overlap import (
    PairCounts,
    RevisitFigures,
    counts_by_pair,
    overlap_graph,
    relevant_counts,
    revisit_figures,
    revisit_overlap,
    robot_pair_counts,
)
from roman_sim.evaluation.types import EvaluationMetrics


def test_relevant_counts_by_hand():
    centres = {
        "a": np.array([[0.0, 0.0, 0.0], [20.0, 0.0, 0.0]]),
        "b": np.array([[5.0, 0.0, 0.0], [30.0, 0.0, 0.0], [100.0, 0.0, 0.0]]),  # (20, 0)-(30, 0): exactly 10 m
        "c": np.zeros((0, 3)),
    }
    assert relevant_counts(centres, 10.0) == {("a", "b"): 2, ("a", "c"): 0, ("b", "c"): 0}
    assert relevant_counts(centres, 9.99) == {("a", "b"): 1, ("a", "c"): 0, ("b", "c"): 0}


def test_overlap_graph_components():
    counts = {("a", "b"): 12, ("a", "c"): 9, ("b", "c"): 3, ("c", "d"): 10}
    g = overlap_graph(counts, ["a", "b", "c", "d"])
    assert g.edges == [("a", "b"), ("c", "d")]
    assert not g.connected and g.components == [["a", "b"], ["c", "d"]]
    assert g.describe().endswith("NOT connected, 2 groups {a, b} {c, d}")
    joined = overlap_graph({**counts, ("b", "c"): 10}, ["a", "b", "c", "d"])
    assert joined.connected and joined.describe().endswith(": connected")
    assert overlap_graph({}, ["solo"]).connected


def test_robot_pair_counts_and_metrics_round_trip(make_score):
    pairs = [("b", "a", True), ("a", "b", False), ("a", "a", True), ("a", "c", True)]
    counts = robot_pair_counts(pairs)
    assert counts == {"a|b": PairCounts(n_pairs=2, n_relevant=1), "a|c": PairCounts(n_pairs=1, n_relevant=1)}
    assert counts_by_pair(counts) == {("a", "b"): 1, ("a", "c"): 1}
    scores = [make_score(str(i), relevant=i < 3, n_assoc=5, correct=True, method=m) for i in range(5) for m in "xy"]
    scores += [make_score("9", relevant=True, n_assoc=5, correct=True, kind="intra")]
    m = compute_metrics(scores)
    assert m.robot_pairs == {"a|b": PairCounts(n_pairs=5, n_relevant=3)}  # one per pair, not per method
    again = from_json(EvaluationMetrics, to_json(m), "test")
    assert again.robot_pairs == m.robot_pairs
    old = to_json(m)
    del old["robot_pairs"]
    assert from_json(EvaluationMetrics, old, "test").robot_pairs is None


def test_revisit_overlap_from_submap_truth(make_submap):
    subs = [
        make_submap("a", 0, 0.0, 0.0, object_ids=(1, 2, 3, 4)),
        make_submap("a", 1, 40.0, 0.0, object_ids=(7, 8)),
        make_submap("b", 0, 3.0, 0.0, object_ids=(2, 3, 9)),  # near a/0: shares 2 of 3
        make_submap("b", 1, 41.0, 4.0, object_ids=(8,)),  # near a/1: shares 1 of 1
        make_submap("b", 2, 80.0, 0.0, object_ids=(1, 2)),  # near nothing
    ]
    ov = revisit_overlap(subs, EvalConfig())
    assert [(v.a, v.b, v.shared_objects) for v in ov.views] == [("a/0", "b/0", 2), ("a/1", "b/1", 1)]
    assert ov.views[0].overlap == pytest.approx(2 / 3) and ov.views[1].overlap == 1.0
    assert ov.median_overlap == pytest.approx((2 / 3 + 1.0) / 2) and ov.median_shared == 1.5
    assert ov.by_robot_pair == {("a", "b"): (2, pytest.approx(5 / 6), 1.5)}
    by_objects = revisit_overlap(subs, EvalConfig(relevance="shared_objects", min_shared_objects=2))
    assert [(v.a, v.b) for v in by_objects.views] == [("a/0", "b/0"), ("a/0", "b/2")]
    assert revisit_overlap(subs, EvalConfig(), kind="intra").views == []
    assert np.isnan(revisit_overlap(subs[:1], EvalConfig()).median_overlap)


def test_revisit_figures_by_hand():
    nan = float("nan")
    pairs = [
        ("a", "b", True, 0.5, 4),
        ("b", "a", True, 1.0, 10),  # the same robot pair, either order
        ("a", "b", True, 0.25, 2),
        ("a", "b", False, 0.9, 9),  # not relevant: left out
        ("a", "a", True, 1.0, 12),  # same robot: left out
        ("a", "c", True, nan, 0),  # counts, but gives no overlap
    ]
    got = revisit_figures(pairs)
    assert list(got) == ["all", "a|b", "a|c"]
    assert got["a|b"] == RevisitFigures(n_relevant=3, median_overlap=0.5, median_shared_objects=4.0)
    assert got["a|c"] == RevisitFigures(n_relevant=1, median_overlap=None, median_shared_objects=0.0)
    # all: overlaps 0.5, 1.0, 0.25 (NaN left out) -> 0.5; shared 4, 10, 2, 0 -> 3
    assert got["all"] == RevisitFigures(n_relevant=4, median_overlap=0.5, median_shared_objects=3.0)
    assert revisit_figures([("a", "a", True, 1.0, 3)]) == {}
    assert revisit_figures([("a", "b", False, 1.0, 3)])["all"] == RevisitFigures(0, None, None)


def test_metrics_record_revisit_figures_once_per_pair(make_score):
    scores = [make_score(str(i), relevant=i < 3, n_assoc=5, correct=True, method=m) for i in range(5) for m in "xy"]
    m = compute_metrics(scores)
    assert m.revisits is not None  # one entry per pair, not per method
    assert m.revisits["all"] == RevisitFigures(n_relevant=3, median_overlap=0.5, median_shared_objects=0.0)
    assert list(m.revisits) == ["all", "a|b"]
    assert from_json(EvaluationMetrics, to_json(m), "test").revisits == m.revisits
    old = to_json(m)
    del old["revisits"]
    assert from_json(EvaluationMetrics, old, "test").revisits is None
