"""Paired verdicts over worlds: the exact sign-flip test by hand and against scipy, the clustered error, power,
and the world bootstrap's interval against scipy's, decided the same under every seed."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import stats

from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.paired_worlds import (
    EFFECT,
    MIN_DRAWS,
    clustered_se,
    detectable,
    near_half_width,
    paired_difference,
    power_for,
    sign_flip_p,
    world_interval,
    worlds_for,
)


def _brute_p(d: list[int]) -> float:
    """Every sign choice written out."""
    observed = abs(sum(d))
    hits = sum(
        1
        for signs in itertools.product((1, -1), repeat=len(d))
        if abs(sum(s * x for s, x in zip(signs, d))) >= observed
    )
    return hits / 2 ** len(d)


@pytest.mark.parametrize("d", [[3, 1, 2], [2, -1, 0, 4, -3], [1, 1, 1, 1, 1, 1], [0, 0, 5], [-2, -2, 1, 0, 3, -4, 2]])
def test_the_sign_flip_p_value_counts_every_sign_choice(d):
    assert sign_flip_p(d) == _brute_p(d)


def test_the_sign_flip_p_value_is_scipys_exact_paired_permutation_test():
    rng = np.random.default_rng(5)
    a, b = rng.integers(0, 30, 11), rng.integers(0, 30, 11)
    ref = stats.permutation_test(
        (a, b),
        lambda x, y, axis=-1: np.sum(x - y, axis=axis),
        permutation_type="samples",
        n_resamples=np.inf,
        alternative="two-sided",
        vectorized=True,
    )
    assert sign_flip_p(a - b) == pytest.approx(ref.pvalue, rel=1e-12)
    assert sign_flip_p(list(range(1, 71))) < 1e-6  # 70 worlds all one way: beyond 64-bit counts, still exact


def test_a_method_ahead_in_every_world_is_ahead_and_the_reverse():
    a, b, n = [8, 9, 7, 10, 6, 9], [2, 3, 1, 4, 2, 3], [20, 20, 18, 22, 15, 20]
    res = paired_difference(a, b, n)
    assert res.verdict == "a ahead" and res.diff == pytest.approx((49 - 15) / 115)
    assert res.p_value == 2 / 64  # every world one way: the observed and its mirror are the only extremes
    assert res.hits_a == 49 and res.hits_b == 15 and res.n_relevant == 115 and res.n_worlds == 6
    assert paired_difference(b, a, n).verdict == "b ahead"
    four = paired_difference(a[:4], b[:4], n[:4])  # four worlds cannot reach p <= 0.05 (2 / 16 at best)
    assert four.p_value == 2 / 16 and four.verdict == "no difference shown"


def test_equal_methods_show_no_difference_and_floors_say_so():
    a = [5, 6, 4, 7, 5, 6, 3, 5]
    same = paired_difference(a, a, [30] * 8)
    assert same.verdict == "no difference shown" and same.diff == 0 and same.p_value == 1.0 and same.se == 0
    floors = paired_difference([1, 0, 2, 0, 1, 0], [0, 1, 0, 1, 0, 2], [10] * 6)
    assert floors.verdict == "too few hits"  # 4 and 4 hits: both below the floor of 10
    one_floor = paired_difference([9, 8, 10, 7, 9, 8], [0, 1, 0, 0, 1, 0], [12] * 6)
    assert one_floor.verdict == "a ahead"  # a floor against a method with hits is still a finding


def test_flipping_one_worlds_truth_moves_the_verdict():
    """Eight worlds where a leads in seven: ahead (p = 2 / 128). The eighth world's truth flipped (a's hits
    there become misses and b's misses hits) turns that world against a: no difference shown any more."""
    n = [20] * 8
    a, b = [9, 8, 9, 10, 8, 7, 9, 9], [5, 5, 6, 6, 5, 5, 6, 9]
    assert paired_difference(a, b, n).verdict == "a ahead" and paired_difference(a, b, n).p_value == 2 / 128
    flipped_a, flipped_b = [*a[:7], 2], [*b[:7], 18]
    moved = paired_difference(flipped_a, flipped_b, n)
    assert moved.verdict == "no difference shown" and moved.p_value > 0.05


def test_the_clustered_error_power_and_worlds_needed_by_hand():
    d, n = np.array([2.0, -1.0, 3.0, 0.0]), np.array([10.0, 12.0, 8.0, 10.0])
    ratio = 4 / 40
    by_hand = math.sqrt(4 / 3 * ((2 - ratio * 10) ** 2 + (-1 - ratio * 12) ** 2 + (3 - ratio * 8) ** 2 + (0 - 1) ** 2))
    assert clustered_se(d, n) == pytest.approx(by_hand / 40, rel=1e-12)
    z = stats.norm.ppf(0.975) + stats.norm.ppf(0.8)
    se80 = EFFECT / z  # the error at which a difference of 0.05 is found 80 % of the time (two-sided)
    assert power_for(EFFECT, se80, 0.95) == pytest.approx(0.8 + stats.norm.cdf(-EFFECT / se80 - 1.959964), abs=1e-9)
    assert worlds_for(0.8, EFFECT, se80, 10, 0.95) == 10
    assert worlds_for(0.8, EFFECT, 2 * se80, 10, 0.95) == 40  # twice the error: four times the worlds
    res = paired_difference([5, 6, 4, 7], [5, 5, 5, 6], [30, 30, 30, 30])
    assert res.worlds_for_power == worlds_for(0.8, EFFECT, res.se, 4, 0.95) and res.powered == (res.power >= 0.8)
    # the difference found 80 % of the time at an error: the effect itself at se80, twice it at twice the error
    assert detectable(0.8, se80, 0.95) == pytest.approx(EFFECT, abs=1e-15)
    assert detectable(0.8, 2 * se80, 0.95) == pytest.approx(2 * EFFECT, abs=1e-15)
    assert res.detectable == pytest.approx(z * res.se, abs=1e-15)


def test_the_world_interval_is_scipys_bootstrap_of_the_ratio():
    rng = np.random.default_rng(3)
    n = rng.integers(10, 40, size=12)
    h = rng.binomial(n, 0.5)
    got = world_interval(h, n, seed=1)
    boot = stats.bootstrap(
        (h, n),
        lambda x, m, axis=-1: x.sum(axis=axis) / m.sum(axis=axis),
        paired=True,
        vectorized=True,
        n_resamples=200_000,
        method="percentile",
        random_state=np.random.default_rng(2),
    )
    assert got is not None and got.draws == MIN_DRAWS
    assert got.low == pytest.approx(boot.confidence_interval.low, abs=3e-3)
    assert got.high == pytest.approx(boot.confidence_interval.high, abs=3e-3)
    assert got.se == pytest.approx(boot.standard_error, rel=0.03)
    assert world_interval([1], [2]) is None and world_interval([0, 0], [0, 0]) is None


def test_a_half_width_near_the_bound_draws_more_and_decides_the_same_under_every_seed():
    rng = np.random.default_rng(8)
    n = rng.integers(20, 60, size=10)
    h = rng.binomial(n, 0.4)
    free = world_interval(h, n, seed=0)
    assert free is not None
    bound = free.half_width  # a bound at the very half-width: the draws double to the most
    near = world_interval(h, n, seed=0, undecided=near_half_width(bound))
    assert near is not None and near.draws > MIN_DRAWS
    for margin in (0.01, -0.01):  # bounds a little away from it: every seed decides the same
        decided = {
            world_interval(h, n, seed=s, undecided=near_half_width(bound + margin)).half_width <= bound + margin  # type: ignore[union-attr]
            for s in range(20)
        }
        assert len(decided) == 1


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
