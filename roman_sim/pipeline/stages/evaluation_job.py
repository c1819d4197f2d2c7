"""The evaluation stage's worker job: every aligner on a chunk of submap pairs, resumable per chunk.

This is only *how* the aligners run; what is scored is the evaluation's business. Pairs
are cut into chunks of ``ctx.chunk_pairs`` in pair order; each chunk is one task
(``align_chunk_task``) that runs every aligner on its pairs (with truth stripped) and
returns each result as its JSON row (``ResultRow``: floats exact, numpy values made plain). The
stage's ``TaskRunner`` checkpoints each finished chunk (``ChunkCodec``: the rows are the
checkpoint's JSON data, read back through ``roman_sim.core.records``) under a hash of its pair
names, so an interrupted evaluation re-aligns only the unfinished chunks. Every result, fresh
or resumed, is read from its row, so the outputs are byte-identical whatever the executor, the
worker count or the interruption.

A worker keeps the aligners it built (``_aligners``), so consecutive chunks of one run do
not rebuild them. ``WORKER_PRELOAD`` names what the job imports, for a local pool's
forkserver to preload (the compiled CLIPPER solver loaded too).
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.align.base import Aligner, AlignResult, ResultRow
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import dumps_record, from_json, loads_record, to_json
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import RunContext
from roman_sim.runner.checkpoint import Kept
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import AlignerEntry

log = logging.getLogger(__name__)

#: ``(a name, b name, aligner label)``: the key of one aligner's result on one pair.
ResultKey = tuple[str, str, str]

#: What the job's workers import (``Stage.worker_preload``), the CLIPPER solver's warm-up last.
WORKER_PRELOAD = (
    __name__,
    "roman_sim.align",
    "roman_sim.align.clipper_jit",
    "roman_sim.align.visual.aligner",
    "roman_sim.align.clipper:warm_up",
)


@dataclass(frozen=True)
class AlignerSpec:
    """One aligner as the alignment tasks take it: its label, method and parameters."""

    label: str
    method: str
    params: dict[str, JSON]


@lru_cache(maxsize=4)
def _aligners(aligners_json: str) -> list[tuple[str, Aligner]]:
    from roman_sim.align import build_aligner
    from roman_sim.pipeline.plugin_guard import guard_aligner

    specs = loads_record(aligners_json, list[AlignerSpec], "the alignment task's aligners")
    return [(e.label, guard_aligner(build_aligner(e.method, e.params), e.method)) for e in specs]


def align_chunk_task(aligners_json: str, submaps: dict[str, Submap], pairs: list[tuple[str, str]]) -> list[ResultRow]:
    """Every aligner on every pair of the chunk (submaps already public); the results' rows in order.

    Returns one row per (pair, aligner), pair-major: the result under the aligner's label.
    """
    from roman_sim.align.checks import remembered_checks

    out: list[ResultRow] = []
    labelled = _aligners(aligners_json)
    with remembered_checks():  # each submap's input checks once per chunk, not once per pair and method
        for a, b in pairs:
            for label, aligner in labelled:
                res = aligner.align(submaps[a], submaps[b])
                res.method = label
                out.append(res.row(a, b))
    return out


def aligners_json(aligners: Sequence[AlignerEntry]) -> str:
    """The aligners (label, method, params) as the JSON the alignment tasks take."""
    return dumps_record([AlignerSpec(e.name, e.method, e.params) for e in aligners])


def _chunk_id(pairs: list[tuple[str, str]], labels: list[str]) -> str:
    return hashlib.sha256(json.dumps([pairs, labels]).encode()).hexdigest()[:16]


class ChunkCodec:
    """Checkpoint codec of a chunk's results (``TaskCodec``): the rows as JSON, no payload file."""

    def write(self, value: list[ResultRow], stem: Path) -> Kept:
        """The rows as the checkpoint's data."""
        return Kept(to_json(value))

    def read(self, data: JSON, stem: Path) -> list[ResultRow]:
        """The rows back (RecordError names the checkpoint and the field when one is damaged)."""
        return from_json(list[ResultRow], data, f"{stem} (chunk checkpoint)")


def align_pairs(
    ctx: RunContext,
    pairs: list[tuple[Submap, Submap]],
    tasks: TaskRunner,
    aligners: Sequence[AlignerEntry],
    on_chunk: Callable[[dict[ResultKey, AlignResult]], None] | None = None,
) -> dict[ResultKey, AlignResult]:
    """Every aligner of ``aligners`` on every pair: ``(a name, b name, label) -> AlignResult``.

    Progress advances by the pairs of each finished chunk (``evaluation:pairs``). ``on_chunk``
    gets each chunk's results as the chunk comes back (in the order chunks finish), so the
    caller can work on them while the workers align the other chunks.
    """
    size = max(1, int(ctx.chunk_pairs))
    names = [(a.name, b.name) for a, b in pairs]
    chunks = [names[i : i + size] for i in range(0, len(names), size)]
    public = {s.name: s.public() for ab in pairs for s in ab}
    spec = aligners_json(aligners)
    ids = [_chunk_id(c, [e.name for e in aligners]) for c in chunks]
    args = [(spec, {n: public[n] for ab in chunk for n in ab}, chunk) for chunk in chunks]
    labels = [f"aligning pairs {i * size}..{i * size + len(c) - 1}" for i, c in enumerate(chunks)]
    done: dict[int, dict[ResultKey, AlignResult]] = {}
    for i, rec in tasks.run(align_chunk_task, args, labels, ids, ChunkCodec()):
        done[i] = {(r.a, r.b, r.method): AlignResult.from_row(r) for r in rec}
        ctx.progress.advance("evaluation:pairs", len(chunks[i]))
        if on_chunk is not None:
            on_chunk(done[i])
    return {k: v for i in range(len(chunks)) for k, v in done[i].items()}
