"""Small typed records of a run: map statistics (and measuring them) and one method's estimate for one pair."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import AlignResult
from roman_sim.core.records import OMIT_NONE, from_json, read_record, to_json, write_record
from roman_sim.mapping.io import packet_bytes
from roman_sim.mapping.types import Submap


@dataclass(frozen=True)
class MapStats:
    """Size of what the robots mapped and would share.

    Attributes:
        robots: robots with submaps.
        segments: finished segments of all robots (None when maps are not available).
        submaps: submaps of all robots.
        segments_per_submap: mean segments per submap.
        kb_per_submap, kb_per_submap_max: mean and largest submap packet (kB).
        trajectory_km: total true trajectory length (None without maps).
        mb_per_km: submap packets (MB) per km of trajectory.
        keyframes_per_submap: mean visual keyframes per submap (None without keyframes).
        keyframe_kb_per_submap, keyframe_kb_per_submap_max: mean and largest keyframe
            packet (kB), what the visual method shares, counted apart from the segments.
        keyframe_mb_per_km: keyframe packets (MB) per km of trajectory.
    """

    robots: int
    segments: int | None
    submaps: int
    segments_per_submap: float | None
    kb_per_submap: float | None
    kb_per_submap_max: float | None
    trajectory_km: float | None
    mb_per_km: float | None
    keyframes_per_submap: float | None = field(default=None, metadata=OMIT_NONE)
    keyframe_kb_per_submap: float | None = field(default=None, metadata=OMIT_NONE)
    keyframe_kb_per_submap_max: float | None = field(default=None, metadata=OMIT_NONE)
    keyframe_mb_per_km: float | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class MapStatsRecord(MapStats):
    """What ``map_stats.json`` holds: the statistics and the run's notes."""

    notes: list[str] = field(default_factory=list)

    def stats(self) -> MapStats:
        """The statistics without the notes."""
        return MapStats(**{f.name: getattr(self, f.name) for f in fields(MapStats)})


def write_map_stats(path: str | Path, stats: MapStats, notes: list[str]) -> Path:
    """Atomically write ``map_stats.json``: the statistics and the run's notes."""
    return write_record(path, MapStatsRecord(**vars(stats), notes=notes))


def read_map_stats(path: str | Path) -> tuple[MapStats, list[str]]:
    """``map_stats.json``: the statistics and the notes (RecordError naming the file and the field)."""
    rec = read_record(path, MapStatsRecord)
    return rec.stats(), list(rec.notes)


def map_stats(submaps: Sequence[Submap], robots: int, segments: int | None, trajectory_m: float | None) -> MapStats:
    """Segments, submaps, packet size per submap and MB per km of trajectory (keyframes apart).

    Args:
        submaps: every submap of the run.
        robots: robots with submaps.
        segments: finished segments of all robots (None when the maps are not available).
        trajectory_m: total true trajectory length (None without maps).
    """
    sizes = [packet_bytes(s) for s in submaps]
    length_m = trajectory_m or 0.0
    with_kf = [s for s in submaps if s.keyframes is not None]
    kf = [packet_bytes(s, "keyframes") for s in with_kf]
    return MapStats(
        keyframes_per_submap=float(np.mean([len(s.keyframes or []) for s in with_kf])) if with_kf else None,
        keyframe_kb_per_submap=float(np.mean(kf)) / 1000.0 if kf else None,
        keyframe_kb_per_submap_max=float(np.max(kf)) / 1000.0 if kf else None,
        keyframe_mb_per_km=(sum(kf) / 1e6) / (length_m / 1000.0) if kf and length_m > 0 else None,
        robots=robots,
        segments=segments,
        submaps=len(submaps),
        segments_per_submap=float(np.mean([len(s) for s in submaps])) if submaps else None,
        kb_per_submap=float(np.mean(sizes)) / 1000.0 if sizes else None,
        kb_per_submap_max=float(np.max(sizes)) / 1000.0 if sizes else None,
        trajectory_km=length_m / 1000.0 if trajectory_m is not None else None,
        mb_per_km=(sum(sizes) / 1e6) / (length_m / 1000.0) if trajectory_m is not None and length_m > 0 else None,
    )


@dataclass(frozen=True)
class AlignmentRecord:
    """What one method estimated for one pair (the input of the pose graph's closures).

    Attributes:
        a, b: submap names (``robot/index``).
        method: method label.
        n_associations: accepted associations.
        T_a_b: 4x4 estimate of b's frame in a's (rounded to 1e-9), or None.
        associations: (k, 2) selected associations (indices into a's and b's segments).
    """

    a: str
    b: str
    method: str
    n_associations: int
    T_a_b: NDArray[np.float64] | None
    associations: NDArray[np.int64] = field(default_factory=lambda: np.zeros((0, 2), np.int64), compare=False)

    def row(self) -> AlignmentRow:
        """The record as ``alignments.json`` stores it (the estimate rounded to 1e-9, lists)."""
        return AlignmentRow(
            self.a,
            self.b,
            self.method,
            self.n_associations,
            None if self.T_a_b is None else np.round(self.T_a_b, 9).tolist(),
            np.asarray(self.associations, dtype=np.int64).reshape(-1, 2).tolist(),
        )

    @classmethod
    def from_row(cls, r: AlignmentRow) -> AlignmentRecord:
        """Inverse of ``row``."""
        T = None if r.T_a_b is None else np.asarray(r.T_a_b, dtype=np.float64).reshape(4, 4)
        return cls(r.a, r.b, r.method, r.n_associations, T, np.asarray(r.associations, dtype=np.int64).reshape(-1, 2))

    def result(self) -> AlignResult:
        """An ``AlignResult`` holding this record's estimate and associations (for drawing)."""
        return AlignResult(
            self.method,
            self.T_a_b,
            np.asarray(self.associations, dtype=np.int64).reshape(-1, 2),
            np.ones(len(self.associations)),
            float("nan"),
            None if self.T_a_b is not None else "no estimate",
        )


@dataclass
class AlignmentRow:
    """One ``AlignmentRecord`` as JSON lists: the 4x4 estimate (or None) and the (k, 2) associations."""

    a: str
    b: str
    method: str
    n_associations: int
    T_a_b: list[list[float]] | None
    associations: list[list[int]]


@dataclass
class AlignmentsFile:
    """What ``alignments.json`` holds: the evaluation's notes and every method's estimate for every pair."""

    notes: list[str]
    alignments: list[AlignmentRow]


#: Schema tag of ``alignments.json``.
ALIGNMENTS_SCHEMA = "roman_sim.alignments/2"


def write_alignments(path: str | Path, records: Sequence[AlignmentRecord], notes: list[str]) -> Path:
    """Atomically write ``alignments.json``."""
    return write_record(path, AlignmentsFile(list(notes), [r.row() for r in records]), ALIGNMENTS_SCHEMA)


def read_alignments(path: str | Path) -> tuple[list[AlignmentRecord], list[str]]:
    """``alignments.json``: the records and the notes (RecordError naming the file and the field)."""
    rec = read_record(path, AlignmentsFile, ALIGNMENTS_SCHEMA)
    return [AlignmentRecord.from_row(r) for r in rec.alignments], rec.notes


@dataclass
class MethodRuntimes:
    """One method's alignment time per pair (s): ``runtime_stats`` and, in a run's own file, every pair's."""

    n: int
    median: float | None
    mean: float | None
    p90: float | None
    per_pair_s: list[float] | None = field(default=None, metadata=OMIT_NONE)


@dataclass
class PairsTiming:
    """The evaluation's gating and alignment figures: pairs before and after gating, the gating's and
    the alignment's wall time (s), the workers and executor they ran on, and the aligners."""

    candidates: int
    aligned: int
    gating_s: float
    alignment_wall_s: float
    workers: int
    executor: str
    aligners: list[str]


@dataclass
class StageTimings:
    """One stage's wall-clock figures: time, peak memory, whether it was reused, and its own figures.

    Attributes:
        seconds: its wall time (None for a stage taken from the shared cache: not timed here).
        pairs: the evaluation's gating and alignment figures (candidates, wall time, executor).
        alignment: the evaluation's runtime per pair, per method.
        posegraph_s: the pose graph's solve time per graph.
    """

    reused: bool
    seconds: float | None = field(default=None, metadata=OMIT_NONE)
    peak_rss_mb: float | None = None
    pairs: PairsTiming | None = field(default=None, metadata=OMIT_NONE)
    alignment: dict[str, MethodRuntimes] | None = field(default=None, metadata=OMIT_NONE)
    posegraph_s: dict[str, float] | None = field(default=None, metadata=OMIT_NONE)


@dataclass
class RunTimings:
    """What ``timings.json`` holds: each stage's wall-clock figures (never part of the reproducible results)."""

    stages: dict[str, StageTimings] = field(default_factory=dict)

    def median_s(self, method: str) -> float | None:
        """Median alignment time per pair of ``method`` (s); None when unknown."""
        ev = self.stages.get("evaluation")
        per = None if ev is None or ev.alignment is None else ev.alignment.get(method)
        return None if per is None else per.median


def run_timings(stages: Mapping[str, Mapping[str, Any]], source: str = "timings") -> RunTimings:
    """Stage name -> its figures (as the stages report them) as checked ``RunTimings``.

    Raises:
        RecordError: a figure is unknown or of another type (names ``source`` and the field).
    """
    return from_json(RunTimings, {"stages": to_json(stages)}, source)


def write_timings(path: str | Path, timings: RunTimings) -> Path:
    """Atomically write ``timings.json``."""
    return write_record(path, timings)


def read_timings(path: str | Path) -> RunTimings:
    """``timings.json`` (RecordError naming the file and the field when it is not one)."""
    return read_record(path, RunTimings)
