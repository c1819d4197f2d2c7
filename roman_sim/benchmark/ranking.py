"""Ranking methods by intervals: an order only where the intervals say so, "tied" elsewhere.

A method's rank is 1 + the number of methods whose interval lies wholly above its own
(their lower bound above its upper bound). If A's interval lies above B's, every method
above A lies above B too, so B's rank exceeds A's; methods that share a rank therefore have
overlapping intervals, and are reported as tied. Two 95 % intervals that do not overlap
separate the two proportions at well beyond 95 % (the test is conservative), so a rank
difference is never a coin flip. Methods without an interval (no relevant pair) get no
rank.

``one_sided_bounds`` gives the one-sided Wilson bounds used to compare one method with a
baseline at a stated level (``roman_sim.testing.assert_not_worse``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from roman_sim.evaluation.intervals import Interval, wilson


@dataclass(frozen=True)
class Rank:
    """A method's rank among others and whether another method shares it."""

    rank: int
    tied: bool

    def label(self) -> str:
        """``1`` or ``tied 1``."""
        return f"tied {self.rank}" if self.tied else str(self.rank)


def rank_by_intervals(intervals: Mapping[str, Interval]) -> dict[str, Rank]:
    """The rank of each method with an interval (see the module docstring)."""
    known = {m: ci for m, ci in intervals.items() if ci is not None}
    ranks = {m: 1 + sum(1 for o, oc in known.items() if o != m and oc[0] > ci[1]) for m, ci in known.items()}
    return {m: Rank(r, sum(1 for x in ranks.values() if x == r) > 1) for m, r in ranks.items()}


def one_sided_bounds(hits: int, n: int, level: float) -> tuple[float, float] | None:
    """(lower, upper) one-sided Wilson bounds of hits / n at ``level`` each; None when ``n == 0``.

    Each bound is one end of the two-sided interval at level ``2 * level - 1``.
    """
    return wilson(hits, n, 2.0 * level - 1.0)
