"""Choosing a setting on calibration worlds: never with the held-out world's truth; the front; the order."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.benchmark.transfer import PairOutcomes
from roman_sim.benchmark.tune_choice import (
    ConfigOutcomes,
    Evidence,
    check_rule,
    choose_setting,
    config_rows,
    nested_held_out,
    setting_new_world,
    setting_spread,
)
from roman_sim.core.errors import ConfigError


def _world(w: str, n_rel: int, good: int, bad: int, good_score: int, bad_score: int) -> list[tuple]:
    """``good`` relevant correct pairs at ``good_score`` associations, ``bad`` wrong ones at ``bad_score``,
    the rest of the relevant pairs missed (0 associations); three robot pairs."""
    rows = []
    for i in range(n_rel):
        ok = i < good
        rows.append((w, f"r{i % 3}", True, ok, good_score if ok else 0))
    rows += [(w, f"r{i % 3}", False, False, bad_score) for i in range(bad)]
    return rows


def _config(rows: list[tuple], time_s: float = 0.01) -> ConfigOutcomes:
    o = PairOutcomes.from_lists(*(list(c) for c in zip(*rows, strict=True)))
    return ConfigOutcomes(o, np.full(len(rows), time_s))


def _configs(flip: str | None = None) -> dict[str, ConfigOutcomes]:
    """Config "tight" (wrong pairs at 3 associations, right ones at 6) and "loose" (more hits at 4,
    wrong pairs at 5) over worlds a, b, c; ``flip`` makes that world's loose config wrong everywhere."""
    tight, loose = [], []
    for w in "abc":
        tight += _world(w, 20, 8, 10, 6, 3)
        if w == flip:
            loose += _world(w, 20, 0, 30, 4, 9)
        else:
            loose += _world(w, 20, 16, 10, 4, 2)
    return {"tight": _config(tight), "loose": _config(loose)}


KM = {"a": 1.0, "b": 1.0, "c": 1.0}
KS = list(range(1, 12))


def test_the_setting_chosen_for_a_world_never_reads_its_truth():
    """Flipping world a's truth (its "loose" pairs all wrong) leaves the setting chosen for a unchanged
    and changes the settings chosen for b and c, whose calibration worlds include a."""
    base = nested_held_out(Evidence(_configs(), KM, KS, 0.9, n_boot=200))
    flipped = nested_held_out(Evidence(_configs(flip="a"), KM, KS, 0.9, n_boot=200))
    assert base.chosen["a"] == flipped.chosen["a"]
    s = base.chosen["a"]
    assert s is not None and (s.config, s.k) == ("loose", 3)  # 16/20 at precision 1 on b and c
    for w in "bc":
        got = flipped.chosen[w]
        assert got is not None and (got.config, got.k) == ("tight", 4), w  # a's loose pairs now ruin loose
    # the held-out figures are world a's own outcome at the setting chosen without it
    assert flipped.figures.cell.hits == 0 + 8 + 8 and flipped.figures.cell.false_positives == 30
    # per world: a 0 of 30, b and c 8 of 8 (Wilson 8/8: [8 / (8 + z^2), 1]); one new world may be any of them
    per = {p.world: (p.hits, p.false_positives, p.precision) for p in flipped.per_world}
    assert per == {"a": (0, 30, 0.0), "b": (8, 0, 1.0), "c": (8, 0, 1.0)}
    z2 = 1.959963984540054**2
    assert flipped.per_world[1].wilson == pytest.approx((8 / (8 + z2), 1.0))
    assert flipped.per_world[0].wilson == pytest.approx((0.0, z2 / (30 + z2)))
    assert flipped.new_world == pytest.approx((0.0, 1.0))
    pooled = flipped.figures.cell.precision_worlds
    assert pooled is not None and flipped.new_world[0] <= pooled[0] and pooled[1] <= flipped.new_world[1]


def test_choice_order_recall_then_false_closures_then_time():
    cfg = _configs()
    s = choose_setting(cfg, KM, ["a", "b"], KS, 0.9)
    assert s is not None and s.config == "loose" and s.k == 3 and s.recall == pytest.approx(16 / 20)
    # equal recall: the fewer false closures per km win, then the faster
    same = {"slow": _config(_world("a", 10, 5, 0, 4, 0), 0.5), "fast": _config(_world("a", 10, 5, 0, 4, 0), 0.1)}
    assert choose_setting(same, {"a": 2.0}, ["a"], KS, 0.9).config == "fast"  # type: ignore[union-attr]
    none = {"x": _config(_world("a", 10, 1, 5, 4, 4))}
    assert choose_setting(none, {"a": 1.0}, ["a"], KS, 0.9) is None


def test_front_and_rows():
    rows = config_rows(Evidence(_configs(), KM, KS, 0.9, n_boot=200))
    by = {r.config: r for r in rows}
    assert by["loose"].thresholds == {"a": 3, "b": 3, "c": 3}
    assert by["loose"].figures.cell.hits == 48 and by["loose"].figures.cell.false_positives == 0
    assert by["tight"].thresholds == {"a": 4, "b": 4, "c": 4} and by["tight"].figures.cell.hits == 24
    assert by["loose"].on_front and not by["tight"].on_front  # same time and false closures, less recall
    slow = _configs()
    slow["loose"] = ConfigOutcomes(slow["loose"].pairs, np.full(len(slow["loose"].runtime_s), 1.0))
    assert all(r.on_front for r in config_rows(Evidence(slow, KM, KS, 0.9, n_boot=200)))  # tight is now faster


def test_one_world_is_refused():
    one = {"x": _config(_world("a", 10, 5, 0, 4, 0))}
    with pytest.raises(ConfigError, match="worlds: need at least two"):
        nested_held_out(Evidence(one, {"a": 1.0}, KS, 0.9))
    with pytest.raises(ConfigError, match="target precision"):
        nested_held_out(Evidence(_configs(), KM, KS, 1.5))


Z2 = 1.959963984540054**2


def _wilson_low(k: int, n: int) -> float:
    """The Wilson lower end written out (95 %)."""
    p = k / n
    centre = (p + Z2 / (2 * n)) / (1 + Z2 / n)
    half = (Z2**0.5) * ((p * (1 - p) / n + Z2 / (4 * n * n)) ** 0.5) / (1 + Z2 / n)
    return centre - half


def _rules_case(sure_hits: int) -> dict[str, ConfigOutcomes]:
    """Config "many": in each of worlds a, b, c 50 relevant pairs, all found and right, and 2 wrong ones, all at
    1 association (precision 50/52 in every world, 150/156 pooled; recall 1). Config "sure": ``sure_hits`` of
    52 relevant pairs found and right at 1 association, nothing wrong (precision 1, recall sure_hits/52)."""
    many, sure = [], []
    for w in "abc":
        many += _world(w, 50, 50, 2, 1, 1)
        sure += _world(w, 52, sure_hits, 0, 1, 1)
    return {"many": _config(many), "sure": _config(sure)}


def test_the_lower_rule_picks_another_setting_than_the_point_rule():
    """By hand: "many" reaches 0.9 pooled (150/156 = 0.96) and has the higher recall, so the point rule picks
    it; the lower end of its one-new-world interval is a world's Wilson lower end at 50/52, 0.870 < 0.9. "sure"
    at 40/40 per world: Wilson lower end 40 / (40 + z^2) = 0.912, and its pooled bootstrap is [1, 1] (nothing
    wrong), so its interval is [0.912, 1] and the lower rule picks it."""
    cfg = _rules_case(40)
    assert _wilson_low(50, 52) == pytest.approx(0.8702, abs=1e-4) and _wilson_low(50, 52) < 0.9
    assert 40 / (40 + Z2) == pytest.approx(0.91238, abs=1e-5)
    point = choose_setting(cfg, KM, list("abc"), [1, 2], 0.9)
    lower = choose_setting(cfg, KM, list("abc"), [1, 2], 0.9, rule="lower", n_boot=200)
    assert point is not None and (point.config, point.k, point.recall) == ("many", 1, 1.0)
    assert lower is not None and (lower.config, lower.k) == ("sure", 1)
    assert lower.recall == pytest.approx(120 / 156)
    iv = setting_new_world(cfg["sure"].pairs, 1, n_boot=200)
    assert iv == pytest.approx((40 / (40 + Z2), 1.0))
    many = setting_new_world(cfg["many"].pairs, 1, n_boot=200)
    assert many is not None and many[0] == pytest.approx(_wilson_low(50, 52))
    # the held-out choice follows the rule too: each world is scored at "sure" chosen on the other two
    nested = nested_held_out(Evidence(cfg, KM, [1, 2], 0.9, n_boot=200, rule="lower"))
    assert {w: (s.config, s.k) for w, s in nested.chosen.items() if s is not None} == {w: ("sure", 1) for w in "abc"}
    assert (nested.figures.cell.hits, nested.figures.cell.false_positives) == (120, 0)


def test_the_lower_rule_recommends_nothing_rather_than_fall_back():
    """At 30/30 per world the Wilson lower end is 30 / (30 + z^2) = 0.887 < 0.9: no setting qualifies under the
    lower rule, and nothing is chosen (the point rule would still choose "many")."""
    cfg = _rules_case(30)
    assert 30 / (30 + Z2) < 0.9
    assert choose_setting(cfg, KM, list("abc"), [1, 2], 0.9, rule="lower", n_boot=200) is None
    assert choose_setting(cfg, KM, list("abc"), [1, 2], 0.9) is not None


def test_a_bad_rule_names_the_allowed_ones():
    with pytest.raises(ConfigError, match=r"^--rule: expected one of point, lower, world, got 'upper'$"):
        check_rule("upper")
    with pytest.raises(ConfigError, match="--rule"):
        choose_setting(_configs(), KM, ["a", "b"], KS, 0.9, rule="upper")


def _spread_case(small_bad: int) -> dict[str, ConfigOutcomes]:
    """One config over worlds a, b, c, d. World a: 80 relevant pairs found and right, 60 of them at 2
    associations and 20 at 1. Worlds b, c, d: 10 relevant pairs found and right, 8 at 2 and 2 at 1, and
    ``small_bad`` wrong pairs at 1 association."""
    rows: list[tuple] = []
    for w, n, top in (("a", 80, 60), ("b", 10, 8), ("c", 10, 8), ("d", 10, 8)):
        rows += [(w, f"r{i % 3}", True, True, 2 if i < top else 1) for i in range(n)]
        if w != "a":
            rows += [(w, f"r{i % 3}", False, False, 1) for i in range(small_bad)]
    return {"only": _config(rows)}


KM4 = {w: 1.0 for w in "abcd"}


def test_the_world_rule_weighs_worlds_not_pairs():
    """By hand: at threshold 1 the pooled precision is 110 / 122 = 0.90 (world a's 80 clean pairs carry b, c and
    d at 10 / 14 = 0.71 each), so the point rule takes it; a new world is three times as likely to be like b, c
    or d, so the worlds' spread puts 56 % of new worlds, not 90 %, at 0.85 or more and the world rule takes
    threshold 2, where no world has a false positive (84 of 110 relevant pairs)."""
    cfg = _spread_case(4)
    assert 110 / 122 >= 0.9
    point = choose_setting(cfg, KM4, list("abcd"), [1, 2], 0.9)
    world = choose_setting(cfg, KM4, list("abcd"), [1, 2], 0.9, rule="world")
    assert point is not None and point.k == 1 and point.recall == 1.0
    assert world is not None and world.k == 2 and world.recall == pytest.approx(84 / 110)
    one = setting_spread(cfg["only"].pairs, 1)
    assert one is not None and one.worlds == 4 and one.share(0.85) < 0.6  # 0.56
    two = setting_spread(cfg["only"].pairs, 2)
    assert two is not None and two.share(0.85) > 0.999
    # each world is scored at the setting chosen on the other three: threshold 2 in every fold (without a, b, c
    # and d agree at 0.71; without one of them, a still disagrees with the other two)
    nested = nested_held_out(Evidence(cfg, KM4, [1, 2], 0.9, rule="world"))
    assert {w: s.k for w, s in nested.chosen.items() if s is not None} == {w: 2 for w in "abcd"}
    assert (nested.figures.cell.hits, nested.figures.cell.false_positives) == (84, 0)


def test_the_world_rule_recommends_nothing_rather_than_fall_back():
    """With 30 wrong pairs at 1 association in each of b, c and d, threshold 2 still drops every wrong pair; with
    the wrong pairs at 2 associations too, no threshold clears them: nothing qualifies, nothing is chosen."""
    rows: list[tuple] = []
    for w, n in (("a", 200), ("b", 10), ("c", 10), ("d", 10)):
        rows += [(w, f"r{i % 3}", True, True, 2) for i in range(n)]
        if w != "a":
            rows += [(w, f"r{i % 3}", False, False, 2) for i in range(4)]
    cfg = {"only": _config(rows)}
    assert 230 / 242 >= 0.9
    assert choose_setting(cfg, KM4, list("abcd"), [1, 2], 0.9) is not None
    assert choose_setting(cfg, KM4, list("abcd"), [1, 2], 0.9, rule="world") is None


def test_the_world_rule_never_reads_the_held_out_worlds_truth():
    """Under the world rule too, flipping world a's truth (its "loose" pairs all wrong) leaves the setting chosen
    for a as it was (made on b and c only) and changes those of b and c, whose calibration worlds include a."""
    base = nested_held_out(Evidence(_configs(), KM, KS, 0.9, rule="world"))
    flipped = nested_held_out(Evidence(_configs(flip="a"), KM, KS, 0.9, rule="world"))
    chosen = {w: (s.config, s.k) for w, s in base.chosen.items() if s is not None}
    assert chosen == {w: ("loose", 3) for w in "abc"}  # 16/20 at precision 1 in every world
    got = {w: (s.config, s.k) for w, s in flipped.chosen.items() if s is not None}
    assert got == {"a": ("loose", 3), "b": ("tight", 4), "c": ("tight", 4)}
