"""The beta-binomial spread of precision over worlds: a maximum of the likelihood, and its figures by hand."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from roman_sim.benchmark.world_spread import CONCENTRATION_BOUNDS, MEAN_BOUNDS, WorldSpread, fit_spread

HITS = [45, 30, 20, 9, 50, 12]
ACCEPTED = [50, 40, 20, 12, 60, 20]


def _loglik(a: float, b: float, hits: list[int], accepted: list[int]) -> float:
    """The log-likelihood by scipy's beta-binomial pmf (binomial coefficients included: the same up to a constant)."""
    return float(stats.betabinom.logpmf(hits, accepted, a, b).sum())


def test_the_fit_is_the_likelihoods_maximum_over_a_grid():
    fit = fit_spread(HITS, ACCEPTED)
    assert fit is not None and fit.worlds == 6
    best = _loglik(fit.a, fit.b, HITS, ACCEPTED)
    grid = [
        (_loglik(m * c, (1 - m) * c, HITS, ACCEPTED), m, c)
        for m in np.linspace(0.6, 0.99, 79)
        for c in np.geomspace(0.5, 1e4, 81)
    ]
    top, m_top, c_top = max(grid)
    assert best >= top - 1e-6  # no grid point beats the fit
    assert fit.mean == pytest.approx(m_top, abs=0.01)  # the grid's step in the mean is 0.005
    assert np.log(fit.a + fit.b) == pytest.approx(np.log(c_top), abs=0.2)  # grid step 0.12 in log c


def test_worlds_that_agree_give_one_rate():
    """Five worlds at 90 of 100: no spread beyond their counts. The concentration goes to its bound, the mean is
    the shared rate, and a new world's precision is that rate."""
    fit = fit_spread([90] * 5, [100] * 5)
    assert fit is not None
    assert fit.a + fit.b == pytest.approx(CONCENTRATION_BOUNDS[1], rel=1e-3)
    assert fit.mean == pytest.approx(0.9, abs=1e-3)
    assert fit.share(0.88) > 0.99 and fit.share(0.92) < 0.01
    lo, hi = fit.interval(0.95)
    assert 0.89 < lo < 0.9 < hi < 0.91


def test_worlds_that_disagree_spread_a_new_world():
    """Three worlds at 100 of 100 and three at 70 of 100: a new world may be either, so far fewer than all new
    worlds reach 0.9 although the pooled precision (0.85) is near it, and the interval spans both groups."""
    fit = fit_spread([100, 100, 100, 70, 70, 70], [100] * 6)
    assert fit is not None
    assert fit.mean == pytest.approx(0.85, abs=0.05)
    assert fit.share(0.9) < 0.75  # half the worlds are at 0.7
    lo, hi = fit.interval(0.95)
    assert lo < 0.7 and hi > 0.99


def test_no_false_positive_anywhere_puts_every_world_at_one():
    fit = fit_spread([12, 7, 30], [12, 7, 30])
    assert fit is not None and fit.mean == pytest.approx(MEAN_BOUNDS[1])
    assert fit.share(0.85) > 0.999


def test_too_few_worlds_with_a_pair_give_no_fit():
    assert fit_spread([5], [6]) is None
    assert fit_spread([5, 0, 0], [6, 0, 0]) is None  # worlds without an accepted pair say nothing
    fit = fit_spread([5, 0, 4], [6, 0, 5])
    assert fit is not None and fit.worlds == 2


def test_figures_of_a_uniform_spread_by_hand():
    """Beta(1, 1): a new world's precision is uniform on [0, 1] (share at 0.9 = 0.1, central 95 % = [0.025,
    0.975]); its hits out of 49 pairs are uniform on 0..49 (cdf (k + 1) / 50): the 2.5 % point is the smallest k
    with (k + 1) / 50 >= 0.025, 1, the 97.5 % point the smallest with (k + 1) / 50 >= 0.975, 48."""
    u = WorldSpread(1.0, 1.0, 3)
    assert u.mean == 0.5
    assert u.share(0.9) == pytest.approx(0.1)
    assert u.interval(0.95) == pytest.approx((0.025, 0.975))
    assert u.hits_interval(49) == (1, 48)
