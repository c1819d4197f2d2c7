"""What cuts a run's fixed costs keeps its values: Wilson intervals asked again, association truth."""

from __future__ import annotations

from roman_sim.evaluation.assoc import association_truth
from roman_sim.evaluation.intervals import wilson


def test_wilson_intervals_are_the_same_asked_again() -> None:
    first = [wilson(k, n) for n in (1, 5, 44) for k in range(n + 1)]
    assert [wilson(k, n) for n in (1, 5, 44) for k in range(n + 1)] == first
    assert wilson(0, 0) is None


def test_association_truth_counts_distinct_correct_rows() -> None:
    ids_a, ids_b = [0, 1, 1, -1], [1, 0, 0, -1]
    # (0, 1) and (0, 2) both correct for object 0, (1, 0) twice, (3, 3) has no object
    assoc = [[0, 1], [0, 2], [1, 0], [1, 0], [3, 3], [2, 2]]
    assert association_truth(ids_a, ids_b, assoc) == (4, 2)
    assert association_truth(ids_a, ids_b, [[3, 3]]) == (0, 0)
