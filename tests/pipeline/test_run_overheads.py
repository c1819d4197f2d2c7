"""What cuts a run's fixed costs keeps its values: remembered checks, Wilson, association truth."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align import checks
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.evaluation.assoc import association_truth
from roman_sim.evaluation.intervals import wilson
from roman_sim.mapping.types import Submap


def test_remembered_checks_give_the_same_reasons_checking_each_submap_once(monkeypatch: pytest.MonkeyPatch) -> None:
    a, b, _ = make_submap_pair(3, 10, 5, 5)
    bad = a.public()
    bad.centers = np.zeros_like(a.centers)  # coincident centres
    calls: list[int] = []
    inner = checks._submap_reason

    def counted(s: Submap, label: str, shape: bool, semantics: bool) -> str | None:
        calls.append(id(s))
        return inner(s, label, shape, semantics)

    plain = [checks.pair_reason(x, y, True, True) for x, y in ((a, b), (bad, b), (a, b))]
    monkeypatch.setattr(checks, "_submap_reason", counted)
    with checks.remembered_checks():
        kept = [checks.pair_reason(x, y, True, True) for x, y in ((a, b), (bad, b), (a, b))]
    assert kept == plain and plain[0] is None and "coincident" in str(plain[1])
    assert sorted(calls) == sorted([id(a), id(b), id(bad)])
    calls.clear()
    checks.pair_reason(a, b)  # outside the block nothing is remembered
    assert calls == [id(a), id(b)]


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
