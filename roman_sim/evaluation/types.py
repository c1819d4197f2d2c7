"""Typed results of the alignment evaluation, with ``to_json`` / ``from_json``.

``EvaluationMetrics`` is what ``metrics.json`` holds: per method the headline numbers
(``CurveStats``), the precision-recall curve, heading and ambiguity bins and per-kind
(inter-/intra-robot) numbers. Undefined values (no relevant pair, no positive) are None,
never 0, so that "could not be computed" is never read as "failed". Wall-clock runtimes
are not part of it (they differ between runs of the same seed; see ``timings.json``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError, StorageError

#: Schema tag of ``metrics.json``.
METRICS_SCHEMA = "roman_sim.metrics/2"


def nan_to_none(values: Any) -> Any:
    """Floats with NaN replaced by None (scalars or 1-D sequences)."""
    if np.ndim(values) == 0:
        v = float(values)
        return None if math.isnan(v) else v
    return [nan_to_none(v) for v in values]


def _none_to_nan(values: list[float | None]) -> NDArray[np.float64]:
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)


@dataclass(frozen=True)
class CurveStats:
    """Headline numbers of one method on a set of pairs.

    Attributes:
        n_pairs: pairs scored.
        n_relevant: pairs that should align.
        max_recall: best recall over the threshold sweep (None without relevant pairs).
        max_hits: true positives at that threshold (recall = max_hits / n_relevant).
        recall_at_precision_1: best recall among thresholds with precision 1 (0 if none).
        best_f1, best_f1_k: best F1 and its threshold (None when undefined).
        auc: area under precision over recall (None when undefined).
    """

    n_pairs: int
    n_relevant: int
    max_recall: float | None
    max_hits: int
    recall_at_precision_1: float | None
    best_f1: float | None
    best_f1_k: int | None
    auc: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "CurveStats":
        """Inverse of ``to_json``."""
        return cls(**{f.name: d[f.name] for f in fields(cls)})


@dataclass(frozen=True)
class BinStats:
    """``CurveStats`` of the pairs whose value lies in ``[lo, hi)`` (last bin closed)."""

    label: str
    lo: float
    hi: float
    stats: CurveStats

    def to_json(self) -> dict[str, Any]:
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

    def to_json(self) -> dict[str, Any]:
        """JSON-friendly lists; undefined values are ``None``."""
        return {
            "k": self.k.tolist(), "tp": self.tp.tolist(), "fp": self.fp.tolist(),
            "n_relevant": self.n_relevant, "precision": nan_to_none(self.precision),
            "recall": nan_to_none(self.recall), "f1": nan_to_none(self.f1),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "PRCurve":
        """Inverse of ``to_json``."""
        return cls(np.asarray(d["k"], dtype=np.int64), np.asarray(d["tp"], dtype=np.int64),
                   np.asarray(d["fp"], dtype=np.int64), int(d["n_relevant"]), _none_to_nan(d["precision"]),
                   _none_to_nan(d["recall"]), _none_to_nan(d["f1"]))


def _bins(rows: list[BinStats]) -> list[dict[str, Any]]:
    return [b.to_json() for b in rows]


def _bins_from(rows: list[dict[str, Any]]) -> list[BinStats]:
    return [BinStats.from_json(r) for r in rows]


@dataclass
class MethodMetrics:
    """Everything the evaluation says about one method.

    Attributes:
        overall: headline numbers over all scored pairs.
        pr_curve: precision/recall over the threshold sweep.
        heading_bins, heading_bins_fine: numbers per coarse / fine heading-difference bin.
        ambiguity_bins: numbers per place-ambiguity bin.
        n_ambiguity_unknown: pairs without an ambiguity value.
        by_kind: numbers of inter-robot (``inter``) and intra-robot (``intra``) pairs.
        n_failed: pairs on which the method produced no estimate.
    """

    overall: CurveStats
    pr_curve: PRCurve
    heading_bins: list[BinStats]
    heading_bins_fine: list[BinStats]
    ambiguity_bins: list[BinStats]
    n_ambiguity_unknown: int
    by_kind: dict[str, CurveStats]
    n_failed: int

    def bin(self, label: str) -> BinStats:
        """The coarse (else fine) heading bin ``label``; EvaluationError lists the known ones."""
        for b in self.heading_bins + self.heading_bins_fine:
            if b.label == label:
                return b
        labels = [b.label for b in self.heading_bins + self.heading_bins_fine]
        raise EvaluationError(f"heading bin {label!r} unknown (bins: {', '.join(labels)})")

    def to_json(self) -> dict[str, Any]:
        """JSON: the overall stats' fields at the top level, then curve, bins, kinds."""
        return {
            **self.overall.to_json(),
            "pr_curve": self.pr_curve.to_json(),
            "heading_bins": _bins(self.heading_bins),
            "heading_bins_fine": _bins(self.heading_bins_fine),
            "ambiguity_bins": _bins(self.ambiguity_bins),
            "n_ambiguity_unknown": self.n_ambiguity_unknown,
            "by_kind": {k: v.to_json() for k, v in self.by_kind.items()},
            "n_failed": self.n_failed,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "MethodMetrics":
        """Inverse of ``to_json``."""
        return cls(CurveStats.from_json(d), PRCurve.from_json(d["pr_curve"]), _bins_from(d["heading_bins"]),
                   _bins_from(d["heading_bins_fine"]), _bins_from(d["ambiguity_bins"]),
                   int(d["n_ambiguity_unknown"]), {k: CurveStats.from_json(v) for k, v in d["by_kind"].items()},
                   int(d["n_failed"]))


@dataclass
class EvaluationMetrics:
    """The evaluation of every method on every scored pair (what ``metrics.json`` holds).

    Attributes:
        config: the evaluation settings used (``EvalConfig`` as JSON).
        n_pairs, n_relevant: distinct pairs scored, and how many should align.
        methods: method label -> its metrics (sorted by label).
        notes: statements for the report (undefined figures and why).
        frontend: the front end's grades against truth (``FrontEndGrades.to_json()``), or
            None when the run did not map (saved submaps).
    """

    config: dict[str, Any]
    n_pairs: int
    n_relevant: int
    methods: dict[str, MethodMetrics]
    notes: list[str] = field(default_factory=list)
    frontend: dict[str, Any] | None = None

    def method(self, name: str) -> MethodMetrics:
        """The metrics of ``name``; EvaluationError lists the known methods."""
        if name not in self.methods:
            raise EvaluationError(f"method {name!r} not in this run (methods: {', '.join(self.methods) or 'none'})")
        return self.methods[name]

    def figure(self, method: str, heading_bin: str | None = None, key: str = "max_recall") -> Any:
        """One figure (a ``CurveStats`` field) of ``method`` overall or in a heading bin."""
        if key not in {f.name for f in fields(CurveStats)}:
            raise EvaluationError(f"figure {key!r} unknown (valid: {', '.join(f.name for f in fields(CurveStats))})")
        m = self.method(method)
        stats = m.overall if heading_bin is None else m.bin(heading_bin).stats
        return getattr(stats, key)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict with the schema tag."""
        return {"schema": METRICS_SCHEMA, "config": self.config, "n_pairs": self.n_pairs,
                "n_relevant": self.n_relevant, "methods": {k: v.to_json() for k, v in self.methods.items()},
                "notes": list(self.notes), "frontend": self.frontend}

    @classmethod
    def from_json(cls, d: Any, source: str = "metrics") -> "EvaluationMetrics":
        """Inverse of ``to_json``; StorageError names ``source`` when the data is not valid."""
        if not isinstance(d, dict) or d.get("schema") != METRICS_SCHEMA:
            found = d.get("schema") if isinstance(d, dict) else type(d).__name__
            raise StorageError(f"{source}: not a metrics file of schema {METRICS_SCHEMA} (found {found!r})")
        try:
            return cls(dict(d["config"]), int(d["n_pairs"]), int(d["n_relevant"]),
                       {k: MethodMetrics.from_json(v) for k, v in d["methods"].items()}, list(d.get("notes", [])),
                       d.get("frontend"))
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise StorageError(f"{source}: malformed metrics ({type(err).__name__}: {err})") from None


#: Schema tag of ``ate.json``.
ATE_SCHEMA = "roman_sim.ate/1"


@dataclass
class AteTable:
    """ATE RMSE (m) per pose-graph variant, alignment (``se3``, ``4dof``) and robot.

    ``variants[variant][alignment][robot]`` with robot ``"all"`` for the concatenated
    multi-robot trajectory; None where the error could not be computed.
    """

    variants: dict[str, dict[str, dict[str, float | None]]] = field(default_factory=dict)

    def rmse(self, variant: str, alignment: str = "se3", robot: str = "all") -> float | None:
        """One RMSE; EvaluationError names what is unknown."""
        if variant not in self.variants:
            raise EvaluationError(f"ATE variant {variant!r} unknown (variants: {', '.join(self.variants) or 'none'})")
        table = self.variants[variant]
        if alignment not in table:
            raise EvaluationError(f"ATE alignment {alignment!r} unknown (alignments: {', '.join(table)})")
        return table[alignment].get(robot)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"schema": ATE_SCHEMA, "variants": self.variants}

    @classmethod
    def from_json(cls, d: Any, source: str = "ate") -> "AteTable":
        """Inverse of ``to_json``."""
        if not isinstance(d, dict) or d.get("schema") != ATE_SCHEMA or not isinstance(d.get("variants"), dict):
            raise StorageError(f"{source}: not an ATE table of schema {ATE_SCHEMA}")
        return cls({str(v): {str(a): dict(r) for a, r in al.items()} for v, al in d["variants"].items()})


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
    keyframes_per_submap: float | None = None
    keyframe_kb_per_submap: float | None = None
    keyframe_kb_per_submap_max: float | None = None
    keyframe_mb_per_km: float | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (keyframe figures only when there are keyframes)."""
        d = asdict(self)
        return d if self.keyframes_per_submap is not None else {k: v for k, v in d.items()
                                                                if not k.startswith("keyframe")}

    @classmethod
    def from_json(cls, d: Any, source: str = "map statistics") -> "MapStats":
        """Inverse of ``to_json`` (files without keyframe figures are read with None)."""
        try:
            values: dict[str, Any] = {f.name: d[f.name] if f.name in d or not f.name.startswith("keyframe") else None
                                      for f in fields(cls)}
            return cls(**values)
        except (KeyError, TypeError) as err:
            raise StorageError(f"{source}: malformed map statistics ({err})") from None


@dataclass(frozen=True)
class AlignmentRecord:
    """What one method estimated for one pair (the input of the pose graph's closures).

    Attributes:
        a, b: submap names (``robot/index``).
        method: method label.
        n_associations: accepted associations.
        T_a_b: 4x4 estimate of b's frame in a's (rounded to 1e-9), or None.
    """

    a: str
    b: str
    method: str
    n_associations: int
    T_a_b: NDArray[np.float64] | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"a": self.a, "b": self.b, "method": self.method, "n_associations": self.n_associations,
                "T_a_b": None if self.T_a_b is None else np.round(self.T_a_b, 9).tolist()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "AlignmentRecord":
        """Inverse of ``to_json``."""
        T = d["T_a_b"]
        return cls(str(d["a"]), str(d["b"]), str(d["method"]), int(d["n_associations"]),
                   None if T is None else np.asarray(T, dtype=np.float64).reshape(4, 4))
