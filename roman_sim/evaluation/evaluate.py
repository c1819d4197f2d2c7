"""Run aligners on submap pairs, score them, and write a run's evaluation files.

The evaluation is four steps, each a plain function so that an executor can replace the
one that costs time:

1. ``select_pairs`` (``pairs.py``): which pairs, and how many a distance cap skipped;
2. ``truths_for_pairs``: the ground truth of each pair;
3. ``align_pairs``: every aligner on every pair, on ``public()`` copies (no truth) - the
   only step that runs the methods;
4. ``score_pairs`` and ``metrics.summary``: pure functions of (pair truths, aligner results).

``evaluate`` chains them; ``save_evaluation`` writes ``pairs.csv``, ``metrics.json``, the
metric plots, each method's example alignments and the map view.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.align.base import Aligner, AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import PairScore, score_pair, summary
from roman_sim.evaluation.pairs import AmbiguityFn, PairSelection, PairTruth, select_pairs, truths_for_pairs
from roman_sim.evaluation.results import write_evaluation
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.mapping.types import Submap
from roman_sim.report.examples import draw_examples
from roman_sim.report.mapview import write_map_view
from roman_sim.report.plots import write_metric_plots

log = logging.getLogger(__name__)

#: ``(a name, b name, method)``
ResultKey = tuple[str, str, str]


@dataclass
class Evaluation:
    """Everything the alignment evaluation produced.

    Attributes:
        truths: truth of each evaluated pair, in pair order.
        scores: one score per (pair, aligner), pair-major.
        results: raw aligner results keyed by ``(a name, b name, method)``.
        metrics: ``metrics.summary`` of the scores.
        notes: statements for the report (e.g. a plot that was not drawn and why).
    """

    truths: list[PairTruth]
    scores: list[PairScore]
    results: dict[ResultKey, AlignResult]
    metrics: EvaluationMetrics
    notes: list[str] = field(default_factory=list)


def check_aligners(aligners: Iterable[Aligner]) -> list[Aligner]:
    """The aligners as a list; EvaluationError when empty, unnamed or with duplicate names."""
    out = list(aligners)
    names = [getattr(a, "name", None) for a in out]
    if not out or any(not isinstance(n, str) or not n for n in names):
        raise EvaluationError("evaluate: give at least one aligner, each with a non-empty 'name'")
    if len(set(names)) != len(names):
        raise EvaluationError(f"evaluate: aligner names must be unique, got {', '.join(map(str, names))}")
    return out


def align_pairs(
    pairs: list[tuple[Submap, Submap]], aligners: list[Aligner], on_pair: Callable[[], None] | None = None
) -> dict[ResultKey, AlignResult]:
    """Every aligner on every pair; the aligners see ``public()`` copies (no truth).

    ``on_pair`` is called after each pair (progress). Results are keyed by
    ``(a name, b name, method)``.
    """
    results: dict[ResultKey, AlignResult] = {}
    for a, b in pairs:
        pa, pb = a.public(), b.public()
        for aligner in aligners:
            results[(a.name, b.name, aligner.name)] = aligner.align(pa, pb)
        if on_pair is not None:
            on_pair()
    return results


def score_pairs(
    truths: list[PairTruth], results: dict[ResultKey, AlignResult], methods: list[str], cfg: EvalConfig | None = None
) -> list[PairScore]:
    """Score each method's result on each pair (pair-major, methods in the given order).

    Raises:
        EvaluationError: a result is missing for a (pair, method).
    """
    cfg = cfg or EvalConfig()
    out = []
    for t in truths:
        for m in methods:
            res = results.get((t.a, t.b, m))
            if res is None:
                raise EvaluationError(f"no result of {m} for the pair {t.a}|{t.b}")
            out.append(score_pair(t, res, cfg))
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
        cfg: evaluation settings (pair selection, relevance, thresholds, bins).
        ambiguity_fn: optional ground-truth ambiguity of a place (see ``pairs.pair_truth``).
        pairs: the pairs to evaluate instead of ``select_pairs(submaps, cfg)``.
    """
    cfg = cfg or EvalConfig()
    methods = check_aligners(aligners)
    sel = select_pairs(submaps, cfg) if pairs is None else PairSelection(pairs, len(pairs), 0, None)
    truths = truths_for_pairs(sel.pairs, ambiguity_fn, cfg)
    results = align_pairs(sel.pairs, methods)
    scores = score_pairs(truths, results, [m.name for m in methods], cfg)
    log.info(
        "evaluated %d pairs with %d aligners (%d skipped by the distance cap)", len(truths), len(methods), sel.n_skipped
    )
    return Evaluation(truths, scores, results, summary(scores, cfg, sel.n_skipped))


def save_evaluation(
    out_dir: str | Path,
    ev: Evaluation,
    submaps: list[Submap],
    map_view: bool = True,
) -> dict[str, Path]:
    """Write pairs.csv, metrics.json and plots/ into ``out_dir``; returns the written paths.

    Plots that would carry a single point are not drawn, and a map view that cannot be
    rendered (no offscreen OpenGL) is not drawn either; both are noted in ``ev.notes``.
    """
    out = Path(out_dir)
    paths = dict(write_evaluation(out, ev.scores, ev.metrics))
    plots = out / "plots"
    written, skipped = write_metric_plots(ev.metrics, plots)
    ev.notes += skipped
    by_name = {s.name: s for s in submaps}
    for p in written + draw_examples(ev.scores, by_name, ev.results, plots):
        paths[p.stem] = p
    if map_view and submaps:
        try:
            paths["map_view"] = write_map_view(plots / "map_view.png", submaps)
        except EvaluationError as err:
            log.warning("map view skipped: %s", err)
            ev.notes.append(f"map view not rendered: {err}")
    return paths
