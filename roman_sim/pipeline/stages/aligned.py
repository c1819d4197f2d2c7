"""Each aligner's results on a run's pairs, kept apart: a run that adds an aligner re-uses the others'.

The evaluation stage's key covers every aligner of the scenario, so adding one changes it.
What one aligner computes depends on less: the aligner (label, method, resolved
parameters), the pairs (the submaps' key, the evaluation's pair selection, the gating) and
the code it runs (the worker job, the input checks, the gating, the pair selection and the
aligner's module, with what they import). ``aligner_key`` hashes exactly that. The stage
writes each aligner's results to ``aligned/<label>.json`` (``AlignedRecord``: the key and
one ``ResultRow`` per pair, in pair order, gated pairs included, without its wall time) and
the pairs' alignment wall times beside them, to ``aligned/<label>.times.json``
(``AlignedTimes``); it lists both among its files, and the experiment stores both in the
shared cache under the aligner's key (``Stage.parts``, part ``alignment``). The record is
thus a pure function of its inputs (the same bytes from any run of the same key); the times,
like ``timings.json``, differ between two runs (``roman_sim.testing.run_folder_bytes`` leaves
them out). A later run reads from the cache the aligners whose keys it finds
(``cached_aligned``: record and times), aligns with the others only, and links the cached
files into its folder when it saves. The results are read
from the same rows as a fresh chunk's results, so the scores are the same bytes.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from roman_sim import __version__
from roman_sim.align.base import AlignResult, ResultRow
from roman_sim.core.config import stable_hash
from roman_sim.core.records import RecordError, read_record
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.resolve import aligner_modules
from roman_sim.pipeline.stages.evaluation_job import ResultKey

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import AlignerEntry
    from roman_sim.pipeline.stages.base import Stage

log = logging.getLogger(__name__)

#: The shared cache's name for one aligner's results (a ``CachePart``).
ALIGNMENT_PART = "alignment"
ALIGNED_DIR = "aligned"
ALIGNED_SCHEMA = "roman_sim.aligned/2"
ALIGNED_TIMES_SCHEMA = "roman_sim.aligned_times/1"
#: Modules every aligner's results depend on besides the aligner's own (with what they import).
ALIGNMENT_CODE = (
    "roman_sim.pipeline.stages.evaluation_job",
    "roman_sim.align.checks",
    "roman_sim.align.gating",
    "roman_sim.evaluation.pairs",
)


@dataclass
class AlignedRecord:
    """What ``aligned/<label>.json`` holds: the aligner's key and its result on every pair, in pair order.

    Attributes:
        aligner: the aligner's label.
        key: ``aligner_key`` of the run that computed the results.
        results: per pair, the result's row (its wall time apart, in ``AlignedTimes``, on disk).
    """

    aligner: str
    key: str
    results: list[ResultRow]


@dataclass
class AlignedTimes:
    """What ``aligned/<label>.times.json`` holds: the alignment wall time of each pair of the record (s)."""

    aligner: str
    key: str
    runtime_s: list[float]


def aligned_file(label: str) -> str:
    """The run-folder path of the aligner ``label``'s results."""
    return f"{ALIGNED_DIR}/{label}.json"


def times_file(label: str) -> str:
    """The run-folder path of the wall times of the aligner ``label``'s results."""
    return f"{ALIGNED_DIR}/{label}.times.json"


def split_aligned(rec: AlignedRecord) -> tuple[AlignedRecord, AlignedTimes]:
    """``rec`` without its wall times, and the times apart: what ``aligned/<label>.json`` and
    ``aligned/<label>.times.json`` hold (the stage's ``save`` writes them)."""
    results = [replace(r, runtime_s=None) for r in rec.results]
    times = [float("nan") if r.runtime_s is None else r.runtime_s for r in rec.results]
    return AlignedRecord(rec.aligner, rec.key, results), AlignedTimes(rec.aligner, rec.key, times)


def read_aligned(folder: Path, label: str) -> AlignedRecord:
    """The aligner ``label``'s record in ``folder`` with its wall times put back (RecordError when either
    file is missing, malformed or of another key or length)."""
    rec = read_record(folder / aligned_file(label), AlignedRecord, ALIGNED_SCHEMA)
    times = read_record(folder / times_file(label), AlignedTimes, ALIGNED_TIMES_SCHEMA)
    if (times.aligner, times.key, len(times.runtime_s)) != (rec.aligner, rec.key, len(rec.results)):
        raise RecordError(f"{folder / times_file(label)}: the wall times of another aligner, key or pair set")
    return AlignedRecord(rec.aligner, rec.key, [replace(r, runtime_s=t) for r, t in zip(rec.results, times.runtime_s)])


def aligner_key(stage: Stage[Any, Any], ctx: RunContext, entry: AlignerEntry) -> str | None:
    """What the aligner's results on the run's pairs depend on, hashed (None outside a run: no submaps key)."""
    submaps = ctx.keys.get("submaps")
    if submaps is None:
        return None
    sc = ctx.scenario.model_dump(mode="json")
    code = stage.fingerprint([*ALIGNMENT_CODE, *aligner_modules(entry.method)])
    own = entry.model_dump(mode="json")
    return stable_hash(__version__, ALIGNMENT_PART, entry.name, own, sc["evaluation"], sc["gating"], submaps, code)


def aligner_keys(stage: Stage[Any, Any], ctx: RunContext) -> dict[str, str]:
    """Label -> ``aligner_key`` of every aligner of the scenario (empty outside a run)."""
    keys = {e.name: aligner_key(stage, ctx, e) for e in ctx.scenario.aligners}
    return {label: k for label, k in keys.items() if k is not None}


def aligned_record(
    label: str, key: str, pairs: Sequence[tuple[str, str]], results: dict[ResultKey, AlignResult]
) -> AlignedRecord:
    """The aligner ``label``'s results on ``pairs`` (in their order) as its record."""
    return AlignedRecord(label, key, [results[(a, b, label)].row(a, b) for a, b in pairs])


def cached_aligned(ctx: RunContext, keys: dict[str, str], pairs: Sequence[tuple[str, str]]) -> list[AlignedRecord]:
    """The records of every aligner whose key the shared cache holds, on exactly ``pairs`` (read, not copied).

    An entry that does not read back, or covers other pairs, is left (the aligner runs again).
    """
    out: list[AlignedRecord] = []
    if ctx.cache is None or ctx.fresh:
        return out
    for label, key in keys.items():
        where = ctx.cache.lookup(ALIGNMENT_PART, key)
        if where is None:
            continue
        try:
            rec = read_aligned(where, label)
            got = [(r.a, r.b) for r in rec.results]
            if rec.key != key or rec.aligner != label or got != list(pairs):
                raise RecordError(f"{where / aligned_file(label)}: the results of another key, aligner or pair set")
        except RecordError as err:
            log.warning("aligner %s: cached results not used (%s); aligning again", label, err)
            continue
        log.info("aligner %s: its results taken from the shared cache", label)
        out.append(rec)
    return out


def aligned_results(rec: AlignedRecord) -> dict[ResultKey, AlignResult]:
    """The record's results, ``(a name, b name, label) -> AlignResult``."""
    return {(r.a, r.b, rec.aligner): AlignResult.from_row(r) for r in rec.results}
