"""Typed results of the alignment evaluation: the records of ``metrics.json``.

``EvaluationMetrics`` is what ``metrics.json`` holds: per method and per pair set
(``inter``: cross-robot pairs, ``intra``: same-robot pairs; never mixed) the headline numbers
(``CurveStats``, each recall with its hits / relevant count and a Wilson interval, plus
association precision and recall against the true correspondences), the precision-recall
curve, and the heading and ambiguity bins. The ``headline`` pair set is ``inter`` when the
run has cross-robot pairs, else ``intra``. Undefined values (no relevant pair, no
positive) are None, never 0, so that "could not be computed" is never read as "failed".
Wall-clock runtimes are not part of it (they differ between runs of the same seed; see
``timings.json``). The file is these dataclasses as ``roman_sim.core.records`` writes them: the
overall figures of a pair set, a bin's figures and a method's pair sets sit at the level of
their parent (``INLINE``), as the file has always had them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.records import INLINE, OMIT_EMPTY, OMIT_NONE, via
from roman_sim.evaluation.atetable import ATE_SCHEMA, AteTable, VariantAte
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.grades import FrontEndGrades
from roman_sim.evaluation.intervals import Interval
from roman_sim.evaluation.operating_points import OperatingPoints
from roman_sim.evaluation.overlap import PairCounts, RevisitFigures
from roman_sim.evaluation.records import AlignmentRecord, MapStats

__all__ = [
    "ATE_SCHEMA",
    "METRICS_SCHEMA",
    "PAIR_SETS",
    "PAIR_SET_LABELS",
    "AlignmentRecord",
    "AteTable",
    "BinStats",
    "CurveStats",
    "EvaluationMetrics",
    "MapStats",
    "MethodMetrics",
    "PRCurve",
    "PairCounts",
    "PairSetMetrics",
    "RevisitFigures",
    "VariantAte",
    "nan_to_none",
]

#: Schema tag of ``metrics.json``.
METRICS_SCHEMA = "roman_sim.metrics/3"


def nan_to_none(values: Any) -> Any:
    """Floats with NaN replaced by None (scalars or 1-D sequences)."""
    if np.ndim(values) == 0:
        v = float(values)
        return None if math.isnan(v) else v
    return [nan_to_none(v) for v in values]


def _none_to_nan(values: list[float | None]) -> NDArray[np.float64]:
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)


def _ints(values: list[int]) -> NDArray[np.int64]:
    return np.asarray(values, dtype=np.int64)


#: An int array written as a list; a float array written with NaN as null (undefined values).
_INTS = via(list[int], lambda a: a.tolist(), _ints)
_RATES = via(list[float | None], nan_to_none, _none_to_nan)


#: The pair sets every method is scored on: cross-robot and same-robot (never mixed).
PAIR_SETS = ("inter", "intra")
#: How the pair sets are named in tables.
PAIR_SET_LABELS = {"inter": "cross-robot", "intra": "same-robot", "all": "all pairs"}


@dataclass(frozen=True)
class CurveStats:
    """Headline numbers of one method on a set of pairs.

    Attributes:
        n_pairs: pairs scored.
        n_relevant: pairs that should align.
        max_recall: best recall over the threshold sweep (None without relevant pairs).
        max_hits: true positives at that threshold (recall = max_hits / n_relevant).
        max_recall_k: smallest threshold k reaching it (None without relevant pairs).
        recall_ci: Wilson interval of max_hits / n_relevant (None without relevant pairs).
        few: fewer relevant pairs than ``EvalConfig.min_relevant``: not a measured recall.
        recall_at_precision_1: best recall among thresholds with precision 1 (0 if none).
        hits_at_precision_1, recall_at_precision_1_ci: its hits and Wilson interval.
        best_f1, best_f1_k: best F1 and its threshold (None when undefined).
        auc: area under precision over recall (None when undefined).
        assoc_selected: associations the method selected on these pairs.
        assoc_correct: of those, true correspondences (same majority object).
        assoc_available: true correspondences available (one-to-one) on these pairs.
        assoc_recovered: true correspondences recovered one-to-one.
        assoc_precision, assoc_precision_ci: correct / selected and its Wilson interval.
        assoc_recall, assoc_recall_ci: recovered / available and its Wilson interval (the
            intervals treat associations as independent; they cluster by pair, so they
            understate the uncertainty).
        operating_points: recall and precision at max recall, at precision >= 0.9 and 1, and
            at the pose graph's acceptance threshold (``operating_points.POINT_NAMES``; empty
            when read from a file written before they existed).
    """

    n_pairs: int
    n_relevant: int
    max_recall: float | None
    max_hits: int
    max_recall_k: int | None
    recall_ci: Interval
    few: bool
    recall_at_precision_1: float | None
    hits_at_precision_1: int
    recall_at_precision_1_ci: Interval
    best_f1: float | None
    best_f1_k: int | None
    auc: float | None
    assoc_selected: int = 0
    assoc_correct: int = 0
    assoc_available: int = 0
    assoc_recovered: int = 0
    assoc_precision: float | None = None
    assoc_precision_ci: Interval = None
    assoc_recall: float | None = None
    assoc_recall_ci: Interval = None
    operating_points: OperatingPoints = field(default_factory=dict, metadata=OMIT_EMPTY)


@dataclass(frozen=True)
class BinStats:
    """``CurveStats`` of the pairs whose value lies in ``[lo, hi)`` (last bin closed)."""

    label: str
    lo: float
    hi: float
    stats: CurveStats = field(metadata=INLINE)


@dataclass
class PRCurve:
    """Precision/recall of one method over association thresholds ``k`` (arrays of len(k))."""

    k: NDArray[np.int64] = field(metadata=_INTS)
    tp: NDArray[np.int64] = field(metadata=_INTS)
    fp: NDArray[np.int64] = field(metadata=_INTS)
    n_relevant: int
    precision: NDArray[np.float64] = field(metadata=_RATES)
    recall: NDArray[np.float64] = field(metadata=_RATES)
    f1: NDArray[np.float64] = field(metadata=_RATES)


@dataclass
class PairSetMetrics:
    """What the evaluation says about one method on one set of pairs (e.g. cross-robot).

    Attributes:
        overall: headline numbers over the set.
        pr_curve: precision/recall over the threshold sweep.
        heading_bins, heading_bins_fine: numbers per coarse / fine heading-difference bin.
        heading_pr: precision/recall curve of each coarse heading bin (same order).
        ambiguity_bins: numbers per place-ambiguity bin.
        n_ambiguity_unknown: pairs without an ambiguity value.
    """

    overall: CurveStats = field(metadata=INLINE)
    pr_curve: PRCurve
    heading_bins: list[BinStats]
    heading_bins_fine: list[BinStats]
    heading_pr: list[PRCurve]
    ambiguity_bins: list[BinStats]
    n_ambiguity_unknown: int

    def bin(self, label: str) -> BinStats:
        """The coarse (else fine) heading bin ``label``; EvaluationError lists the known ones."""
        for b in self.heading_bins + self.heading_bins_fine:
            if b.label == label:
                return b
        labels = [b.label for b in self.heading_bins + self.heading_bins_fine]
        raise EvaluationError(f"heading bin {label!r} unknown (bins: {', '.join(labels)})")


@dataclass
class MethodMetrics:
    """Everything the evaluation says about one method.

    Attributes:
        sets: pair set (``inter``, ``intra``) -> its metrics.
        n_failed: pairs on which the method produced no estimate.
    """

    sets: dict[str, PairSetMetrics] = field(metadata=INLINE)
    n_failed: int

    def set(self, kind: str) -> PairSetMetrics:
        """The metrics of pair set ``kind``; EvaluationError lists the known sets."""
        if kind not in self.sets:
            raise EvaluationError(f"pair set {kind!r} unknown (sets: {', '.join(self.sets)})")
        return self.sets[kind]


@dataclass
class EvaluationMetrics:
    """The evaluation of every method on every scored pair (what ``metrics.json`` holds).

    Attributes:
        config: the evaluation settings used.
        headline: the pair set headline figures refer to (``inter`` when there are
            cross-robot pairs, else ``intra``).
        n_pairs, n_relevant: distinct pairs scored, and how many should align.
        pairs: per pair set and ``all``, its pair counts.
        n_candidates, n_skipped: pairs before the distance cap, and how many it skipped.
        methods: method label -> its metrics (sorted by label).
        notes: statements for the report (undefined figures and why).
        frontend: the front end's grades against truth, or None when the run did not map
            (saved submaps).
        acceptance_k: the pose graph's acceptance threshold the ``acceptance`` operating
            points use (None: not given, no acceptance point).
        robot_pairs: cross-robot pairs scored and relevant per robot pair (``"a|b"``,
            ``overlap.robot_pair_counts``); None in files written before it was recorded.
        revisits: median overlap and shared objects of the relevant cross-robot pairs,
            overall (``"all"``) and per robot pair (``overlap.revisit_figures``); None in files
            written before it was recorded.
    """

    config: EvalConfig
    headline: str
    n_pairs: int
    n_relevant: int
    pairs: dict[str, PairCounts]
    n_candidates: int
    n_skipped: int
    methods: dict[str, MethodMetrics]
    notes: list[str] = field(default_factory=list)
    frontend: FrontEndGrades | None = field(default=None, metadata=OMIT_NONE)
    acceptance_k: int | None = None
    robot_pairs: dict[str, PairCounts] | None = field(default=None, metadata=OMIT_NONE)
    revisits: dict[str, RevisitFigures] | None = field(default=None, metadata=OMIT_NONE)

    def method(self, name: str) -> MethodMetrics:
        """The metrics of ``name``; EvaluationError lists the known methods."""
        if name not in self.methods:
            raise EvaluationError(f"method {name!r} not in this run (methods: {', '.join(self.methods) or 'none'})")
        return self.methods[name]

    def stats(self, method: str, heading_bin: str | None = None, kind: str | None = None) -> CurveStats:
        """``CurveStats`` of ``method`` on pair set ``kind`` (default: the headline), overall or in a bin."""
        m = self.method(method).set(kind or self.headline)
        return m.overall if heading_bin is None else m.bin(heading_bin).stats

    def figure(
        self, method: str, heading_bin: str | None = None, key: str = "max_recall", kind: str | None = None
    ) -> Any:
        """One figure (a ``CurveStats`` field) of ``method`` overall or in a heading bin.

        ``kind`` is the pair set (``inter``, ``intra``); default the headline set.
        """
        if key not in {f.name for f in fields(CurveStats)}:
            raise EvaluationError(f"figure {key!r} unknown (valid: {', '.join(f.name for f in fields(CurveStats))})")
        return getattr(self.stats(method, heading_bin, kind), key)
