"""Scoring aligner results against pair truth: correctness, precision/recall over k, bins.

Definitions: a pair is *relevant* when it should align (``EvalConfig.relevance``: true
centres within ``relevant_dist_m``, or at least ``min_shared_objects`` true objects in
common); a registration is *correct* when its rotation error is within ``rot_tol_deg`` and
its translation error within ``trans_tol_m``; a pair is *positive* at threshold k when the
aligner accepted at least k associations. TP = relevant, positive and correct; FP =
positive and not correct; recall = TP / relevant; precision = TP / (TP + FP). Every recall
comes with its count (hits / relevant) and a Wilson interval; a set with fewer than
``min_relevant`` relevant pairs is flagged ``few``. Next to max recall every set and bin
has its operating points (``operating_points``): max recall with its precision, recall at
precision >= 0.9 and 1 with their thresholds, and recall at the pose graph's acceptance
threshold.

Association truth (``assoc``): per pair, the true correspondences available and, of the
method's selected associations, the correct and recovered ones; a pair set's association
precision is correct / selected and its recall recovered / available, summed over pairs.

Every method is scored on cross-robot pairs (``inter``) and same-robot pairs (``intra``)
apart; the headline set is ``inter`` when the run has cross-robot pairs. Undefined
values (no relevant pair, no positive) are NaN inside curves and ``None`` in summaries,
never 0, so that "could not be computed" is never read as "failed".

Everything here is a pure function of pair truths and aligner results (or of the scores
read back from ``pairs.csv``), so ``metrics.json`` can be recomputed from ``pairs.csv``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.align.base import AlignResult, segment_associations
from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import pose_error
from roman_sim.evaluation.assoc import association_truth
from roman_sim.evaluation.bins import bin_groups, bin_table, fine_edges
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.intervals import wilson
from roman_sim.evaluation.operating_points import OperatingPoints, point_at, sweep_points
from roman_sim.evaluation.overlap import PairCounts, revisit_figures, robot_pair_counts
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.types import (
    PAIR_SET_LABELS,
    PAIR_SETS,
    CurveStats,
    EvaluationMetrics,
    MethodMetrics,
    PairSetMetrics,
    PRCurve,
    nan_to_none,
)

if TYPE_CHECKING:
    from roman_sim.mapping.types import Submap
    from roman_sim.posegraph.types import LoopClosure

log = logging.getLogger(__name__)

__all__ = [
    "EvalConfig",
    "PairScore",
    "auc",
    "curve_stats",
    "operating_points",
    "pr_curve",
    "compute_metrics",
    "score_pair",
]


@dataclass(frozen=True)
class PairScore:
    """One method's result on one pair, scored against truth.

    Attributes:
        truth: the pair's ground truth.
        method: aligner name.
        n_assoc: number of accepted associations.
        rot_err_deg, trans_err_m: errors of the estimate (NaN when there is none).
        correct: estimate within both tolerances.
        runtime_s: alignment wall time (NaN when read back from ``pairs.csv``).
        reason: why no estimate was produced (None otherwise).
        assoc_correct: selected associations that are true correspondences (-1: not graded,
            the method's associations are not segment pairs, e.g. the visual method's
            feature matches).
        assoc_recovered: true correspondences recovered one-to-one by the selection (-1: not
            graded).
    """

    truth: PairTruth
    method: str
    n_assoc: int
    rot_err_deg: float
    trans_err_m: float
    correct: bool
    runtime_s: float
    reason: str | None = None
    assoc_correct: int = 0
    assoc_recovered: int = 0


def score_pair(truth: PairTruth, result: AlignResult, cfg: EvalConfig | None = None) -> PairScore:
    """Score ``result`` (estimate of ``T_a_b``) against ``truth``."""
    cfg = cfg or EvalConfig()
    rot, trans = float("nan"), float("nan")
    if result.T_a_b is not None:
        T = np.asarray(result.T_a_b, dtype=np.float64)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise EvaluationError(f"{result.method} on {truth.a}|{truth.b}: T_a_b must be a finite 4x4")
        r, trans = pose_error(T, truth.T_a_b_true)
        rot = math.degrees(r)
    good, recovered = 0, 0
    if not segment_associations(result):
        good, recovered = -1, -1
    elif truth.ids_a is not None and truth.ids_b is not None:
        try:
            good, recovered = association_truth(truth.ids_a, truth.ids_b, result.associations)
        except EvaluationError as err:
            raise EvaluationError(f"{result.method} on {truth.a}|{truth.b}: {err}") from None
    return PairScore(
        truth,
        result.method,
        result.n_associations,
        rot,
        trans,
        is_correct(rot, trans, cfg),
        float(result.runtime_s),
        result.reason,
        good,
        recovered,
    )


def is_correct(rot_err_deg: float, trans_err_m: float, cfg: EvalConfig) -> bool:
    """Whether an estimate with these errors is within both tolerances (NaN: no estimate, not correct)."""
    return bool(rot_err_deg <= cfg.rot_tol_deg and trans_err_m <= cfg.trans_tol_m)


def closure_correct(c: LoopClosure, submaps: Mapping[str, Submap], rot_tol_deg: float, trans_tol_m: float) -> bool:
    """Whether closure ``c``'s relative pose is within the tolerances of the true one of its submaps.

    Raises:
        EvaluationError: a submap of the closure has no truth.
    """
    a, b = submaps[f"{c.robot_a}/{c.submap_a}"], submaps[f"{c.robot_b}/{c.submap_b}"]
    if a.truth is None or b.truth is None:
        raise EvaluationError(f"closure {a.name}|{b.name} joins submaps without truth")
    rot, trans = pose_error(c.T_a_b, np.linalg.inv(a.truth.T_world_submap) @ b.truth.T_world_submap)
    return bool(math.degrees(rot) <= rot_tol_deg and trans <= trans_tol_m)


def pr_curve(scores: list[PairScore], k_values: list[int] | None = None) -> PRCurve:
    """Precision/recall/F1 at each threshold (default k = 0..30) for one method's scores."""
    if len({s.method for s in scores}) > 1:
        raise EvaluationError("pr_curve: scores of several methods given; group them by method first")
    ks = np.asarray(k_values if k_values is not None else EvalConfig().k_values(), dtype=np.int64)
    n = np.array([s.n_assoc for s in scores], dtype=np.int64)
    rel = np.array([s.truth.relevant for s in scores], dtype=bool)
    ok = np.array([s.correct for s in scores], dtype=bool)
    pos = n[None, :] >= ks[:, None]  # (K, N)
    tp = (pos & rel & ok).sum(axis=1)
    fp = (pos & ~ok).sum(axis=1)
    n_rel = int(rel.sum())
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = np.where(tp + fp > 0, tp / np.maximum(tp + fp, 1), np.nan)
        recall = np.full(len(ks), np.nan) if n_rel == 0 else tp / n_rel
        denom = precision + recall
        f1 = np.where(denom > 0, 2 * precision * recall / np.where(denom > 0, denom, 1), 0.0)
    f1 = np.where(np.isnan(precision) | np.isnan(recall), np.nan, f1)
    return PRCurve(ks, tp.astype(np.int64), fp.astype(np.int64), n_rel, precision, recall, f1)


def auc(curve: PRCurve) -> float:
    """Area under precision over recall (trapezoid); NaN when undefined.

    Points with undefined precision or recall are skipped; at equal recall the best
    precision is kept; the curve starts at recall 0 with the precision of its
    lowest-recall point (so a single perfect point has area 1).
    """
    ok = ~(np.isnan(curve.precision) | np.isnan(curve.recall))
    if not ok.any():
        return float("nan")
    r, p = curve.recall[ok], curve.precision[ok]
    ur = np.unique(r)
    up = np.array([p[r == x].max() for x in ur])
    if ur[0] > 0:
        ur, up = np.concatenate([[0.0], ur]), np.concatenate([[up[0]], up])
    return float(np.trapezoid(up, ur))


def _assoc_stats(scores: list[PairScore], level: float) -> dict[str, object]:
    """Association precision and recall against the true correspondences, summed over the pairs.

    Pairs whose associations are not graded (not segment pairs) are left out; with none
    graded every figure is 0 or None.
    """
    scores = [s for s in scores if s.assoc_correct >= 0]
    sel = sum(s.n_assoc for s in scores)
    good = sum(s.assoc_correct for s in scores)
    avail = sum(s.truth.true_correspondences for s in scores)
    rec = sum(min(s.assoc_recovered, s.truth.true_correspondences) for s in scores)
    return {
        "assoc_selected": sel,
        "assoc_correct": good,
        "assoc_available": avail,
        "assoc_recovered": rec,
        "assoc_precision": good / sel if sel else None,
        "assoc_precision_ci": wilson(min(good, sel), sel, level),
        "assoc_recall": rec / avail if avail else None,
        "assoc_recall_ci": wilson(rec, avail, level),
    }


def operating_points(scores: list[PairScore], c: PRCurve, acceptance_k: int | None, level: float) -> OperatingPoints:
    """The operating points of ``scores`` (whose sweep is ``c``); acceptance at ``acceptance_k`` if given."""
    points: OperatingPoints = dict(sweep_points(c.k, c.tp, c.fp, c.n_relevant, level))
    points["acceptance"] = None
    if acceptance_k is not None:
        at = pr_curve(scores, [acceptance_k])
        points["acceptance"] = point_at(acceptance_k, int(at.tp[0]), int(at.fp[0]), c.n_relevant, level)
    return points


def curve_stats(
    scores: list[PairScore], k_values: list[int], cfg: EvalConfig | None = None, acceptance_k: int | None = None
) -> CurveStats:
    """Headline numbers of one method on a set of pairs (``None`` where undefined).

    ``acceptance_k`` is the pose graph's acceptance threshold (the ``acceptance`` operating point).
    """
    cfg = cfg or EvalConfig()
    c = pr_curve(scores, k_values)
    p1 = np.flatnonzero(c.precision == 1.0)
    has_f1 = not np.all(np.isnan(c.f1))
    best = int(np.nanargmax(c.f1)) if has_f1 else None
    undefined = c.n_relevant == 0
    hits = int(c.tp.max()) if len(c.tp) else 0
    # no threshold reaching precision 1 means recall 0 at that precision (defined)
    hits_p1 = int(c.tp[p1].max()) if len(p1) else 0
    return CurveStats(
        n_pairs=len(scores),
        n_relevant=c.n_relevant,
        max_recall=None if undefined else hits / c.n_relevant,
        max_hits=hits,
        max_recall_k=None if undefined else int(c.k[int(np.argmax(c.tp))]),
        recall_ci=wilson(hits, c.n_relevant, cfg.interval_level),
        few=c.n_relevant < cfg.min_relevant,
        recall_at_precision_1=None if undefined else hits_p1 / c.n_relevant,
        hits_at_precision_1=hits_p1,
        recall_at_precision_1_ci=wilson(hits_p1, c.n_relevant, cfg.interval_level),
        best_f1=None if best is None else float(c.f1[best]),
        best_f1_k=None if best is None else int(c.k[best]),
        auc=nan_to_none(auc(c)),
        **_assoc_stats(scores, cfg.interval_level),  # type: ignore[arg-type]
        operating_points=operating_points(scores, c, acceptance_k, cfg.interval_level),
    )


def _set_metrics(scores: list[PairScore], cfg: EvalConfig, acceptance_k: int | None) -> PairSetMetrics:
    ks = cfg.k_values()
    stats = partial(curve_stats, cfg=cfg, acceptance_k=acceptance_k)
    head = [s.truth.heading_diff_deg for s in scores]
    amb = [s.truth.ambiguity for s in scores]
    return PairSetMetrics(
        overall=stats(scores, ks),
        pr_curve=pr_curve(scores, ks),
        heading_bins=bin_table(scores, head, cfg.heading_bins_deg, ks, stats),
        heading_bins_fine=bin_table(
            scores, head, fine_edges(cfg.heading_bins_deg, cfg.fine_heading_bin_deg), ks, stats
        ),
        heading_pr=[pr_curve(group, ks) for group in bin_groups(scores, head, cfg.heading_bins_deg)],
        ambiguity_bins=bin_table(scores, amb, cfg.ambiguity_bins, ks, stats),
        n_ambiguity_unknown=int(np.sum(np.isnan(np.asarray(amb, dtype=float)))),
    )


def _method_metrics(scores: list[PairScore], cfg: EvalConfig, acceptance_k: int | None) -> MethodMetrics:
    sets = {k: _set_metrics([s for s in scores if s.truth.kind == k], cfg, acceptance_k) for k in PAIR_SETS}
    return MethodMetrics(sets, n_failed=sum(1 for s in scores if s.reason is not None))


def _distinct_truths(scores: list[PairScore]) -> list[PairTruth]:
    """The truth of each distinct pair (scores hold one row per pair and method)."""
    return list({(s.truth.a, s.truth.b): s.truth for s in scores}.values())


def _pair_counts(scores: list[PairScore]) -> dict[str, PairCounts]:
    pairs = {(t.a, t.b): t for t in _distinct_truths(scores)}
    return {
        k: PairCounts(
            sum(1 for t in pairs.values() if k == "all" or t.kind == k),
            sum(1 for t in pairs.values() if (k == "all" or t.kind == k) and t.relevant),
        )
        for k in (*PAIR_SETS, "all")
    }


def compute_metrics(
    scores: list[PairScore],
    cfg: EvalConfig | None = None,
    n_skipped: int = 0,
    acceptance_k: int | None = None,
    n_segments: int | None = None,
) -> EvaluationMetrics:
    """Per-method metrics of ``scores`` (undefined figures are ``None`` and explained in ``notes``).

    Args:
        scores: scored pairs of every method.
        cfg: the evaluation settings.
        n_skipped: pairs a distance cap left out (reported, not scored).
        acceptance_k: the pose graph's acceptance threshold (``lc_association_thresh``) for
            the ``acceptance`` operating points; None: no such point.
        n_segments: segments over all submaps (None: unknown). With none, no method had
            anything to align: one note says so instead of a failure note per method.
    """
    cfg = cfg or EvalConfig()
    methods = sorted({s.method for s in scores})
    counts = _pair_counts(scores)
    truths = _distinct_truths(scores)
    headline = "inter" if counts["inter"].n_pairs else "intra"
    out = EvaluationMetrics(
        config=cfg.model_copy(deep=True),
        headline=headline,
        n_pairs=counts["all"].n_pairs,
        n_relevant=counts["all"].n_relevant,
        pairs=counts,
        n_candidates=counts["all"].n_pairs + n_skipped,
        n_skipped=n_skipped,
        methods={m: _method_metrics([s for s in scores if s.method == m], cfg, acceptance_k) for m in methods},
        acceptance_k=acceptance_k,
        robot_pairs=robot_pair_counts((t.robot_a, t.robot_b, t.relevant) for t in truths),
        revisits=revisit_figures((t.robot_a, t.robot_b, t.relevant, t.overlap, t.shared_objects) for t in truths),
    )
    out.notes += _notes(out, cfg, n_segments)
    return out


#: The note of a run whose submaps hold no segment (a world without objects, or nothing mapped).
NO_SEGMENTS_NOTE = (
    "no submap holds a segment (a world without objects, or none mapped): no method had anything to align, "
    "so every method's recall, precision and F1 are undefined, not 0"
)


def _notes(out: EvaluationMetrics, cfg: EvalConfig, n_segments: int | None = None) -> list[str]:
    notes = []
    label = PAIR_SET_LABELS[out.headline]
    if not out.n_pairs:
        return ["no pairs were evaluated: no metric could be computed"]
    if n_segments == 0:
        return [NO_SEGMENTS_NOTE]
    if out.pairs[out.headline].n_relevant == 0:
        notes.append(
            f"no relevant {label} pairs ({cfg.describe_relevance()}): recall, F1 and AUC could not be computed"
        )
    for m, mm in out.methods.items():
        s = mm.set(out.headline).overall
        if s.n_relevant and s.best_f1 == 0.0:
            notes.append(f"{m}: no correct alignment of any relevant {label} pair")
    return notes
