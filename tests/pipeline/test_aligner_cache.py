"""Each aligner's results are cached apart: a run that adds an aligner aligns with the new one only.

Runs start from a copy of the session's smoke run (aligners roman and clipper), so only the
evaluation onward is computed. The aligners' calls are counted in this process (the default
executor runs the tasks here).
"""

from __future__ import annotations

import json
import shutil
from collections import Counter

import pytest

import roman_sim.align
from roman_sim.align.base import AlignResult
from roman_sim.evaluation.results import read_pairs_csv
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stagecache import StageCache
from roman_sim.pipeline.stages import evaluation_job
from roman_sim.pipeline.stages.aligned import ALIGNMENT_PART, aligned_file, times_file

ADDED = ["aligners=[roman, clipper, ransac100k]"]
#: What the evaluation writes, and what the stages after it write from it.
SAME_BYTES = ["pairs.csv", "metrics.json", "alignments.json", "posegraph.json", "ate.json", "map_stats.json"]


def _counted_run(exp: Experiment, monkeypatch: pytest.MonkeyPatch) -> tuple[RunResult, Counter[str]]:
    """Run ``exp`` counting each aligner method's ``align`` calls."""
    calls: Counter[str] = Counter()
    build = roman_sim.align.build_aligner

    def counting_build(method: str, params: dict) -> object:
        aligner = build(method, params)
        align = aligner.align

        def counted(a: object, b: object) -> AlignResult:
            calls[method] += 1
            return align(a, b)

        aligner.align = counted  # type: ignore[method-assign]
        return aligner

    evaluation_job._aligners.cache_clear()  # workers keep built aligners: build them again, counted
    with monkeypatch.context() as mp:
        mp.setattr(roman_sim.align, "build_aligner", counting_build)
        result = exp.run()
    evaluation_job._aligners.cache_clear()
    return result, calls


@pytest.fixture(scope="module")
def runs(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[RunResult, Counter[str]]]:
    """The smoke run in a cache; an aligner added in a new folder; the same computed without the cache."""
    tmp = tmp_path_factory.mktemp("aligners")
    cache = StageCache(tmp / "cache")
    mp = pytest.MonkeyPatch()
    try:
        first = _counted_run(
            Experiment(load_scenario("smoke"), shutil.copytree(smoke_run.run_dir, tmp / "first"), cache=cache), mp
        )
        added = _counted_run(Experiment(load_scenario("smoke", ADDED), tmp / "added", cache=cache), mp)
        alone = shutil.copytree(smoke_run.run_dir, tmp / "alone")
        fresh = _counted_run(Experiment(load_scenario("smoke", ADDED), alone), mp)
        copy = shutil.copytree(tmp / "added", tmp / "again")
        again = _counted_run(Experiment(load_scenario("smoke", ADDED), copy, cache=cache, from_stage="evaluation"), mp)
    finally:
        mp.undo()
    return {"first": first, "added": added, "fresh": fresh, "again": again, "cache": cache}  # type: ignore[dict-item]


def test_the_cached_run_publishes_each_aligners_results(runs) -> None:
    first, calls = runs["first"]
    assert not calls  # every stage of its own folder reused
    entries = [e for e in runs["cache"].entries() if e.parent.name == ALIGNMENT_PART]
    assert len(entries) == 3  # roman and clipper from the first run, ransac100k from the added, each under its key
    for label in ("roman", "clipper"):
        assert (first.run_dir / aligned_file(label)).is_file()


def test_adding_an_aligner_aligns_with_the_new_one_only(runs) -> None:
    added, calls = runs["added"]
    fresh, fresh_calls = runs["fresh"]
    n_pairs = _timings(fresh)["evaluation"]["pairs"]["aligned"]  # the pairs gating kept
    assert n_pairs == len(read_pairs_csv(fresh.run_dir / "pairs.csv")) // 3 > 0
    assert calls == Counter({"ransac100k": n_pairs})  # roman and clipper not called once
    assert fresh_calls == Counter({"roman": n_pairs, "clipper": n_pairs, "ransac100k": n_pairs})
    timings = _timings(added)
    assert timings["evaluation"]["pairs"]["aligners"] == ["ransac100k"]
    assert timings["maps"]["reused"] and not timings["evaluation"]["reused"]


def test_from_evaluation_aligns_with_every_aligner_again(runs) -> None:
    """``--from evaluation`` recomputes the stage: no aligner's results are taken from the cache."""
    again, calls = runs["again"]
    n_pairs = _timings(again)["evaluation"]["pairs"]["aligned"]
    assert calls == Counter({"roman": n_pairs, "clipper": n_pairs, "ransac100k": n_pairs})
    assert (again.run_dir / "pairs.csv").read_bytes() == (runs["fresh"][0].run_dir / "pairs.csv").read_bytes()


def test_reused_results_give_the_same_bytes_as_computed_ones(runs) -> None:
    first, _ = runs["first"]
    added, _ = runs["added"]
    fresh, _ = runs["fresh"]
    for name in SAME_BYTES:  # the evaluation and everything after it, as if every aligner had run
        assert (added.run_dir / name).read_bytes() == (fresh.run_dir / name).read_bytes(), name
    for label in ("roman", "clipper"):  # the very results of the first run, and its wall times
        for name in (aligned_file(label), times_file(label)):
            assert (added.run_dir / name).read_bytes() == (first.run_dir / name).read_bytes(), name
    for label in ("roman", "clipper", "ransac100k"):  # computed again: the same record (its wall times apart)
        assert (added.run_dir / aligned_file(label)).read_bytes() == (fresh.run_dir / aligned_file(label)).read_bytes()
        assert b"runtime_s" not in (fresh.run_dir / aligned_file(label)).read_bytes()


def _timings(run: RunResult) -> dict:
    return json.loads((run.run_dir / "timings.json").read_text(encoding="utf-8"))["stages"]
