"""Applying the aligners to submap pairs: in chunks, through the run's executor, resumable per chunk.

This is only *how* the aligners run; what is scored is the evaluation's business. Pairs
are cut into chunks of ``ctx.chunk_pairs`` in pair order; each chunk is one task that runs
every aligner on its pairs (with truth stripped) and returns JSON-ready results. The
stage's ``TaskRunner`` checkpoints each finished chunk (``ChunkCodec``: the records are the
checkpoint's JSON data) under a hash of its pair names, so an interrupted evaluation
re-aligns only the unfinished chunks. Every result, fresh or resumed, goes through the same
JSON round trip, so the outputs are byte-identical whatever the executor, the worker count
or the interruption.

``Replay`` then hands the results to the evaluation as aligners that look them up.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable
from pathlib import Path
from typing import cast

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.core.jsontypes import JSON
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.tasks import ChunkRecord, align_chunk_task, result_from_json
from roman_sim.runner.checkpoint import Kept
from roman_sim.runner.taskrunner import TaskRunner

log = logging.getLogger(__name__)

ResultKey = tuple[str, str, str]


def aligners_json(ctx: RunContext) -> str:
    """The scenario's aligners (label, method, params) as the JSON the alignment tasks take."""
    return json.dumps(
        [{"label": e.name, "method": e.method, "params": e.params} for e in ctx.scenario.aligners], sort_keys=True
    )


def _chunk_id(pairs: list[tuple[str, str]]) -> str:
    return hashlib.sha256(json.dumps(pairs).encode()).hexdigest()[:16]


class ChunkCodec:
    """Checkpoint codec of a chunk's results (``TaskCodec``): the JSON records themselves, no payload file."""

    def write(self, value: list[ChunkRecord], stem: Path) -> Kept:
        """The records as the checkpoint's data."""
        return Kept(cast(JSON, value))

    def read(self, data: JSON, stem: Path) -> list[ChunkRecord]:
        """The records back (a list of JSON objects)."""
        if not isinstance(data, list) or not all(isinstance(r, dict) for r in data):
            raise EvaluationError(f"{stem}: malformed chunk checkpoint")
        return cast(list[ChunkRecord], data)


def align_pairs(
    ctx: RunContext,
    pairs: list[tuple[Submap, Submap]],
    tasks: TaskRunner,
    on_chunk: Callable[[dict[ResultKey, AlignResult]], None] | None = None,
) -> dict[ResultKey, AlignResult]:
    """Every scenario aligner on every pair: ``(a name, b name, label) -> AlignResult``.

    Progress advances by the pairs of each finished chunk (``evaluation:pairs``). ``on_chunk``
    gets each chunk's results as the chunk comes back (in the order chunks finish), so the
    caller can work on them while the workers align the other chunks.
    """
    size = max(1, int(ctx.chunk_pairs))
    names = [(a.name, b.name) for a, b in pairs]
    chunks = [names[i : i + size] for i in range(0, len(names), size)]
    public = {s.name: s.public() for ab in pairs for s in ab}
    spec = aligners_json(ctx)
    args = [(spec, {n: public[n] for ab in chunk for n in ab}, chunk) for chunk in chunks]
    labels = [f"aligning pairs {i * size}..{i * size + len(c) - 1}" for i, c in enumerate(chunks)]
    done: dict[int, dict[ResultKey, AlignResult]] = {}
    for i, rec in tasks.run(align_chunk_task, args, labels, [_chunk_id(c) for c in chunks], ChunkCodec()):
        done[i] = {(str(r["a"]), str(r["b"]), str(r["method"])): result_from_json(r) for r in rec}
        ctx.progress.advance("evaluation:pairs", len(chunks[i]))
        if on_chunk is not None:
            on_chunk(done[i])
    return {k: v for i in range(len(chunks)) for k, v in done[i].items()}


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
