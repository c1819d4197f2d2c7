"""The paired world bootstrap: verdicts by hand, against scipy's bootstrap, and stable under its seed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.paired_worlds import (
    EFFECT,
    MIN_DRAWS,
    paired_difference,
    power_for,
    worlds_for,
)


def test_a_method_ahead_in_every_world_is_ahead_and_the_reverse():
    a, b, n = [8, 9, 7, 10, 6, 9], [2, 3, 1, 4, 2, 3], [20, 20, 18, 22, 15, 20]
    res = paired_difference(a, b, n)
    assert res.verdict == "a ahead" and res.diff == pytest.approx((49 - 15) / 115)
    assert res.hits_a == 49 and res.hits_b == 15 and res.n_relevant == 115 and res.n_worlds == 6
    assert res.interval[0] > 0 and res.draws == MIN_DRAWS  # far from 0: no doubling
    assert paired_difference(b, a, n).verdict == "b ahead"


def test_equal_methods_show_no_difference_and_floors_say_so():
    a = [5, 6, 4, 7, 5, 6, 3, 5]
    n = [30] * 8
    same = paired_difference(a, a, n)
    assert same.verdict == "no difference shown" and same.diff == 0 and same.interval == (0.0, 0.0)
    floors = paired_difference([1, 0, 2, 0, 1, 0], [0, 1, 0, 1, 0, 2], [10] * 6)
    assert floors.verdict == "too few hits"  # 4 and 4 hits: both below the floor of 10
    one_floor = paired_difference([9, 8, 10, 7, 9, 8], [0, 1, 0, 0, 1, 0], [12] * 6)
    assert one_floor.verdict == "a ahead"  # a floor against a method with hits is still a finding


def test_the_interval_is_scipys_paired_bootstrap_of_the_ratio():
    rng = np.random.default_rng(3)
    n = rng.integers(10, 40, size=12)
    a = rng.binomial(n, 0.5)
    b = rng.binomial(n, 0.4)
    res = paired_difference(a, b, n, seed=1)
    boot = stats.bootstrap(
        (a - b, n),
        lambda d, m, axis=-1: d.sum(axis=axis) / m.sum(axis=axis),
        paired=True,
        vectorized=True,
        n_resamples=200_000,
        method="percentile",
        random_state=np.random.default_rng(2),
    )
    ref = boot.confidence_interval
    assert res.interval[0] == pytest.approx(ref.low, abs=3e-3)
    assert res.interval[1] == pytest.approx(ref.high, abs=3e-3)
    assert res.se == pytest.approx(boot.standard_error, rel=0.02)


def test_verdicts_do_not_move_with_the_seed():
    """Random worlds, many of them near the edge of a verdict: the same verdict under 20 seeds."""
    rng = np.random.default_rng(11)
    cases = []
    for _ in range(25):
        worlds = int(rng.integers(4, 20))
        n = rng.integers(5, 40, size=worlds)
        p = rng.uniform(0.05, 0.6)
        a = rng.binomial(n, p)
        b = rng.binomial(n, np.clip(p + rng.normal(0, 0.08), 0, 1))
        cases.append((a, b, n))
    kinds = set()
    for a, b, n in cases:
        verdicts = {paired_difference(a, b, n, seed=s).verdict for s in range(20)}
        assert len(verdicts) == 1, (a.tolist(), b.tolist(), n.tolist(), verdicts)
        kinds |= verdicts
    assert {"a ahead", "b ahead", "no difference shown"} <= kinds  # the cases reach every verdict


def test_power_and_worlds_needed_by_hand():
    z = stats.norm.ppf(0.975) + stats.norm.ppf(0.8)
    se80 = EFFECT / z  # the standard error at which a 0.05 difference is found 80 % of the time
    assert power_for(EFFECT, se80, 0.95) == pytest.approx(0.8 + stats.norm.cdf(-EFFECT / se80 - 1.959964), abs=1e-9)
    assert worlds_for(0.8, EFFECT, se80, 10, 0.95) == 10
    assert worlds_for(0.8, EFFECT, 2 * se80, 10, 0.95) == 40  # twice the error: four times the worlds
    res = paired_difference([5, 6, 4, 7], [5, 5, 5, 6], [30, 30, 30, 30])
    assert res.worlds_for_power == worlds_for(0.8, EFFECT, res.se, 4, 0.95)
    assert res.powered == (res.power >= 0.8)


@pytest.mark.parametrize(
    ("a", "b", "n", "message"),
    [
        ([1, 2], [1], [3, 3], "2, 1 and 2 worlds"),
        ([1], [1], [3], "at least two worlds"),
        ([4, 1], [1, 1], [3, 3], "hits outside 0..relevant"),
    ],
)
def test_bad_input_is_one_line(a, b, n, message):
    with pytest.raises(EvaluationError, match=message):
        paired_difference(a, b, n)
