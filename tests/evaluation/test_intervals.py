"""Wilson and Student-t intervals against values computed by hand from their closed forms."""

from __future__ import annotations

import math

import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.intervals import mean_interval, wilson

Z = 1.959963984540054  # 97.5 % normal quantile


def _wilson_by_hand(k: int, n: int) -> tuple[float, float]:
    p = k / n
    centre = (p + Z * Z / (2 * n)) / (1 + Z * Z / n)
    half = Z / (1 + Z * Z / n) * math.sqrt(p * (1 - p) / n + Z * Z / (4 * n * n))
    return centre - half, centre + half


@pytest.mark.parametrize("k, n", [(1, 2), (0, 10), (10, 10), (33, 43), (7, 19)])
def test_wilson_matches_the_closed_form(k, n):
    lo, hi = wilson(k, n)
    assert (lo, hi) == pytest.approx(_wilson_by_hand(k, n), abs=1e-12)


def test_wilson_hand_values_and_edges():
    # 1 of 2: centre 0.5, half-width 1.96 / 5.8415 * sqrt(0.5 + 0.9604) = 0.4055
    assert wilson(1, 2) == pytest.approx((0.0945, 0.9055), abs=1e-4)
    # 0 of 10: the interval still has width (0 to 0.2775), unlike the normal approximation
    assert wilson(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson(0, 0) is None
    with pytest.raises(EvaluationError, match="successes"):
        wilson(3, 2)
    with pytest.raises(EvaluationError, match="level"):
        wilson(1, 2, level=1.0)


def test_mean_interval_hand_values():
    # mean 0.6, sd 0.1, t(0.975, 2 dof) = 4.302653: half-width 4.302653 * 0.1 / sqrt(3) = 0.248414
    mean, ci = mean_interval([0.5, 0.7, 0.6])
    assert mean == pytest.approx(0.6) and ci == pytest.approx((0.6 - 0.248414, 0.6 + 0.248414), abs=1e-6)
    assert mean_interval([0.4]) == (0.4, None)  # one seed: no spread to estimate
    assert mean_interval([]) == (None, None)
    assert mean_interval([0.2, None, float("nan"), 0.4])[0] == pytest.approx(0.3)
