"""Scoring aligner results against pair truth: correctness, precision/recall over k, bins.

Definitions (REFERENCE.md section 7): a pair is *relevant* when its true centres are within
``relevant_dist_m``; a registration is *correct* when its rotation error is within
``rot_tol_deg`` and its translation error within ``trans_tol_m``; a pair is *positive* at
threshold k when the aligner accepted at least k associations. TP = relevant, positive and
correct; FP = positive and not correct; recall = TP / relevant; precision = TP / (TP + FP).

Undefined values (no relevant pair, no positive) are NaN inside curves and ``None`` in
summaries, never 0, so that "could not be computed" is never read as "failed".
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field, model_validator

from roman_sim.align.base import AlignResult
from roman_sim.core.config import StrictModel
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.bins import bin_table, fine_edges
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics, MethodMetrics, PRCurve, nan_to_none
from roman_sim.geometry import pose_error

log = logging.getLogger(__name__)


def _increasing(edges: list[float], name: str) -> None:
    if len(edges) < 2 or any(b <= a for a, b in zip(edges, edges[1:])):
        raise ValueError(f"{name} must hold at least 2 strictly increasing edges")


class EvalConfig(StrictModel):
    """Evaluation settings (thresholds, k sweep, bins, pair selection)."""

    relevant_dist_m: float = Field(10.0, gt=0, description="relevance: true centres within this")
    rot_tol_deg: float = Field(5.0, gt=0, le=180, description="correct: rotation error within this")
    trans_tol_m: float = Field(1.0, gt=0, description="correct: translation error within this")
    k_min: int = Field(0, ge=0, description="smallest association count threshold of the sweep")
    k_max: int = Field(30, ge=0, le=10000, description="largest association count threshold")
    heading_bins_deg: list[float] = Field(default_factory=lambda: [0.0, 60.0, 120.0, 180.0])
    fine_heading_bin_deg: float = Field(30.0, gt=0, le=180)
    ambiguity_bins: list[float] = Field(default_factory=lambda: [0.0, 0.25, 0.5, 0.75, 1.0])
    intra_min_gap: int = Field(2, ge=1, description="smallest index gap of intra-robot pairs")
    max_pair_dist_m: float | None = Field(None, ge=0, description="drop farther pairs (None: keep all)")

    @model_validator(mode="after")
    def _check(self) -> "EvalConfig":
        if self.k_max < self.k_min:
            raise ValueError(f"k_max ({self.k_max}) must be >= k_min ({self.k_min})")
        _increasing(self.heading_bins_deg, "heading_bins_deg")
        _increasing(self.ambiguity_bins, "ambiguity_bins")
        if self.heading_bins_deg[0] < 0 or self.heading_bins_deg[-1] > 180:
            raise ValueError("heading_bins_deg must lie within [0, 180]")
        return self

    def k_values(self) -> list[int]:
        """The swept thresholds ``k_min..k_max``."""
        return list(range(self.k_min, self.k_max + 1))


@dataclass(frozen=True)
class PairScore:
    """One method's result on one pair, scored against truth.

    Attributes:
        truth: the pair's ground truth.
        method: aligner name.
        n_assoc: number of accepted associations.
        rot_err_deg, trans_err_m: errors of the estimate (NaN when there is none).
        correct: estimate within both tolerances.
        runtime_s: alignment wall time.
        reason: why no estimate was produced (None otherwise).
    """

    truth: PairTruth
    method: str
    n_assoc: int
    rot_err_deg: float
    trans_err_m: float
    correct: bool
    runtime_s: float
    reason: str | None = None


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
    correct = bool(rot <= cfg.rot_tol_deg and trans <= cfg.trans_tol_m)  # NaN compares False
    return PairScore(truth, result.method, result.n_associations, rot, trans, correct,
                     float(result.runtime_s), result.reason)


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


def curve_stats(scores: list[PairScore], k_values: list[int]) -> CurveStats:
    """Headline numbers of one method on a set of pairs (``None`` where undefined)."""
    c = pr_curve(scores, k_values)
    at_p1 = c.recall[c.precision == 1.0]
    has_f1 = not np.all(np.isnan(c.f1))
    best = int(np.nanargmax(c.f1)) if has_f1 else None
    undefined = c.n_relevant == 0
    return CurveStats(
        n_pairs=len(scores),
        n_relevant=c.n_relevant,
        max_recall=None if undefined else float(np.nanmax(c.recall)),
        max_hits=int(c.tp.max()) if len(c.tp) else 0,
        # no threshold reaching precision 1 means recall 0 at that precision (defined)
        recall_at_precision_1=None if undefined else float(at_p1.max() if len(at_p1) else 0.0),
        best_f1=None if best is None else float(c.f1[best]),
        best_f1_k=None if best is None else int(c.k[best]),
        auc=nan_to_none(auc(c)),
    )


def _method_summary(scores: list[PairScore], cfg: EvalConfig) -> MethodMetrics:
    ks = cfg.k_values()
    head = [s.truth.heading_diff_deg for s in scores]
    amb = [s.truth.ambiguity for s in scores]
    return MethodMetrics(
        overall=curve_stats(scores, ks),
        pr_curve=pr_curve(scores, ks),
        heading_bins=bin_table(scores, head, cfg.heading_bins_deg, ks, curve_stats),
        heading_bins_fine=bin_table(scores, head, fine_edges(cfg.heading_bins_deg, cfg.fine_heading_bin_deg),
                                    ks, curve_stats),
        ambiguity_bins=bin_table(scores, amb, cfg.ambiguity_bins, ks, curve_stats),
        n_ambiguity_unknown=int(np.sum(np.isnan(np.asarray(amb, dtype=float)))),
        by_kind={kind: curve_stats([s for s in scores if s.truth.kind == kind], ks) for kind in ("inter", "intra")},
        n_failed=sum(1 for s in scores if s.reason is not None),
    )


def summary(scores: list[PairScore], cfg: EvalConfig | None = None) -> EvaluationMetrics:
    """Per-method metrics of ``scores`` (undefined figures are ``None`` and explained in ``notes``)."""
    cfg = cfg or EvalConfig()
    methods = sorted({s.method for s in scores})
    by_method = {m: [s for s in scores if s.method == m] for m in methods}
    pairs = {(s.truth.a, s.truth.b): s.truth.relevant for s in scores}
    out = EvaluationMetrics(
        config=cfg.model_dump(mode="json"),
        n_pairs=len(pairs),
        n_relevant=sum(pairs.values()),
        methods={m: _method_summary(by_method[m], cfg) for m in methods},
    )
    if not scores:
        out.notes.append("no pairs were evaluated: no metric could be computed")
    elif out.n_relevant == 0:
        out.notes.append("no relevant pairs (true centres within "
                         f"{cfg.relevant_dist_m:g} m): recall, F1 and AUC could not be computed")
    for m in methods:
        s = out.methods[m].overall
        if out.n_relevant and not s.n_relevant:
            out.notes.append(f"{m}: evaluated on no relevant pair: its recall could not be computed")
        if s.n_relevant and s.best_f1 == 0.0:
            out.notes.append(f"{m}: no correct alignment of any relevant pair")
    return out
