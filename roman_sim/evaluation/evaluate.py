"""Run aligners on submap pairs, score them, and write a run's evaluation files.

``evaluate`` is the library entry point of the alignment evaluation: it enumerates the
pairs (or takes the user's), runs every aligner on every pair with truth stripped, and
scores the results. ``save_evaluation`` writes ``pairs.csv``, ``metrics.json``, the metric
plots, one correct and one wrong alignment drawing, and the map view.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.align.base import Aligner, AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.mapview import write_map_view
from roman_sim.evaluation.metrics import EvalConfig, PairScore, score_pair, summary
from roman_sim.evaluation.pairs import AmbiguityFn, PairTruth, enumerate_pairs, pair_truth
from roman_sim.evaluation.plots import draw_examples, write_metric_plots
from roman_sim.evaluation.results import write_evaluation
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)

ResultKey = tuple[str, str, str]


@dataclass
class Evaluation:
    """Everything the alignment evaluation produced.

    Attributes:
        truths: truth of each evaluated pair, in pair order.
        scores: one score per (pair, aligner), pair-major.
        results: raw aligner results keyed by ``(a name, b name, method)``.
        metrics: ``metrics.summary`` of the scores.
        notes: statements for the report (e.g. a map view that could not be rendered).
    """

    truths: list[PairTruth]
    scores: list[PairScore]
    results: dict[ResultKey, AlignResult]
    metrics: EvaluationMetrics
    notes: list[str] = field(default_factory=list)


def _check_aligners(aligners: Iterable[Aligner]) -> list[Aligner]:
    out = list(aligners)
    names = [getattr(a, "name", None) for a in out]
    if not out or any(not isinstance(n, str) or not n for n in names):
        raise EvaluationError("evaluate: give at least one aligner, each with a non-empty 'name'")
    if len(set(names)) != len(names):
        raise EvaluationError(f"evaluate: aligner names must be unique, got {', '.join(map(str, names))}")
    return out


def evaluate(
    submaps: list[Submap],
    aligners: Iterable[Aligner],
    cfg: EvalConfig | None = None,
    ambiguity_fn: AmbiguityFn | None = None,
    pairs: list[tuple[Submap, Submap]] | None = None,
) -> Evaluation:
    """Align and score every pair with every aligner.

    Args:
        submaps: submaps with truth (used when ``pairs`` is None).
        aligners: objects with ``name`` and ``align(a, b)``; they see ``public()`` copies.
        cfg: evaluation settings (pair selection, thresholds, bins).
        ambiguity_fn: optional ground-truth ambiguity of a place (see ``pairs.pair_truth``).
        pairs: the pairs to evaluate instead of ``enumerate_pairs(submaps)``.
    """
    cfg = cfg or EvalConfig()
    methods = _check_aligners(aligners)
    if pairs is None:
        pairs = enumerate_pairs(submaps, cfg.intra_min_gap, cfg.max_pair_dist_m, cfg.relevant_dist_m)
    truths, scores, results = [], [], {}
    for a, b in pairs:
        truth = pair_truth(a, b, ambiguity_fn, cfg.relevant_dist_m)
        truths.append(truth)
        pa, pb = a.public(), b.public()
        for aligner in methods:
            res = aligner.align(pa, pb)
            results[(a.name, b.name, aligner.name)] = res
            scores.append(score_pair(truth, res, cfg))
    log.info("evaluated %d pairs with %d aligners", len(truths), len(methods))
    return Evaluation(truths, scores, results, summary(scores, cfg))


def save_evaluation(
    out_dir: str | Path, ev: Evaluation, submaps: list[Submap], map_view: bool = True,
) -> dict[str, Path]:
    """Write pairs.csv, metrics.json and plots/ into ``out_dir``; returns the written paths.

    A map view that cannot be rendered (no offscreen OpenGL) is noted in ``ev.notes``
    rather than failing the run.
    """
    out = Path(out_dir)
    paths = dict(write_evaluation(out, ev.scores, ev.metrics))
    plots = out / "plots"
    for p in write_metric_plots(ev.metrics, plots):
        paths[p.stem] = p
    by_name = {s.name: s for s in submaps}
    for p in draw_examples(ev.scores, by_name, ev.results, plots):
        paths[p.stem] = p
    if map_view and submaps:
        try:
            paths["map_view"] = write_map_view(plots / "map_view.png", submaps)
        except EvaluationError as err:
            log.warning("map view skipped: %s", err)
            ev.notes.append(f"map view not rendered: {err}")
    return paths
