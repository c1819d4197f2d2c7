"""Two methods compared on the same worlds and pairs: an exact paired test over worlds, and world intervals.

Two methods scored on the same relevant pairs of the same worlds differ world by world. The
difference of their pooled recalls is ``D = sum_w d_w / sum_w n_w`` with ``d_w = h_a,w - h_b,w``
(``h``: held-out hits, ``n``: relevant pairs of world ``w``). Pairs of one world share its
objects and its threshold, so the world, not the pair, is the independent unit; pairing
removes what the two methods share in a world (its size, its difficulty), which two separate
intervals keep.

The verdict comes from the exact sign-flip test over worlds (``paired_difference``): if the
two methods were exchangeable, each world's difference would be as likely ``+d_w`` as
``-d_w``; the exact distribution of ``sum_w +-d_w`` over the ``2^W`` signs is counted (the
differences are whole numbers of hits, so a convolution over their sums counts it exactly)
and the two-sided p-value is the share of sign choices at least as far from 0 as the observed
sum. Nothing is drawn at random, so no verdict depends on a seed.

- ``a ahead`` / ``b ahead``: p at most ``1 - level`` and the difference above / below 0.
- ``no difference shown``: p above it. With it comes the power to detect a true difference of
  ``effect`` (two-sided, normal approximation with the ratio's world-clustered standard
  error, ``sqrt(W / (W - 1) * sum_w (d_w - D n_w)^2) / sum_w n_w``) and the number of worlds
  that power ``POWER`` needs (the error shrinks as one over the square root of the worlds).
- ``too few hits``: both methods have fewer held-out hits than ``min_hits``: two floors
  compared say nothing.

``world_interval`` is the world bootstrap of a ratio of sums over worlds (a recall, a
precision): each draw takes as many worlds as there are, with replacement
(``rng.integers(0, n, (draws, n))`` of ``numpy.random.default_rng(seed)``, counted per
world), each drawn world's pairs kept whole; a draw without a denominator is left out; the
percentile interval of the draws (numpy's linear rule) is the interval. The draws are made in
batches: the Monte-Carlo error of each bound is the spread of that bound between ``BATCHES``
equal batches over the square root of their number. While the interval is within
``MC_MARGIN`` Monte-Carlo errors of a decision (``undecided``: a half-width near a bound), the
draws double, from ``MIN_DRAWS`` up to ``MAX_DRAWS``, so the decision does not depend on the
seed unless the half-width lies at the bound itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm

from roman_sim.core.errors import EvaluationError

#: Draws the bootstrap starts with, and the most it doubles to.
MIN_DRAWS = 20_000
MAX_DRAWS = 640_000
#: Batches the draws are split into to measure the Monte-Carlo error of the interval bounds.
BATCHES = 20
#: A bound this many Monte-Carlo errors from 0 or closer makes the draws double.
MC_MARGIN = 4.0
#: The effect size a level's worlds should detect, and the power they should have for it.
EFFECT = 0.05
POWER = 0.8
#: Held-out hits below which a method's figure is a floor, not a rank.
MIN_HITS = 10

Verdict = Literal["a ahead", "b ahead", "no difference shown", "too few hits"]


@dataclass(frozen=True)
class PairedDifference:
    """Method ``a`` against method ``b`` on the same worlds and relevant pairs.

    Attributes:
        hits_a, hits_b: held-out hits of each, pooled over the worlds.
        n_relevant: relevant pairs, pooled.
        n_worlds: worlds compared.
        diff: ``(hits_a - hits_b) / n_relevant``.
        p_value: the exact two-sided sign-flip p-value over worlds.
        se: the world-clustered standard error of ``diff``.
        power: the power to detect a true difference of ``effect`` at ``level``.
        worlds_for_power: worlds that power ``POWER`` for ``effect`` needs at this spread.
        detectable: the smallest true difference these worlds detect with power ``POWER`` (``detectable``).
        verdict: see the module docstring.
        level, effect: the test's level and the effect the power is for.
    """

    hits_a: int
    hits_b: int
    n_relevant: int
    n_worlds: int
    diff: float
    p_value: float
    se: float
    power: float
    worlds_for_power: int
    detectable: float
    verdict: Verdict
    level: float
    effect: float

    @property
    def powered(self) -> bool:
        """Whether the worlds had the power ``POWER`` to detect ``effect``."""
        return self.power >= POWER


def sign_flip_p(diffs: Sequence[int] | NDArray[np.float64]) -> float:
    """Exact two-sided p-value of ``sum(diffs)`` under random signs: the share of the ``2^W`` sign choices
    whose sum is at least as far from 0 (``diffs``: whole numbers, one per world)."""
    d = np.abs(np.rint(np.asarray(diffs, dtype=np.float64))).astype(np.int64)
    total = int(d.sum())
    observed = abs(int(np.rint(np.asarray(diffs, dtype=np.float64).sum())))
    if total == 0:
        return 1.0
    moving = d[d > 0]  # a world without a difference has the same sum under either sign
    counts = np.zeros(2 * total + 1, dtype=object)  # Python integers: 2^W exceeds int64 beyond 62 worlds
    counts[total] = 1
    for x in moving:
        counts = np.roll(counts, int(x)) + np.roll(counts, -int(x))
    sums = np.arange(-total, total + 1)
    extreme = int(counts[np.abs(sums) >= observed].sum())
    return extreme / 2 ** len(moving)


def clustered_se(d: NDArray[np.float64], n: NDArray[np.float64]) -> float:
    """The world-clustered standard error of ``sum(d) / sum(n)`` (0 with fewer than two worlds)."""
    w = len(d)
    if w < 2 or n.sum() <= 0:
        return 0.0
    ratio = d.sum() / n.sum()
    return float(math.sqrt(w / (w - 1) * float(((d - ratio * n) ** 2).sum())) / n.sum())


def power_for(effect: float, se: float, level: float) -> float:
    """Power of a two-sided test at ``level`` to detect a true difference ``effect`` with standard error ``se``."""
    if se <= 0:
        return 1.0
    z = norm.ppf(0.5 + level / 2)
    return float(norm.cdf(effect / se - z) + norm.cdf(-effect / se - z))


def detectable(power: float, se: float, level: float) -> float:
    """The smallest true difference a two-sided test at ``level`` detects with ``power`` when its standard error
    is ``se``: ``(z(1 - (1 - level) / 2) + z(power)) * se`` (the far tail left out, as in ``worlds_for``)."""
    return float((norm.ppf(0.5 + level / 2) + norm.ppf(power)) * se)


def worlds_for(power: float, effect: float, se: float, n_worlds: int, level: float) -> int:
    """Worlds a test needs for ``power`` against ``effect`` when ``n_worlds`` worlds give standard error ``se``."""
    target = effect / (norm.ppf(0.5 + level / 2) + norm.ppf(power))
    return max(2, math.ceil(n_worlds * (se / target) ** 2)) if se > 0 else 2


def _draw_stats(
    rng: np.random.Generator, num: NDArray[np.float64], den: NDArray[np.float64], draws: int
) -> NDArray[np.float64]:
    """``draws`` draws of ``sum(num) / sum(den)`` over worlds drawn with replacement; a draw whose ``den``
    sums to 0 (no relevant pair, no positive) has no ratio and is left out."""
    n = len(num)
    picks = rng.integers(0, n, (draws, n))  # each draw: n worlds drawn with replacement
    w = np.bincount((picks + n * np.arange(draws)[:, None]).ravel(), minlength=draws * n).reshape(draws, n)
    top, bottom = w @ num, w @ den
    return top[bottom > 0] / bottom[bottom > 0]


def _bounds(stats: NDArray[np.float64], level: float) -> tuple[float, float, float]:
    """The percentile interval of ``stats`` and the Monte-Carlo error of its bounds (over ``BATCHES``)."""
    q = [(1 - level) / 2, 1 - (1 - level) / 2]
    lo, hi = np.quantile(stats, q)
    batches = np.array_split(stats, BATCHES)
    per = np.array([np.quantile(b, q) for b in batches])
    err = float(per.std(axis=0, ddof=1).max() / math.sqrt(BATCHES))
    return float(lo), float(hi), err


@dataclass(frozen=True)
class WorldInterval:
    """A world bootstrap's percentile interval of a ratio of sums over worlds.

    Attributes:
        low, high: the interval at its level.
        se: the standard deviation of the draws.
        draws: the draws made.
        mc_error: the Monte-Carlo error of the bounds (the larger of the two).
    """

    low: float
    high: float
    se: float
    draws: int
    mc_error: float

    @property
    def half_width(self) -> float:
        """Half the interval's width."""
        return (self.high - self.low) / 2


def world_interval(
    num: Sequence[float] | NDArray[np.float64],
    den: Sequence[float] | NDArray[np.float64],
    *,
    level: float = 0.95,
    seed: int = 0,
    undecided: Callable[[float, float, float], bool] | None = None,
) -> WorldInterval | None:
    """The world bootstrap of ``sum(num) / sum(den)`` (one entry per world), with draws made until decided.

    None with fewer than two worlds or when ``den`` is 0 in every world.

    ``undecided(low, high, mc_error)`` says whether the interval is still too close to a
    decision for its Monte-Carlo error (a bound near 0, a half-width near a bound); while it
    is, the draws double, from ``MIN_DRAWS`` up to ``MAX_DRAWS``.
    """
    n, d = np.asarray(num, dtype=np.float64), np.asarray(den, dtype=np.float64)
    if len(n) != len(d) or len(n) < 2 or not np.any(d > 0):
        return None
    rng = np.random.default_rng(seed)
    stats = _draw_stats(rng, n, d, MIN_DRAWS)
    draws = MIN_DRAWS
    lo, hi, err = _bounds(stats, level)
    while undecided is not None and draws < MAX_DRAWS and undecided(lo, hi, err):
        stats = np.concatenate([stats, _draw_stats(rng, n, d, draws)])
        draws *= 2
        lo, hi, err = _bounds(stats, level)
    return WorldInterval(lo, hi, float(stats.std(ddof=1)), draws, err)


def near_half_width(bound: float) -> Callable[[float, float, float], bool]:
    """Whether an interval's half-width lies within ``MC_MARGIN`` Monte-Carlo errors of ``bound``."""
    return lambda low, high, err: err > 0 and abs((high - low) / 2 - bound) <= MC_MARGIN * err


def paired_difference(
    hits_a: Sequence[int] | NDArray[np.float64],
    hits_b: Sequence[int] | NDArray[np.float64],
    relevant: Sequence[int] | NDArray[np.float64],
    *,
    level: float = 0.95,
    effect: float = EFFECT,
    min_hits: int = MIN_HITS,
) -> PairedDifference:
    """Compare two methods' held-out hits world by world (the same worlds, in the same order).

    Args:
        hits_a: method ``a``'s held-out hits in each world.
        hits_b: method ``b``'s held-out hits in each world.
        relevant: relevant pairs in each world (the same pairs for both methods).
        level: the test's level (a verdict needs p at most ``1 - level``).
        effect: the difference the power is stated for.
        min_hits: held-out hits below which a method is a floor (both below: ``too few hits``).

    Raises:
        EvaluationError: sequences of different lengths, fewer than two worlds, or hits
            outside ``0..relevant``.
    """
    a = np.asarray(hits_a, dtype=np.float64)
    b = np.asarray(hits_b, dtype=np.float64)
    n = np.asarray(relevant, dtype=np.float64)
    if not len(a) == len(b) == len(n):
        raise EvaluationError(f"paired difference: {len(a)}, {len(b)} and {len(n)} worlds given")
    if len(n) < 2:
        raise EvaluationError(f"paired difference: needs at least two worlds, got {len(n)}")
    if np.any(a < 0) or np.any(b < 0) or np.any(a > n) or np.any(b > n):
        raise EvaluationError("paired difference: hits outside 0..relevant in some world")
    total = float(n.sum())
    diff = float((a.sum() - b.sum()) / total) if total else 0.0
    p = sign_flip_p(a - b)
    se = clustered_se(a - b, n)
    verdict: Verdict
    if a.sum() < min_hits and b.sum() < min_hits:
        verdict = "too few hits"
    elif p <= 1 - level and diff != 0:
        verdict = "a ahead" if diff > 0 else "b ahead"
    else:
        verdict = "no difference shown"
    return PairedDifference(
        hits_a=int(a.sum()),
        hits_b=int(b.sum()),
        n_relevant=int(total),
        n_worlds=len(n),
        diff=diff,
        p_value=p,
        se=se,
        power=power_for(effect, se, level),
        worlds_for_power=worlds_for(POWER, effect, se, len(n), level),
        detectable=detectable(POWER, se, level),
        verdict=verdict,
        level=level,
        effect=effect,
    )


__all__ = [
    "EFFECT",
    "MAX_DRAWS",
    "MIN_DRAWS",
    "MIN_HITS",
    "POWER",
    "PairedDifference",
    "Verdict",
    "WorldInterval",
    "near_half_width",
    "clustered_se",
    "detectable",
    "paired_difference",
    "power_for",
    "sign_flip_p",
    "world_interval",
    "worlds_for",
]
