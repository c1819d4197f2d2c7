"""The deployable operating point of a benchmark level: thresholds chosen on other worlds.

A deployed system runs one threshold per method on its confidence score, for every heading,
chosen before it sees the world it runs in. The score is the association count
(``associations``, thresholds ``k`` of the evaluation's sweep) unless the benchmark names
another (``roman-sim benchmark --score NAME``: a method's own score, ``AlignResult.confidence``;
its thresholds are the calibration pairs' own values, and a pair without the score is accepted
at no threshold). Per level and method this module chooses it as
``benchmark.transfer`` does: leave one world (cell = scenario seed) out, choose on the
others the smallest threshold whose pooled precision over all headings of their cross-robot
pairs reaches the target, score the left-out world at it; pool the held-out
outcomes over the level's worlds. The threshold chosen on every world of the level is kept
too (``deployed``): it is what a new world runs at (``roman-sim benchmark check``).

Per heading bin (and ``"all"``), from each world's held-out counts:

- held-out hits, false positives and relevant pairs; recall with its pooled Wilson interval
  and its world-bootstrap interval; precision with its world-bootstrap interval, and
  whether it is within ``transfer.PRECISION_SLACK`` of the target. The world bootstrap
  draws worlds with replacement and keeps each drawn world's pairs whole
  (``evaluation.paired_worlds.world_interval``): the world is the independent unit, and
  resampling the robot pairs inside it as well would count the within-world spread twice.
  Its draws double while a recall half-width lies within four Monte-Carlo errors of the
  suite's bound, so whether the bound is met does not depend on the bootstrap's seed.
- a paired verdict for every two methods (``evaluation.paired_worlds.paired_difference``):
  the same worlds and relevant pairs, the difference of held-out recall, the exact sign-flip
  test over worlds (nothing drawn at random), the power for the effect size.
- a floor: a method with fewer than ``MIN_HITS`` held-out hits in the bin is "too few hits
  to rank (h in n)": it gets no rank and counts toward no bound.
- ranks: 1 + the number of methods a paired verdict puts ahead (methods above the floor).

Per method, over all headings, the spread of held-out precision from world to world
(``precision_spread``: a beta-binomial fit of each world's held-out hits out of its accepted
pairs, ``world_spread``) and the interval it states for one new world's precision, the one
``roman-sim benchmark check`` tests fresh worlds against.

A level with a single world has no held-out figures: its entry says so.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.board_records import (
    Deployable,
    DeployableCell,
    HeldOutFigures,
    PairVerdict,
    PrecisionSpread,
)
from roman_sim.benchmark.ranking import Rank
from roman_sim.benchmark.transfer import PairOutcomes, choose_threshold, held_out, transfers
from roman_sim.benchmark.world_spread import fit_spread
from roman_sim.evaluation.bins import bin_index, bin_label
from roman_sim.evaluation.intervals import wilson
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.paired_worlds import EFFECT, MIN_HITS, near_half_width, paired_difference, world_interval

log = logging.getLogger(__name__)

#: Default target precision of the deployable point.
DEFAULT_TARGET = 0.9
#: Widest held-out recall half-width the standard suite promises per level x heading bin (the bound the
#: world intervals' draws are made precise around).
HALF_WIDTH_BOUND = 0.1


def single_world_note(n_worlds: int) -> str:
    """The statement a level with fewer than two worlds carries instead of held-out figures."""
    return (
        f"held-out figures need at least two worlds (seeds) to choose a threshold on others; this level has {n_worlds}"
    )


def _world(s: PairScore) -> str:
    """The cell (world) a pooled pair came from: its name is ``<cell>:<robot>/<index>``."""
    return s.truth.a.split(":", 1)[0]


def outcomes(scores: Sequence[PairScore], method: str, score: str = DEFAULT_SCORE) -> tuple[PairOutcomes, np.ndarray]:
    """One method's cross-robot pairs as ``PairOutcomes`` (world = cell, cluster = robot pair, score: the
    score ``score``, -inf where the pair has none), and headings."""
    rows = [s for s in scores if s.method == method and s.truth.kind == "inter"]
    o = PairOutcomes.from_lists(
        [_world(s) for s in rows],
        ["|".join(sorted((s.truth.robot_a, s.truth.robot_b))) for s in rows],
        [s.truth.relevant for s in rows],
        [s.correct for s in rows],
        [-np.inf if (v := s.score(score)) is None else v for s in rows],
    )
    return o, np.asarray([s.truth.heading_diff_deg for s in rows], dtype=np.float64)


def _pair(ci: tuple[float, float] | None) -> list[float] | None:
    return None if ci is None else [float(ci[0]), float(ci[1])]


@dataclass(frozen=True)
class WorldCounts:
    """One method's held-out counts in one heading bin, per world (the level's worlds, in order)."""

    hits: NDArray[np.float64]
    false_positives: NDArray[np.float64]
    relevant: NDArray[np.float64]


def bin_masks(heading: NDArray[np.float64], edges: Sequence[float]) -> list[tuple[str, NDArray[np.bool_]]]:
    """(label, mask) of each heading bin of ``edges`` over pairs of the given headings, then ``("all", every pair)``."""
    idx = bin_index(heading, edges)
    masks = [(bin_label(edges[i], edges[i + 1]), idx == i) for i in range(len(edges) - 1)]
    return [*masks, ("all", np.ones(len(idx), dtype=np.bool_))]


def world_counts(
    o: PairOutcomes, positive: NDArray[np.bool_], mask: NDArray[np.bool_], worlds: Sequence[str]
) -> WorldCounts:
    """Per world of ``worlds``: held-out hits, false positives and relevant pairs among the pairs of ``mask``."""
    at = {w: i for i, w in enumerate(worlds)}
    idx = np.asarray([at[str(w)] for w in o.world[mask]], dtype=np.int64)
    hit = (positive & o.relevant & o.correct)[mask]
    fp = (positive & ~o.correct)[mask]
    rel = o.relevant[mask]
    n = len(worlds)
    return WorldCounts(
        np.bincount(idx, hit, n).astype(np.float64),
        np.bincount(idx, fp, n).astype(np.float64),
        np.bincount(idx, rel, n).astype(np.float64),
    )


def held_out_figures(c: WorldCounts, target: float, level: float, bound: float, seed: int = 0) -> HeldOutFigures:
    """A method's held-out figures in one bin as ``leaderboard.json`` holds them."""
    tp, fp, rel = int(c.hits.sum()), int(c.false_positives.sum()), int(c.relevant.sum())
    rec = world_interval(c.hits, c.relevant, level=level, seed=seed, undecided=near_half_width(bound)) if rel else None
    prec = world_interval(c.hits, c.hits + c.false_positives, level=level, seed=seed) if tp + fp else None
    precision = tp / (tp + fp) if tp + fp else None
    return HeldOutFigures(
        hits=tp,
        false_positives=fp,
        n_relevant=rel,
        recall=tp / rel if rel else None,
        recall_wilson=_pair(wilson(tp, rel, level)),
        recall_worlds=None if rec is None else [rec.low, rec.high],
        precision=precision,
        precision_worlds=None if prec is None else [prec.low, prec.high],
        transfers=transfers(precision, target),
    )


def precision_spread(c: WorldCounts, level: float) -> PrecisionSpread | None:
    """The beta-binomial spread of a method's held-out precision over worlds (``world_spread.fit_spread`` of each
    world's held-out hits out of its accepted pairs) and the one-new-world interval it states (None: fewer than
    two worlds accepted a pair)."""
    fit = fit_spread([int(h) for h in c.hits], [int(n) for n in c.hits + c.false_positives])
    if fit is None:
        return None
    lo, hi = fit.interval(level)
    return PrecisionSpread(fit.a, fit.b, fit.worlds, level, [lo, hi])


def floor_line(c: HeldOutFigures) -> str:
    """What a method below the floor is reported as."""
    return f"too few hits to rank ({c.hits} in {c.n_relevant})"


def paired_ranks(methods: Sequence[str], verdicts: Sequence[PairVerdict]) -> dict[str, Rank]:
    """1 + the number of methods a verdict puts ahead of each of ``methods``; tied where a rank is shared."""
    ahead = {m: sum(1 for v in verdicts if m in (v.a, v.b) and v.winner() not in (None, m)) for m in methods}
    ranks = {m: 1 + n for m, n in ahead.items()}
    return {m: Rank(r, sum(1 for x in ranks.values() if x == r) > 1) for m, r in ranks.items()}


def _cell(
    label: str, counts: dict[str, WorldCounts], target: float, level: float, bound: float, seed: int
) -> DeployableCell:
    """One bin across methods: held-out figures, the paired verdicts, the floor, ranks, widest half-width."""
    figures = {m: held_out_figures(c, target, level, bound, seed) for m, c in counts.items()}
    floor = {m: floor_line(f) for m, f in figures.items() if f.n_relevant and f.hits < MIN_HITS}
    names = list(counts)
    verdicts = []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            d = paired_difference(counts[a].hits, counts[b].hits, counts[a].relevant, level=level)
            verdicts.append(PairVerdict(a, b, d.verdict, d.diff, d.p_value, d.power, d.worlds_for_power, d.detectable))
    ranked = [m for m in names if m not in floor and figures[m].n_relevant]
    halves = [(f.recall_worlds[1] - f.recall_worlds[0]) / 2 for m in ranked if (f := figures[m]).recall_worlds]
    return DeployableCell(
        label,
        figures,
        paired_ranks(ranked, [v for v in verdicts if v.a in ranked and v.b in ranked]),
        max(halves) if halves else None,
        verdicts,
        floor,
    )


def deployable(
    scores: Sequence[PairScore],
    methods: Sequence[str],
    edges: Sequence[float],
    k_values: Sequence[int],
    target: float,
    level: float = 0.95,
    bound: float = HALF_WIDTH_BOUND,
    seed: int = 0,
    score: str = DEFAULT_SCORE,
) -> Deployable:
    """A level's deployable point as ``leaderboard.json`` holds it (see the module docstring).

    ``seed`` seeds the world bootstraps of the intervals; the verdicts draw nothing, and the bound's
    draws are made until it is decided. ``score``: the score thresholds are chosen on (``k_values`` are
    the thresholds of ``associations``; any other score's are the calibration pairs' own values).
    """
    worlds = sorted({_world(s) for s in scores})
    if len(worlds) < 2:
        return Deployable(target, worlds, note=single_world_note(len(worlds)))
    thresholds: dict[str, dict[str, int | float | None]] = {}
    deployed: dict[str, int | float | None] = {}
    ks = list(k_values) if score == DEFAULT_SCORE else None
    per_bin: list[tuple[str, dict[str, WorldCounts]]] = []
    for m in methods:
        o, heading = outcomes(scores, m, score)
        if len(o.score) == 0:
            continue
        res = held_out(o, ks, target)
        thresholds[m] = {w: t.k for w, t in res.thresholds.items()}
        deployed[m] = choose_threshold(o, ks, target).k
        masks = bin_masks(heading, edges)
        if not per_bin:
            per_bin = [(label, {}) for label, _ in masks]
        for (_, mask), (_, cell) in zip(masks, per_bin, strict=True):
            cell[m] = world_counts(o, res.positive, mask, worlds)
        log.info("deployable %s: thresholds %s, on every world %s", m, thresholds[m], deployed[m])
    rows = [_cell(label, counts, target, level, bound, seed) for label, counts in per_bin]
    return Deployable(
        target,
        worlds,
        thresholds=thresholds,
        deployed=deployed,
        min_hits=MIN_HITS,
        effect=EFFECT,
        transfers={m: f.transfers for m, f in rows[-1].methods.items()} if rows else {},
        spread={m: precision_spread(c, level) for m, c in per_bin[-1][1].items()} if per_bin else {},
        bins=rows[:-1],
        overall=rows[-1] if rows else None,
    )
