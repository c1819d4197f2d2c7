"""Typed results of the alignment evaluation, with ``to_json`` / ``from_json``.

``EvaluationMetrics`` is what ``metrics.json`` holds: per method and per pair set
(``inter``: cross-robot pairs, ``intra``: same-robot pairs; never mixed) the headline numbers
(``CurveStats``, each recall with its hits / relevant count and a Wilson interval, plus
association precision and recall against the true correspondences), the precision-recall
curve, and the heading and ambiguity bins. The ``headline`` pair set is ``inter`` when the
run has cross-robot pairs, else ``intra``. Undefined values (no relevant pair, no
positive) are None, never 0, so that "could not be computed" is never read as "failed".
Wall-clock runtimes are not part of it (they differ between runs of the same seed; see
``timings.json``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.evaluation.atetable import ATE_SCHEMA, AteTable, VariantAte
from roman_sim.evaluation.intervals import Interval, interval_from_json
from roman_sim.evaluation.operating_points import OperatingPoints, points_from_json, points_to_json
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
    "PairSetMetrics",
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


def _robot_pairs(d: Any) -> dict[str, dict[str, int]] | None:
    if d is None:
        return None
    return {str(k): {str(a): int(b) for a, b in v.items()} for k, v in d.items()}


def revisit_figure(v: Any, to_int: Callable[[Any], int] = int) -> dict[str, float | int | None]:
    """One ``revisits`` entry (``n_relevant``, ``median_overlap``, ``median_shared_objects``) read
    from JSON (KeyError, TypeError or ValueError when malformed); ``to_int`` reads the count."""
    ov, sh = v["median_overlap"], v["median_shared_objects"]
    return {
        "n_relevant": to_int(v["n_relevant"]),
        "median_overlap": None if ov is None else float(ov),
        "median_shared_objects": None if sh is None else float(sh),
    }


def _revisits(d: Any) -> dict[str, dict[str, float | int | None]] | None:
    return None if d is None else {str(k): revisit_figure(v) for k, v in d.items()}


def _none_to_nan(values: list[float | None]) -> NDArray[np.float64]:
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)


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
    operating_points: OperatingPoints = field(default_factory=dict)

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (intervals as [low, high] lists; operating points only when computed)."""
        out: dict[str, JSONLike] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name != "operating_points":
                out[f.name] = list(v) if isinstance(v, tuple) else v
        if self.operating_points:
            out["operating_points"] = points_to_json(self.operating_points)
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "CurveStats":
        """Inverse of ``to_json``."""
        values: dict[str, Any] = {
            f.name: (interval_from_json(d[f.name]) if f.name.endswith("_ci") else d[f.name])
            for f in fields(cls)
            if f.name != "operating_points"
        }
        return cls(**values, operating_points=points_from_json(d.get("operating_points")))


@dataclass(frozen=True)
class BinStats:
    """``CurveStats`` of the pairs whose value lies in ``[lo, hi)`` (last bin closed)."""

    label: str
    lo: float
    hi: float
    stats: CurveStats

    def to_json(self) -> dict[str, JSONLike]:
        """Flat JSON: ``label``, ``lo``, ``hi`` and the stats' fields."""
        return {"label": self.label, "lo": self.lo, "hi": self.hi, **self.stats.to_json()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "BinStats":
        """Inverse of ``to_json``."""
        return cls(str(d["label"]), float(d["lo"]), float(d["hi"]), CurveStats.from_json(d))


@dataclass
class PRCurve:
    """Precision/recall of one method over association thresholds ``k`` (arrays of len(k))."""

    k: NDArray[np.int64]
    tp: NDArray[np.int64]
    fp: NDArray[np.int64]
    n_relevant: int
    precision: NDArray[np.float64]
    recall: NDArray[np.float64]
    f1: NDArray[np.float64]

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-friendly lists; undefined values are ``None``."""
        return {
            "k": self.k.tolist(),
            "tp": self.tp.tolist(),
            "fp": self.fp.tolist(),
            "n_relevant": self.n_relevant,
            "precision": nan_to_none(self.precision),
            "recall": nan_to_none(self.recall),
            "f1": nan_to_none(self.f1),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "PRCurve":
        """Inverse of ``to_json``."""
        return cls(
            np.asarray(d["k"], dtype=np.int64),
            np.asarray(d["tp"], dtype=np.int64),
            np.asarray(d["fp"], dtype=np.int64),
            int(d["n_relevant"]),
            _none_to_nan(d["precision"]),
            _none_to_nan(d["recall"]),
            _none_to_nan(d["f1"]),
        )


def _bins(rows: list[BinStats]) -> list[dict[str, JSONLike]]:
    return [b.to_json() for b in rows]


def _bins_from(rows: list[dict[str, Any]]) -> list[BinStats]:
    return [BinStats.from_json(r) for r in rows]


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

    overall: CurveStats
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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON: the overall stats' fields at the top level, then curve and bins."""
        return {
            **self.overall.to_json(),
            "pr_curve": self.pr_curve.to_json(),
            "heading_bins": _bins(self.heading_bins),
            "heading_bins_fine": _bins(self.heading_bins_fine),
            "heading_pr": [c.to_json() for c in self.heading_pr],
            "ambiguity_bins": _bins(self.ambiguity_bins),
            "n_ambiguity_unknown": self.n_ambiguity_unknown,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "PairSetMetrics":
        """Inverse of ``to_json``."""
        return cls(
            CurveStats.from_json(d),
            PRCurve.from_json(d["pr_curve"]),
            _bins_from(d["heading_bins"]),
            _bins_from(d["heading_bins_fine"]),
            [PRCurve.from_json(c) for c in d["heading_pr"]],
            _bins_from(d["ambiguity_bins"]),
            int(d["n_ambiguity_unknown"]),
        )


@dataclass
class MethodMetrics:
    """Everything the evaluation says about one method.

    Attributes:
        sets: pair set (``inter``, ``intra``) -> its metrics.
        n_failed: pairs on which the method produced no estimate.
    """

    sets: dict[str, PairSetMetrics]
    n_failed: int

    def set(self, kind: str) -> PairSetMetrics:
        """The metrics of pair set ``kind``; EvaluationError lists the known sets."""
        if kind not in self.sets:
            raise EvaluationError(f"pair set {kind!r} unknown (sets: {', '.join(self.sets)})")
        return self.sets[kind]

    def to_json(self) -> dict[str, JSONLike]:
        """JSON: ``n_failed`` and one object per pair set."""
        return {"n_failed": self.n_failed, **{k: v.to_json() for k, v in self.sets.items()}}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "MethodMetrics":
        """Inverse of ``to_json``."""
        return cls({k: PairSetMetrics.from_json(d[k]) for k in PAIR_SETS if k in d}, int(d["n_failed"]))


@dataclass
class EvaluationMetrics:
    """The evaluation of every method on every scored pair (what ``metrics.json`` holds).

    Attributes:
        config: the evaluation settings used (``EvalConfig`` as JSON).
        headline: the pair set headline figures refer to (``inter`` when there are
            cross-robot pairs, else ``intra``).
        n_pairs, n_relevant: distinct pairs scored, and how many should align.
        pairs: per pair set and ``all``, ``{"n_pairs": .., "n_relevant": ..}``.
        n_candidates, n_skipped: pairs before the distance cap, and how many it skipped.
        methods: method label -> its metrics (sorted by label).
        notes: statements for the report (undefined figures and why).
        frontend: the front end's grades against truth (``FrontEndGrades.to_json()``), or
            None when the run did not map (saved submaps).
        acceptance_k: the pose graph's acceptance threshold the ``acceptance`` operating
            points use (None: not given, no acceptance point).
        robot_pairs: cross-robot pairs scored and relevant per robot pair (``"a|b"`` ->
            ``{"n_pairs": .., "n_relevant": ..}``, ``overlap.robot_pair_counts``); None in files
            written before it was recorded.
        revisits: median overlap and shared objects of the relevant cross-robot pairs,
            overall (``"all"``) and per robot pair (``overlap.revisit_figures``); None in files
            written before it was recorded.
    """

    config: dict[str, Any]
    headline: str
    n_pairs: int
    n_relevant: int
    pairs: dict[str, dict[str, int]]
    n_candidates: int
    n_skipped: int
    methods: dict[str, MethodMetrics]
    notes: list[str] = field(default_factory=list)
    frontend: dict[str, JSONLike] | None = None
    acceptance_k: int | None = None
    robot_pairs: dict[str, dict[str, int]] | None = None
    revisits: dict[str, dict[str, float | int | None]] | None = None

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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict with the schema tag (``frontend`` only when the run graded its front end)."""
        return {
            "schema": METRICS_SCHEMA,
            "config": self.config,
            "headline": self.headline,
            "n_pairs": self.n_pairs,
            "n_relevant": self.n_relevant,
            "pairs": self.pairs,
            "n_candidates": self.n_candidates,
            "n_skipped": self.n_skipped,
            "methods": {k: v.to_json() for k, v in self.methods.items()},
            "notes": list(self.notes),
            **({} if self.frontend is None else {"frontend": self.frontend}),
            "acceptance_k": self.acceptance_k,
            **({} if self.robot_pairs is None else {"robot_pairs": self.robot_pairs}),
            **({} if self.revisits is None else {"revisits": self.revisits}),
        }

    @classmethod
    def from_json(cls, d: object, source: str = "metrics") -> "EvaluationMetrics":
        """Inverse of ``to_json``; StorageError names ``source`` when the data is not valid."""
        if not isinstance(d, dict) or d.get("schema") != METRICS_SCHEMA:
            found = d.get("schema") if isinstance(d, dict) else type(d).__name__
            raise StorageError(f"{source}: not a metrics file of schema {METRICS_SCHEMA} (found {found!r})")
        try:
            return cls(
                dict(d["config"]),
                str(d["headline"]),
                int(d["n_pairs"]),
                int(d["n_relevant"]),
                {str(k): {str(a): int(b) for a, b in v.items()} for k, v in d["pairs"].items()},
                int(d["n_candidates"]),
                int(d["n_skipped"]),
                {k: MethodMetrics.from_json(v) for k, v in d["methods"].items()},
                list(d.get("notes", [])),
                d.get("frontend"),
                None if d.get("acceptance_k") is None else int(d["acceptance_k"]),
                _robot_pairs(d.get("robot_pairs")),
                _revisits(d.get("revisits")),
            )
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise StorageError(f"{source}: malformed metrics ({type(err).__name__}: {err})") from None
