"""Applying the aligners to submap pairs: in chunks, through the run's executor, resumable per chunk.

This is only *how* the aligners run; what is scored is the evaluation's business. Pairs
are cut into chunks of ``ctx.chunk_pairs`` in pair order; each chunk is one task that runs
every aligner on its pairs (with truth stripped) and returns JSON-ready results. Each
finished chunk is checkpointed under the stage key and a hash of its pair names, so an
interrupted evaluation re-aligns only the unfinished chunks. Every result, fresh or
resumed, goes through the same JSON round trip, so the outputs are byte-identical
whatever the executor, the worker count or the interruption.

``Replay`` then hands the results to the evaluation as aligners that look them up.
"""

from __future__ import annotations

import hashlib
import json
import logging
from typing import Any

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.checkpoint import Checkpoint
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.tasks import align_chunk_task, result_from_json

log = logging.getLogger(__name__)

ResultKey = tuple[str, str, str]


def aligners_json(ctx: RunContext) -> str:
    """The scenario's aligners (label, method, params) as the JSON the alignment tasks take."""
    return json.dumps(
        [{"label": e.name, "method": e.method, "params": e.params} for e in ctx.scenario.aligners], sort_keys=True
    )


def _chunk_id(pairs: list[tuple[str, str]]) -> str:
    return hashlib.sha256(json.dumps(pairs).encode()).hexdigest()[:16]


def align_pairs(ctx: RunContext, pairs: list[tuple[Submap, Submap]]) -> dict[ResultKey, AlignResult]:
    """Every scenario aligner on every pair: ``(a name, b name, label) -> AlignResult``.

    Progress advances by the pairs of each finished chunk (``evaluation:pairs``).
    """
    size = max(1, int(ctx.chunk_pairs))
    names = [(a.name, b.name) for a, b in pairs]
    chunks = [names[i : i + size] for i in range(0, len(names), size)]
    public = {s.name: s.public() for ab in pairs for s in ab}
    done = Checkpoint(ctx.run_dir, "evaluation", None if ctx.fresh else ctx.stage_key)
    records: dict[int, list[dict[str, Any]]] = {}
    for i, chunk in enumerate(chunks):
        rec = done.get(_chunk_id(chunk))
        if rec is not None:
            records[i] = rec
            ctx.progress.advance("evaluation:pairs", len(chunk))
    todo = [i for i in range(len(chunks)) if i not in records]
    if len(todo) < len(chunks):
        log.info("evaluation: %d of %d chunks reused from an interrupted run", len(chunks) - len(todo), len(chunks))
    spec = aligners_json(ctx)
    args = [(spec, {n: public[n] for ab in chunks[i] for n in ab}, chunks[i]) for i in todo]
    labels = [f"aligning pairs {i * size}..{i * size + len(chunks[i]) - 1}" for i in todo]
    for j, rec in ctx.tasks().run_tasks(align_chunk_task, args, labels):
        i = todo[j]
        done.put(_chunk_id(chunks[i]), rec)
        records[i] = json.loads(json.dumps(rec))  # the checkpoint's round trip, for fresh chunks too
        ctx.progress.advance("evaluation:pairs", len(chunks[i]))
    out: dict[ResultKey, AlignResult] = {}
    for i in range(len(chunks)):
        for r in records[i]:
            out[(r["a"], r["b"], r["method"])] = result_from_json(r)
    return out


class Replay:
    """An aligner that returns the precomputed result of each pair (``Aligner`` protocol).

    Pairs without a result (skipped by submap gating) get "no alignment" with ``reason``.
    """

    def __init__(self, name: str, results: dict[ResultKey, AlignResult], missing_reason: str | None = None) -> None:
        self.name = name
        self.results = results
        self.missing_reason = missing_reason

    def align(self, a: Submap, b: Submap) -> AlignResult:
        res = self.results.get((a.name, b.name, self.name))
        if res is not None:
            return res
        if self.missing_reason is None:
            raise EvaluationError(f"{self.name}: no alignment computed for {a.name}|{b.name}")
        return AlignResult.failure(self.name, self.missing_reason)


def replay_aligners(
    ctx: RunContext, results: dict[ResultKey, AlignResult], missing_reason: str | None = None
) -> list[Replay]:
    """One ``Replay`` per scenario aligner, in scenario order."""
    return [Replay(e.name, results, missing_reason) for e in ctx.scenario.aligners]
