"""Ranks by interval: an order only where intervals separate; one-sided Wilson bounds."""

from __future__ import annotations

import pytest

from roman_sim.benchmark.ranking import Rank, one_sided_bounds, rank_by_intervals
from roman_sim.evaluation.intervals import wilson


def test_ranks_separate_only_disjoint_intervals():
    ranks = rank_by_intervals({"a": (0.8, 0.9), "b": (0.7, 0.85), "c": (0.5, 0.6), "d": None})
    # a and b overlap: tied for 1; both lie wholly above c: c is third; d has no interval, no rank
    assert ranks == {"a": Rank(1, True), "b": Rank(1, True), "c": Rank(3, False)}
    assert ranks["a"].label() == "tied 1" and ranks["c"].label() == "3"


def test_a_chain_of_overlaps_stays_consistent():
    # a overlaps b, b overlaps c, a lies above c: ranks 1, 1, 2 (c below a only)
    ranks = rank_by_intervals({"a": (0.6, 0.8), "b": (0.45, 0.65), "c": (0.3, 0.5)})
    assert ranks["c"].rank == 2
    assert ranks["a"].rank == ranks["b"].rank == 1 and ranks["a"].tied and ranks["b"].tied
    assert not ranks["c"].tied


def test_single_and_separated_methods_are_not_tied():
    assert rank_by_intervals({"a": (0.1, 0.2)}) == {"a": Rank(1, False)}
    assert rank_by_intervals({"a": (0.7, 0.9), "b": (0.1, 0.3)}) == {"a": Rank(1, False), "b": Rank(2, False)}


def test_one_sided_bounds_are_the_ends_of_the_wider_two_sided_interval():
    lo, hi = one_sided_bounds(20, 50, 0.95)
    assert (lo, hi) == pytest.approx(wilson(20, 50, 0.90))
    assert one_sided_bounds(0, 0, 0.95) is None
