"""Stage ``evaluation``: every aligner on every pair of submaps, scored against truth.

The evaluation is four steps, each a plain function:

1. ``select_pairs`` (``roman_sim.evaluation.pairs``): every pair unless the scenario sets a
   distance cap (and how many pairs that cap skipped);
2. ``truths_for_pairs``: the ground truth of each pair;
3. ``apply_aligners``: optional submap gating, then every aligner on every pair in chunks
   on the run's executor (serial, process pool or Dask), resumable per chunk, on
   ``public()`` copies (no truth) - the only step that runs the methods; the results are
   the same bytes whatever the executor;
4. ``IncrementalScorer`` (each result scored as its chunk comes back) and ``metrics.compute_metrics``: pure
   functions of (pair truths, aligner results).

The alignment itself, the stage's worker job, is ``roman_sim.pipeline.stages.evaluation_job``.

``save`` writes ``pairs.csv`` (one row per pair and method), ``alignments.json`` (each
method's estimate and selected associations per pair: the pose graph's closures and the
report's example drawings) and ``metrics.json`` (with the front end's grades from the maps
stage in its ``frontend`` section); the report stage draws the plots. Per-pair runtimes go
to the run's timings (the output's ``timings``), not into these files. Each aligner's raw
results are also kept apart, ``aligned/<label>.json`` under a key of their own
(``roman_sim.pipeline.stages.aligned``): a run that adds an aligner takes the others' results
from the shared cache and aligns with the new one only.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.align.base import AlignResult, segment_associations
from roman_sim.core.errors import EvaluationError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import write_record
from roman_sim.evaluation.bins import runtime_stats
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import PairScore, compute_metrics, score_pair
from roman_sim.evaluation.pairs import AmbiguityFn, PairTruth, select_pairs, truths_for_pairs, world_ambiguity_fn
from roman_sim.evaluation.records import read_alignments, write_alignments
from roman_sim.evaluation.results import read_evaluation, write_evaluation
from roman_sim.evaluation.types import AlignmentRecord, EvaluationMetrics
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.aligned import (
    ALIGNED_SCHEMA,
    ALIGNED_TIMES_SCHEMA,
    ALIGNMENT_PART,
    AlignedRecord,
    aligned_file,
    aligned_record,
    aligned_results,
    aligner_keys,
    cached_aligned,
    split_aligned,
    times_file,
)
from roman_sim.pipeline.stages.base import CachePart, Stage, Timings
from roman_sim.pipeline.stages.evaluation_job import WORKER_PRELOAD, ResultKey, align_pairs
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import AlignerEntry

log = logging.getLogger(__name__)

ALIGNMENTS_JSON = "alignments.json"


@dataclass
class EvaluationOutput:
    """Scores of every (pair, method), each method's estimates, the metrics and the notes.

    ``aligned`` holds each aligner's results, kept apart (``roman_sim.pipeline.stages.aligned``),
    ``aligned_cached`` the aligners whose results were taken from the shared cache; both are
    empty when loaded.
    ``timings`` holds the gating and alignment wall times (``pairs``) and each method's
    per-pair runtimes (``alignment``).
    """

    scores: list[PairScore]
    alignments: list[AlignmentRecord]
    metrics: EvaluationMetrics
    notes: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)
    aligned: list[AlignedRecord] = field(default_factory=list, repr=False, compare=False)
    aligned_cached: list[str] = field(default_factory=list, repr=False, compare=False)

    def truths(self) -> dict[tuple[str, str], PairTruth]:
        """Truth of each scored pair, keyed by (a name, b name)."""
        return {(s.truth.a, s.truth.b): s.truth for s in self.scores}


@dataclass(frozen=True)
class EvaluationInputs:
    """The submaps; the world (for the ambiguity of places) and the maps (front-end grades) when the run has them."""

    submaps: Submaps
    world: WorldOutput | None = None
    maps: Maps | None = None


def apply_aligners(
    ctx: RunContext,
    pairs: list[tuple[Submap, Submap]],
    tasks: TaskRunner,
    aligners: Sequence[AlignerEntry] | None = None,
    on_chunk: Callable[[dict[ResultKey, AlignResult]], None] | None = None,
) -> tuple[dict[ResultKey, AlignResult], Timings]:
    """Each aligner (default: the scenario's) on every pair, ``(a name, b name, label) -> AlignResult``; wall times.

    Gated (when ``gating.enabled``), then in chunks through ``tasks``; pairs that gating
    skipped get "no alignment" with the gating reason, so they count as misses.
    ``on_chunk`` gets the results of each chunk of aligned pairs as it comes back.
    """
    from roman_sim.align.gating import GATED_REASON, gate_pairs

    aligners = list(ctx.scenario.aligners if aligners is None else aligners)
    t0 = time.perf_counter()
    keep, _ = gate_pairs(pairs, ctx.scenario.gating)
    kept = [p for p, k in zip(pairs, keep) if k]
    gating_s = time.perf_counter() - t0
    ctx.progress.start("evaluation:pairs", len(kept))
    t1 = time.perf_counter()
    results = align_pairs(ctx, kept, tasks, aligners, on_chunk) if aligners else {}
    ctx.progress.end("evaluation:pairs")
    timings: Timings = {
        "candidates": len(pairs),
        "aligned": len(kept),
        "gating_s": round(gating_s, 4),
        "alignment_wall_s": round(time.perf_counter() - t1, 3),
        "workers": tasks.workers,
        "executor": tasks.kind,
        "aligners": [e.name for e in aligners],
    }
    for (a, b), k in zip(pairs, keep):
        if not k:
            for e in aligners:
                results[(a.name, b.name, e.name)] = AlignResult.failure(e.name, GATED_REASON)
    return results, timings


class IncrementalScorer:
    """Each method's result on each pair scored as results come in: truths on the first chunk, each result on arrival.

    The evaluation hands ``add`` to the alignment, so this process scores the chunks that
    are back while the workers align the others; ``scores`` then scores what is left (pairs
    that gating skipped).
    """

    def __init__(
        self,
        pairs: list[tuple[Submap, Submap]],
        ambiguity: AmbiguityFn | None,
        methods: list[str],
        cfg: EvalConfig,
    ) -> None:
        self.pairs, self.ambiguity, self.methods, self.cfg = pairs, ambiguity, methods, cfg
        self._truths: list[PairTruth] | None = None
        self._by_pair: dict[tuple[str, str], PairTruth] = {}
        self._scored: dict[ResultKey, PairScore] = {}

    def truths(self) -> list[PairTruth]:
        """Truth of every pair, in pair order (computed once)."""
        if self._truths is None:
            self._truths = truths_for_pairs(self.pairs, self.ambiguity, self.cfg)
            self._by_pair = {(t.a, t.b): t for t in self._truths}
        return self._truths

    def add(self, results: dict[ResultKey, AlignResult]) -> None:
        """Score ``results`` (of the scenario's methods on pairs of ``pairs``)."""
        self.truths()
        for key, res in results.items():
            truth = self._by_pair.get(key[:2])
            if truth is not None and key[2] in self.methods:
                self._scored[key] = score_pair(truth, res, self.cfg)

    def scores(self, results: dict[ResultKey, AlignResult]) -> list[PairScore]:
        """Every (pair, method) score, pair-major, the methods in their order.

        Raises:
            EvaluationError: a result is missing for a (pair, method).
        """
        out = []
        for t in self.truths():
            for m in self.methods:
                key = (t.a, t.b, m)
                if key not in self._scored:
                    res = results.get(key)
                    if res is None:
                        raise EvaluationError(f"no result of {m} for the pair {t.a}|{t.b}")
                    self._scored[key] = score_pair(t, res, self.cfg)
                out.append(self._scored[key])
        return out


def _records(results: dict[ResultKey, AlignResult]) -> list[AlignmentRecord]:
    """Records of every result; associations kept only where they index segments (drawn and graded)."""
    empty = np.zeros((0, 2), np.int64)
    return [
        AlignmentRecord(
            a,
            b,
            method,
            r.n_associations,
            r.T_a_b,
            np.asarray(r.associations, np.int64).reshape(-1, 2) if segment_associations(r) else empty,
        )
        for (a, b, method), r in sorted(results.items())
    ]


def _runtimes(scores: list[PairScore]) -> Timings:
    """Per method: runtime statistics and the per-pair runtimes in ``pairs.csv`` order (s)."""
    methods = sorted({s.method for s in scores})
    return {
        m: {
            **runtime_stats([s.runtime_s for s in scores if s.method == m]),
            "per_pair_s": [s.runtime_s for s in scores if s.method == m],
        }
        for m in methods
    }


class EvaluationStage(Stage[EvaluationInputs, EvaluationOutput]):
    """Align and score every pair with every aligner of the scenario."""

    name = "evaluation"
    input_type = EvaluationInputs
    format = "aligned-times/1"  # each aligner's wall times apart from its results
    uses_workers = True
    code = ("roman_sim.align.checks",)  # its worker job's
    components = ("aligners",)
    worker_preload = WORKER_PRELOAD

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["aligners"], sc["evaluation"], sc["submaps"]["submap_radius"], sc["gating"]]

    def run(self, ctx: RunContext, inputs: EvaluationInputs, tasks: TaskRunner) -> EvaluationOutput:
        ec = ctx.scenario.evaluation
        sel = select_pairs(inputs.submaps.all(), ec)
        world = inputs.world
        ambiguity = None if world is None else world_ambiguity_fn(world.world.truth, ctx.scenario.submaps.submap_radius)
        scorer = IncrementalScorer(sel.pairs, ambiguity, [e.name for e in ctx.scenario.aligners], ec)
        names = [(a.name, b.name) for a, b in sel.pairs]
        keys = aligner_keys(self, ctx)
        cached = cached_aligned(ctx, keys, names)  # aligners whose results on these pairs are in the shared cache
        results = {k: v for rec in cached for k, v in aligned_results(rec).items()}
        scorer.add(results)
        taken = {rec.aligner for rec in cached}
        todo = [e for e in ctx.scenario.aligners if e.name not in taken]
        # pairs are scored as their chunks come back, while the workers align the others
        fresh, pair_timings = apply_aligners(ctx, sel.pairs, tasks, todo, scorer.add)
        results.update(fresh)
        scores = scorer.scores(results)
        aligned = cached + [aligned_record(e.name, keys[e.name], names, results) for e in todo if e.name in keys]
        n_segments = sum(len(s) for s in inputs.submaps.all())
        metrics = compute_metrics(scores, ec, sel.n_skipped, ctx.scenario.posegraph.lc_association_thresh, n_segments)
        log.info("evaluated %d pairs (%d skipped by the distance cap)", len(sel.pairs), sel.n_skipped)
        maps = inputs.maps
        if maps is not None and maps.frontend is not None:
            metrics.frontend = maps.frontend
        timings: Timings = {"pairs": pair_timings, "alignment": _runtimes(scores)}
        return EvaluationOutput(scores, _records(results), metrics, [], timings, aligned, sorted(taken))

    def parts(self, ctx: RunContext) -> list[CachePart]:
        """Each aligner's results, under its own key (``roman_sim.pipeline.stages.aligned``)."""
        return [
            CachePart(ALIGNMENT_PART, k, [aligned_file(label), times_file(label)])
            for label, k in aligner_keys(self, ctx).items()
        ]

    def save(self, out: EvaluationOutput, ctx: RunContext) -> list[str]:
        for rec in out.aligned:  # those from the shared cache copied (verified), the others written
            cache = ctx.cache if rec.aligner in out.aligned_cached else None
            if cache is None or cache.fetch(ALIGNMENT_PART, rec.key, ctx.run_dir) is None:
                record, times = split_aligned(rec)
                write_record(ctx.run_dir / aligned_file(rec.aligner), record, ALIGNED_SCHEMA, indent=None)
                write_record(ctx.run_dir / times_file(rec.aligner), times, ALIGNED_TIMES_SCHEMA, indent=None)
        paths = write_evaluation(ctx.run_dir, out.scores, out.metrics)
        write_alignments(ctx.run_dir / ALIGNMENTS_JSON, out.alignments, out.notes)
        kept = [f for rec in out.aligned for f in (aligned_file(rec.aligner), times_file(rec.aligner))]
        return [*sorted(p.relative_to(ctx.run_dir).as_posix() for p in paths.values()), ALIGNMENTS_JSON, *kept]

    def load(self, ctx: RunContext, files: list[str]) -> EvaluationOutput:
        scores, metrics = read_evaluation(ctx.run_dir)
        records, notes = read_alignments(ctx.run_dir / ALIGNMENTS_JSON)
        return EvaluationOutput(scores, records, metrics, notes)
