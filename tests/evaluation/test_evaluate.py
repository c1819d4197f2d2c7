"""End to end on hand-made submaps: run aligners, score, write every result file."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.evaluate import evaluate, save_evaluation
from roman_sim.evaluation.metrics import EvalConfig
from roman_sim.evaluation.results import read_evaluation
from roman_sim.report.markdown import write_report


class IdentityAligner:
    """Claims the submaps coincide; right only when the true relative pose is the identity."""

    name = "identity"

    def __init__(self) -> None:
        self.saw_truth = False

    def align(self, a, b) -> AlignResult:
        self.saw_truth |= a.truth is not None or b.truth is not None
        n = min(len(a), len(b))
        idx = np.arange(n, dtype=np.int64)
        return AlignResult(self.name, np.eye(4), np.stack([idx, idx], 1), np.ones(n), 0.001)


class NeverAligner:
    name = "never"

    def align(self, a, b) -> AlignResult:
        return AlignResult.failure(self.name, "no putative associations")


def test_evaluate_and_save(make_submap, tmp_path):
    ids = (1, 2, 3, 4)
    subs = [
        make_submap("a", 0, 0.0, 0.0, 0.0, ids, True),
        make_submap("b", 0, 0.0, 0.0, 0.0, ids, True),
        make_submap("b", 1, 3.0, 0.0, 0.0, ids, True),
        make_submap("b", 2, 60.0, 0.0, 0.0, ids, True),
    ]
    ident = IdentityAligner()
    ev = evaluate(subs, [ident, NeverAligner()], EvalConfig(k_max=5), ambiguity_fn=lambda xy: 0.4)
    assert not ident.saw_truth
    # pairs: a0-b0, a0-b1, a0-b2, b0-b2 (b0-b1 and b1-b2 are time neighbours)
    assert [(t.a, t.b) for t in ev.truths] == [("a/0", "b/0"), ("a/0", "b/1"), ("a/0", "b/2"), ("b/0", "b/2")]
    m = ev.metrics.methods
    # cross-robot: a0-b0 (relevant, identity right), a0-b1 (relevant, 3 m off), a0-b2 (far); same-robot: b0-b2
    ident = m["identity"].set("inter").overall
    assert (ident.n_pairs, ident.n_relevant, ident.max_hits, ident.max_recall) == (3, 2, 1, 0.5)
    assert m["identity"].set("intra").overall.n_relevant == 0 and m["identity"].set("intra").overall.n_pairs == 1
    # association truth: identity selects (i, i) on submaps with the same ids -> every association correct
    assert (ident.assoc_selected, ident.assoc_correct, ident.assoc_available) == (12, 12, 12)
    assert m["never"].set("inter").overall.max_recall == 0.0 and m["never"].n_failed == 4
    paths = save_evaluation(tmp_path, ev, subs)
    assert {"pairs", "metrics", "precision_recall", "alignment_identity", "map_view"} <= set(paths)
    scores, metrics = read_evaluation(tmp_path)
    assert len(scores) == 8 and metrics.figure("identity") == 0.5
    plots = [p.relative_to(tmp_path).as_posix() for k, p in paths.items() if p.suffix == ".png"]
    text = write_report(tmp_path, "hand", metrics, notes=ev.notes, plots=plots).read_text()
    assert "| identity | 3 | 2 | n<5: 1/2 | n<5: 0/2 |" in text and "plots/map_view.png" in text


def test_evaluate_rejects_bad_aligner_sets(make_submap):
    subs = [make_submap("a", 0, 0.0, 0.0), make_submap("b", 0, 0.0, 0.0)]
    with pytest.raises(EvaluationError, match="at least one"):
        evaluate(subs, [])
    with pytest.raises(EvaluationError, match="unique"):
        evaluate(subs, [NeverAligner(), NeverAligner()])


def test_roman_aligner_on_a_synthetic_pair_is_scored_correct():
    from roman_sim.align.aligners import RomanAligner
    from roman_sim.align.synthetic import make_submap_pair

    a, b, _ = make_submap_pair(0, n_inliers=12, n_outliers_a=5, n_outliers_b=5, descriptor_dim=32)
    ev = evaluate([a, b], [RomanAligner(), NeverAligner()], pairs=[(a, b)])
    roman = next(s for s in ev.scores if s.method == "roman")
    assert roman.truth.relevant and roman.truth.kind == "inter"
    assert roman.correct and roman.n_assoc >= 10
    assert ev.metrics.figure("roman") == 1.0
    assert ev.metrics.figure("never") == 0.0
