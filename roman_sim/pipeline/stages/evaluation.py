"""Stage ``evaluation``: every aligner on every pair of submaps, scored against truth.

The stage enumerates the pairs (every pair unless the scenario sets a distance cap), takes
their truth, aligns them (one call, ``align_pairs``) and scores them (pure functions of the
pair truths and the aligner results, in ``roman_sim.evaluation``). Writes ``pairs.csv``
(one row per pair and method), ``alignments.json`` (each method's estimate and selected
associations per pair: the pose graph's closures and the report's example drawings) and
``metrics.json`` (with the front end's grades from the maps stage in its ``frontend``
section); the report stage draws the plots. Per-pair runtimes go to the run's timings, not
into these files.

The aligners run through ``apply_aligners``: optional submap gating, then chunks of pairs on
the run's executor (serial, process pool or Dask), resumable per chunk; the results are the
same bytes whatever the executor.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.align.base import AlignResult, segment_associations
from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.evaluation.bins import runtime_stats
from roman_sim.evaluation.evaluate import Evaluation, score_pairs
from roman_sim.evaluation.metrics import PairScore, summary
from roman_sim.evaluation.pairs import PairTruth, select_pairs, truths_for_pairs, world_ambiguity_fn
from roman_sim.evaluation.results import read_evaluation, write_evaluation
from roman_sim.evaluation.types import AlignmentRecord, EvaluationMetrics
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.pipeline.stages.world import WorldOutput

log = logging.getLogger(__name__)

ALIGNMENTS_JSON = "alignments.json"
ALIGNMENTS_SCHEMA = "roman_sim.alignments/2"


@dataclass
class EvaluationOutput:
    """Scores of every (pair, method), each method's estimates, the metrics and the notes.

    ``written`` lists the files the run wrote besides ``alignments.json`` (the tables); it is
    not persisted.
    """

    scores: list[PairScore]
    alignments: list[AlignmentRecord]
    metrics: EvaluationMetrics
    notes: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list, repr=False)

    def truths(self) -> dict[tuple[str, str], PairTruth]:
        """Truth of each scored pair, keyed by (a name, b name)."""
        return {(s.truth.a, s.truth.b): s.truth for s in self.scores}


def apply_aligners(ctx: RunContext, pairs: list[tuple[Submap, Submap]]) -> dict[tuple[str, str, str], AlignResult]:
    """Every scenario aligner on every pair, ``(a name, b name, label) -> AlignResult``.

    Gated (when ``gating.enabled``), then in chunks through the run's executor; pairs that
    gating skipped get "no alignment" with the gating reason, so they count as misses.
    """
    import time

    from roman_sim.align.gating import GATED_REASON, gate_pairs
    from roman_sim.pipeline.pairwork import align_pairs as run_chunks

    t0 = time.perf_counter()
    keep, _ = gate_pairs(pairs, ctx.scenario.gating)
    kept = [p for p, k in zip(pairs, keep) if k]
    gating_s = time.perf_counter() - t0
    ctx.progress.start("evaluation:pairs", len(kept))
    t1 = time.perf_counter()
    results = run_chunks(ctx, kept)
    ctx.progress.end("evaluation:pairs")
    ctx.timings["pairs"] = {
        "candidates": len(pairs),
        "aligned": len(kept),
        "gating_s": round(gating_s, 4),
        "alignment_wall_s": round(time.perf_counter() - t1, 3),
        "workers": ctx.tasks().workers,
        "executor": ctx.tasks().kind,
    }
    for (a, b), k in zip(pairs, keep):
        if not k:
            for e in ctx.scenario.aligners:
                results[(a.name, b.name, e.name)] = AlignResult.failure(e.name, GATED_REASON)
    return results


def _records(results: dict[tuple[str, str, str], AlignResult]) -> list[AlignmentRecord]:
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


def _runtimes(scores: list[PairScore]) -> dict[str, Any]:
    """Per method: runtime statistics and the per-pair runtimes in ``pairs.csv`` order (s)."""
    methods = sorted({s.method for s in scores})
    return {
        m: {
            **runtime_stats([s.runtime_s for s in scores if s.method == m]),
            "per_pair_s": [s.runtime_s for s in scores if s.method == m],
        }
        for m in methods
    }


class EvaluationStage(Stage[EvaluationOutput]):
    """Align and score every pair with every aligner of the scenario."""

    name = "evaluation"
    inputs = ("world", "maps", "submaps")

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["aligners"], sc["evaluation"], sc["submaps"]["submap_radius"], sc["gating"]]

    def run(
        self,
        ctx: RunContext,
        world: WorldOutput | None = None,
        maps: Maps | None = None,
        submaps: Submaps | None = None,
        **_: Any,
    ) -> EvaluationOutput:
        assert submaps is not None, "the evaluation stage needs the submaps"
        all_subs = submaps.all()
        ec = ctx.scenario.evaluation
        sel = select_pairs(all_subs, ec)
        ambiguity = None if world is None else world_ambiguity_fn(world.world.truth, ctx.scenario.submaps.submap_radius)
        truths = truths_for_pairs(sel.pairs, ambiguity, ec)
        results = apply_aligners(ctx, sel.pairs)
        scores = score_pairs(truths, results, [e.name for e in ctx.scenario.aligners], ec)
        metrics = summary(scores, ec, sel.n_skipped, ctx.scenario.posegraph.lc_association_thresh)
        ev = Evaluation(truths, scores, results, metrics)
        if maps is not None and maps.frontend is not None:
            ev.metrics.frontend = maps.frontend.to_json()
        paths = write_evaluation(ctx.run_dir, ev.scores, ev.metrics)
        ctx.timings["alignment"] = _runtimes(ev.scores)
        written = sorted(p.relative_to(ctx.run_dir).as_posix() for p in paths.values())
        return EvaluationOutput(ev.scores, _records(ev.results), ev.metrics, list(ev.notes), written)

    def save(self, out: EvaluationOutput, ctx: RunContext) -> list[str]:
        write_json(
            ctx.run_dir / ALIGNMENTS_JSON,
            {"schema": ALIGNMENTS_SCHEMA, "notes": out.notes, "alignments": [r.to_json() for r in out.alignments]},
        )
        return [*out.written, ALIGNMENTS_JSON]

    def load(self, ctx: RunContext, files: list[str]) -> EvaluationOutput:
        scores, metrics = read_evaluation(ctx.run_dir)
        path = ctx.run_dir / ALIGNMENTS_JSON
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("schema") != ALIGNMENTS_SCHEMA:
                raise ValueError(f"schema {data.get('schema')!r}")
            records = [AlignmentRecord.from_json(r) for r in data["alignments"]]
            notes = [str(n) for n in data["notes"]]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{path}: unreadable ({type(err).__name__}: {err})") from None
        return EvaluationOutput(scores, records, metrics, notes, [f for f in files if f != ALIGNMENTS_JSON])
