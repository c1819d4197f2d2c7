"""Thresholds chosen on other worlds and intervals over worlds, on constructed pair sets."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.benchmark.transfer import (
    PairOutcomes,
    choose_threshold,
    counts,
    held_out,
    new_world_interval,
    positives,
    transfers,
    world_bootstrap,
    world_precisions,
)
from roman_sim.core.errors import ConfigError

K = list(range(0, 21))


def _world(name: str, rows: list[tuple[bool, bool, int]], robots: int = 1) -> list[tuple[str, str, bool, bool, int]]:
    """Rows (relevant, correct, score) of one world, spread round-robin over ``robots`` robot pairs."""
    return [(name, f"p{i % robots}", rel, cor, s) for i, (rel, cor, s) in enumerate(rows)]


def _outcomes(rows: list[tuple[str, str, bool, bool, int]]) -> PairOutcomes:
    w, c, r, k, s = zip(*rows)
    return PairOutcomes.from_lists(w, c, r, k, s)


def test_choose_threshold_is_the_smallest_k_reaching_the_target_in_exact_integers() -> None:
    # scores of correct relevant pairs 5,6,7,8,9,10,11,12,13; one wrong pair at 6 and one at 4
    rows = [(True, True, s) for s in range(5, 14)] + [(False, False, 6), (True, False, 4)]
    o = _outcomes(_world("w", rows))
    # k <= 4: 9 TP, 2 FP (0.818); k = 5, 6: 9 TP, 1 FP (0.9 exactly: reaches 0.9); k = 7: 7 TP, 0 FP
    th = choose_threshold(o, K, 0.9)
    assert (th.k, th.tp, th.fp) == (5, 9, 1)
    th1 = choose_threshold(o, K, 1.0)
    assert (th1.k, th1.tp, th1.fp) == (7, 7, 0)
    assert not choose_threshold(_outcomes(_world("w", [(True, False, 3)])), K, 0.5).reached


def test_held_out_threshold_is_never_chosen_with_the_held_out_worlds_truth() -> None:
    # worlds b and c: wrong pairs up to score 6, so precision 1 needs k = 7
    others = [(True, True, s) for s in (7, 8, 9, 10)] + [(False, False, s) for s in (5, 6)]
    # world a: its own truth would pick k = 0 (no wrong pair at all), the others' truth picks 7
    a_rows = [(True, True, s) for s in (3, 4, 5, 8)]
    rows = _world("a", a_rows) + _world("b", others) + _world("c", others)
    o = _outcomes(rows)
    res = held_out(o, K, 1.0)
    assert res.thresholds["a"].k == 7
    assert choose_threshold(o.subset(o.world == "a"), K, 1.0).k == 0  # the oracle would differ
    # scoring world a at k = 7: only the pair at 8 is accepted
    a = o.world == "a"
    assert counts(o.subset(a), res.positive[a]) == (1, 0, 4)
    # changing world a's truth (all its pairs wrong) changes nothing of its own threshold
    flipped = PairOutcomes(o.world, o.cluster, o.relevant, np.where(a, False, o.correct), o.score)
    assert held_out(flipped, K, 1.0).thresholds["a"] == res.thresholds["a"]
    # but it does change the thresholds chosen for the other worlds, which see world a
    assert held_out(flipped, K, 1.0).thresholds["b"].k == 9


def test_held_out_positives_are_each_worlds_own_threshold() -> None:
    rows = _world("a", [(True, True, 5), (True, False, 2)]) + _world("b", [(True, True, 3), (True, False, 4)])
    o = _outcomes(rows)
    res = held_out(o, K, 1.0)
    assert res.thresholds["a"].k is None  # on b, the correct pair scores 3 below the wrong one's 4: never reached
    assert res.thresholds["b"].k == 3  # a: the correct pair at 5, the wrong at 2
    np.testing.assert_array_equal(res.positive, [False, False, True, True])
    np.testing.assert_array_equal(positives(o, None), [False] * 4)


def test_world_bootstrap_widens_when_worlds_disagree() -> None:
    def suite(recalls: list[float]) -> PairOutcomes:
        rows: list[tuple[str, str, bool, bool, int]] = []
        for wi, r in enumerate(recalls):
            hits = round(40 * r)
            rows += _world(f"w{wi}", [(True, True, 10)] * hits + [(True, True, 0)] * (40 - hits), robots=8)
        return _outcomes(rows)

    agree, disagree = suite([0.5] * 6), suite([0.9, 0.1, 0.9, 0.1, 0.9, 0.1])
    for o in (agree, disagree):  # the same pooled recall: 120 of 240
        tp, _, rel = counts(o, positives(o, 5))
        assert (tp, rel) == (120, 240)
    lo_a, hi_a = world_bootstrap(agree, positives(agree, 5), "recall", n_boot=1000)  # type: ignore[misc]
    lo_d, hi_d = world_bootstrap(disagree, positives(disagree, 5), "recall", n_boot=1000)  # type: ignore[misc]
    assert lo_d <= 0.5 <= hi_d and lo_a <= 0.5 <= hi_a
    assert hi_d - lo_d > 3 * (hi_a - lo_a)


def test_world_bootstrap_is_seeded_and_degenerate_where_nothing_varies() -> None:
    o = _outcomes(_world("a", [(True, True, 9)] * 5, robots=2) + _world("b", [(True, True, 9)] * 5, robots=3))
    pos = positives(o, 1)
    assert world_bootstrap(o, pos, "recall", n_boot=200) == (1.0, 1.0)
    assert world_bootstrap(o, pos, "precision", n_boot=200, seed=3) == (1.0, 1.0)
    assert world_bootstrap(o, positives(o, None), "precision", n_boot=50) is None  # no positive at all


@pytest.mark.parametrize("target", [0, -0.1, 1.5, float("nan")])
def test_target_outside_the_unit_interval_is_refused(target: float) -> None:
    o = _outcomes(_world("a", [(True, True, 5)]) + _world("b", [(True, True, 5)]))
    with pytest.raises(ConfigError, match=r"target precision: must lie in \(0, 1\]"):
        held_out(o, K, target)


def test_one_world_cannot_be_split() -> None:
    with pytest.raises(ConfigError, match="need at least two worlds to split into calibration and held-out, got 1"):
        held_out(_outcomes(_world("a", [(True, True, 5)])), K, 0.9)


def test_transfer_flag_allows_the_stated_slack_only() -> None:
    assert transfers(0.86, 0.9) and not transfers(0.84, 0.9) and transfers(None, 0.9)


def test_held_out_cells_count_per_heading_bin_and_overall() -> None:
    from roman_sim.benchmark.transfer import held_out_cells

    rows = _world("a", [(True, True, 8), (True, True, 2), (False, False, 9)]) + _world(
        "b", [(True, True, 8), (True, False, 8), (True, True, 9)]
    )
    o = _outcomes(rows)
    heading = np.array([10.0, 100.0, 170.0, 30.0, 60.0, 179.0])
    pos = positives(o, 8)  # accepted: 8, 9 | 8, 8, 9
    cells = held_out_cells(o, pos, heading, [0, 60, 120, 180], n_boot=50)
    got = {c.label: (c.hits, c.false_positives, c.n_relevant) for c in cells}
    assert got == {"0-60": (2, 0, 2), "60-120": (0, 1, 2), "120-180": (1, 1, 1), "all": (3, 2, 5)}
    assert cells[-1].recall == 3 / 5 and cells[-1].precision == 3 / 5
    assert cells[1].precision == 0.0 and cells[1].recall_wilson is not None


def _wilson_by_hand(k: int, n: int) -> tuple[float, float]:
    """The Wilson score interval at 95 %, written out: (k + z^2/2 +- z sqrt(k (n - k) / n + z^2/4)) / (n + z^2)."""
    z = 1.959963984540054
    centre, half = k + z * z / 2, z * np.sqrt(k * (n - k) / n + z * z / 4)
    return (centre - half) / (n + z * z), (centre + half) / (n + z * z)


def test_one_new_world_is_stated_by_every_worlds_own_interval_and_the_pooled_one() -> None:
    """World a: 9 hits and 1 false positive; b: 2 and 2; c: nothing accepted. One new world may be
    either: the interval spans a's Wilson interval up to 0.982 and b's down to 0.150."""
    rows = _world("a", [(True, True, 5)] * 9 + [(False, False, 5)] + [(True, True, 1)] * 3)
    rows += _world("b", [(True, True, 5)] * 2 + [(True, False, 5)] * 2 + [(True, True, 1)])
    rows += _world("c", [(True, True, 1)] * 4)
    o = _outcomes(rows)
    per = world_precisions(o, positives(o, 5))
    assert [(p.world, p.hits, p.false_positives, p.precision) for p in per] == [
        ("a", 9, 1, 0.9),
        ("b", 2, 2, 0.5),
        ("c", 0, 0, None),
    ]
    a, b = _wilson_by_hand(9, 10), _wilson_by_hand(2, 4)
    assert per[0].wilson == pytest.approx(a) and per[1].wilson == pytest.approx(b) and per[2].wilson is None
    assert a == pytest.approx((0.5958, 0.9821), abs=1e-4) and b == pytest.approx((0.1500, 0.8500), abs=1e-4)
    assert new_world_interval(per, None) == pytest.approx((b[0], a[1]))
    assert new_world_interval(per, (0.1, 0.99)) == (0.1, 0.99)  # a wider pooled interval widens it
    assert new_world_interval(per[2:], None) is None  # no world accepted anything
    # the pooled bootstrap of 11 / 14 over these worlds is narrower than what one world gives
    pooled = world_bootstrap(o, positives(o, 5), "precision", n_boot=500)
    assert pooled is not None and b[0] < pooled[0]
