"""The leaderboard's deployable point on constructed levels: thresholds from the other worlds, ranks by
world intervals, the flag where precision falls short, one statement for a single world, bad targets."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from typer.testing import CliRunner

from roman_sim.benchmark.board_markdown import _deployable_section, deployable_readme_lines
from roman_sim.benchmark.board_records import BoardCell, BoardLevel, Leaderboard
from roman_sim.benchmark.deployable import deployable
from roman_sim.cli import app
from roman_sim.core.records import to_json

EDGES = [0.0, 90.0, 180.0]
K = list(range(0, 21))


def _in_world(s, world: str, robot_pair: int):
    """``s`` as a pair of cell ``world`` (names ``<cell>:<robot>/<index>``), robots ``a`` and ``b<robot_pair>``."""
    t = s.truth
    return replace(s, truth=replace(t, a=f"{world}:{t.a}", b=f"{world}:{t.b}", robot_b=f"b{robot_pair}"))


def _level(make_score):
    """Two worlds. Method ``good``: correct pairs score 5..8, wrong ones 1..2 (k = 3 is clean everywhere).
    Method ``leaky``: in world w0 wrong pairs score up to 4, in w1 up to 9; chosen on w0, w1 gets k = 5."""
    scores = []
    for w in ("w0", "w1"):
        for i in range(20):
            head = 30.0 if i % 2 else 120.0
            scores.append(_in_world(make_score(f"{i}", True, 5 + i % 4, True, "good", head), w, i % 5))
            scores.append(_in_world(make_score(f"{100 + i}", False, 1 + i % 2, False, "good", head), w, i % 5))
            scores.append(_in_world(make_score(f"{i}", True, 6 + i % 4, True, "leaky", head), w, i % 5))
            bad = (1 + i % 4) if w == "w0" else (6 + i % 4)
            scores.append(_in_world(make_score(f"{100 + i}", False, bad, False, "leaky", head), w, i % 5))
    return scores


def test_thresholds_come_from_the_other_world_and_a_leaky_method_is_flagged(make_score) -> None:
    dep = deployable(_level(make_score), ["good", "leaky"], EDGES, K, 0.9)
    d: Any = to_json(dep)  # as leaderboard.json holds it
    assert d["worlds"] == ["w0", "w1"] and "note" not in d
    assert d["thresholds"]["good"] == {"w0": 3, "w1": 3}
    # leaky: chosen on w1 (wrong pairs up to 9) no k reaches 0.9 (None: w0 accepts nothing); on w0, k = 5
    assert d["thresholds"]["leaky"] == {"w0": None, "w1": 5}
    good, leaky = d["overall"]["methods"]["good"], d["overall"]["methods"]["leaky"]
    assert (good["hits"], good["false_positives"], good["n_relevant"]) == (40, 0, 40)
    # w0: nothing accepted; w1 at k = 5: its 20 correct pairs and its 20 wrong ones (scores 6..9)
    assert (leaky["hits"], leaky["false_positives"], leaky["n_relevant"]) == (20, 20, 40)
    assert d["transfers"] == {"good": True, "leaky": False}
    assert good["recall_worlds"] == [1.0, 1.0]
    # leaky's world interval [0, 1] reaches good's: tied, though the pooled Wilson intervals separate
    assert d["overall"]["ranks"] == {"good": {"rank": 1, "tied": True}, "leaky": {"rank": 1, "tied": True}}
    assert leaky["recall_wilson"][1] < good["recall_wilson"][0]
    # recall 0 in w0 and 1 in w1: the world bootstrap spans both, far wider than the pooled Wilson interval
    lo, hi = leaky["recall_worlds"]
    wlo, whi = leaky["recall_wilson"]
    assert lo == 0.0 and hi == 1.0 and hi - lo > 2 * (whi - wlo)
    assert [b["heading"] for b in d["bins"]] == ["0-90", "90-180"]
    assert sum(b["methods"]["good"]["n_relevant"] for b in d["bins"]) == 40
    level = BoardLevel("one", 0.0, [], None, overall=BoardCell("all", 0, 0, {}, {}, None), deployable=dep)
    board = Leaderboard("t", "", ["good", "leaky"], [], list(EDGES), 0.1, {}, [level], target_precision=0.9)
    md = "\n".join(_deployable_section(board))
    assert "w0: none, w1: 5" in md and "**short**" in md
    assert "tied 1 good 1.00 (40/40, P 1.00); tied 1 leaky 0.50 (20/40, P 0.50, short of the target)" in "\n".join(
        deployable_readme_lines(board)
    )


def test_a_level_with_one_world_says_held_out_figures_need_two(make_score) -> None:
    one = [s for s in _level(make_score) if s.truth.a.startswith("w0:")]
    d = deployable(one, ["good", "leaky"], EDGES, K, 0.9)
    assert to_json(d) == {
        "target_precision": 0.9,
        "worlds": ["w0"],
        "note": "held-out figures need at least two worlds (seeds) to choose a threshold on others; this level has 1",
    }
    level = BoardLevel("one", 0.0, [], None, deployable=d)
    board = Leaderboard("t", "", ["good"], [], list(EDGES), 0.1, {}, [level], target_precision=0.9)
    assert "No held-out figures: held-out figures need at least two worlds" in "\n".join(_deployable_section(board))


def test_a_target_precision_outside_the_unit_interval_fails_in_one_line(tmp_path) -> None:
    for bad in ("0", "1.5", "-0.2"):
        res = CliRunner().invoke(app, ["benchmark", "quick", "--report-only", "--target-precision", bad])
        assert res.exit_code == 1, res.output
        assert [x for x in res.output.splitlines() if x.strip()] == [
            f"--target-precision: must lie in (0, 1], got {float(bad):g}"
        ]
    res = CliRunner().invoke(app, ["benchmark", "quick", "--report-only", "--out", str(tmp_path)])
    assert res.exit_code == 1 and res.output.strip().startswith("--report-only: no benchmark.json in")


def _board(dep, edges=EDGES, failed=None) -> Leaderboard:
    """A one-level board holding the deployable point ``dep``, its bound computed as the leaderboard does."""
    from roman_sim.benchmark.board import deployable_bound_met

    level = BoardLevel("one", 0.0, [], None, overall=BoardCell("all", 0, 0, {}, {}, None), deployable=dep)
    board = Leaderboard("t", "", ["good", "leaky"], [], list(edges), 0.1, failed or {}, [level], target_precision=0.9)
    return replace(board, deployable_bound_met=deployable_bound_met(board))


def test_the_deployable_bound_fails_where_worlds_disagree_and_holds_where_they_agree(make_score) -> None:
    from roman_sim.benchmark.board_markdown import deployable_bound_readme_line

    # leaky: recall 0 in w0 (nothing accepted) and 1 in w1, in both bins: half-width 0.5, over the bound
    wide = _board(deployable(_level(make_score), ["good", "leaky"], EDGES, K, 0.9))
    assert wide.deployable_widths() == {"one": {"0-90": 0.5, "90-180": 0.5}}
    assert not wide.deployable_bound_met
    assert wide.deployable_over() == [("one", "0-90", 0.5), ("one", "90-180", 0.5)]
    md = "\n".join(_deployable_section(wide))
    assert "at most 0.1: **not met**." in md and "| one | 0.500 (leaky) **over** | 0.500 (leaky) **over** |" in md
    assert deployable_readme_line_ok(
        deployable_bound_readme_line(wide), "no (one 0-90 deg 0.500; one 90-180 deg 0.500)."
    )
    # good alone: recall 1 in every world, half-width 0 in both bins: the bound holds
    good = [s for s in _level(make_score) if s.method == "good"]
    narrow = _board(deployable(good, ["good"], EDGES, K, 0.9))
    assert narrow.deployable_widths() == {"one": {"0-90": 0.0, "90-180": 0.0}}
    assert narrow.deployable_bound_met and not narrow.deployable_over()
    assert "at most 0.1: met." in "\n".join(_deployable_section(narrow))
    assert deployable_readme_line_ok(deployable_bound_readme_line(narrow), "yes (widest 0.000, one 0-90 deg).")
    # a failed cell, or a bin without any relevant pair, is not met either
    assert not _board(narrow.levels[0].deployable, failed={"one-s2": "boom"}).deployable_bound_met
    sparse = _board(deployable(good, ["good"], [0.0, 90.0, 100.0, 180.0], K, 0.9), edges=[0.0, 90.0, 100.0, 180.0])
    assert sparse.deployable_widths()["one"]["90-100"] is None and not sparse.deployable_bound_met


def deployable_readme_line_ok(line: str, verdict: str) -> bool:
    return line.startswith("- Deployable world-bootstrap half-width of held-out recall at most 0.1") and line.endswith(
        verdict
    )


def test_a_single_world_level_reports_the_bound_not_met_without_crashing(make_score) -> None:
    from roman_sim.benchmark.board_markdown import deployable_bound_readme_line

    one = [s for s in _level(make_score) if s.truth.a.startswith("w0:")]
    board = _board(deployable(one, ["good", "leaky"], EDGES, K, 0.9))
    assert board.deployable_widths() == {"one": {}} and not board.deployable_bound_met
    assert "| one | no held-out figures (1 world) | no held-out figures (1 world) |" in "\n".join(
        _deployable_section(board)
    )
    assert deployable_bound_readme_line(board).endswith("no (one without held-out figures).")


def test_the_bound_round_trips_through_leaderboard_json(make_score, tmp_path) -> None:
    from roman_sim.benchmark.board_records import read_leaderboard, write_leaderboard_json

    for scores, methods in ((_level(make_score), ["good", "leaky"]), (_level(make_score), ["good"])):
        board = _board(deployable(scores, methods, EDGES, K, 0.9))
        write_leaderboard_json(tmp_path / "leaderboard.json", board)
        back = read_leaderboard(tmp_path / "leaderboard.json")
        assert back == board and back.deployable_bound_met == (methods == ["good"])
