"""Paired non-inferiority: the bound against Clopper-Pearson from the beta distribution, by hand."""

from __future__ import annotations

import pytest
from scipy.stats import beta

from roman_sim.evaluation.paired import compare_paired, loss_upper_bound


def _cp_upper(k: int, n: int, level: float) -> float:
    """One-sided Clopper-Pearson upper bound, from its textbook beta quantile."""
    return 1.0 if k == n else float(beta.ppf(level, k + 1, n - k))


@pytest.mark.parametrize(("worse", "better", "n"), [(5, 0, 15), (4, 0, 50), (10, 10, 300), (0, 0, 36), (6, 1, 51)])
def test_the_bound_is_the_product_of_two_exact_bounds(worse: int, better: int, n: int) -> None:
    m = worse + better
    q = _cp_upper(worse, m, 0.975) if m else 1.0
    want = max(0.0, _cp_upper(m, n, 0.975) * (2 * q - 1)) if q > 0.5 else 0.0
    assert loss_upper_bound(worse, better, n, 0.95) == pytest.approx(want, rel=1e-9)


def test_counts_loss_and_needed_sample() -> None:
    c = compare_paired([True] + [False] * 14, [True] * 6 + [False] * 9, 0.1, 0.95)
    assert (c.n, c.hits, c.baseline_hits, c.worse, c.better) == (15, 1, 6, 5, 0)
    assert c.loss == pytest.approx(5 / 15) and c.mcnemar_p == pytest.approx(0.5**5)
    assert not c.not_worse and c.needed is None  # the observed loss exceeds the margin: no sample shows it
    tie = compare_paired([True] * 3 + [False] * 12, [True] * 3 + [False] * 12, 0.1, 0.95)
    assert not tie.not_worse and tie.needed == 36  # 0 of 36 discordant: upper bound just below 0.1
    assert _cp_upper(0, 36, 0.975) <= 0.1 < _cp_upper(0, 35, 0.975)
    assert compare_paired([True] * 36, [True] * 36, 0.1, 0.95).not_worse
    with pytest.raises(ValueError, match="compare_paired: 2 outcomes against 3"):
        compare_paired([True, False], [True, True, False], 0.1, 0.95)
