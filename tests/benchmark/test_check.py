"""``roman-sim benchmark check FOLDER --seeds A:B``: a finished board checked on worlds it never saw.

A tiny suite (one level, two worlds) is run as a board on seeds 0:2 and checked on seeds 2:4. The
check's precision at the board's deployed thresholds, each fresh world against the board's
one-new-world interval and the sign of each stated paired verdict are counted again by hand from the
fresh cells' raw pairs; fresh hits moved by hand first keep a stated verdict's sign, then flip it
(reported as not held); the independent scorer re-derives every figure; bad input is refused in one
line with nothing written.

Two board worlds cannot state a paired verdict (the exact sign-flip test's smallest two-sided p-value
over two worlds is 0.5): the board's verdicts are stated by hand in its ``leaderboard.json``, with the
sign of the board's own difference, as a board with more worlds would state them.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import shutil
from dataclasses import replace
from pathlib import Path

import pytest
from scipy.stats import betabinom
from typer.testing import CliRunner

from roman_sim.benchmark.board_records import read_leaderboard, write_leaderboard_json
from roman_sim.benchmark.check import check_dir, run_check
from roman_sim.benchmark.check_records import BoardCheck, read_check
from roman_sim.benchmark.suites import load_suite
from roman_sim.cli import app

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]

SUITE = """\
name: tinycheck
description: one tiny crossing scene at each seed
scene: {robots: 3, length_m: 24.0, site_radius_m: 2.0, extent_m: 40.0, render_rgb: false,
        image_width: 160, image_height: 120}
levels: {distinct: 0.0}
seeds: [0, 1]
methods: [ransac100k, ransac1m]
"""
METHODS = ["ransac100k", "ransac1m"]
FRESH = ["distinct-s2", "distinct-s3"]

#: One cross-robot row of a cell: method, associations, relevant, correct, heading difference.
Row = tuple[str, int, bool, bool, float]


def _rows(cell: Path) -> list[Row]:
    """The cross-robot rows of a cell's raw pairs, judged from the raw columns (10 m, 5 deg, 1 m)."""
    text = gzip.decompress((cell / "pairs.csv.gz").read_bytes()).decode("utf-8")
    out = []
    for r in csv.DictReader(io.StringIO(text)):
        if r["kind"] != "inter":
            continue
        rot, trans = (float(r[f] or "nan") for f in ("rot_err_deg", "trans_err_m"))
        rel, ok = float(r["center_dist_m"]) <= 10.0, rot <= 5.0 and trans <= 1.0
        out.append((r["method"], int(r["n_assoc"]), rel, ok, float(r["heading_diff_deg"])))
    return out


def _counts(rows: list[Row], method: str, k: int | None) -> tuple[int, int, int]:
    """(hits, false positives, relevant) of ``method`` at threshold ``k`` (None accepts nothing)."""
    mine = [r for r in rows if r[0] == method]
    pos = [r for r in mine if k is not None and r[1] >= k]
    return sum(1 for r in pos if r[2] and r[3]), sum(1 for r in pos if not r[3]), sum(1 for r in mine if r[2])


def _deployed_by_hand(board: Path, method: str) -> int | None:
    """The smallest k of 0..30 whose precision over every board world's pairs is at least 9/10."""
    rows = [r for c in ("distinct-s0", "distinct-s1") for r in _rows(board / "cells" / c)]
    for k in range(31):
        tp, fp, _ = _counts(rows, method, k)
        if tp + fp and 10 * tp >= 9 * (tp + fp):
            return k
    return None


def _state_verdicts(board: Path) -> None:
    """Every paired verdict of the board stated with the sign of its difference ("a ahead" when it is 0)."""
    lb = read_leaderboard(board / "leaderboard.json")
    (level,) = lb.levels
    d = level.deployable
    assert d is not None
    cells = [
        replace(c, verdicts=[replace(v, verdict="b ahead" if v.diff < 0 else "a ahead") for v in c.verdicts])
        for c in d.cells()
    ]
    dep = replace(d, bins=cells[:-1], overall=cells[-1])
    write_leaderboard_json(board / "leaderboard.json", replace(lb, levels=[replace(level, deployable=dep)]))


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The board on seeds 0:2 (its verdicts stated), checked on seeds 2:4 through the command line."""
    d = tmp_path_factory.mktemp("check")
    (d / "tiny.yaml").write_text(SUITE)
    board = d / "board"
    res = CliRunner().invoke(app, ["benchmark", str(d / "tiny.yaml"), "--out", str(board), "--executor", "serial"])
    assert res.exit_code == 0, res.output
    _state_verdicts(board)
    res = CliRunner().invoke(app, ["benchmark", "check", str(board), "--seeds", "2:4", "--executor", "serial"])
    return {"board": board, "code": res.exit_code, "output": res.output, "stderr": res.stderr}


def _check(home: dict) -> BoardCheck:
    return read_check(home["board"] / "check-2-4" / "check.json")


def test_the_check_runs_fresh_worlds_of_the_same_suite(home: dict) -> None:
    assert home["code"] == 0, home["output"]
    out = home["board"] / "check-2-4"
    rec = json.loads((out / "benchmark.json").read_text())
    board = json.loads((home["board"] / "benchmark.json").read_text())
    assert [(c["id"], c["status"]) for c in rec["cells"]] == [(c, "ok") for c in FRESH]
    assert rec["methods"] == board["methods"] == METHODS and rec["overrides"] == board["overrides"] == []
    assert {**rec["suite_spec"], "seeds": [0, 1]} == board["suite_spec"]  # the same definition, other seeds
    assert (out / "check.md").is_file() and not (out / "leaderboard.json").exists()
    check = _check(home)
    assert check.suite == "tinycheck" and check.seeds == [2, 4] and not check.failed_cells
    assert check.target_precision == 0.9 and check.precision_slack == 0.05


def test_precision_at_the_deployed_thresholds_is_the_hand_count(home: dict) -> None:
    board = home["board"]
    lb = read_leaderboard(board / "leaderboard.json")
    dep = lb.levels[0].deployable
    assert dep is not None and dep.deployed is not None and dep.spread is not None
    (level,) = _check(home).levels
    assert level.worlds == FRESH and [p.method for p in level.precision] == METHODS
    fresh = {c: _rows(board / "check-2-4" / "cells" / c) for c in FRESH}
    for p in level.precision:
        k = dep.deployed[p.method]
        assert p.k == k == _deployed_by_hand(board, p.method)  # chosen on the board's worlds, not again
        per = {c: _counts(rows, p.method, k) for c, rows in fresh.items()}
        tp, fp = sum(x[0] for x in per.values()), sum(x[1] for x in per.values())
        assert (p.hits, p.false_positives) == (tp, fp) and tp + fp > 0, p.method
        assert p.precision == pytest.approx(tp / (tp + fp), abs=1e-12)
        assert p.target_held == (tp / (tp + fp) >= 0.85)
        spread = dep.spread[p.method]
        assert (p.stated is None) == (spread is None)
        for w in p.worlds:
            hits, false, _ = per[w.world]
            assert (w.hits, w.accepted) == (hits, hits + false), (p.method, w.world)
            if spread is None or not w.accepted:
                assert w.inside is None
                continue
            lo, hi = (int(x) for x in betabinom.ppf([0.025, 0.975], hits + false, spread.a, spread.b))
            assert w.hits_interval == [lo, hi] and w.inside == (lo <= hits <= hi), (p.method, w.world)
    assert any(p.stated is not None for p in level.precision)  # some interval is tested


def test_every_stated_verdicts_sign_is_the_hand_count(home: dict) -> None:
    board = home["board"]
    lb = read_leaderboard(board / "leaderboard.json")
    dep = lb.levels[0].deployable
    assert dep is not None and dep.deployed is not None
    fresh = [r for c in FRESH for r in _rows(board / "check-2-4" / "cells" / c)]
    (level,) = _check(home).levels
    stated = [(c.heading, v) for c in dep.cells() for v in c.verdicts]
    assert [(v.heading, v.a, v.b) for v in level.verdicts] == [(h, v.a, v.b) for h, v in stated]
    for v in level.verdicts:
        lo, hi = (0.0, 180.0) if v.heading == "all" else (float(x) for x in v.heading.split("-"))
        rows = [r for r in fresh if lo <= r[4] < hi or (hi == 180.0 and r[4] == hi)]
        ha, _, rel = _counts(rows, v.a, dep.deployed[v.a])
        hb, _, _ = _counts(rows, v.b, dep.deployed[v.b])
        assert (v.hits_a, v.hits_b, v.n_relevant) == (ha, hb, rel), v.heading
        sign = 1 if v.stated == "a ahead" else -1
        assert v.held == (None if not rel else sign * (ha - hb) > 0), v.heading
        assert v.fresh_verdict is not None and v.significant is False  # two worlds: p >= 0.5, nothing shown


def test_the_report_and_the_printed_table_say_it(home: dict) -> None:
    md = (home["board"] / "check-2-4" / "check.md").read_text()
    check = _check(home)
    kept, significant, stated = check.verdicts_held()
    assert stated == 7  # two methods: one verdict in each of six heading bins and all
    assert f"that kept their sign on the fresh worlds: {kept} of {stated}" in md
    held, rows = check.precision_held()
    assert f"held in {held} of {rows} level x method rows" in md
    for p in check.levels[0].precision:
        line = next(x for x in md.splitlines() if x.startswith(f"| distinct | {p.method} |"))
        assert f"({p.hits}/{p.hits + p.false_positives})" in line
        assert any(
            f"│ {p.method}" in x and f"({p.hits}/{p.hits + p.false_positives})" in x for x in home["output"].split("\n")
        )


def _fields(obj: object, names: str) -> list:
    return [getattr(obj, n) for n in names.split()]


def _keys(d: dict, names: str) -> list:
    return [d[n] for n in names.split()]


def test_the_independent_scorer_rederives_the_check(home: dict) -> None:
    """Every figure of check.json, as the independent scorer (code of its own) re-derives it from the board's and
    the fresh cells' raw pairs, the board's stated Beta(a, b) and its stated verdicts."""
    from roman_sim.studies.independent_scorer import benchmark_check

    board = home["board"]
    mine = benchmark_check(board, board / "check-2-4")
    (level,) = _check(home).levels
    for p in level.precision:
        own = mine[f"distinct|{p.method}"]
        assert _fields(p, "k hits false_positives precision target_held") == _keys(
            own, "k hits false_positives precision target_held"
        )
        for w in p.worlds:
            fields = "hits accepted hits_interval inside"
            assert _fields(w, fields) == _keys(own["worlds"][w.world], fields), (p.method, w.world)
    for v in level.verdicts:
        own = mine[f"distinct|{v.heading}|{v.a}|{v.b}"]
        assert _fields(v, "hits_a hits_b n_relevant held") == _keys(own, "hits_a hits_b relevant held"), v.heading
        fresh = own["fresh"]
        assert (v.fresh_verdict, v.p_value) == (fresh["verdict"], fresh["p_value"]), v.heading
    n_precision, n_verdicts = len(level.precision), len(level.verdicts)
    assert len(mine) == n_precision + n_verdicts == 2 + 7  # nothing the check left out


def _flip(cell: Path, method: str, k: int, n: int) -> None:
    """Make ``n`` of ``method``'s hits at threshold ``k`` in a cell misses (a rotation error of 90 deg)."""
    text = gzip.decompress((cell / "pairs.csv.gz").read_bytes()).decode("utf-8")
    reader = csv.DictReader(io.StringIO(text))
    rows = list(reader)
    left = n
    for r in rows:
        hit = float(r["center_dist_m"]) <= 10.0 and float(r["rot_err_deg"] or "nan") <= 5.0
        hit = hit and float(r["trans_err_m"] or "nan") <= 1.0 and int(r["n_assoc"]) >= k
        if left and r["kind"] == "inter" and r["method"] == method and hit:
            r["rot_err_deg"], r["correct"] = "90.0", "false"
            left -= 1
    assert left == 0, f"{cell.name}: fewer than {n} hits of {method}"
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=reader.fieldnames or [], lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    (cell / "pairs.csv.gz").write_bytes(gzip.compress(out.getvalue().encode("utf-8"), mtime=0))


def _flip_fresh(board: Path, method: str, k: int, n: int) -> None:
    """Make ``n`` of ``method``'s fresh hits at threshold ``k`` misses, the worlds with the most hits first."""
    for c in sorted(FRESH, key=lambda c: -_counts(_rows(board / "check-2-4" / "cells" / c), method, k)[0]):
        take = min(n, _counts(_rows(board / "check-2-4" / "cells" / c), method, k)[0])
        if take:
            _flip(board / "check-2-4" / "cells" / c, method, k, take)
        n -= take
    assert n == 0, f"fewer fresh hits of {method} than asked"


def test_a_verdict_whose_sign_flips_on_the_fresh_worlds_is_not_held(home: dict, tmp_path: Path) -> None:
    """The board's verdict over all headings, its fresh hits moved by hand: first to the stated leader ahead by
    one hit (held), then behind by one (the sign flipped: not held); each time the check's counts are the hand
    count of the changed fresh pairs, and it runs nothing again."""
    board = tmp_path / "board"
    shutil.copytree(home["board"], board, ignore=shutil.ignore_patterns("work"))
    before = {v.heading: v for v in _check(home).levels[0].verdicts}["all"]
    dep = read_leaderboard(board / "leaderboard.json").levels[0].deployable
    assert dep is not None and dep.deployed is not None
    ahead, other = (before.a, before.b) if before.stated == "a ahead" else (before.b, before.a)
    k = {m: dep.deployed[m] or 0 for m in (ahead, other)}
    assert all(dep.deployed[m] is not None for m in k)
    lead = (before.hits_a - before.hits_b) * (1 if ahead == before.a else -1)  # the stated leader's fresh margin
    # the leader ahead by exactly one hit: the leader loses hits, or the other does
    first = (ahead, lead - 1) if lead >= 1 else (other, 1 - lead)
    for (method, n), held in ((first, True), ((ahead, 2), False)):
        if n:
            _flip_fresh(board, method, k[method], n)
        result, outcome = run_check(board, "2:4")
        assert sorted(outcome.reused) == FRESH and not outcome.failures  # resumed: nothing run again
        after = {v.heading: v for v in result.levels[0].verdicts}["all"]
        rows = [r for c in FRESH for r in _rows(board / "check-2-4" / "cells" / c)]
        hits = {m: _counts(rows, m, k[m])[0] for m in k}
        assert (after.hits_a, after.hits_b) == (hits[after.a], hits[after.b])
        assert hits[ahead] - hits[other] == (1 if held else -1)
        assert after.held is held and after.stated == before.stated
        assert read_check(check_dir(board, (2, 4)) / "check.json") == result
    prec = {p.method: p for p in result.levels[0].precision}
    was = {p.method: p for p in _check(home).levels[0].precision}
    moved = {ahead: 2 + (first[1] if first[0] == ahead else 0), other: first[1] if first[0] == other else 0}
    for m, n in moved.items():  # each flipped hit became a false positive
        assert (prec[m].hits, prec[m].false_positives) == (was[m].hits - n, was[m].false_positives + n), m


# -- bad input: one line, exit code 1, nothing written ------------------------------------------
def _folder_copy(home: dict, tmp_path: Path) -> Path:
    board = tmp_path / "board"
    shutil.copytree(home["board"], board, ignore=shutil.ignore_patterns("work", "check-*"))
    return board


def _refused(cli_fails, board: Path, seeds: str = "2:4") -> str:
    before = sorted(p.name for p in board.iterdir()) if board.is_dir() else None
    line = cli_fails("benchmark", "check", board, "--seeds", seeds)
    assert (sorted(p.name for p in board.iterdir()) if board.is_dir() else None) == before
    return line


def test_malformed_or_overlapping_seeds_are_refused(home: dict, tmp_path: Path, cli_fails) -> None:
    board = _folder_copy(home, tmp_path)
    for bad in ("2-4", "4:2", "2:3", "a:b", "-1:3", "2:4:6"):
        assert _refused(cli_fails, board, bad).startswith("error: --seeds: "), bad
    line = _refused(cli_fails, board, "1:3")
    assert line == ("error: --seeds 1:3: seed 1 is one of the board's own (0-1); choose seeds it never used, e.g. 2:4")
    assert (
        cli_fails("benchmark", "check", board) == "error: --seeds: give the fresh seeds as A:B (e.g. --seeds 100:104)"
    )


def test_a_folder_that_is_not_a_finished_benchmark_is_refused(home: dict, tmp_path: Path, cli_fails) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "not a finished benchmark (no benchmark.json" in _refused(cli_fails, empty)
    board = _folder_copy(home, tmp_path)
    (board / "leaderboard.json").unlink()
    assert "not a finished benchmark (no leaderboard.json" in _refused(cli_fails, board)
    rec = json.loads((home["board"] / "benchmark.json").read_text())
    rec["cells"][1]["status"] = "pending"
    (board / "benchmark.json").write_text(json.dumps(rec))
    assert "not a finished benchmark (1 cells pending, first distinct-s1" in _refused(cli_fails, board)


def test_a_board_without_deployed_thresholds_is_refused(home: dict, tmp_path: Path, cli_fails) -> None:
    board = _folder_copy(home, tmp_path)
    raw = json.loads((home["board"] / "leaderboard.json").read_text())
    del raw["levels"][0]["deployable"]["deployed"]
    (board / "leaderboard.json").write_text(json.dumps(raw))
    line = _refused(cli_fails, board)
    assert "level 'distinct' states no deployed thresholds" in line and "an older leaderboard schema" in line
    raw["schema"] = "roman_sim.leaderboard/1"
    (board / "leaderboard.json").write_text(json.dumps(raw))
    assert "an older leaderboard schema" in _refused(cli_fails, board)


def test_a_board_of_another_suite_version_is_refused(home: dict, tmp_path: Path, cli_fails) -> None:
    board = _folder_copy(home, tmp_path)
    rec = json.loads((board / "benchmark.json").read_text())
    spec = load_suite("quick").model_dump(mode="json")
    spec["scene"]["image_width"] = 160  # the built-in suite as it was when this board was run
    rec.update(suite="quick", suite_spec=spec)
    (board / "benchmark.json").write_text(json.dumps(rec))
    line = _refused(cli_fails, board)
    assert "from another suite version: the recorded 'quick' suite differs from the current one in " in line
    assert "scene.image_width (recorded 160, now 320)" in line


def test_the_docs_state_the_command_and_what_four_worlds_can_show() -> None:
    """docs/benchmark.md's section on the check: the command, the files, and the exact test's smallest p-value
    over four fresh worlds (every world's difference of one sign: 2 of the 16 sign choices reach it)."""
    from roman_sim.evaluation.paired_worlds import paired_difference

    root = Path(__file__).resolve().parents[2]
    docs = " ".join((root / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert "roman-sim benchmark check results/benchmark/mine --seeds 100:104" in docs
    assert "`check.json` (`benchmark.check_records.BoardCheck`" in docs and "`check.md`" in docs
    d = paired_difference([12, 15, 11, 20], [0, 1, 2, 3], [40, 40, 40, 40])
    assert d.p_value == 2 / 16 == 0.125 and d.verdict == "no difference shown"
    assert "with four worlds its smallest two-sided p-value is 0.125" in docs


def test_fresh_worlds_without_the_boards_score_are_refused(home: dict) -> None:
    """A board on a score the fresh worlds' pairs do not carry (here ``margin``, which RANSAC does not give)
    cannot be checked: one line, before anything is written."""
    from roman_sim.benchmark.check import score_check
    from roman_sim.core.errors import ConfigError

    board = replace(read_leaderboard(home["board"] / "leaderboard.json"), score="margin")
    out = check_dir(home["board"], (2, 4))
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(ConfigError, match=r"^check: the fresh worlds cannot be scored as the board is: score 'margin'"):
        score_check(board, out, (2, 4))
    assert sorted(p.name for p in out.iterdir()) == before


def test_a_suite_whose_description_or_power_plan_changed_is_the_same_suite(tmp_path: Path) -> None:
    """Only the fields that decide the cells are compared: a changed description or power plan is not a new
    version, a changed level is."""
    from roman_sim.benchmark.cells import BenchmarkRecord
    from roman_sim.benchmark.check import current_suite
    from roman_sim.core.errors import ConfigError

    spec = load_suite("standard").model_dump(mode="json")
    spec["description"] = "said otherwise"
    spec["power"]["pilot"] = "another pilot"
    rec = BenchmarkRecord("standard", spec, [], [], [], [], [])
    assert current_suite(tmp_path, rec).name == "standard"
    spec["levels"]["mild"] = 0.7
    with pytest.raises(
        ConfigError, match=r"differs from the current one in levels\.mild \(recorded 0\.7, now 0\.758\)"
    ):
        current_suite(tmp_path, rec)
