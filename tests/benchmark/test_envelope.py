"""The perception envelope: one suite's boards per front end read side by side, and which verdicts hold.

The committed standard board stands in for each front end's board: the same board twice holds every
verdict; a copy with one paired verdict turned over, or one method's heading-bin recall moved, makes
exactly that row depend on the front end. The rows' rules are re-derived by hand from the JSON text.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml
from committed_results import STANDARD

from roman_sim.benchmark import envelope as env_mod
from roman_sim.benchmark.board_records import read_leaderboard
from roman_sim.benchmark.envelope import drop_verdict, envelope_markdown, envelope_rows, read_boards
from roman_sim.benchmark.run import BenchmarkOutcome
from roman_sim.benchmark.suites import FRONTENDS, load_suite
from roman_sim.core.errors import ConfigError

pytestmark = pytest.mark.skipif(
    not (STANDARD / "leaderboard.json").is_file(), reason="no committed standard benchmark results"
)


def _raw() -> dict:
    return json.loads((STANDARD / "leaderboard.json").read_text(encoding="utf-8"))


def _board(raw: dict, tmp_path: Path, name: str):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(raw), encoding="utf-8")
    return read_leaderboard(path)


def test_the_same_board_twice_holds_every_verdict(tmp_path: Path) -> None:
    raw = _raw()
    env = envelope_rows({"simulated": _board(raw, tmp_path, "a"), "image": _board(raw, tmp_path, "b")})
    n_methods, n_levels = len(raw["methods"]), len(raw["levels"])
    pairs = n_methods * (n_methods - 1) // 2
    assert len(env.rows) == n_levels * (pairs + n_methods) + n_methods
    assert all(r.holds == "holds for every front end" for r in env.rows)
    # each ranking row states the overall cell's verdict of the JSON text, read from either side
    lv = raw["levels"][0]
    stated = {(v["a"], v["b"]): v for v in lv["deployable"]["overall"]["verdicts"]}
    for r in (r for r in env.rows if r.kind == "ranking" and r.level == lv["name"]):
        a, b = r.subject.split(" - ")
        v = stated.get((a, b)) or stated[(b, a)]
        winner = v["a"] if v["verdict"] == "a ahead" else v["b"] if v["verdict"] == "b ahead" else None
        assert r.stated == (f"{winner} ahead" if winner else v["verdict"]), r.subject


def test_one_verdict_turned_over_makes_only_its_row_depend(tmp_path: Path) -> None:
    raw = _raw()
    other = json.loads(json.dumps(raw))
    lv = other["levels"][0]
    v = next(v for v in lv["deployable"]["overall"]["verdicts"] if v["verdict"] in ("a ahead", "b ahead"))
    v["verdict"] = "b ahead" if v["verdict"] == "a ahead" else "a ahead"
    env = envelope_rows({"simulated": _board(raw, tmp_path, "a"), "image": _board(other, tmp_path, "b")})
    moved = [r for r in env.rows if r.holds != "holds for every front end"]
    assert [(r.kind, r.level, set(r.subject.split(" - "))) for r in moved] == [
        ("ranking", lv["name"], {v["a"], v["b"]})
    ]
    assert not moved[0].cells["image"].holds and moved[0].cells["simulated"].holds
    text = envelope_markdown(env)
    assert f"{len(env.rows) - 1} of {len(env.rows)} verdicts hold for every front end." in text
    assert text.count("**differs**") == 1 and "depends on the front end" in text


def test_the_heading_drop_is_read_from_the_world_intervals_by_hand(tmp_path: Path) -> None:
    """A drop where the first bin's world interval lies above the last's; moving the last bin's interval above
    the first's turns it into a rise in that front end only."""
    raw = _raw()
    board = _board(raw, tmp_path, "a")
    for lv_raw, lv in zip(raw["levels"], board.levels, strict=True):
        bins = lv_raw["deployable"]["bins"]
        for m in raw["methods"]:
            first, last = bins[0]["methods"][m], bins[-1]["methods"][m]
            lo1, hi1 = first["recall_worlds"]
            lo2, hi2 = last["recall_worlds"]
            hand = (
                "too few hits"
                if first["hits"] < 10 and last["hits"] < 10
                else "drop"
                if lo1 > hi2
                else "rise"
                if lo2 > hi1
                else "none shown"
            )
            assert lv.deployable is not None and lv.deployable.bins is not None
            got = drop_verdict(lv.deployable.bins[0].methods[m], lv.deployable.bins[-1].methods[m])
            assert got == hand, (lv_raw["name"], m)
    other = json.loads(json.dumps(raw))
    lv = other["levels"][0]
    m = raw["methods"][0]
    lv["deployable"]["bins"][0]["methods"][m].update(hits=50, recall_worlds=[0.0, 0.1])
    lv["deployable"]["bins"][-1]["methods"][m].update(hits=50, recall_worlds=[0.5, 0.6])
    env = envelope_rows({"simulated": board, "image": _board(other, tmp_path, "b")})
    row = next(r for r in env.rows if r.kind == "heading drop" and r.level == lv["name"] and r.subject == m)
    assert row.cells["image"].verdict == "rise"
    assert row.holds == ("holds for every front end" if row.stated == "rise" else "depends on the front end")


def test_boards_that_cannot_be_compared_are_refused_in_one_line(tmp_path: Path) -> None:
    raw = _raw()
    other = json.loads(json.dumps(raw))
    other["methods"] = other["methods"][:-1]
    with pytest.raises(ConfigError, match=r"^envelope: front end 'image' has other methods"):
        envelope_rows({"simulated": _board(raw, tmp_path, "a"), "image": _board(other, tmp_path, "b")})
    with pytest.raises(ConfigError, match="needs at least two front ends' boards, got 1"):
        envelope_rows({"simulated": _board(raw, tmp_path, "a")})
    with pytest.raises(ConfigError, match="no board of front end 'paper'"):
        read_boards(tmp_path, ["paper"])


def test_the_envelope_runs_one_board_per_front_end_with_its_overrides(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each front end runs as a board of its own with its overrides before the user's, then the envelope is
    written from those boards (the boards stand in for the runs: each job copies the committed one)."""
    made: list[tuple[Path, list[str]]] = []

    class Job:
        def __init__(self, suite, out, methods, overrides, **rest) -> None:
            self.out, self.overrides = Path(out), list(overrides)

        def run(self) -> BenchmarkOutcome:
            made.append((self.out, self.overrides))
            self.out.mkdir(parents=True)
            shutil.copy(STANDARD / "leaderboard.json", self.out / "leaderboard.json")
            return BenchmarkOutcome(self.out, [])

    monkeypatch.setattr(env_mod, "BenchmarkJob", Job)
    suite = load_suite("envelope")
    env, outcomes = env_mod.run_envelope(suite, tmp_path / "env", overrides=["gating.top_k=4"])
    assert [m[0].relative_to(tmp_path) for m in made] == [Path("env/frontends") / f for f in suite.frontends or []]
    assert [m[1] for m in made] == [[*FRONTENDS[f], "gating.top_k=4"] for f in suite.frontends or []]
    assert env is not None and env.frontends == ["simulated", "paper", "image"] and list(outcomes) == env.frontends
    assert json.loads((tmp_path / "env" / "envelope.json").read_text())["schema"] == "roman_sim.envelope/1"
    assert (tmp_path / "env" / "envelope.md").read_text().startswith("# Perception envelope of `standard`")


@pytest.mark.parametrize(
    ("frontends", "expect"),
    [
        (["simulated", "pixels"], "frontends: unknown front end 'pixels' (valid: simulated, paper, image)"),
        (["image"], "frontends: at least two distinct front ends, got ['image']"),
        (["image", "image"], "frontends: at least two distinct front ends"),
    ],
)
def test_a_front_end_set_naming_an_unknown_front_end_is_one_line(
    tmp_path: Path, cli_fails: Callable[..., str], frontends: list[str], expect: str
) -> None:
    path = tmp_path / "env.yaml"
    path.write_text(yaml.safe_dump({"name": "env", "levels": {"low": 0.0}, "frontends": frontends}))
    out = tmp_path / "out"
    assert expect in cli_fails("benchmark", str(path), "--out", out)
    assert not out.exists()
