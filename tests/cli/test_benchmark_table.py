"""The benchmark's terminal table: the deployable point first (flagged where it does not transfer), max recall after."""

from __future__ import annotations

from committed_results import STANDARD
from rich.console import Console

from roman_sim.benchmark.board_records import read_leaderboard
from roman_sim.cli.benchmark import _board_table

BOARD = STANDARD / "leaderboard.json"


def _cells(text: str) -> dict[str, list[str]]:
    rows = {}
    for line in text.splitlines():
        parts = [p.strip() for p in line.split("│")]
        if len(parts) > 2 and parts[1]:
            rows[parts[1]] = parts[2:-1]
    return rows


def test_deployable_point_then_max_recall():
    board = read_leaderboard(BOARD)
    console = Console(width=400, record=True)
    console.print(_board_table(board))
    rows = _cells(console.export_text())
    levels = [e for e in board.finished_levels() if e.overall is not None]
    flagged = 0
    for m in board.methods:
        shown = rows[m]
        assert len(shown) == 2 * len(levels)
        for i, e in enumerate(levels):
            c = e.deployable.overall.methods[m]  # type: ignore[union-attr]
            p = "-" if c.precision is None else f"{c.precision:.2f}"
            expected = f"{c.hits}/{c.n_relevant} P {p}"
            assert shown[i] == (expected if c.transfers else f"{expected} does not transfer"), (m, e.name)
            flagged += not c.transfers
            a = e.overall.point(m, "max_recall")  # type: ignore[union-attr]
            assert a is not None and shown[len(levels) + i] == f"{a.hits}/{a.n_relevant}"
    assert flagged > 0  # the committed standard results hold methods whose threshold does not transfer
