"""Confidence intervals of the evaluation's proportions and of means over seeds.

- ``wilson``: the Wilson score interval of a proportion k / n (scipy's ``binomtest``), which
  stays inside [0, 1] and is sensible at k = 0 or k = n, where the normal approximation
  collapses to a point.
- ``mean_interval``: the mean of per-seed values and its Student-t interval (None with
  fewer than two values: one seed says nothing about seed-to-seed spread).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from roman_sim.core.errors import EvaluationError

#: A (low, high) interval, or None where it is undefined.
Interval = tuple[float, float] | None


def wilson(k: int, n: int, level: float = 0.95) -> tuple[float, float] | None:
    """Wilson score interval of ``k`` successes in ``n`` trials; None when ``n == 0``.

    Raises:
        EvaluationError: ``k`` outside ``0..n`` or ``level`` outside (0, 1).
    """
    if not 0 < level < 1:
        raise EvaluationError(f"interval level must lie in (0, 1), got {level}")
    if n == 0:
        return None
    if not 0 <= k <= n:
        raise EvaluationError(f"Wilson interval: {k} successes out of {n} trials")
    return _wilson(int(k), int(n), float(level))


@lru_cache(maxsize=4096)
def _wilson(k: int, n: int, level: float) -> tuple[float, float]:
    """``wilson`` of checked arguments; a run's metrics ask for the same few (k, n) many times."""
    from scipy import stats  # imported on first use: scipy.stats takes about a second to import

    ci = stats.binomtest(k, n).proportion_ci(confidence_level=level, method="wilson")
    return float(ci.low), float(ci.high)


def mean_interval(values: Sequence[float], level: float = 0.95) -> tuple[float | None, tuple[float, float] | None]:
    """(mean, Student-t interval of the mean) of the finite ``values``; (None, None) when empty."""
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=np.float64)
    if len(v) == 0:
        return None, None
    mean = float(v.mean())
    if len(v) < 2:
        return mean, None
    from scipy import stats

    half = float(stats.t.ppf(0.5 + level / 2, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v)))
    return mean, (mean - half, mean + half)
