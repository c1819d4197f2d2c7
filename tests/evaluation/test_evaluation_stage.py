"""The evaluation stage end to end on hand-made submaps: align, score, save, draw and report."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align import ALIGNERS
from roman_sim.align.base import AlignResult
from roman_sim.core.errors import ConfigError
from roman_sim.evaluation.results import read_evaluation
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages.evaluation import EvaluationInputs, EvaluationStage
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.report.mapview import map_view_png
from roman_sim.report.markdown import report_markdown
from roman_sim.report.render import example_pngs, metric_plot_pngs
from roman_sim.runner.taskrunner import TaskRunner


class IdentityAligner:
    """Claims the submaps coincide; right only when the true relative pose is the identity."""

    name = "identity"
    saw_truth = False

    def align(self, a, b) -> AlignResult:
        IdentityAligner.saw_truth |= a.truth is not None or b.truth is not None
        n = min(len(a), len(b))
        idx = np.arange(n, dtype=np.int64)
        return AlignResult(self.name, np.eye(4), np.stack([idx, idx], 1), np.ones(n), 0.001)


class NeverAligner:
    name = "never"

    def align(self, a, b) -> AlignResult:
        return AlignResult.failure(self.name, "no putative associations")


@pytest.fixture
def hand_aligners():
    ALIGNERS.register("identity", IdentityAligner)
    ALIGNERS.register("never", NeverAligner)
    yield
    for name in ("identity", "never"):
        ALIGNERS._items.pop(name, None)


def _run(tmp_path, submaps: dict, aligners: str, *sets: str):
    ctx = RunContext(load_scenario("smoke", [f"aligners={aligners}", "posegraph_method=null", *sets]), tmp_path)
    stage = EvaluationStage()
    return ctx, stage, stage.run(ctx, EvaluationInputs(Submaps(submaps)), TaskRunner())


def test_evaluation_stage_scores_saves_and_reports(make_submap, tmp_path, hand_aligners):
    ids = (1, 2, 3, 4)
    subs = {
        "a": [make_submap("a", 0, 0.0, 0.0, 0.0, ids, True)],
        "b": [make_submap("b", i, x, 0.0, 0.0, ids, True) for i, x in enumerate((0.0, 3.0, 60.0))],
    }
    IdentityAligner.saw_truth = False
    ctx, stage, out = _run(tmp_path, subs, "[identity, never]", "evaluation.k_max=5")
    assert not IdentityAligner.saw_truth  # the aligners see public copies
    # pairs: a0-b0, a0-b1, a0-b2, b0-b2 (b0-b1 and b1-b2 are time neighbours)
    pairs = list(dict.fromkeys((s.truth.a, s.truth.b) for s in out.scores))
    assert pairs == [("a/0", "b/0"), ("a/0", "b/1"), ("a/0", "b/2"), ("b/0", "b/2")]
    m = out.metrics.methods
    # cross-robot: a0-b0 (relevant, identity right), a0-b1 (relevant, 3 m off), a0-b2 (far); same-robot: b0-b2
    ident = m["identity"].set("inter").overall
    assert (ident.n_pairs, ident.n_relevant, ident.max_hits, ident.max_recall) == (3, 2, 1, 0.5)
    assert m["identity"].set("intra").overall.n_relevant == 0 and m["identity"].set("intra").overall.n_pairs == 1
    # association truth: identity selects (i, i) on submaps with the same ids -> every association correct
    assert (ident.assoc_selected, ident.assoc_correct, ident.assoc_available) == (12, 12, 12)
    assert m["never"].set("inter").overall.max_recall == 0.0 and m["never"].n_failed == 4
    assert sorted(stage.save(out, ctx)) == ["alignments.json", "metrics.json", "pairs.csv"]
    scores, metrics = read_evaluation(tmp_path)
    assert len(scores) == 8 and metrics.figure("identity") == 0.5
    # what the report stage draws from this output
    metric, notes = metric_plot_pngs(metrics)
    results = {(r.a, r.b, r.method): r.result() for r in out.alignments}
    examples = example_pngs(out.scores, {s.name: s for v in subs.values() for s in v}, results)
    assert "precision_recall.png" in metric and set(examples) == {"alignment_identity.png"}
    assert all(png.startswith(b"\x89PNG") for png in [*metric.values(), *examples.values()])
    assert map_view_png([s for v in subs.values() for s in v]).startswith(b"\x89PNG")
    plots = [f"plots/{n}" for n in [*metric, *examples]] + ["plots/map_view.png"]
    text = report_markdown("hand", metrics, notes=notes, plots=plots)
    assert "| identity | 3 | 2 | n<5: 1/2 | n<5: 0/2 |" in text and "plots/map_view.png" in text


def test_aligner_sets_are_checked_by_the_scenario():
    with pytest.raises(ConfigError, match="aligners"):
        load_scenario("smoke", ["aligners=[]"])
    with pytest.raises(ConfigError, match="labels must be unique"):
        load_scenario("smoke", ["aligners=[roman, roman]"])


def test_roman_aligner_on_a_synthetic_pair_is_scored_correct(tmp_path, hand_aligners):
    from roman_sim.align.synthetic import make_submap_pair

    a, b, _ = make_submap_pair(0, n_inliers=12, n_outliers_a=5, n_outliers_b=5, descriptor_dim=32)
    _, _, out = _run(tmp_path, {"a": [a], "b": [b]}, "[roman, never]")
    roman = next(s for s in out.scores if s.method == "roman")
    assert roman.truth.relevant and roman.truth.kind == "inter"
    assert roman.correct and roman.n_assoc >= 10
    assert out.metrics.figure("roman") == 1.0
    assert out.metrics.figure("never") == 0.0
    assert not list(tmp_path.iterdir())  # run() wrote nothing
