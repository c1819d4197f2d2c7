"""Compact views of a run's results for tables, sweeps, the reference summary and regression tests.

``summarize_run`` gives a ``RunSummary``, the record ``summary.json`` holds per run
(``roman_sim.core.records``), so the reference tables and claims work on the dataclass whether
the summary was just computed or read from the committed file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from roman_sim.core.errors import StorageError
from roman_sim.core.records import NONE_AS_EMPTY, OMIT_NONE
from roman_sim.evaluation.atetable import ALL, COMMON, AteTable
from roman_sim.evaluation.grades import CosineStats, FrontEndGrades
from roman_sim.evaluation.operating_points import POINT_NAMES, OperatingPoint, PointName
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics, MapStats, PairCounts, RevisitFigures


@dataclass(frozen=True)
class RecallSummary:
    """A recall with its hits / relevant count, Wilson interval and small-set flag, and its operating points.

    ``points`` maps the names of ``operating_points.POINT_NAMES`` to the points (max recall with
    its precision, recall at precision >= 0.9 and 1, recall at the acceptance threshold when the
    run had one); it is empty for a summary written before the points were recorded.
    """

    max_recall: float | None
    max_hits: int
    n_relevant: int
    recall_ci: tuple[float, float] | None
    few: bool
    points: dict[PointName, OperatingPoint] = field(default_factory=dict)

    @classmethod
    def of(cls, s: CurveStats) -> RecallSummary:
        """The recall figures and operating points of ``s``."""
        ci = None if s.recall_ci is None else (s.recall_ci[0], s.recall_ci[1])
        return cls(s.max_recall, s.max_hits, s.n_relevant, ci, s.few, _present(s))


def _present(s: CurveStats) -> dict[PointName, OperatingPoint]:
    """The operating points ``s`` has, in table order (acceptance only when the run had a threshold)."""
    return {n: p for n in POINT_NAMES if (p := s.operating_points.get(n)) is not None}


@dataclass(frozen=True)
class SetSummary(RecallSummary):
    """One method on one pair set (cross-robot or same-robot): recall, precision-1 recall, F1, AUC,
    association precision / recall and the coarse heading bins."""

    n_pairs: int = 0
    recall_at_precision_1: float | None = None
    hits_at_precision_1: int = 0
    best_f1: float | None = None
    auc: float | None = None
    assoc_precision: float | None = None
    assoc_recall: float | None = None
    bins: dict[str, RecallSummary] = field(default_factory=dict)

    def recall(self) -> RecallSummary:
        """The recall figures alone (without the set's other figures and bins)."""
        return RecallSummary(self.max_recall, self.max_hits, self.n_relevant, self.recall_ci, self.few, self.points)


def _set(metrics: EvaluationMetrics, method: str, kind: str) -> SetSummary:
    ps = metrics.method(method).set(kind)
    o = ps.overall
    r = RecallSummary.of(o)
    return SetSummary(
        r.max_recall,
        r.max_hits,
        r.n_relevant,
        r.recall_ci,
        r.few,
        r.points,
        n_pairs=o.n_pairs,
        recall_at_precision_1=o.recall_at_precision_1,
        hits_at_precision_1=o.hits_at_precision_1,
        best_f1=o.best_f1,
        auc=o.auc,
        assoc_precision=o.assoc_precision,
        assoc_recall=o.assoc_recall,
        bins={b.label: RecallSummary.of(b.stats) for b in ps.heading_bins},
    )


@dataclass(frozen=True)
class MethodSummary:
    """One method: its cross-robot and same-robot figures and its median runtime per pair (s)."""

    inter: SetSummary
    intra: SetSummary
    runtime_median_s: float | None = None

    def set(self, kind: str) -> SetSummary:
        """The figures of pair set ``kind`` (``inter`` or ``intra``)."""
        if kind not in ("inter", "intra"):
            raise StorageError(f"pair set {kind!r} unknown (valid: inter, intra)")
        return self.inter if kind == "inter" else self.intra


@dataclass(frozen=True)
class AteSummary:
    """One ATE row: robots placed and the SE(3) ATE RMSE (m) over the common robots and over all."""

    connected: int
    common: float | None
    all: float | None


@dataclass(frozen=True)
class AteRobots:
    """The robots of an ATE table: every robot, and those every variant placed."""

    robots: list[str]
    common: list[str]


@dataclass(frozen=True)
class FrontEndSummary:
    """The front end's grades in short (see ``frontend_summary``)."""

    segmenter: str
    encoder: str | None
    frames: int
    objects: int
    masks: int
    precision: float | None
    recall: float | None
    mean_iou: float | None
    over_segmented: int
    under_segmented: int
    spurious: int
    cosine_same_instance: float | None
    cosine_same_family: float | None
    cosine_other_family: float | None


def _weighted_mean(classes: Mapping[str, CosineStats], names: tuple[str, ...]) -> float | None:
    """Pair-weighted mean cosine of the descriptor classes ``names`` (None without pairs)."""
    got = [(c.pairs, c.mean) for n in names if (c := classes.get(n)) is not None and c.pairs and c.mean is not None]
    total = sum(n for n, _ in got)
    return sum(n * m for n, m in got) / total if total else None


def frontend_summary(grades: FrontEndGrades | None) -> FrontEndSummary | None:
    """The front end's grades in short (None when not graded).

    Segmentation precision, recall, mean IoU, over- / under-segmented and spurious counts over
    the graded frames; descriptor cosine means for the same instance, the same family and other
    families (pairs of the same group and of other groups, weighted by their pair counts).
    """
    if grades is None:
        return None
    s = grades.segmentation
    classes = {} if grades.descriptors is None else grades.descriptors.classes
    counts = (s.frames, s.objects, s.masks, s.precision, s.recall, s.mean_iou)
    errors = (s.over_segmented, s.under_segmented, s.spurious)
    groups = (("same_instance",), ("same_family",), ("same_group", "other_group"))
    cosines = (_weighted_mean(classes, g) for g in groups)
    return FrontEndSummary(grades.segmenter, grades.encoder, *counts, *errors, *cosines)


@dataclass(frozen=True)
class RunSummary:
    """A run in short (see ``summarize_run``): its entry in ``summary.json``.

    Attributes:
        headline: the headline pair set (``inter`` or ``intra``).
        pairs: per pair set and ``all``, its pair counts (``metrics.json``'s ``pairs``).
        n_skipped: pairs a distance cap skipped.
        methods: per method, its figures.
        ate: per ATE variant, robots placed and SE(3) ATE (empty without a pose graph).
        ate_robots: every robot and the common robots of the ATE table (None without one;
            written as ``{}``).
        map: map and packet sizes (None when not given; written as ``{}``).
        frontend: the front end's grades (None when the run did not grade it).
        revisits: what the relevant cross-robot pairs share: ``n_relevant``,
            ``median_overlap`` and ``median_shared_objects`` (None without cross-robot pairs
            or in a summary written before it was recorded).
    """

    headline: str
    pairs: dict[str, PairCounts]
    n_skipped: int
    methods: dict[str, MethodSummary] = field(default_factory=dict)
    ate: dict[str, AteSummary] = field(default_factory=dict)
    ate_robots: AteRobots | None = field(default=None, metadata=NONE_AS_EMPTY)
    map: MapStats | None = field(default=None, metadata=NONE_AS_EMPTY)
    frontend: FrontEndSummary | None = None
    revisits: RevisitFigures | None = field(default=None, metadata=OMIT_NONE)


def summarize_run(
    metrics: EvaluationMetrics,
    ate: AteTable | None,
    map_stats: MapStats | None,
    runtimes: Mapping[str, float | None] | None = None,
) -> RunSummary:
    """A run in short.

    ``methods[name]`` holds, per pair set (``inter`` cross-robot, ``intra`` same-robot),
    the max recall with its hits / relevant count, Wilson interval and small-set flag, the
    operating points (``RecallSummary.points``, also per heading bin), recall
    at precision 1, F1, AUC, association precision / recall and the coarse heading bins; plus
    the median runtime when given. ``ate[variant]`` holds the robots it placed and the SE(3)
    ATE over the common robots and over all robots; ``map`` the map size; ``frontend`` the
    front end's grades against truth when the run graded it (``frontend_summary``). Undefined
    values are None.
    """
    methods = {
        name: MethodSummary(_set(metrics, name, "inter"), _set(metrics, name, "intra"), (runtimes or {}).get(name))
        for name in metrics.methods
    }
    rows: dict[str, AteSummary] = {}
    robots = None
    if ate is not None and ate.variants:
        robots = AteRobots(list(ate.robots), list(ate.common))
        rows = {
            variant: AteSummary(len(row.connected), ate.rmse(variant, "se3", COMMON), ate.rmse(variant, "se3", ALL))
            for variant, row in ate.variants.items()
        }
    return RunSummary(
        metrics.headline,
        metrics.pairs,
        metrics.n_skipped,
        methods,
        rows,
        robots,
        map_stats,
        frontend_summary(metrics.frontend),
        None if not metrics.revisits else metrics.revisits["all"],
    )
