"""Two methods compared on the same worlds and pairs: a world bootstrap of the paired difference.

Two methods scored on the same relevant pairs of the same worlds differ world by world. The
statistic is the difference of their pooled recalls, ``D = sum_w (h_a,w - h_b,w) / sum_w n_w``
(``h``: held-out hits, ``n``: relevant pairs of world ``w``). Its interval comes from a
bootstrap over worlds: worlds are drawn with replacement (multinomial weights), both
methods keep their outcomes in each drawn world, and ``D`` is recomputed; the percentile
interval of the draws is the interval. Pairs of one world share its objects and its
threshold, so the world, not the pair, is the independent unit; pairing removes what the
two methods share in a world (its size, its difficulty), which separate intervals keep.

Verdicts do not move with the bootstrap's seed. The draws are made in batches, and the
Monte-Carlo error of each interval bound is the spread of the bound between batches over
the square root of their number. While a bound lies within ``MC_MARGIN`` Monte-Carlo errors
of 0, the draws are doubled, up to ``MAX_DRAWS``; a bound still that close then is reported
as undecided (``no difference shown``). Starting from ``MIN_DRAWS`` draws, two seeds put a
bound on different sides of 0 only when it lies within a few Monte-Carlo errors of 0, which
the doubling rules out.

Verdicts, for methods ``a`` and ``b``:

- ``a ahead`` / ``b ahead``: the interval lies above / below 0 (by more than ``MC_MARGIN``
  Monte-Carlo errors).
- ``no difference shown``: the interval holds 0. With it comes the power to detect a true
  difference of ``effect`` (two-sided, normal approximation with the bootstrap's standard
  error) and the number of worlds that power 0.8 needs (the error shrinks as one over the
  square root of the worlds).
- ``too few hits``: both methods have fewer held-out hits than ``min_hits``: two floors
  compared say nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm

from roman_sim.core.errors import EvaluationError

#: Draws the bootstrap starts with, and the most it doubles to.
MIN_DRAWS = 40_000
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
        interval: the bootstrap's percentile interval of ``diff`` at ``level``.
        se: the standard deviation of the bootstrap draws (the standard error of ``diff``).
        draws: bootstrap draws made.
        mc_error: Monte-Carlo error of the interval bounds (the larger of the two).
        power: the power to detect a true difference of ``effect`` at ``level``.
        worlds_for_power: worlds that power ``POWER`` for ``effect`` needs at this spread.
        verdict: see the module docstring.
        level, effect: the interval's level and the effect the power is for.
    """

    hits_a: int
    hits_b: int
    n_relevant: int
    n_worlds: int
    diff: float
    interval: tuple[float, float]
    se: float
    draws: int
    mc_error: float
    power: float
    worlds_for_power: int
    verdict: Verdict
    level: float
    effect: float

    @property
    def powered(self) -> bool:
        """Whether the worlds had the power ``POWER`` to detect ``effect``."""
        return self.power >= POWER


def power_for(effect: float, se: float, level: float) -> float:
    """Power of a two-sided test at ``level`` to detect a true difference ``effect`` with standard error ``se``."""
    if se <= 0:
        return 1.0
    z = norm.ppf(0.5 + level / 2)
    return float(norm.cdf(effect / se - z) + norm.cdf(-effect / se - z))


def worlds_for(power: float, effect: float, se: float, n_worlds: int, level: float) -> int:
    """Worlds a test needs for ``power`` against ``effect`` when ``n_worlds`` worlds give standard error ``se``."""
    target = effect / (norm.ppf(0.5 + level / 2) + norm.ppf(power))
    return max(2, math.ceil(n_worlds * (se / target) ** 2)) if se > 0 else 2


def _draw_stats(
    rng: np.random.Generator, d: NDArray[np.float64], n: NDArray[np.float64], draws: int
) -> NDArray[np.float64]:
    """``draws`` values of the paired difference over worlds drawn with replacement."""
    w = rng.multinomial(len(d), np.full(len(d), 1.0 / len(d)), size=draws).astype(np.float64)
    den = w @ n
    num = w @ d
    # a draw of worlds without a relevant pair has no recall: it counts as no difference
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def _bounds(stats: NDArray[np.float64], level: float) -> tuple[float, float, float]:
    """The percentile interval of ``stats`` and the Monte-Carlo error of its bounds (over ``BATCHES``)."""
    q = [(1 - level) / 2, 1 - (1 - level) / 2]
    lo, hi = np.quantile(stats, q)
    batches = np.array_split(stats, BATCHES)
    per = np.array([np.quantile(b, q) for b in batches])
    err = float(per.std(axis=0, ddof=1).max() / math.sqrt(BATCHES))
    return float(lo), float(hi), err


def paired_difference(
    hits_a: Sequence[int],
    hits_b: Sequence[int],
    relevant: Sequence[int],
    *,
    level: float = 0.95,
    effect: float = EFFECT,
    min_hits: int = MIN_HITS,
    seed: int = 0,
) -> PairedDifference:
    """Compare two methods' held-out hits world by world (the same worlds, in the same order).

    Args:
        hits_a: method ``a``'s held-out hits in each world.
        hits_b: method ``b``'s held-out hits in each world.
        relevant: relevant pairs in each world (the same pairs for both methods).
        level: the interval's level.
        effect: the difference the power is stated for.
        min_hits: held-out hits below which a method is a floor (both below: ``too few hits``).
        seed: the bootstrap's seed (verdicts do not depend on it; see the module docstring).

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
    rng = np.random.default_rng(seed)
    d = a - b
    stats = _draw_stats(rng, d, n, MIN_DRAWS)
    lo, hi, err = _bounds(stats, level)
    while len(stats) < MAX_DRAWS and (abs(lo) <= MC_MARGIN * err or abs(hi) <= MC_MARGIN * err):
        stats = np.concatenate([stats, _draw_stats(rng, d, n, len(stats))])
        lo, hi, err = _bounds(stats, level)
    se = float(stats.std(ddof=1))
    power = power_for(effect, se, level)
    verdict: Verdict
    if a.sum() < min_hits and b.sum() < min_hits:
        verdict = "too few hits"
    elif lo > MC_MARGIN * err:
        verdict = "a ahead"
    elif hi < -MC_MARGIN * err:
        verdict = "b ahead"
    else:
        verdict = "no difference shown"
    return PairedDifference(
        hits_a=int(a.sum()),
        hits_b=int(b.sum()),
        n_relevant=int(total),
        n_worlds=len(n),
        diff=diff,
        interval=(lo, hi),
        se=se,
        draws=len(stats),
        mc_error=err,
        power=power,
        worlds_for_power=worlds_for(POWER, effect, se, len(n), level),
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
    "paired_difference",
    "power_for",
    "worlds_for",
]
