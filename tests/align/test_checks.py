"""Submap checks remembered within a block (a run's fixed cost cut) give the reasons of the plain checks."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align import checks
from roman_sim.align.synthetic import make_submap_pair
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
