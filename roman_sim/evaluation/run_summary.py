"""Compact views of a run's results for tables, sweeps, the reference summary and regression tests.

``summarize_run`` gives a ``RunSummary``; its ``to_json()`` is what ``summary.json`` holds
per run (``from_json`` reads it back, so the reference tables and claims work on the
dataclass whether the summary was just computed or read from the committed file).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.evaluation.atetable import ALL, COMMON, AteTable
from roman_sim.evaluation.operating_points import POINT_NAMES, OperatingPoint
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics, MapStats, revisit_figure


def _f(v: JSONLike) -> float | None:
    """A number or None, unchanged (an int stays an int, so the JSON written back is the same)."""
    if v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)):
        return v
    raise ValueError(f"expected a number, got {v!r}")


def _i(v: JSONLike) -> int:
    if isinstance(v, int) and not isinstance(v, bool):
        return v
    raise ValueError(f"expected an integer, got {v!r}")


def _pair(v: JSONLike) -> tuple[float, float] | None:
    if v is None:
        return None
    if isinstance(v, (list, tuple)) and len(v) == 2:
        lo, hi = _f(v[0]), _f(v[1])
        if lo is not None and hi is not None:
            return lo, hi
    raise ValueError(f"expected an interval [lo, hi], got {v!r}")


def _obj(v: JSONLike, what: str) -> Mapping[str, JSONLike]:
    if not isinstance(v, Mapping):
        raise StorageError(f"run summary: {what} is not an object")
    return v


def _points(v: JSONLike) -> dict[str, OperatingPoint]:
    """Operating points read back from JSON (absent, from a summary written before them: empty)."""
    if v is None:
        return {}
    o = _obj(v, "operating points")
    out = {}
    for name, p in o.items():
        if name not in POINT_NAMES:
            raise ValueError(f"unknown operating point {name!r}")
        d = _obj(p, f"operating point {name}")
        out[name] = OperatingPoint(
            None if d["k"] is None else _i(d["k"]),
            bool(d["reached"]),
            _i(d["hits"]),
            _i(d["n_relevant"]),
            _i(d["false_positives"]),
            _f(d["recall"]),
            _pair(d["recall_ci"]),
            _f(d["precision"]),
            _pair(d["precision_ci"]),
        )
    return out


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
    points: dict[str, OperatingPoint] = field(default_factory=dict)

    @classmethod
    def of(cls, s: CurveStats) -> RecallSummary:
        """The recall figures and operating points of ``s``."""
        ci = None if s.recall_ci is None else (s.recall_ci[0], s.recall_ci[1])
        return cls(s.max_recall, s.max_hits, s.n_relevant, ci, s.few, _present(s))

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (``points`` in table order)."""
        return {
            "max_recall": self.max_recall,
            "max_hits": self.max_hits,
            "n_relevant": self.n_relevant,
            "recall_ci": None if self.recall_ci is None else list(self.recall_ci),
            "few": self.few,
            "points": {n: self.points[n].to_json() for n in POINT_NAMES if n in self.points},
        }

    @staticmethod
    def _fields(
        d: Mapping[str, JSONLike],
    ) -> tuple[float | None, int, int, tuple[float, float] | None, bool, dict[str, OperatingPoint]]:
        return (
            _f(d["max_recall"]),
            _i(d["max_hits"]),
            _i(d["n_relevant"]),
            _pair(d["recall_ci"]),
            bool(d["few"]),
            _points(d.get("points")),
        )

    @classmethod
    def from_json(cls, d: JSONLike) -> RecallSummary:
        """Inverse of ``to_json`` (a summary without ``points`` reads with none)."""
        return cls(*cls._fields(_obj(d, "recall")))


def _present(s: CurveStats) -> dict[str, OperatingPoint]:
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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return {
            **super().to_json(),
            "n_pairs": self.n_pairs,
            "recall_at_precision_1": self.recall_at_precision_1,
            "hits_at_precision_1": self.hits_at_precision_1,
            "best_f1": self.best_f1,
            "auc": self.auc,
            "assoc_precision": self.assoc_precision,
            "assoc_recall": self.assoc_recall,
            "bins": {k: b.to_json() for k, b in self.bins.items()},
        }

    @classmethod
    def from_json(cls, d: JSONLike) -> SetSummary:
        """Inverse of ``to_json``."""
        o = _obj(d, "pair set")
        return cls(
            *cls._fields(o),
            n_pairs=_i(o["n_pairs"]),
            recall_at_precision_1=_f(o["recall_at_precision_1"]),
            hits_at_precision_1=_i(o["hits_at_precision_1"]),
            best_f1=_f(o["best_f1"]),
            auc=_f(o["auc"]),
            assoc_precision=_f(o["assoc_precision"]),
            assoc_recall=_f(o["assoc_recall"]),
            bins={k: RecallSummary.from_json(b) for k, b in _obj(o["bins"], "bins").items()},
        )


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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return {"inter": self.inter.to_json(), "intra": self.intra.to_json(), "runtime_median_s": self.runtime_median_s}

    @classmethod
    def from_json(cls, d: JSONLike) -> MethodSummary:
        """Inverse of ``to_json``."""
        o = _obj(d, "method")
        return cls(SetSummary.from_json(o["inter"]), SetSummary.from_json(o["intra"]), _f(o["runtime_median_s"]))


@dataclass(frozen=True)
class AteSummary:
    """One ATE row: robots placed and the SE(3) ATE RMSE (m) over the common robots and over all."""

    connected: int
    common: float | None
    all: float | None

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return {"connected": self.connected, "common": self.common, "all": self.all}

    @classmethod
    def from_json(cls, d: JSONLike) -> AteSummary:
        """Inverse of ``to_json``."""
        o = _obj(d, "ATE row")
        return cls(_i(o["connected"]), _f(o["common"]), _f(o["all"]))


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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (field order)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    @classmethod
    def from_json(cls, d: JSONLike) -> FrontEndSummary:
        """Inverse of ``to_json``."""
        o = _obj(d, "front end")
        return cls(
            str(o["segmenter"]),
            None if o["encoder"] is None else str(o["encoder"]),
            *(_i(o[k]) for k in ("frames", "objects", "masks")),
            *(_f(o[k]) for k in ("precision", "recall", "mean_iou")),
            *(_i(o[k]) for k in ("over_segmented", "under_segmented", "spurious")),
            *(_f(o[k]) for k in ("cosine_same_instance", "cosine_same_family", "cosine_other_family")),
        )


def _weighted_mean(classes: Mapping[str, JSONLike], names: tuple[str, ...]) -> float | None:
    """Pair-weighted mean cosine of the descriptor classes ``names`` (None without pairs)."""
    got = []
    for n in names:
        c = classes.get(n)
        if isinstance(c, Mapping) and c["pairs"]:
            pairs, mean = _f(c["pairs"]), _f(c["mean"])
            if pairs is not None and mean is not None:
                got.append((pairs, mean))
    total = sum(n for n, _ in got)
    return sum(n * m for n, m in got) / total if total else None


def frontend_summary(grades: Mapping[str, JSONLike] | None) -> FrontEndSummary | None:
    """The front end's grades in short (from metrics.json's ``frontend`` section; None when not graded).

    Segmentation precision, recall, mean IoU, over- / under-segmented and spurious counts over
    the graded frames; descriptor cosine means for the same instance, the same family and other
    families (pairs of the same group and of other groups, weighted by their pair counts).
    """
    if not grades:
        return None
    s = _obj(grades["segmentation"], "segmentation")
    descriptors = grades.get("descriptors")
    classes = descriptors.get("classes") if isinstance(descriptors, Mapping) else None
    cls: Mapping[str, JSONLike] = classes if isinstance(classes, Mapping) else {}
    encoder = grades.get("encoder")
    return FrontEndSummary(
        segmenter=str(grades["segmenter"]),
        encoder=None if encoder is None else str(encoder),
        frames=_i(s["frames"]),
        objects=_i(s["objects"]),
        masks=_i(s["masks"]),
        precision=_f(s.get("precision")),
        recall=_f(s.get("recall")),
        mean_iou=_f(s.get("mean_iou")),
        over_segmented=_i(s["over_segmented"]),
        under_segmented=_i(s["under_segmented"]),
        spurious=_i(s["spurious"]),
        cosine_same_instance=_weighted_mean(cls, ("same_instance",)),
        cosine_same_family=_weighted_mean(cls, ("same_family",)),
        cosine_other_family=_weighted_mean(cls, ("same_group", "other_group")),
    )


@dataclass(frozen=True)
class RunSummary:
    """A run in short (see ``summarize_run``); ``to_json()`` is its entry in ``summary.json``.

    Attributes:
        headline: the headline pair set (``inter`` or ``intra``).
        pairs: per pair set and ``all``, its pair counts (``metrics.json``'s ``pairs``).
        n_skipped: pairs a distance cap skipped.
        methods: per method, its figures.
        ate: per ATE variant, robots placed and SE(3) ATE (empty without a pose graph).
        ate_robots: every robot and the common robots of the ATE table (None without one).
        map: map and packet sizes (None when not given).
        frontend: the front end's grades (None when the run did not grade it).
        revisits: what the relevant cross-robot pairs share: ``n_relevant``,
            ``median_overlap`` and ``median_shared_objects`` (None without cross-robot pairs
            or in a summary written before it was recorded).
    """

    headline: str
    pairs: dict[str, dict[str, int]]
    n_skipped: int
    methods: dict[str, MethodSummary] = field(default_factory=dict)
    ate: dict[str, AteSummary] = field(default_factory=dict)
    ate_robots: tuple[list[str], list[str]] | None = None
    map: MapStats | None = None
    frontend: FrontEndSummary | None = None
    revisits: dict[str, float | int | None] | None = None

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (the layout ``summary.json`` has always had)."""
        robots: dict[str, JSONLike] = {}
        if self.ate_robots is not None:
            robots = {"robots": list(self.ate_robots[0]), "common": list(self.ate_robots[1])}
        return {
            "headline": self.headline,
            "pairs": {k: {a: b for a, b in v.items()} for k, v in self.pairs.items()},
            "n_skipped": self.n_skipped,
            "methods": {k: m.to_json() for k, m in self.methods.items()},
            "ate": {k: a.to_json() for k, a in self.ate.items()},
            "ate_robots": robots,
            "map": self.map.to_json() if self.map else {},
            "frontend": None if self.frontend is None else self.frontend.to_json(),
            **({} if self.revisits is None else {"revisits": dict(self.revisits)}),
        }

    @classmethod
    def from_json(cls, d: JSONLike) -> RunSummary:
        """Inverse of ``to_json`` (StorageError when ``d`` is not a run summary)."""
        try:
            o = _obj(d, "run")
            robots = _obj(o["ate_robots"], "ate_robots")
            ate_robots = None
            if robots:
                ate_robots = (_names(robots["robots"]), _names(robots["common"]))
            map_json = _obj(o["map"], "map")
            pairs = {k: {a: _i(b) for a, b in _obj(v, "pairs").items()} for k, v in _obj(o["pairs"], "pairs").items()}
            return cls(
                headline=str(o["headline"]),
                pairs=pairs,
                n_skipped=_i(o["n_skipped"]),
                methods={k: MethodSummary.from_json(m) for k, m in _obj(o["methods"], "methods").items()},
                ate={k: AteSummary.from_json(a) for k, a in _obj(o["ate"], "ate").items()},
                ate_robots=ate_robots,
                map=MapStats.from_json(map_json) if map_json else None,
                frontend=None if o["frontend"] is None else FrontEndSummary.from_json(o["frontend"]),
                revisits=_revisits(o.get("revisits")),
            )
        except (KeyError, TypeError, ValueError, IndexError) as err:
            raise StorageError(f"run summary: malformed ({type(err).__name__}: {err})") from None


def _revisits(v: JSONLike) -> dict[str, float | int | None] | None:
    if v is None:
        return None
    return revisit_figure(_obj(v, "revisits"), _i)


def _names(v: JSONLike) -> list[str]:
    if not isinstance(v, (list, tuple)):
        raise ValueError(f"expected a list of names, got {v!r}")
    return [str(x) for x in v]


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
        robots = (list(ate.robots), list(ate.common))
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
        None if not metrics.revisits else dict(metrics.revisits["all"]),
    )
