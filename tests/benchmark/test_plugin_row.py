"""Your own method as a benchmark row, end to end: ``roman-sim benchmark SUITE --methods roman,pkg.mod:Class``.

The cells run the plug-in, the board ranks it in every table (``leaderboard.json``, every ranked
table of ``leaderboard.md``, the command's table, the recall-against-heading figure) under its
class name, with the hits its cells' raw pairs give when counted by hand; a plug-in that raises
inside a cell makes the command exit 1 with the cell's one-line reason (and, with ``--debug``,
the plug-in's file and line).
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import re
from pathlib import Path

import pytest

from roman_sim.benchmark.board_records import read_leaderboard
from roman_sim.core.figures import read_png_data

pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]

#: One level, two worlds: the level has held-out (deployable) figures, so every table of the board is drawn.
SUITE = """\
name: plugrow
description: one tiny crossing scene at two seeds
scene: {robots: 3, length_m: 24.0, site_radius_m: 2.0, extent_m: 40.0, render_rgb: false,
        image_width: 160, image_height: 120}
levels: {distinct: 0.0}
seeds: [0, 1]
methods: [roman]
"""
PLUGIN = "myteam.align:EveryOtherPair"
ROW = "EveryOtherPair"  # a plug-in's row: its class name
RAISES = "myteam.align:Raises"  # raises on every pair of a run (the dry call passes)


def _cross_rows(folder: Path, cell: str, method: str) -> list[tuple[float, bool, bool, int]]:
    """(heading difference, relevant, correct, associations) of ``method``'s cross-robot pairs in a cell."""
    text = gzip.decompress((folder / "cells" / cell / "pairs.csv.gz").read_bytes()).decode("utf-8")
    return [
        (float(r["heading_diff_deg"]), float(r["center_dist_m"]) <= 10.0, r["correct"] == "true", int(r["n_assoc"]))
        for r in csv.DictReader(io.StringIO(text))
        if r["kind"] == "inter" and r["method"] == method
    ]


def _max_recall(rows: list[tuple[float, bool, bool, int]]) -> tuple[int, int]:
    """(hits, relevant) at the threshold of 0..30 that keeps the most hits."""
    hits = max(sum(1 for _, rel, ok, n in rows if n >= k and rel and ok) for k in range(31))
    return hits, sum(1 for _, rel, _, _ in rows if rel)


def _held_out(per_world: dict[str, list[tuple[float, bool, bool, int]]]) -> tuple[dict[str, int | None], int, int, int]:
    """Leave one world out by hand: per world the smallest k of 0..30 at which the other world's pairs reach
    precision 9/10, and the pooled held-out (hits, false positives, relevant) of each world at its k."""
    ks: dict[str, int | None] = {}
    hits = fps = rel = 0
    for w, own in per_world.items():
        others = [r for v, rows in per_world.items() if v != w for r in rows]
        k_w = None
        for k in range(31):
            tp = sum(1 for _, r, ok, n in others if n >= k and r and ok)
            fp = sum(1 for _, _, ok, n in others if n >= k and not ok)
            if tp + fp and 10 * tp >= 9 * (tp + fp):
                k_w = k
                break
        ks[w] = k_w
        if k_w is not None:
            hits += sum(1 for _, r, ok, n in own if n >= k_w and r and ok)
            fps += sum(1 for _, _, ok, n in own if n >= k_w and not ok)
        rel += sum(1 for _, r, _, _ in own if r)
    return ks, hits, fps, rel


def _tables(markdown: str) -> list[tuple[str, list[str], list[list[str]]]]:
    """Every markdown table as (its ``## `` section, its header cells, its rows of cells)."""
    out: list[tuple[str, list[str], list[list[str]]]] = []
    section, previous = "", ""
    for line in markdown.splitlines():
        if line.startswith("## "):
            section = line[3:]
        elif line.startswith("| ") and not previous.startswith("|"):
            out.append((section, [c.strip() for c in line.strip().strip("|").split("|")], []))
        elif line.startswith("| "):
            out[-1][2].append([c.strip() for c in line.strip().strip("|").split("|")])
        previous = line
    return out


@pytest.fixture(scope="module")
def row(user_package: Path, invoke_in) -> dict:
    """The suite with roman and the user's plug-in through the command line; everything read at once
    (the failure test below reuses the folder)."""
    home = user_package
    (home / "plugrow.yaml").write_text(SUITE)
    out = home / "out"
    res = invoke_in(
        home, "benchmark", "plugrow.yaml", "--methods", f"roman,{PLUGIN}", "--out", str(out), "--executor", "serial"
    )
    cells = ["distinct-s0", "distinct-s1"]
    return {
        "home": home,
        "folder": out,
        "code": res.exit_code,
        "output": res.output,
        "board": read_leaderboard(out / "leaderboard.json") if (out / "leaderboard.json").is_file() else None,
        "json": json.loads((out / "leaderboard.json").read_text()) if (out / "leaderboard.json").is_file() else None,
        "md": (out / "leaderboard.md").read_text() if (out / "leaderboard.md").is_file() else "",
        "figure": read_png_data(out / "plots" / "recall_heading.png") if (out / "plots").is_dir() else None,
        "pairs": {c: _cross_rows(out, c, ROW) for c in cells if (out / "cells" / c / "pairs.csv.gz").is_file()},
        "record": json.loads((out / "benchmark.json").read_text()),
    }


def test_the_cells_run_the_plugin_and_the_command_succeeds(row: dict) -> None:
    assert row["code"] == 0, row["output"]
    assert row["record"]["methods"] == ["roman", PLUGIN]  # what the cells run: the full path
    assert [c["status"] for c in row["record"]["cells"]] == ["ok", "ok"]
    assert sorted(row["pairs"]) == ["distinct-s0", "distinct-s1"] and all(row["pairs"].values())
    board = row["board"]
    assert board.methods == ["roman", ROW] and board.plugins == {ROW: PLUGIN}
    assert row["json"]["methods"] == ["roman", ROW] and not board.failed_cells


def test_every_cell_of_the_board_holds_the_plugins_hand_counted_hits(row: dict) -> None:
    board = row["board"]
    (level,) = board.levels
    pooled = [r for rows in row["pairs"].values() for r in rows]
    edges = board.heading_edges_deg
    ranked = 0
    for cell in level.all_cells():
        if cell.heading == "all":
            mine = pooled
        else:
            lo, hi = (float(x) for x in cell.heading.split("-"))
            mine = [r for r in pooled if lo <= r[0] < hi or (hi == edges[-1] and r[0] == hi)]
        p = cell.point(ROW, "max_recall")
        assert p is not None and (p.hits, p.n_relevant) == _max_recall(mine), cell.heading
        for point in ("max_recall", "precision_90"):  # ranked, or a floor: too few hits to rank
            q = cell.point(ROW, point)
            assert (ROW in cell.ranks[point]) == (q is not None and q.k is not None and q.hits >= 10), cell.heading
        ranked += 1
    assert ranked == len(edges)  # every heading bin and "all"
    assert level.overall is not None and sum(1 for r in pooled if r[1]) == level.overall.n_relevant > 0
    mine, roman = level.overall.point(ROW, "max_recall"), level.overall.point("roman", "max_recall")
    assert mine is not None and roman is not None and 0 < mine.hits < roman.hits  # a row of its own


def test_the_deployable_point_ranks_the_plugin_at_thresholds_chosen_by_hand(row: dict) -> None:
    (level,) = row["board"].levels
    dep = level.deployable
    assert dep is not None and dep.note is None and dep.overall is not None and dep.thresholds is not None
    ks, hits, fps, rel = _held_out(row["pairs"])
    assert dep.thresholds[ROW] == ks
    got = dep.overall.methods[ROW]
    assert (got.hits, got.false_positives, got.n_relevant) == (hits, fps, rel)
    for c in dep.cells():  # every cell ranks the plug-in or states its floor with its counts
        f = c.methods[ROW]
        assert (ROW in c.ranks) != (ROW in c.floor), c.heading
        assert ROW not in c.floor or c.floor[ROW] == f"too few hits to rank ({f.hits} in {f.n_relevant})"
        assert c.verdict(ROW, "roman") is not None  # and compares it with every other method


def test_every_ranked_table_of_the_markdown_has_the_plugins_row(row: dict) -> None:
    md = row["md"]
    assert f"- Methods: roman, {ROW} (`{PLUGIN}`)." in md
    tables = _tables(md)
    ranked = [
        (sec, rows)
        for sec, head, rows in tables
        if head[0] in ("method", "held-out precision") and sec != "Runtime per pair"
    ]
    assert sorted({sec for sec, _ in ranked}) == [
        "Deployable ranking: held-out recall at target precision 0.9",
        "Max recall, ranked",
        "Recall at P>=0.9, ranked",
    ]
    assert len(ranked) == 5  # held-out recall and precision, the area under the curve, max recall, P>=0.9
    for sec, rows in ranked:
        assert [r[0] for r in rows] == ["roman", ROW], sec
    (level,) = row["board"].levels
    assert level.overall is not None
    p, q = level.overall.point(ROW, "max_recall"), level.overall.point(ROW, "precision_90")
    assert p is not None and q is not None
    for sec, point in (("Max recall, ranked", p), ("Recall at P>=0.9, ranked", q)):
        (mine,) = [r for s, rows in ranked if s == sec for r in rows if r[0] == ROW]
        assert f"({point.hits}/{point.n_relevant})" in mine[-1], (sec, mine)
    points = [r for sec, head, rows in tables if head[:2] == ["level", "method"] for r in rows]
    assert [r[:2] for r in points if r[1] == ROW] == [["distinct", ROW]]
    runtime = [r for sec, head, rows in tables if sec == "Runtime per pair" for r in rows]
    assert ROW in [r[0] for r in runtime]


def test_the_commands_table_and_the_figure_show_the_plugin(row: dict) -> None:
    (level,) = row["board"].levels
    assert level.overall is not None and level.deployable is not None and level.deployable.overall is not None
    p = level.overall.point(ROW, "max_recall")
    d = level.deployable.overall.methods[ROW]
    assert p is not None
    (line,) = [x for x in row["output"].splitlines() if x.startswith(f"│ {ROW} ")]
    cells = [c.strip() for c in line.split("│")[1:-1]]
    assert (
        cells[0] == ROW and cells[1].startswith(f"{d.hits}/{d.n_relevant}") and cells[2] == f"{p.hits}/{p.n_relevant}"
    )
    shown = row["figure"]["distinct"]["max_recall"][ROW]  # per heading bin: [hits, relevant, recall, low, high]
    assert [None if s is None else s[:2] for s in shown] == [
        None if (q := b.point(ROW, "max_recall")) is None else [q.hits, q.n_relevant] for b in level.bins
    ]


def test_a_plugin_raising_in_a_cell_fails_the_command_with_the_cells_reason(row: dict, invoke_in) -> None:
    home, folder = row["home"], row["folder"]
    args = ["benchmark", "plugrow.yaml", "--methods", f"roman,{RAISES}", "--out", str(folder)]
    plain = invoke_in(home, *args, "--executor", "serial")
    debug = invoke_in(home, "--debug", *args, "--executor", "serial")
    assert plain.exit_code == 1 and debug.exit_code == 1, plain.output
    reason = re.compile(
        r"^cell (distinct-s[01]) failed: aligner 'myteam\.align:Raises' failed on pair r\d\d/\d+ - r\d\d/\d+: "
        r"RuntimeError: model weights missing$"
    )
    said = [m.group(1) for line in plain.stderr.splitlines() if (m := reason.match(line))]
    assert said == ["distinct-s0", "distinct-s1"], plain.stderr
    assert "2 cell(s) failed, the others ran; run the command again to retry" in plain.stderr
    assert "Traceback" not in plain.stderr
    lines = debug.stderr.splitlines()
    source = home / "myteam" / "align.py"
    raise_line = source.read_text().splitlines().index('        raise RuntimeError("model weights missing")') + 1
    bug = f'  File "{source}", line {raise_line}, in align'
    assert lines.count(bug) == 2 and '    raise RuntimeError("model weights missing")' in lines
    first = next(i for i, x in enumerate(lines) if reason.match(x))
    assert lines[first + 1] == "Traceback (most recent call last):" and lines.index(bug) > first
    rec = json.loads((folder / "benchmark.json").read_text())
    assert [c["status"] for c in rec["cells"]] == ["failed", "failed"]


def test_two_methods_of_one_row_name_are_refused_in_one_line(user_package: Path, monkeypatch) -> None:
    from roman_sim.benchmark.suites import check_methods
    from roman_sim.core.errors import ConfigError

    (user_package / "myteam" / "other.py").write_text("from myteam.align import EveryOtherPair as roman\n")
    (user_package / "myteam" / "again.py").write_text("from myteam.align import EveryOtherPair\n")
    monkeypatch.chdir(user_package)
    assert check_methods(["roman", PLUGIN]) == ["roman", PLUGIN]
    with pytest.raises(ConfigError, match=r"^--methods: myteam.align:EveryOtherPair and myteam.again:EveryOtherPair "):
        check_methods([PLUGIN, "myteam.again:EveryOtherPair"])
    with pytest.raises(ConfigError, match=r"^--methods: roman and myteam.other:roman would share the row 'roman' "):
        check_methods(["roman", "myteam.other:roman"])
