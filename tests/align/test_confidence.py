"""A method's own named scores: ROMAN's objective, density, percent, margin and semantic; the baselines'."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roman_sim.align import AlignResult, build_aligner
from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.align.confidence import percent_associations
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import AlignmentError
from roman_sim.core.geometry import pose_4dof

ROMAN_SCORES = {"objective", "density", "percent_associations", "margin"}


@pytest.fixture(scope="module")
def pair():
    T = pose_4dof(3.0, 2.0, 0.2, np.deg2rad(30.0))
    a, b, truth = make_submap_pair(8, 12, 6, 4, T_a_b=T, noise_m=0.05, descriptor_dim=64)
    return a.public(), b.public(), truth


@pytest.mark.parametrize("name", ["roman", "clipper", "clipper_prune", "gravity"])
def test_roman_scores_against_hand_formulas(pair, name: str) -> None:
    a, b, _ = pair
    r = build_aligner(name).align(a, b)
    s = r.named_scores()
    assert s[DEFAULT_SCORE] == len(r.associations) == r.score >= 3
    assert ROMAN_SCORES <= set(s)
    # the reference's formula: associations over the mean segment count of the two submaps (18 and 16)
    assert len(a) == 18 and len(b) == 16
    assert s["percent_associations"] == len(r.associations) / 17.0
    assert s["objective"] == r.info["F"] and s["density"] == r.info["density"]
    assert s["margin"] >= 0 and s["margin"] <= s["objective"]
    reads_descriptors = name in ("roman", "clipper_prune")
    assert ("semantic" in s) == reads_descriptors
    if reads_descriptors:
        cos = [
            float(a.descriptors[i] @ b.descriptors[j])
            / (np.linalg.norm(a.descriptors[i].astype(float)) * np.linalg.norm(b.descriptors[j].astype(float)))
            for i, j in r.associations
        ]
        assert s["semantic"] == pytest.approx(sum(cos) / len(cos), rel=1e-6)


def test_the_margin_sees_a_repeated_layout_that_geometry_cannot_tell_apart() -> None:
    # a holds an exact copy of the shared layout made of other families: geometry alone has two
    # equally dense hypotheses (margin 0), semantics leaves one (a margin of most of its objective)
    a, b, _ = make_submap_pair(3, 10, 0, 0, noise_m=0.0, repeated_layout=True)
    geometry = build_aligner("gravity").align(a, b).named_scores()
    semantic = build_aligner("roman").align(a, b).named_scores()
    assert geometry["objective"] > 9 and geometry["margin"] < 1e-6
    assert semantic["margin"] > 0.5 * semantic["objective"]


def test_ransac_gives_its_best_hypothesis_inliers(pair) -> None:
    a, b, _ = pair
    r = build_aligner("ransac100k", {"iterations": 20_000}).align(a, b)
    assert r.named_scores() == {DEFAULT_SCORE: float(len(r.associations)), "inliers": float(r.info["n_inliers"])}


def test_a_failure_offers_the_association_count_only() -> None:
    r = AlignResult.failure("roman", "no putative associations")
    assert r.named_scores() == {DEFAULT_SCORE: 0.0}


@pytest.mark.parametrize("n,na,nb,want", [(0, 0, 0, 0.0), (6, 10, 14, 0.5), (3, 4, 0, 1.5), (5, 40, 40, 0.125)])
def test_percent_associations_is_the_count_over_the_mean_segment_count(n, na, nb, want) -> None:
    assert percent_associations(n, na, nb) == want


@pytest.mark.parametrize(
    "confidence,what",
    [
        ({"Margin": 1.0}, "score name 'Margin'"),
        ({"associations": 3.0}, "score name 'associations'"),
        ({"my score": 1.0}, "score name 'my score'"),
        ({"mine": math.nan}, "score 'mine': expected a finite number"),
        ({"mine": "high"}, "score 'mine': expected a finite number"),
        ({"mine": True}, "score 'mine': expected a finite number"),
    ],
)
def test_a_bad_named_score_is_one_line_naming_it(confidence, what: str) -> None:
    r = AlignResult.failure("plugin", "x")
    r.confidence = confidence
    with pytest.raises(AlignmentError, match=what):
        r.named_scores()


def test_named_scores_survive_the_json_row_and_an_old_row_reads_without_them(pair) -> None:
    a, b, _ = pair
    r = build_aligner("roman").align(a, b)
    row = r.row("a/0", "b/0")
    back = AlignResult.from_row(row)
    assert back.named_scores() == r.named_scores()
    old = AlignResult.failure("ransac100k", "x").row("a/0", "b/0")
    assert old.confidence == {}
    from roman_sim.core.records import to_json

    assert "confidence" not in to_json(old)  # rows without named scores are written as before
    assert "confidence" in to_json(row)
