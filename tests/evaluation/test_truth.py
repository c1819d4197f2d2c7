"""Association truth, relevance criteria, pair selection with a cap, and per pair-set metrics, by hand."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.assoc import association_truth, shared_objects, true_correspondences
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics, score_pair
from roman_sim.evaluation.overlap import PairCounts
from roman_sim.evaluation.pairs import pair_truth, select_pairs


def test_true_correspondences_count_split_objects_once_per_pairing():
    # object 7 split in two segments in a, one in b: one correspondence available; 8: 2 and 2; 9 only in a
    a, b = [7, 7, 8, 8, 9, -1], [8, 7, 8, -1, -1]
    assert true_correspondences(a, b) == 1 + 2
    assert shared_objects(a, b) == 2
    assert true_correspondences([-1, -1], [-1]) == 0  # unassigned segments are never correspondences


def test_association_truth_correct_and_recovered():
    a, b = [7, 7, 8, 8, 9], [8, 7, 8]
    # (0,1): 7-7 right; (1,1): 7-7 right again (b's segment reused); (2,0): 8-8 right; (4,2): 9-8 wrong
    correct, recovered = association_truth(a, b, [[0, 1], [1, 1], [2, 0], [4, 2]])
    assert correct == 3 and recovered == 2  # b's segment 1 can pair with only one of a's
    assert association_truth(a, b, np.zeros((0, 2), int)) == (0, 0)
    with pytest.raises(EvaluationError, match="outside"):
        association_truth(a, b, [[5, 0]])


def test_score_pair_counts_associations_against_segment_truth(make_submap, result_for):
    a = make_submap("a", 0, 0.0, 0.0, object_ids=(1, 2, 3, 4))
    b = make_submap("b", 0, 1.0, 0.0, object_ids=(2, 1, 3, 5))
    t = pair_truth(a, b)
    assert (t.shared_objects, t.true_correspondences) == (3, 3)
    res = result_for(t.T_a_b_true, 4, n_segments=4)  # (0,0) 1-2 no, (1,1) 2-1 no, (2,2) 3-3 yes, (3,3) 4-5 no
    s = score_pair(t, res)
    assert (s.n_assoc, s.assoc_correct, s.assoc_recovered) == (4, 1, 1)
    st = compute_metrics([s]).stats("m")
    assert (st.assoc_selected, st.assoc_correct, st.assoc_available, st.assoc_recovered) == (4, 1, 3, 1)
    assert st.assoc_precision == pytest.approx(0.25) and st.assoc_recall == pytest.approx(1 / 3)


def test_relevance_by_shared_objects(make_submap):
    a = make_submap("a", 0, 0.0, 0.0, object_ids=(1, 2, 3, 4))
    far = make_submap("b", 0, 30.0, 0.0, object_ids=(1, 2, 3))
    near = make_submap("b", 1, 5.0, 0.0, object_ids=(8, 9))
    by_objects = EvalConfig(relevance="shared_objects", min_shared_objects=3)
    assert pair_truth(a, far, cfg=by_objects).relevant and not pair_truth(a, far).relevant
    assert not pair_truth(a, near, cfg=by_objects).relevant and pair_truth(a, near).relevant
    assert "at least 3 true objects" in by_objects.describe_relevance()
    assert not pair_truth(a, far, cfg=EvalConfig(relevance="shared_objects", min_shared_objects=4)).relevant


def test_every_pair_by_default_and_a_cap_counts_what_it_skips(make_submap):
    subs = [make_submap("a", i, 10.0 * i, 0.0) for i in range(4)] + [make_submap("b", 0, 0.0, 5.0)]
    every = select_pairs(subs)
    # a: 3 pairs with gap >= 2; a-b: 4
    assert (len(every.pairs), every.n_candidates, every.n_skipped, every.cap_m) == (7, 7, 0, None)
    capped = select_pairs(subs, EvalConfig(max_pair_dist_m=12.0))
    kept = {(p.name, q.name) for p, q in capped.pairs}
    # b/0 is 5 m from a/0 (relevant), 11.2 m from a/1; a/0-a/2 20 m, a/0-a/3 30 m, a/1-a/3 20 m, a/2-b 20.6, a/3-b 30.4
    assert kept == {("a/0", "b/0"), ("a/1", "b/0")}
    assert (capped.n_candidates, capped.n_skipped, capped.cap_m) == (7, 5, 12.0)
    # relevant pairs survive any cap, whatever the relevance criterion
    objects = select_pairs(subs, EvalConfig(max_pair_dist_m=0.0, relevance="shared_objects", min_shared_objects=3))
    assert {(p.name, q.name) for p, q in objects.pairs} == {(p.name, q.name) for p, q in every.pairs}


def test_cross_and_same_robot_pairs_are_scored_apart(make_score):
    scores = [
        make_score("0", True, 6, True, kind="inter"),
        make_score("1", True, 6, False, kind="inter"),
        make_score("2", True, 6, True, kind="intra"),
        make_score("3", True, 6, True, kind="intra"),
        make_score("4", True, 6, True, kind="intra"),
    ]
    m = compute_metrics(scores, EvalConfig(min_relevant=3))
    assert m.headline == "inter"
    assert m.pairs == {"inter": PairCounts(2, 2), "intra": PairCounts(3, 3), "all": PairCounts(5, 5)}
    inter, intra = (m.stats("m", kind=k) for k in ("inter", "intra"))
    assert (inter.max_hits, inter.n_relevant, inter.few) == (1, 2, True)
    assert (intra.max_hits, intra.n_relevant, intra.few) == (3, 3, False)
    assert set(m.methods["m"].sets) == {"inter", "intra"}  # never mixed
    assert m.figure("m") == 0.5 and m.figure("m", kind="intra") == 1.0
    only_intra = compute_metrics([make_score("0", True, 6, True, kind="intra")])
    assert only_intra.headline == "intra" and only_intra.figure("m") == 1.0
