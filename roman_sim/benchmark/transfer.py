"""Figures that hold in the next world: thresholds chosen on other worlds, intervals over worlds.

A recall "at precision >= 0.9" read off one world's own precision-recall sweep is an oracle:
the threshold that reaches the target is chosen with the truth of the very pairs it is
scored on, and per heading bin with a truth no robot has before it aligns a pair. Here:

- ``choose_threshold``: the smallest association threshold ``k`` whose pooled precision
  over *all* headings of the calibration pairs reaches the target (one setting for every
  heading, as a deployed system runs); exact in integers (TP * q >= p * (TP + FP)).
- ``held_out``: leave-one-world-out cross-validation. Each world's pairs are scored at the
  threshold chosen on the *other* worlds only; the chosen thresholds and the held-out
  positives are returned, so recall and precision are what a new world would give.
- ``world_bootstrap``: a two-stage cluster bootstrap of a ratio (recall or precision):
  resample worlds with replacement, then the robot pairs within each drawn world. Submap
  pairs of one robot pair, and robot pairs of one world, are not independent draws; a
  Wilson interval that treats them so is too narrow when worlds disagree.
- ``world_precisions`` and ``new_world_interval``: what *one* new world gives. The bootstrap
  interval is one of the pooled ratio over as many worlds as were seen; one new world's
  precision varies more: by the world (the spread between the held-out worlds) and by its
  own few positives (its Wilson interval). The new-world interval is the hull of every
  held-out world's Wilson interval and the pooled interval. With n exchangeable worlds the
  range of n draws covers the next with probability (n - 1) / (n + 1) only (one half at
  three worlds): a statement about a new world needs worlds, not pairs.

Thresholds follow the pairs' rule: a pair is positive when its score (the number of
associations, or a method's named score: ``roman-sim benchmark --score``) is at least ``k``;
TP = relevant, positive and correct; FP = positive and not correct (see
``roman_sim.evaluation.operating_points``).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError

log = logging.getLogger(__name__)

#: Held-out precision may fall this far below the target before a method is flagged.
PRECISION_SLACK = 0.05


@dataclass(frozen=True)
class PairOutcomes:
    """One method's submap pairs, as parallel arrays of length n.

    Attributes:
        world: (n,) world (scenario seed) id of each pair.
        cluster: (n,) robot-pair id within its world (e.g. ``"r00|r03"``).
        relevant: (n,) whether the pair should align (truth).
        correct: (n,) whether the method's registration is correct (truth).
        score: (n,) the method's score (the number of associations, or a named score); positive when
            >= k; ``-inf`` for a pair without the score (accepted at no threshold).
    """

    world: NDArray[np.str_]
    cluster: NDArray[np.str_]
    relevant: NDArray[np.bool_]
    correct: NDArray[np.bool_]
    score: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = len(self.world)
        for name in ("cluster", "relevant", "correct", "score"):
            if len(getattr(self, name)) != n:
                raise ConfigError(f"pair outcomes: '{name}' has {len(getattr(self, name))} entries, expected {n}")

    @classmethod
    def from_lists(
        cls,
        world: Sequence[str],
        cluster: Sequence[str],
        relevant: Sequence[bool],
        correct: Sequence[bool],
        score: Sequence[float],
    ) -> PairOutcomes:
        """Outcomes from plain sequences (one entry per submap pair)."""
        return cls(
            np.asarray(world, dtype=np.str_),
            np.asarray(cluster, dtype=np.str_),
            np.asarray(relevant, dtype=np.bool_),
            np.asarray(correct, dtype=np.bool_),
            np.asarray(score, dtype=np.float64),
        )

    def subset(self, mask: NDArray[np.bool_]) -> PairOutcomes:
        """The pairs where ``mask`` holds."""
        return PairOutcomes(
            self.world[mask], self.cluster[mask], self.relevant[mask], self.correct[mask], self.score[mask]
        )

    def worlds(self) -> list[str]:
        """The distinct worlds, sorted."""
        return sorted({str(w) for w in self.world})


@dataclass(frozen=True)
class Threshold:
    """A threshold chosen for a target precision on calibration pairs.

    Attributes:
        k: the threshold (an int of the association sweep, a float of a named score), or None when no
            threshold reaches the target (nothing accepted).
        tp, fp: true and false positives at ``k`` on the calibration pairs (0, 0 when None).
    """

    k: int | float | None
    tp: int
    fp: int

    @property
    def reached(self) -> bool:
        """Whether some threshold reached the target on the calibration pairs."""
        return self.k is not None


def check_target(target: float) -> Fraction:
    """The target precision as an exact fraction; it must lie in (0, 1]."""
    if not (isinstance(target, (int, float)) and 0 < float(target) <= 1):
        raise ConfigError(f"target precision: must lie in (0, 1], got {target!r}")
    return Fraction(str(float(target))).limit_denominator(10_000)


def positives(o: PairOutcomes, k: float | None) -> NDArray[np.bool_]:
    """(n,) whether each pair is accepted at threshold ``k`` (None accepts nothing)."""
    if k is None:
        return np.zeros(len(o.score), dtype=np.bool_)
    return o.score >= k


def counts(o: PairOutcomes, positive: NDArray[np.bool_]) -> tuple[int, int, int]:
    """(true positives, false positives, relevant pairs) of ``positive`` over ``o``."""
    tp = int(np.count_nonzero(positive & o.relevant & o.correct))
    fp = int(np.count_nonzero(positive & ~o.correct))
    return tp, fp, int(np.count_nonzero(o.relevant))


def own_values(o: PairOutcomes) -> list[float]:
    """The distinct finite scores of ``o``, ascending: the thresholds a named score is swept over."""
    return [float(v) for v in np.unique(o.score[np.isfinite(o.score)])]


def choose_threshold(o: PairOutcomes, k_values: Sequence[float] | None, target: float) -> Threshold:
    """The smallest threshold of ``k_values`` (None: the calibration pairs' own values, ``own_values``) whose
    pooled precision on ``o`` reaches ``target``; an int of ``k_values`` stays an int.

    True positives only fall as the threshold rises, so the smallest such one keeps the most recall.
    A threshold with no positive at all does not reach any target.
    """
    t = check_target(target)
    ks = own_values(o) if k_values is None else sorted(k_values)
    at = np.asarray(ks, dtype=np.float64)
    hits = np.sort(o.score[o.relevant & o.correct])
    wrong = np.sort(o.score[~o.correct])
    tp = len(hits) - np.searchsorted(hits, at, side="left")  # pairs with score >= each threshold
    fp = len(wrong) - np.searchsorted(wrong, at, side="left")
    ok = np.flatnonzero((tp + fp > 0) & (tp * t.denominator >= t.numerator * (tp + fp)))
    if not len(ok):
        return Threshold(None, 0, 0)
    i = int(ok[0])
    return Threshold(ks[i], int(tp[i]), int(fp[i]))


@dataclass(frozen=True)
class HeldOut:
    """Leave-one-world-out result.

    Attributes:
        thresholds: world -> the threshold chosen on every *other* world.
        positive: (n,) whether each pair is accepted at its own world's held-out threshold.
    """

    thresholds: dict[str, Threshold]
    positive: NDArray[np.bool_]


def held_out(o: PairOutcomes, k_values: Sequence[float] | None, target: float) -> HeldOut:
    """Score each world at the threshold chosen on the other worlds (needs two worlds or more); ``k_values``
    None: each choice among its calibration pairs' own values (``choose_threshold``)."""
    check_target(target)
    worlds = o.worlds()
    if len(worlds) < 2:
        raise ConfigError(
            f"held-out thresholds: need at least two worlds to split into calibration and held-out, got {len(worlds)}"
        )
    positive = np.zeros(len(o.score), dtype=np.bool_)
    chosen: dict[str, Threshold] = {}
    for w in worlds:
        own = o.world == w
        th = choose_threshold(o.subset(~own), k_values, target)
        chosen[w] = th
        positive[own] = positives(o.subset(own), th.k)
        log.debug("world %s: threshold %s chosen on the other %d worlds", w, th.k, len(worlds) - 1)
    return HeldOut(chosen, positive)


def transfers(precision: float | None, target: float) -> bool:
    """Whether a held-out precision is within ``PRECISION_SLACK`` of the target (None: nothing accepted)."""
    return precision is None or precision >= float(check_target(target)) - PRECISION_SLACK


def _cluster_totals(
    o: PairOutcomes, positive: NDArray[np.bool_]
) -> tuple[list[str], NDArray[np.int64], NDArray[np.float64]]:
    """Per (world, robot pair): world id, and counts [tp, fp, relevant] as a (c, 3) array."""
    # (world, robot pair) as a tuple: a separator character inside numpy strings could be lost
    # (numpy drops trailing NULs) and merge or split worlds
    keys = sorted({(str(w), str(c)) for w, c in zip(o.world, o.cluster, strict=True)})
    at = {k: i for i, k in enumerate(keys)}
    inv = np.asarray([at[(str(w), str(c))] for w, c in zip(o.world, o.cluster, strict=True)], dtype=np.int64)
    tot = np.zeros((len(keys), 3))
    np.add.at(tot[:, 0], inv, (positive & o.relevant & o.correct).astype(np.float64))
    np.add.at(tot[:, 1], inv, (positive & ~o.correct).astype(np.float64))
    np.add.at(tot[:, 2], inv, o.relevant.astype(np.float64))
    worlds = [w for w, _ in keys]
    return worlds, inv, tot


def world_bootstrap(
    o: PairOutcomes,
    positive: NDArray[np.bool_],
    stat: str = "recall",
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> tuple[float, float] | None:
    """Percentile interval of recall (TP / relevant) or precision (TP / (TP + FP)) over worlds.

    Two stages: draw as many worlds as there are, with replacement; within each drawn world
    draw as many robot pairs as it has, with replacement; the statistic is the ratio of the
    summed counts. Draws whose denominator is 0 are left out; None when every draw is.
    """
    if stat not in ("recall", "precision"):
        raise ConfigError(f"bootstrap statistic: expected 'recall' or 'precision', got {stat!r}")
    if not 0 < level < 1:
        raise ConfigError(f"interval level: must lie in (0, 1), got {level}")
    if len(o.score) == 0:
        return None
    worlds, _, tot = _cluster_totals(o, positive)
    num = tot[:, 0]
    den = tot[:, 2] if stat == "recall" else tot[:, 0] + tot[:, 1]
    names = sorted(set(worlds))
    members = [np.flatnonzero(np.asarray(worlds) == w) for w in names]
    rng = np.random.default_rng(seed)
    # stage 1: (n_boot, n_worlds) drawn worlds; stage 2: for each draw slot and world, its robot
    # pairs drawn with replacement (drawn for every world, used where that world was drawn)
    drawn = rng.integers(0, len(names), (n_boot, len(names)))
    n_sum = np.zeros(n_boot)
    d_sum = np.zeros(n_boot)
    for slot in range(len(names)):
        for wi, mem in enumerate(members):
            idx = mem[rng.integers(0, len(mem), (n_boot, len(mem)))]
            use = drawn[:, slot] == wi
            n_sum += np.where(use, num[idx].sum(axis=1), 0.0)
            d_sum += np.where(use, den[idx].sum(axis=1), 0.0)
    ratios = np.full(n_boot, np.nan)
    np.divide(n_sum, d_sum, out=ratios, where=d_sum > 0)
    ok = ratios[np.isfinite(ratios)]
    if len(ok) == 0:
        return None
    a = (1 - level) / 2
    return float(np.quantile(ok, a)), float(np.quantile(ok, 1 - a))


@dataclass(frozen=True)
class WorldPrecision:
    """One world's precision at its positives, with the Wilson interval of its own counts.

    Attributes:
        world: the world id.
        hits, false_positives: its true and false positives.
        precision: hits / (hits + false positives); None without a positive.
        wilson: the Wilson interval of that ratio; None without a positive.
    """

    world: str
    hits: int
    false_positives: int
    precision: float | None
    wilson: tuple[float, float] | None


def world_precisions(o: PairOutcomes, positive: NDArray[np.bool_], level: float = 0.95) -> list[WorldPrecision]:
    """Per world of ``o`` (sorted) its precision at ``positive`` and that ratio's Wilson interval."""
    from roman_sim.evaluation.intervals import wilson

    out = []
    for w in o.worlds():
        own = o.world == w
        tp, fp, _ = counts(o.subset(own), positive[own])
        out.append(WorldPrecision(w, tp, fp, tp / (tp + fp) if tp + fp else None, wilson(tp, tp + fp, level)))
    return out


def new_world_interval(
    per_world: Sequence[WorldPrecision], pooled: tuple[float, float] | None
) -> tuple[float, float] | None:
    """The hull of each world's Wilson interval and the ``pooled`` interval (None: no world has a positive)."""
    got = [p.wilson for p in per_world if p.wilson is not None]
    if pooled is not None:
        got.append(pooled)
    if not got:
        return None
    return min(lo for lo, _ in got), max(hi for _, hi in got)


@dataclass(frozen=True)
class HeldOutCell:
    """Held-out recall and precision of one heading bin, with pooled and world-bootstrap intervals.

    Attributes:
        label: the bin (``"0-60"``; ``"all"`` for every heading).
        hits, false_positives, n_relevant: held-out counts in the bin.
        recall, recall_wilson, recall_worlds: hits / relevant, its pooled Wilson interval and
            its world-bootstrap interval (None without relevant pairs).
        precision, precision_worlds: hits / (hits + false positives) and its world-bootstrap
            interval (None without a positive).
    """

    label: str
    hits: int
    false_positives: int
    n_relevant: int
    recall: float | None
    recall_wilson: tuple[float, float] | None
    recall_worlds: tuple[float, float] | None
    precision: float | None
    precision_worlds: tuple[float, float] | None


def held_out_cell(
    label: str,
    o: PairOutcomes,
    positive: NDArray[np.bool_],
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> HeldOutCell:
    """The ``HeldOutCell`` of ``positive`` over the pairs ``o``, named ``label``."""
    from roman_sim.evaluation.intervals import wilson

    tp, fp, rel = counts(o, positive)
    return HeldOutCell(
        label=label,
        hits=tp,
        false_positives=fp,
        n_relevant=rel,
        recall=tp / rel if rel else None,
        recall_wilson=wilson(tp, rel, level),
        recall_worlds=world_bootstrap(o, positive, "recall", n_boot, level, seed) if rel else None,
        precision=tp / (tp + fp) if tp + fp else None,
        precision_worlds=world_bootstrap(o, positive, "precision", n_boot, level, seed) if tp + fp else None,
    )


def held_out_cells(
    o: PairOutcomes,
    positive: NDArray[np.bool_],
    heading_deg: NDArray[np.float64],
    edges: Sequence[float],
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> list[HeldOutCell]:
    """One ``HeldOutCell`` per heading bin of ``edges`` (bins as ``roman_sim.evaluation.bins``), then ``"all"``."""
    from roman_sim.evaluation.bins import bin_index, bin_label

    idx = bin_index(heading_deg, edges)
    masks = [(bin_label(edges[i], edges[i + 1]), idx == i) for i in range(len(edges) - 1)]
    masks.append(("all", np.ones(len(idx), dtype=np.bool_)))
    return [held_out_cell(label, o.subset(m), positive[m], n_boot, level, seed) for label, m in masks]
