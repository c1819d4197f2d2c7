"""Each level's precision-recall curve on the chosen score, with world intervals, and the area under it.

The deployable point is one threshold per method; the curve is every threshold. Per level and
method, over its cross-robot pairs of every heading pooled over the level's worlds, the sweep
is ``evaluation.score_curves``' (``associations``: the thresholds ``k`` of the evaluation's
sweep; a named score: every distinct value it takes; a pair without the score is positive at
no threshold). Its area under precision over recall (``operating_points.pr_area``, the
trapezoid rule) is the threshold-free summary beside the deployable point.

World intervals: a world bootstrap as the board's other intervals draw it
(``evaluation.paired_worlds``: ``numpy.random.default_rng(seed).integers(0, n, (draws, n))``,
each draw as many worlds as the level has, with replacement, each drawn world's pairs kept
whole), ``CURVE_DRAWS`` draws. Each draw pools its worlds' counts at every threshold and gives
a curve and an area; a draw without a relevant pair (or, for a point's precision, without a
positive) is left out; the percentile interval (numpy's linear rule) of the draws is the
interval. These intervals decide no verdict and no bound; the Monte-Carlo error of the area's
bounds (their spread over ``BATCHES`` equal batches, over its square root) is kept beside them.

Paired verdicts on the area (``AucVerdict``): every two methods compared on the same worlds.
Each world's own curve (its pairs only) has an area; a world where both methods have one gives
a difference, rounded to 0.001 (``AUC_SCALE``) so that the exact sign-flip test over worlds
(``paired_worlds.sign_flip_p``: each world's difference as likely + as -, every sign choice
counted, nothing drawn) can run on whole numbers. ``a ahead`` or ``b ahead`` where p is at most
0.05, ``no difference shown`` otherwise, and ``too few hits`` where both methods reach fewer than
``paired_worlds.MIN_HITS`` hits at their loosest threshold. No verdict depends on a seed.

The stored curve has at most ``CURVE_POINTS`` thresholds (a named score takes many values:
evenly spaced ranks of its sorted thresholds, both ends kept); the area is that of the full sweep.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.core.records import OMIT_NONE
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.operating_points import pr_area
from roman_sim.evaluation.paired_worlds import BATCHES, MIN_HITS, sign_flip_p

#: World-bootstrap draws of each level's curves and areas.
CURVE_DRAWS = 4000
#: Most thresholds a stored curve keeps.
CURVE_POINTS = 41
#: Draws whose full curves are held at once (a named score sweeps many thresholds).
CHUNK = 250
#: The per-world area differences the paired area verdicts test are rounded to 1 / AUC_SCALE.
AUC_SCALE = 1000


@dataclass(frozen=True)
class CurvePoint:
    """One threshold of a method's curve: pooled counts, recall and precision with world intervals.

    Attributes:
        threshold: the threshold (an int on ``associations``, a float on a named score).
        hits, false_positives: relevant and correct pairs, and wrong pairs, accepted at it.
        recall, precision: hits / relevant (None without one) and hits / accepted (None without one).
        recall_worlds, precision_worlds: their world-bootstrap intervals (None without a draw).
    """

    threshold: int | float
    hits: int
    false_positives: int
    recall: float | None
    precision: float | None
    recall_worlds: list[float] | None
    precision_worlds: list[float] | None


@dataclass(frozen=True)
class MethodCurve:
    """One method's curve over a level's cross-robot pairs and the area under it.

    Attributes:
        n_pairs, n_relevant: cross-robot pairs scored and relevant ones.
        auc: area under precision over recall of the full sweep (None when undefined).
        auc_worlds: its world-bootstrap interval (None without a draw that has an area).
        auc_mc_error: the Monte-Carlo error of that interval's bounds.
        points: the curve (at most ``CURVE_POINTS`` thresholds, ascending).
        world_auc: each world's own area, in the level's world order (None: the world has no relevant pair or
            the method no positive there).
        max_hits: hits at the loosest threshold (the floor's count).
    """

    n_pairs: int
    n_relevant: int
    auc: float | None
    auc_worlds: list[float] | None
    auc_mc_error: float | None
    points: list[CurvePoint]
    world_auc: list[float | None] = field(default_factory=list)
    max_hits: int | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class AucVerdict:
    """Two methods' areas compared world by world (see the module docstring).

    Attributes:
        a, b: the methods (in the board's order).
        verdict: ``a ahead``, ``b ahead``, ``no difference shown`` or ``too few hits``.
        diff: the mean over the compared worlds of ``a``'s area less ``b``'s.
        p_value: the exact two-sided sign-flip p-value of the rounded differences.
        worlds: the worlds where both have an area.
    """

    a: str
    b: str
    verdict: str
    diff: float | None
    p_value: float
    worlds: int


@dataclass(frozen=True)
class LevelCurves:
    """A level's curves on one score: per method its ``MethodCurve``.

    Attributes:
        score: the score swept (``associations`` or a method's named score).
        draws: world-bootstrap draws of the intervals.
        methods: per method (the board's order) its curve.
        verdicts: one paired area verdict per two methods (``AucVerdict``).
    """

    score: str
    draws: int
    methods: dict[str, MethodCurve]
    verdicts: list[AucVerdict] = field(default_factory=list)

    def verdict(self, a: str, b: str) -> AucVerdict | None:
        """The area verdict of ``a`` against ``b`` (in either order as stored), None when not compared."""
        return next((v for v in self.verdicts if {v.a, v.b} == {a, b}), None)


def thresholds_of(values: NDArray[np.float64], score: str, k_values: Sequence[int]) -> list[int] | list[float]:
    """The sweep's thresholds: ``k_values`` on ``associations``, else the distinct finite values, ascending."""
    if score == DEFAULT_SCORE:
        return sorted(int(k) for k in k_values)
    return [float(v) for v in np.unique(values[np.isfinite(values)])]


def world_sweep(
    values: NDArray[np.float64],
    hit: NDArray[np.bool_],
    wrong: NDArray[np.bool_],
    relevant: NDArray[np.bool_],
    world: NDArray[np.int64],
    n_worlds: int,
    thresholds: Sequence[float],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per world (rows) and threshold (columns): hits and false positives at ``values >= threshold``; and
    per world its relevant pairs."""
    t = np.asarray(thresholds, dtype=np.float64)
    tp = np.zeros((n_worlds, len(t)))
    fp = np.zeros((n_worlds, len(t)))
    for w in range(n_worlds):
        for out, keep in ((tp, hit), (fp, wrong)):
            v = np.sort(values[keep & (world == w)])
            out[w] = len(v) - np.searchsorted(v, t, side="left")
    return tp, fp, np.bincount(world, relevant, n_worlds).astype(np.float64)


def _ratio(num: NDArray[np.float64], den: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def _interval(draws: NDArray[np.float64], level: float) -> list[float] | None:
    """The percentile interval of the defined draws (None without one)."""
    ok = draws[~np.isnan(draws)]
    if not len(ok):
        return None
    lo, hi = np.quantile(ok, [(1 - level) / 2, 1 - (1 - level) / 2])
    return [float(lo), float(hi)]


def _mc_error(draws: NDArray[np.float64], level: float) -> float | None:
    """The Monte-Carlo error of the interval's bounds: their spread over ``BATCHES`` batches / sqrt(BATCHES)."""
    ok = draws[~np.isnan(draws)]
    if len(ok) < 2 * BATCHES:
        return None
    q = [(1 - level) / 2, 1 - (1 - level) / 2]
    per = np.array([np.quantile(b, q) for b in np.array_split(ok, BATCHES)])
    return float(per.std(axis=0, ddof=1).max() / math.sqrt(BATCHES))


def _none(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


def method_curve(
    tp: NDArray[np.float64],
    fp: NDArray[np.float64],
    rel: NDArray[np.float64],
    thresholds: Sequence[float],
    n_pairs: int,
    level: float = 0.95,
    draws: int = CURVE_DRAWS,
    seed: int = 0,
) -> MethodCurve:
    """One method's ``MethodCurve`` from its per-world counts (``world_sweep``) (see the module docstring)."""
    n = len(rel)
    pooled_tp, pooled_fp, n_rel = tp.sum(axis=0), fp.sum(axis=0), float(rel.sum())
    precision = _ratio(pooled_tp, pooled_tp + pooled_fp)
    recall = pooled_tp / n_rel if n_rel > 0 else np.full(len(pooled_tp), np.nan)
    pooled_area = pr_area(precision, recall) if len(pooled_tp) else math.nan
    picks = np.random.default_rng(seed).integers(0, n, (draws, n))
    weights = np.bincount((picks + n * np.arange(draws)[:, None]).ravel(), minlength=draws * n).reshape(draws, n)
    d_rel = weights @ rel
    areas = np.concatenate(
        [_draw_areas(weights[i : i + CHUNK], d_rel[i : i + CHUNK], tp, fp) for i in range(0, draws, CHUNK)]
    )
    keep = _kept(len(thresholds))
    d_tp, d_fp = weights @ tp[:, keep], weights @ fp[:, keep]  # (draws, kept thresholds)
    d_rec = _ratio(d_tp, np.broadcast_to(d_rel[:, None], d_tp.shape))
    d_prec = _ratio(d_tp, d_tp + d_fp)
    points = [
        CurvePoint(
            thresholds[i],
            int(pooled_tp[i]),
            int(pooled_fp[i]),
            _none(recall[i]),
            _none(precision[i]),
            _interval(d_rec[:, j], level),
            _interval(d_prec[:, j], level),
        )
        for j, i in enumerate(keep)
    ]
    own = [_none(area(_ratio(tp[w], tp[w] + fp[w]), tp[w] / rel[w])) if rel[w] > 0 else None for w in range(n)]
    return MethodCurve(
        n_pairs,
        int(n_rel),
        _none(pooled_area),
        _interval(areas, level),
        _mc_error(areas, level),
        points,
        own,
        int(pooled_tp.max()) if len(pooled_tp) else 0,
    )


def auc_verdict(a: str, b: str, ca: MethodCurve, cb: MethodCurve, level: float = 0.95) -> AucVerdict:
    """``a`` against ``b``: their per-world areas compared over the worlds where both have one (module docstring)."""
    both = [(x, y) for x, y in zip(ca.world_auc, cb.world_auc, strict=True) if x is not None and y is not None]
    diffs = [x - y for x, y in both]
    steps = np.rint(np.asarray(diffs, dtype=np.float64) * AUC_SCALE)
    p = sign_flip_p(steps) if len(steps) else 1.0
    mean = float(np.mean(diffs)) if diffs else None
    if (ca.max_hits or 0) < MIN_HITS and (cb.max_hits or 0) < MIN_HITS:
        verdict = "too few hits"
    elif mean is not None and p <= 1 - level and steps.sum() != 0:
        verdict = "a ahead" if steps.sum() > 0 else "b ahead"
    else:
        verdict = "no difference shown"
    return AucVerdict(a, b, verdict, mean, p, len(both))


def _draw_areas(
    weights: NDArray[np.int64], d_rel: NDArray[np.float64], tp: NDArray[np.float64], fp: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The area under each draw's pooled curve (NaN for a draw without a relevant pair)."""
    d_tp, d_fp = weights @ tp, weights @ fp
    d_prec = _ratio(d_tp, d_tp + d_fp)
    return np.asarray([area(d_prec[i], d_tp[i] / d_rel[i]) if d_rel[i] > 0 else math.nan for i in range(len(d_rel))])


def area(precision: NDArray[np.float64], recall: NDArray[np.float64]) -> float:
    """``operating_points.pr_area`` in one sort (the same figure: best precision per recall, the curve
    started at recall 0 with the precision of its lowest-recall point, the trapezoid rule); NaN when undefined."""
    ok = ~(np.isnan(precision) | np.isnan(recall))
    if not ok.any():
        return math.nan
    r, p = recall[ok], precision[ok]
    order = np.lexsort((-p, r))  # by recall, the best precision first
    r, p = r[order], p[order]
    first = np.concatenate([[True], r[1:] != r[:-1]])
    r, p = r[first], p[first]
    if r[0] > 0:
        r, p = np.concatenate([[0.0], r]), np.concatenate([[p[0]], p])
    return float(np.trapezoid(p, r))


def _kept(n: int) -> list[int]:
    """Indices of the stored thresholds: all of them, or ``CURVE_POINTS`` evenly spaced ranks (ends kept)."""
    if n <= CURVE_POINTS:
        return list(range(n))
    return sorted({int(round(x)) for x in np.linspace(0, n - 1, CURVE_POINTS)})


def level_curves(
    scores: Sequence[PairScore],
    methods: Sequence[str],
    score: str,
    k_values: Sequence[int],
    level: float = 0.95,
    draws: int = CURVE_DRAWS,
    seed: int = 0,
) -> LevelCurves | None:
    """A level's curves on ``score`` (None with fewer than two worlds: no world interval)."""
    worlds = sorted({s.truth.a.split(":", 1)[0] for s in scores})
    if len(worlds) < 2:
        return None
    at = {w: i for i, w in enumerate(worlds)}
    out = {}
    for m in methods:
        rows = [s for s in scores if s.method == m and s.truth.kind == "inter"]
        if not rows:
            continue
        values = np.asarray([-np.inf if (v := s.score(score)) is None else v for s in rows], dtype=np.float64)
        relevant = np.asarray([s.truth.relevant for s in rows], dtype=np.bool_)
        correct = np.asarray([s.correct for s in rows], dtype=np.bool_)
        world = np.asarray([at[s.truth.a.split(":", 1)[0]] for s in rows], dtype=np.int64)
        t = thresholds_of(values, score, k_values)
        tp, fp, rel = world_sweep(values, relevant & correct, ~correct, relevant, world, len(worlds), t)
        out[m] = method_curve(tp, fp, rel, t, len(rows), level, draws, seed)
    names = list(out)
    verdicts = [auc_verdict(a, b, out[a], out[b], level) for i, a in enumerate(names) for b in names[i + 1 :]]
    return LevelCurves(score, draws, out, verdicts)
