"""The committed ``standard`` benchmark results: the leaderboard follows from their raw pairs, every cell
meets the interval bound, and the README's benchmark block is what they render to.

Skipped until ``results/benchmark/standard/`` is committed (``roman-sim benchmark standard``).
The counts are re-derived twice: by the package (``benchmark.board.leaderboard``) and by hand
(the ``by_hand`` fixture), from the raw pairs tables with the standard library only.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from roman_sim.benchmark.board import leaderboard
from roman_sim.core.records import to_json
from roman_sim.evaluation.leaderboard import Leaderboard, read_leaderboard
from roman_sim.report.leaderboard import README_BEGIN, README_END, readme_block
from roman_sim.report.recompute import compare

ROOT = Path(__file__).resolve().parents[2]
STANDARD = ROOT / "results" / "benchmark" / "standard"
FIGURE = "results/benchmark/standard/plots/recall_heading.png"

pytestmark = pytest.mark.skipif(
    not (STANDARD / "leaderboard.json").is_file(), reason="no committed standard benchmark results"
)


def _committed() -> Leaderboard:
    return read_leaderboard(STANDARD / "leaderboard.json")


@pytest.fixture(scope="module", name="again")
def _again() -> Leaderboard:
    """The leaderboard re-derived from the committed raw pairs (once for the module)."""
    return leaderboard(STANDARD)[0]


@pytest.fixture(scope="module", name="scored")
def _scored() -> dict[str, Any]:
    """The independent scorer's held-out figures of the committed raw pairs (once for the module)."""
    from fractions import Fraction

    from roman_sim.studies.independent_scorer import benchmark_held_out

    return benchmark_held_out(STANDARD, Fraction(str(_committed().target_precision)))


def test_the_leaderboard_follows_from_the_raw_pairs(again, by_hand_points, by_hand_precision_90):
    raw = json.loads((STANDARD / "leaderboard.json").read_text(encoding="utf-8"))
    rederived = {"schema": raw["schema"], **json.loads(json.dumps(to_json(again)))}
    diffs = compare(raw, rederived, "leaderboard.json", rel_tol=1e-9, abs_tol=1e-12)
    assert not diffs, diffs[:10]
    hand, p90 = by_hand_points(STANDARD), by_hand_precision_90(STANDARD)
    for e in _committed().levels:
        for b in e.bins:
            for m, pts in b.methods.items():
                p, q = pts["max_recall"], pts["precision_90"]
                assert p is not None and q is not None, (e.name, b.heading, m)
                got = (p.hits, p.n_relevant, p.k, p.false_positives)
                assert hand[(e.name, b.heading, m)] == got, (e.name, b.heading, m)
                assert p90[(e.name, b.heading, m)] == (q.hits, q.k, q.false_positives), (e.name, b.heading, m)


def test_every_cell_meets_the_interval_bound():
    board = _committed()
    assert board.bound_met and not board.failed_cells
    assert [e.name for e in board.levels] == ["low", "medium", "high"]
    for e in board.levels:
        assert len(e.bins) == 6
        for b in e.bins:
            assert b.n_relevant >= 100, (e.name, b.heading)
            assert b.max_half_width is not None and b.max_half_width <= board.half_width_bound, (e.name, b.heading)


def test_readme_block_is_rendered_from_the_committed_results():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    if README_BEGIN not in readme:
        pytest.skip("the README has no benchmark block yet")
    start, end = readme.index(README_BEGIN), readme.index(README_END) + len(README_END)
    assert readme[start:end] == readme_block(_committed(), FIGURE)


def test_readme_figure_shows_the_rederived_leaderboard(again, by_hand_points):
    from roman_sim.report.benchmark_plots import recall_heading_data
    from roman_sim.report.plots import read_png_data

    shown = read_png_data(ROOT / FIGURE)
    assert shown == json.loads(json.dumps(recall_heading_data(again)))
    hand = by_hand_points(STANDARD)
    for level in ("low", "medium", "high"):
        for m, rows in shown[level]["max_recall"].items():
            for heading, row in zip(shown["bins"], rows, strict=True):
                assert tuple(row[:2]) == hand[(level, heading, m)][:2], (level, heading, m)


def test_the_deployable_point_follows_from_the_independent_scorer(scored):
    """Thresholds chosen on the other world of each level and the held-out counts per heading bin, as the
    independent scorer (code of its own, the raw pairs and each cell's config) re-derives them."""
    board = _committed()
    checked = 0
    for e in board.levels:
        d = e.deployable
        assert d is not None and len(d.worlds) == 2 and d.note is None and d.thresholds is not None, e.name
        for m, ks in d.thresholds.items():
            own = scored[f"{e.name}|{m}"]
            assert own["thresholds"] == ks, (e.name, m)
            for cell in d.cells():
                c = cell.methods[m]
                got = [c.hits, c.false_positives, c.n_relevant]
                assert own["bins"][cell.heading] == got, (e.name, m, cell.heading)
                checked += 1
    assert checked == 3 * 7 * len(board.methods)


def test_the_deployable_intervals_follow_from_the_independent_scorer(scored):
    """The Wilson and world-bootstrap intervals of every held-out cell, as the independent scorer re-derives
    them from the raw pairs with its own bootstrap (the documented protocol: worlds, then robot pairs)."""
    board = _committed()
    checked = widened = 0
    for e in board.levels:
        d = e.deployable
        assert d is not None and d.thresholds is not None
        for m in d.thresholds:
            own = scored[f"{e.name}|{m}"]["intervals"]
            for cell in d.cells():
                c, mine = cell.methods[m], own[cell.heading]
                for name in ("recall_wilson", "recall_worlds", "precision_worlds"):
                    ci = getattr(c, name)
                    if ci is None:
                        assert mine[name] is None, (e.name, m, cell.heading, name)
                    else:
                        assert mine[name] == pytest.approx(ci, abs=1e-12), (e.name, m, cell.heading, name)
                worlds, wilson = c.recall_worlds, c.recall_wilson
                widened += worlds is not None and wilson is not None and worlds[1] - worlds[0] > wilson[1] - wilson[0]
                checked += 1
    assert checked == 3 * 7 * len(board.methods)
    assert widened > 0  # worlds that disagree widen some intervals beyond the pooled Wilson ones
