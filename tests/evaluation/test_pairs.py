"""Pair enumeration and pair truth against hand-made submap poses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.pairs import enumerate_pairs, pair_truth, truths_for_pairs


def _set(make_submap):
    # robot a: 4 submaps along x every 5 m; robot b: 2 submaps, one far away
    a = [make_submap("a", i, 5.0 * i, 0.0) for i in range(4)]
    b = [make_submap("b", 0, 0.0, 3.0, 180.0), make_submap("b", 1, 100.0, 0.0)]
    return a + b


def test_enumeration_counts_inter_and_intra_with_gap(make_submap):
    subs = _set(make_submap)
    pairs = enumerate_pairs(subs)
    names = {(p.name, q.name) for p, q in pairs}
    inter = [x for x in names if x[0][0] != x[1][0]]
    intra = [x for x in names if x[0][0] == x[1][0]]
    assert len(inter) == 4 * 2
    # robot a: gaps >= 2 -> (0,2),(0,3),(1,3); robot b: (0,1) has gap 1 -> excluded
    assert sorted(intra) == [("a/0", "a/2"), ("a/0", "a/3"), ("a/1", "a/3")]
    assert len(enumerate_pairs(subs, intra_min_gap=1)) == 8 + 6 + 1


def test_enumeration_order_is_deterministic_and_sorted(make_submap):
    subs = _set(make_submap)
    p1 = [(a.name, b.name) for a, b in enumerate_pairs(subs)]
    p2 = [(a.name, b.name) for a, b in enumerate_pairs(list(reversed(subs)))]
    assert p1 == p2
    assert all(a < b for a, b in p1)


def test_max_distance_keeps_relevant_pairs_only_when_small(make_submap):
    subs = _set(make_submap)
    pairs = enumerate_pairs(subs, max_center_dist_m=0.0)
    # threshold below relevance: relevant ones (<= 10 m) stay, far ones go
    for a, b in pairs:
        assert pair_truth(a, b).relevant
    assert ("a/0", "b/0") in {(a.name, b.name) for a, b in pairs}
    assert all("b/1" not in (a.name, b.name) for a, b in pairs)
    assert len(enumerate_pairs(subs, max_center_dist_m=20.0)) > len(pairs)


def test_bad_arguments_raise(make_submap):
    with pytest.raises(EvaluationError, match="intra_min_gap"):
        enumerate_pairs(_set(make_submap), intra_min_gap=0)
    dup = [make_submap("a", 0, 0, 0), make_submap("a", 0, 1, 0)]
    with pytest.raises(EvaluationError, match="duplicate"):
        enumerate_pairs(dup)
    with pytest.raises(EvaluationError, match="truth"):
        pair_truth(make_submap("a", 0, 0, 0).public(), make_submap("b", 0, 0, 0))


def test_relative_pose_heading_distance_from_hand_poses(make_submap):
    a = make_submap("a", 0, 2.0, 1.0, 90.0, object_ids=(1, 2, 3, 4))
    b = make_submap("b", 0, 2.0, 7.0, -120.0, object_ids=(3, 4, 5))
    t = pair_truth(a, b)
    # b's centre is 6 m along world +y = a's +x (a faces +y)
    np.testing.assert_allclose(t.T_a_b_true[:3, 3], [6.0, 0.0, 0.0], atol=1e-12)
    assert t.center_dist_m == pytest.approx(6.0)
    # relative yaw = -120 - 90 = -210 = +150
    assert t.heading_diff_deg == pytest.approx(150.0)
    assert t.overlap == pytest.approx(2 / 3)
    assert t.relevant and t.kind == "inter"
    assert math.isnan(t.ambiguity)


def test_relevance_threshold_and_intra_kind_and_ambiguity_callable(make_submap):
    a = make_submap("a", 0, 0.0, 0.0)
    b = make_submap("a", 3, 10.0, 0.0, object_ids=(-1, 7))
    seen = []
    t = pair_truth(a, b, ambiguity_fn=lambda xy: seen.append(xy) or float(xy[0]) / 20.0)
    # the pair's ambiguity is the mean over its two true centres: (0 + 10) / 20 / 2
    assert t.relevant and t.kind == "intra" and t.ambiguity == pytest.approx(0.25)
    np.testing.assert_allclose(seen, [[0.0, 0.0], [10.0, 0.0]])
    assert t.overlap == 0.0 and t.shared_objects == 0 and t.true_correspondences == 0
    assert not pair_truth(a, b, cfg=EvalConfig(relevant_dist_m=9.99)).relevant
    empty = make_submap("b", 0, 0.0, 0.0, object_ids=(-1,))
    assert math.isnan(pair_truth(a, empty).overlap)
    assert len(truths_for_pairs([(a, b), (a, empty)])) == 2


def test_world_ambiguity_fn_matches_place_ambiguity(make_submap):
    amb = pytest.importorskip("roman_sim.world.ambiguity")
    from roman_sim.core.geometry import make_T
    from roman_sim.evaluation.pairs import world_ambiguity_fn
    from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth

    objs = [
        ObjectTruth(
            i,
            "conifer" if i % 2 else "rock",
            make_T(None, [3.0 * i - 6, (i % 3) * 2.0, 0]),
            np.array([2.0, 1.0, 1.0]),
            2.0,
            np.array([3.0 * i - 6, (i % 3) * 2.0, 1.0]),
            [i],
            [],
            np.eye(4),
            np.ones(3),
            0.5,
        )
        for i in range(6)
    ]
    world = WorldTruth(objs, Terrain(60.0, 60.0, np.zeros((5, 5))))
    t = pair_truth(make_submap("a", 0, 0.0, 0.0), make_submap("b", 0, 4.0, 2.0), world_ambiguity_fn(world, 10.0))
    expected = [amb.place_ambiguity(world, np.array(xy), radius_m=10.0) for xy in ([0.0, 0.0], [4.0, 2.0])]
    assert t.ambiguity == pytest.approx(np.mean(expected))
