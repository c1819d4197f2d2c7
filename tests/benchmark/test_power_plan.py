"""A suite's power plan: the worlds per level a pilot board's paired verdicts need, and its check."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from roman_sim.benchmark.board_records import read_leaderboard
from roman_sim.benchmark.power_plan import pilot_plan
from roman_sim.benchmark.suites import load_suite
from roman_sim.core.errors import ConfigError
from roman_sim.evaluation.paired_worlds import EFFECT, POWER, worlds_for
from tests.committed_results import STANDARD


def _raw_plan(path: Path) -> dict[str, tuple[int, str, str, str]]:
    """The plan read from the JSON text itself: per level the largest worlds_for_power of a verdict above the floor."""
    data = json.loads(path.read_text())
    out = {}
    for level in data["levels"]:
        dep = level.get("deployable") or {}
        cells = [*(dep.get("bins") or []), *([dep["overall"]] if dep.get("overall") else [])]
        rows = [
            (v["worlds_for_power"], c["heading"], v["a"], v["b"])
            for c in cells
            for v in c.get("verdicts", [])
            if v["verdict"] != "too few hits"
        ]
        if rows:
            best = max(r[0] for r in rows)
            out[level["name"]] = next(r for r in rows if r[0] == best)
    return out


def test_the_committed_board_as_a_pilot_plans_each_level_by_its_hardest_comparison() -> None:
    path = STANDARD / "leaderboard.json"
    plan = pilot_plan(read_leaderboard(path))
    raw = _raw_plan(path)
    levels = ["low", "mild", "moderate", "medium", "high"]
    assert sorted(plan) == sorted(raw) == sorted(levels)
    for level, (worlds, heading, a, b) in raw.items():
        got = plan[level]
        assert (got.worlds, got.heading, got.a, got.b) == (worlds, heading, a, b)
    assert [plan[x].pilot_worlds for x in levels] == [22, 20, 16, 12, 8]
    # every level's hardest comparison needs more worlds than it ran: planned for 0.10, not 0.05
    assert all(plan[x].worlds > plan[x].pilot_worlds for x in levels)


def test_worlds_for_power_is_the_normal_approximation_by_hand() -> None:
    # se 0.03 at 30 worlds; detecting 0.05 at power 0.8 (two-sided, 95 %) needs se 0.05 / (1.95996 + 0.84162)
    target = EFFECT / (1.959964 + 0.841621)
    assert worlds_for(POWER, EFFECT, 0.03, 30, 0.95) == int(-(-30 * (0.03 / target) ** 2 // 1))


def _suite(tmp_path: Path, worlds: dict[str, int], plan: dict[str, int]) -> Path:
    p = tmp_path / "powered.yaml"
    p.write_text(
        yaml.safe_dump(
            {
                "name": "powered",
                "levels": {"low": 0.0, "mid": 0.86},
                "min_worlds": worlds,
                "max_seeds": 40,
                "power": {"worlds": plan, "pilot": "pilot board of 2026-12-08"},
            }
        )
    )
    return p


def test_a_level_with_the_worlds_its_plan_needs_is_accepted(tmp_path: Path) -> None:
    suite = load_suite(_suite(tmp_path, {"low": 12, "mid": 20}, {"low": 12, "mid": 19}))
    assert suite.power is not None and suite.worlds_needed("mid") == 20


def test_a_level_short_of_its_plan_is_refused_in_one_line(tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    path = _suite(tmp_path, {"low": 12, "mid": 8}, {"low": 12, "mid": 19})
    with pytest.raises(ConfigError, match=r"levels\.mid: planned with 8 worlds, but its power plan needs 19"):
        load_suite(path)
    out = tmp_path / "out"
    line = cli_fails("benchmark", str(path), "--out", out)
    assert "levels.mid: planned with 8 worlds, but its power plan needs 19" in line
    assert "from pilot board of 2026-12-08" in line and "min_worlds.mid (and max_seeds) of at least 19" in line
    assert not out.exists()


@pytest.mark.parametrize(
    ("plan", "expect"),
    [({"far": 5}, "power.worlds: unknown level 'far' (levels: low, mid)"), ({"low": 1}, "worlds.low: a paired test")],
)
def test_a_plan_naming_no_level_or_too_few_worlds_is_refused(tmp_path: Path, plan: dict[str, int], expect: str) -> None:
    with pytest.raises(ConfigError, match=expect.replace("(", r"\(").replace(")", r"\)")):
        load_suite(_suite(tmp_path, {"low": 12, "mid": 20}, plan))


def test_the_docs_state_the_pilot_plan_and_the_measured_knob_curve() -> None:
    from tests.committed_results import BENCHMARKS_OUT, ROOT

    text = " ".join((ROOT / "docs" / "benchmark.md").read_text().split())
    plan = pilot_plan(read_leaderboard(STANDARD / "leaderboard.json"))
    for level, p in plan.items():
        head = f"{level} {p.worlds} worlds" if level == "low" else f"{level} {p.worlds}"
        assert f"{head} ({p.a} - {p.b}, {p.heading} deg)" in text, (level, p)
    curve = {c["knob"]: c["index"] for c in json.loads((BENCHMARKS_OUT / "levels.json").read_text())["curve"]}
    stated = {
        0.7: "0.11 at knob 0.7",
        0.8: "0.18 at 0.8",
        0.875: "0.32 at 0.875",
        0.9: "0.45 at 0.9",
        0.95: "0.84 at 0.95",
    }
    for knob, phrase in stated.items():
        assert phrase in text and phrase.startswith(f"{curve[knob]:.2f}"), (knob, curve[knob])
    assert "from 0 to 0.96 over 8 seeds" in text and max(curve) == 0.96


def test_the_standard_suite_plans_its_levels_from_the_committed_pilot() -> None:
    """The standard suite's knobs are the measured curve's for its target indexes, and its worlds are the pilot's
    plan carried to those indexes for a difference of 0.10 (at least 8), as its stated pilot line says."""
    from roman_sim.benchmark.power_plan import planned_worlds
    from roman_sim.benchmark.suites import STANDARD_INDEX, STANDARD_PILOT
    from tests.committed_results import BENCHMARKS_OUT

    suite = load_suite("standard")
    levels = json.loads((BENCHMARKS_OUT / "levels.json").read_text())
    for level, index in STANDARD_INDEX.items():
        if level != "low":
            assert levels["targets"][f"{index:g}"] == suite.levels[level], level
    curve = {c["knob"]: c["index"] for c in levels["curve"]}
    assert suite.levels["low"] == 0.0 and round(curve[0.0], 2) == 0.04
    pilot = read_leaderboard(BENCHMARKS_OUT / "standard_pilot.json")
    planned = planned_worlds(pilot, STANDARD_INDEX, 0.1, least=8)
    assert suite.power is not None and suite.power.effect == 0.1
    assert (
        planned
        == suite.power.worlds
        == suite.min_worlds
        == {"low": 22, "mild": 20, "moderate": 16, "medium": 12, "high": 8}
    )
    plan = pilot_plan(pilot)
    said = " / ".join(str(plan[x].worlds) for x in ("low", "medium", "high"))
    pairs = ", ".join(f"{plan[x].a} - {plan[x].b} {plan[x].heading} deg" for x in ("low", "medium", "high"))
    index = " / ".join(f"{e.ambiguity_index:.2f}" for e in pilot.levels)
    assert f"needs {said} worlds ({pairs})" in STANDARD_PILOT and f"at index {index}," in STANDARD_PILOT
    assert suite.scene.image_width == 320 and suite.scene.image_height == 240


def test_a_plan_for_a_larger_effect_scales_as_one_over_its_square(tmp_path: Path) -> None:
    """The refusal names the effect the plan is for; planned_worlds divides by (effect / 0.05)^2 and rounds up."""
    from roman_sim.benchmark.power_plan import planned_worlds
    from tests.committed_results import BENCHMARKS_OUT

    p = _suite(tmp_path, {"low": 12, "mid": 8}, {"low": 12, "mid": 19})
    data = yaml.safe_load(p.read_text())
    data["power"]["effect"] = 0.1
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"a paired difference of recall of 0\.1 detected with power 0\.8"):
        load_suite(p)
    pilot = read_leaderboard(BENCHMARKS_OUT / "standard_pilot.json")
    plan = pilot_plan(pilot)
    at = {e.name: e.ambiguity_index for e in pilot.levels}
    for effect, div in ((0.05, 1), (0.1, 4), (0.2, 16)):
        got = planned_worlds(pilot, {"x": at["medium"]}, effect)
        assert got == {"x": max(2, -(-plan["medium"].worlds // div))}, effect
    with pytest.raises(ValueError, match="effect"):
        planned_worlds(pilot, {"x": 0.1}, 0.0)
