"""Precision-recall on a chosen confidence score: the sweep, its operating points and its area.

A method accepts a pair when its score reaches a threshold. The default score is the
association count (``associations``): its sweep is the integer thresholds of
``EvalConfig.k_values`` and gives exactly the curve of ``metrics.pr_curve``. Any other score
a method names (``AlignResult.confidence``: ROMAN's ``objective``, ``margin``, ...; a plug-in's
own) is swept over every distinct value it takes on the pairs, ascending: a pair is positive
at threshold ``t`` when its score is at least ``t``; a pair without that score (an alignment
that failed before scoring) is positive at no threshold. TP, FP, precision and recall are
those of ``roman_sim.evaluation.metrics``.

Beside the operating points (max recall, recall at precision >= 0.9 and 1, each with its
threshold, as ``operating_points.sweep_points`` chooses them), the area under the curve
(``operating_points.pr_area``, the trapezoid rule of ``metrics.auc``) summarises the whole
sweep without choosing a threshold.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import PairScore, sweep_counts
from roman_sim.evaluation.operating_points import POINT_NAMES, OperatingPoint, pr_area, sweep_points


def offered_scores(scores: Sequence[PairScore], method: str) -> list[str]:
    """The scores ``method`` offers on ``scores``: ``associations``, then every name a row of it carries, sorted."""
    names = {k for s in scores if s.method == method for k, _ in s.named}
    return [DEFAULT_SCORE, *sorted(names)]


def check_score(scores: Sequence[PairScore], name: str) -> None:
    """Raise unless every method of ``scores`` offers the score ``name``.

    Raises:
        EvaluationError: one line naming the score, the first method without it and the scores it offers.
    """
    for method in sorted({s.method for s in scores}):
        offered = offered_scores(scores, method)
        if name not in offered:
            offers = ", ".join(offered)
            raise EvaluationError(f"score {name!r}: method {method} does not offer it (it offers: {offers})")


@dataclass(frozen=True)
class ScoreCurve:
    """Precision and recall of one method over the thresholds of one score (arrays of len(thresholds)).

    Attributes:
        score: the score's name.
        thresholds: (T,) ascending thresholds.
        tp, fp: (T,) true and false positives at each threshold.
        n_relevant: relevant pairs (the recall's denominator).
        precision, recall: (T,) TP / (TP + FP) (NaN without a positive) and TP / relevant (NaN
            without a relevant pair).
    """

    score: str
    thresholds: NDArray[np.float64]
    tp: NDArray[np.int64]
    fp: NDArray[np.int64]
    n_relevant: int
    precision: NDArray[np.float64]
    recall: NDArray[np.float64]


def score_values(scores: Sequence[PairScore], name: str) -> NDArray[np.float64]:
    """(n,) each pair's score ``name``; -inf where the pair has none (positive at no threshold)."""
    got = (s.score(name) for s in scores)
    return np.asarray([-np.inf if v is None else v for v in got], dtype=np.float64)


def score_curve(scores: Sequence[PairScore], name: str = DEFAULT_SCORE, cfg: EvalConfig | None = None) -> ScoreCurve:
    """The precision-recall sweep of one method's ``scores`` over the score ``name`` (module docstring)."""
    if len({s.method for s in scores}) > 1:
        raise EvaluationError("score_curve: scores of several methods given; group them by method first")
    v = score_values(scores, name)
    if name == DEFAULT_SCORE:
        t = np.asarray((cfg or EvalConfig()).k_values(), dtype=np.float64)
    else:
        t = np.unique(v[np.isfinite(v)])
    tp, fp, n_rel, precision, recall = sweep_counts(v, t, scores)
    return ScoreCurve(name, t, tp, fp, n_rel, precision.astype(np.float64), recall.astype(np.float64))


@dataclass(frozen=True)
class ScorePoint:
    """An operating point on a score: its threshold (None: not reached) and its counts and intervals."""

    threshold: float | None
    point: OperatingPoint


@dataclass(frozen=True)
class ScoreSummary:
    """One method's sweep on one score over one pair set: the area under it and its operating points.

    Attributes:
        method, score: the method and the score swept.
        n_pairs, n_relevant: pairs scored and relevant pairs.
        auc: area under precision over recall (None when undefined).
        points: ``max_recall``, ``precision_90``, ``precision_100`` -> the point on this score.
    """

    method: str
    score: str
    n_pairs: int
    n_relevant: int
    auc: float | None
    points: dict[str, ScorePoint]


def score_summary(
    scores: Sequence[PairScore], name: str = DEFAULT_SCORE, cfg: EvalConfig | None = None, method: str | None = None
) -> ScoreSummary:
    """The ``ScoreSummary`` of one method's ``scores`` on the score ``name`` (``method``: its name when ``scores``
    is empty)."""
    cfg = cfg or EvalConfig()
    c = score_curve(scores, name, cfg)
    idx = np.arange(len(c.thresholds), dtype=np.int64)  # points by index, read back as thresholds
    raw = sweep_points(idx, c.tp, c.fp, c.n_relevant, cfg.interval_level)
    points: dict[str, ScorePoint] = {
        n: ScorePoint(None if p.k is None else float(c.thresholds[p.k]), p)
        for n in POINT_NAMES[:3]
        if (p := raw[n]) is not None
    }
    area = pr_area(c.precision, c.recall)
    method = method if method is not None else (scores[0].method if scores else "")
    return ScoreSummary(method, name, len(scores), c.n_relevant, None if np.isnan(area) else area, points)


def score_summaries(
    scores: Sequence[PairScore], name: str = DEFAULT_SCORE, cfg: EvalConfig | None = None
) -> list[ScoreSummary]:
    """Per method (sorted) its summary on ``name`` over the headline pair set (cross-robot when there are any).

    Raises:
        EvaluationError: a method that does not offer ``name`` (``check_score``).
    """
    check_score(scores, name)
    kind = "inter" if any(s.truth.kind == "inter" for s in scores) else "intra"
    rows = [s for s in scores if s.truth.kind == kind]
    methods = sorted({s.method for s in scores})
    return [score_summary([s for s in rows if s.method == m], name, cfg, m) for m in methods]
