"""The committed ``standard`` benchmark results: the leaderboard follows from their raw pairs, every level x
heading bin meets the deployable world-bootstrap bound (as the independent scorer re-derives it), and the
README's benchmark block is what they render to.

Skipped until ``results/benchmark/standard/`` is committed (``roman-sim benchmark standard``).
The counts are re-derived twice: by the package (``benchmark.board.leaderboard``) and by hand
(the ``by_hand`` fixture), from the raw pairs tables with the standard library only.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from committed_results import STANDARD

from roman_sim.benchmark.board import leaderboard
from roman_sim.benchmark.board_markdown import README_BEGIN, README_END, readme_block
from roman_sim.benchmark.board_records import Leaderboard, read_leaderboard
from roman_sim.core.records import to_json
from roman_sim.report.recompute import compare

ROOT = Path(__file__).resolve().parents[2]
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


#: Worlds (seeds) per level of the standard suite (its ``min_worlds``).
WORLDS = {"low": 30, "medium": 8, "high": 8}


def test_every_level_and_bin_meets_the_deployable_bound(scored):
    """The suite's promise: at the deployable point every level x 60 deg bin has a world-bootstrap half-width of
    held-out recall at most 0.1 for every method, as the leaderboard states and the independent scorer finds."""
    from roman_sim.benchmark.suites import load_suite
    from roman_sim.studies.independent_scorer import (
        benchmark_deployable_bound_met,
        benchmark_deployable_widths,
        benchmark_floor_bins,
    )

    board = _committed()
    suite = load_suite("standard")
    assert board.heading_edges_deg == suite.heading_edges() == [0.0, 60.0, 120.0, 180.0]
    assert not board.failed_cells and [e.name for e in board.levels] == ["low", "medium", "high"]
    widths = board.deployable_widths()
    for e in board.levels:
        assert len(e.cells) == WORLDS[e.name] == suite.worlds_needed(e.name), e.name
        assert e.deployable is not None and e.deployable.bins is not None and len(e.bins) == 3, e.name
        assert e.deployable.worlds == sorted(e.cells), e.name
        for c in e.deployable.bins:
            above = {m: f for m, f in c.methods.items() if f.hits >= 10}  # the floor: fewer than 10 held-out hits
            assert set(c.floor) == set(c.methods) - set(above), (e.name, c.heading)
            if not above:  # every method on the floor: no bound holds or fails there
                assert (e.name, c.heading) in board.deployable_floors() and c.max_half_width is None
                continue
            halves = [(f.recall_worlds[1] - f.recall_worlds[0]) / 2 for f in above.values() if f.recall_worlds]
            assert len(halves) == len(above) and c.max_half_width == max(halves), (e.name, c.heading)
            assert widths[e.name][c.heading] == c.max_half_width <= board.half_width_bound == 0.1, (e.name, c.heading)
    assert board.deployable_bound_met
    own = benchmark_deployable_widths(scored)
    assert own.keys() == widths.keys()
    for level, bins in widths.items():
        assert own[level] == pytest.approx(bins, abs=1e-12), level
    floors = benchmark_floor_bins(scored)
    assert floors == sorted(board.deployable_floors())
    assert benchmark_deployable_bound_met(STANDARD, own, 0.1, floors)


def test_the_pooled_wilson_bound_is_reported_beside_it():
    """The per-bin (oracle) operating points' pooled Wilson intervals: the suite keeps at least 100 relevant pairs
    per bin (``min_relevant_per_bin``), so every one is at most +-0.1 too."""
    board = _committed()
    assert board.bound_met
    for e in board.levels:
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
    from roman_sim.benchmark.board_plots import recall_heading_data
    from roman_sim.core.figures import read_png_data

    shown = read_png_data(ROOT / FIGURE)
    assert shown == json.loads(json.dumps(recall_heading_data(again)))
    hand = by_hand_points(STANDARD)
    for level in ("low", "medium", "high"):
        for m, rows in shown[level]["max_recall"].items():
            for heading, row in zip(shown["bins"], rows, strict=True):
                assert tuple(row[:2]) == hand[(level, heading, m)][:2], (level, heading, m)


def test_the_deployable_point_follows_from_the_independent_scorer(scored):
    """Thresholds chosen on the other worlds of each level and the held-out counts per heading bin, as the
    independent scorer (code of its own, the raw pairs and each cell's config) re-derives them."""
    board = _committed()
    checked = 0
    for e in board.levels:
        d = e.deployable
        assert d is not None and len(d.worlds) == WORLDS[e.name] and d.note is None and d.thresholds is not None, e.name
        for m, ks in d.thresholds.items():
            own = scored[f"{e.name}|{m}"]
            assert own["thresholds"] == ks, (e.name, m)
            for cell in d.cells():
                c = cell.methods[m]
                got = [c.hits, c.false_positives, c.n_relevant]
                assert own["bins"][cell.heading] == got, (e.name, m, cell.heading)
                checked += 1
    assert checked == 3 * 4 * len(board.methods)


def test_the_deployable_intervals_follow_from_the_independent_scorer(scored):
    """The Wilson and world-bootstrap intervals of every held-out cell, as the independent scorer re-derives
    them from the raw pairs with its own bootstrap (the documented protocol: worlds drawn with replacement,
    their pairs kept whole, draws doubled while a half-width is near the bound)."""
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
    assert checked == 3 * 4 * len(board.methods)
    assert widened > 0  # worlds that disagree widen some intervals beyond the pooled Wilson ones


def test_the_readme_and_docs_state_the_suite_and_its_committed_figures():
    """The README's and the docs' words on the standard suite: its definition and the committed counts."""
    from roman_sim.benchmark.suites import load_suite

    suite = load_suite("standard")
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    n = {lv: suite.worlds_needed(lv) for lv in suite.levels}
    assert (
        f"runs every built-in method on {suite.scene.robots}-robot crossing scenes at three ambiguity levels "
        f"({n['low']} worlds at low, {n['medium']} at medium and high)" in readme
    )
    assert n["medium"] == n["high"] and f"every level x {suite.heading_bin_deg:g} deg bin" in readme
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    sc = suite.scene
    row = (
        f"| `standard` | {sc.robots} robots, {sc.length_m:g} m drives, {sc.extent_m:g} m world, RGB "
        f"{sc.image_width} x {sc.image_height} | low {n['low']}, medium {n['medium']}, high {n['high']} "
        f"(`min_worlds`) | {', '.join(suite.methods)} |"
    )
    assert row in docs and suite.min_relevant_per_bin == 100 and sc.site_radius_m == 6.0
    board = _committed()
    rel = {e.name: [b.n_relevant for b in e.bins] for e in board.levels}
    flat = [v for vs in rel.values() for v in vs]
    assert f"| {min(flat)}-{max(flat)} per 60 deg bin and level, pooled over its worlds |" in docs
    assert f"deg bin gets the fewest relevant pairs (at low {rel['low'][1]} over 30 worlds)" in docs
    assert rel["low"][1] == min(rel["low"])
    low = next(e for e in board.levels if e.name == "low")
    assert low.deployable is not None and low.deployable.overall is not None
    vis = low.deployable.overall.methods["visual"]
    assert vis.recall is not None
    said = f"held-out recall over all headings at low ambiguity: {vis.recall:.2f} ({vis.hits}/{vis.n_relevant})"
    assert said in docs


def test_the_paired_verdicts_and_floors_follow_from_the_independent_scorer(scored):
    """Every two methods in every level x bin: the verdict, the difference and its interval, as the independent
    scorer re-derives them from each world's held-out counts with code of its own; and each bin's floor."""
    from roman_sim.studies.independent_scorer import benchmark_verdicts

    mine = benchmark_verdicts(scored)
    checked = 0
    for e in _committed().levels:
        d = e.deployable
        assert d is not None and d.min_hits == 10 and d.effect == 0.05
        for c in d.cells():
            assert sorted(c.floor) == mine[f"{e.name}|{c.heading}"], (e.name, c.heading)
            for m, line in c.floor.items():
                f = c.methods[m]
                assert line == f"too few hits to rank ({f.hits} in {f.n_relevant})" and f.hits < 10
            for v in c.verdicts:
                a, b = sorted((v.a, v.b))
                own = mine[f"{e.name}|{c.heading}|{a}|{b}"]
                sign = 1 if v.a == a else -1
                flip = {"a ahead": "b ahead", "b ahead": "a ahead"}
                assert (own["verdict"] if sign == 1 else flip.get(own["verdict"], own["verdict"])) == v.verdict
                assert sign * v.diff == pytest.approx(own["diff"], abs=1e-12)
                assert v.p_value == own["p_value"] and v.power == pytest.approx(own["power"], abs=1e-12)
                assert v.detectable == pytest.approx(own["detectable"], abs=1e-12)
                checked += 1
    n = len(_committed().methods)
    assert checked == 3 * 4 * n * (n - 1) // 2


def test_the_one_new_world_intervals_follow_from_the_independent_scorer(scored):
    """Each method's one-new-world precision interval: the independent scorer fits the beta-binomial to each
    world's held-out hits out of its accepted pairs with an optimiser of its own; the board's Beta(a, b) is as
    likely as the scorer's maximum (to 1e-4 of log-likelihood), and the stated interval is the central 95 % of it."""
    from scipy.stats import beta

    from roman_sim.studies.independent_scorer import benchmark_precision_spreads, beta_binomial_loglik

    mine = benchmark_precision_spreads(scored)
    checked = 0
    for e in _committed().levels:
        d = e.deployable
        assert d is not None and d.spread is not None and d.thresholds is not None
        assert sorted(d.spread) == sorted(d.thresholds), e.name
        for m, s in d.spread.items():
            own = mine[f"{e.name}|{m}"]
            fit = own["fit"]
            if s is None:
                assert fit is None, (e.name, m)
                continue
            assert fit is not None and s.worlds == fit["worlds"] and s.level == 0.95, (e.name, m)
            kept = [(h, n) for h, n in zip(own["hits"], own["accepted"], strict=True) if n]
            stated = beta_binomial_loglik(s.a, s.b, [h for h, _ in kept], [n for _, n in kept])
            assert stated == pytest.approx(fit["loglik"], abs=1e-4), (e.name, m)  # two optimisers: 1e-4 apart
            assert s.interval == pytest.approx(list(beta.ppf([0.025, 0.975], s.a, s.b)), abs=1e-12), (e.name, m)
            checked += 1
    assert checked > 0


def test_the_docs_state_how_crude_the_one_new_world_fit_is():
    """docs/benchmark.md's examples of one-new-world intervals, read off the committed board."""
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    spreads = {
        (e.name, m): s
        for e in _committed().levels
        if e.deployable is not None
        for m, s in (e.deployable.spread or {}).items()
        if s is not None
    }
    whole = {lv for (lv, _), s in spreads.items() if f"{s.interval[0]:.2f} {s.interval[1]:.2f}" == "0.00 1.00"}
    assert whole == {"medium", "high"}
    assert "some medium and high intervals are [0.00, 1.00]" in docs
    narrow = spreads[("high", "ransac100k")]
    assert narrow.worlds == 5 and f"[{narrow.interval[0]:.2f}, {narrow.interval[1]:.2f}]" == "[0.61, 0.62]"
    assert narrow.a + narrow.b == pytest.approx(1e5)  # the upper concentration bound
    assert "RANSAC-100k's at high is [0.61, 0.62] (five worlds" in docs


def test_no_verdict_or_bound_moves_with_the_bootstrap_seed(scored):
    """The verdicts come from the exact sign-flip test (nothing drawn): the same from each world's counts
    whatever the seed. The bound's world intervals are drawn: recomputed under bootstrap seeds 1-19, every
    bin above the floor decides the bound as the committed board does."""
    from roman_sim.evaluation.paired_worlds import near_half_width, paired_difference, world_interval

    board = _committed()
    for e in board.levels:
        d = e.deployable
        assert d is not None
        for c in d.cells():
            counts = {m: scored[f"{e.name}|{m}"]["worlds"][c.heading] for m in c.methods}
            for v in c.verdicts:
                assert paired_difference(counts[v.a][0], counts[v.b][0], counts[v.a][2]).verdict == v.verdict
            if c.heading == "all":
                continue
            for m, f in c.methods.items():
                if m in c.floor or f.recall_worlds is None:
                    continue
                committed = (f.recall_worlds[1] - f.recall_worlds[0]) / 2 <= board.half_width_bound
                for seed in range(1, 20):
                    iv = world_interval(counts[m][0], counts[m][2], seed=seed, undecided=near_half_width(0.1))
                    assert iv is not None and (iv.half_width <= 0.1) == committed, (e.name, c.heading, m, seed)


def test_the_docs_state_the_committed_paired_verdict_and_floor_bins():
    """docs/benchmark.md's example of pairing and of floor bins, read off the committed board."""
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    board = _committed()
    low = next(e for e in board.levels if e.name == "low")
    assert low.deployable is not None and low.deployable.overall is not None
    cell = low.deployable.overall
    v = cell.verdict("roman", "ransac1m")
    assert v is not None and v.p_value < 0.001
    diff = v.diff if v.a == "roman" else -v.diff
    assert v.winner() == "roman" and f"ROMAN is ahead of RANSAC-1M by {diff:.3f} of held-out recall" in docs
    rom, r1m = cell.methods["roman"].recall_worlds, cell.methods["ransac1m"].recall_worlds
    assert rom is not None and r1m is not None and rom[0] <= r1m[1]  # the separate intervals overlap
    floors = board.deployable_floors()
    assert floors == [("medium", "60-120"), ("high", "60-120")]
    assert "in the committed board medium and high 60-120 deg are such bins" in docs


def test_the_areas_under_the_curves_follow_from_the_independent_scorer():
    """The committed board is on the association count; the area under each level's precision-recall curve on it
    and its world interval, as the independent scorer re-derives them from the raw pairs (its own sweep,
    trapezoid rule and world draws)."""
    from roman_sim.studies.independent_scorer import benchmark_pr_areas

    board = _committed()
    assert board.score == "associations"
    draws = {e.curves.draws for e in board.levels if e.curves is not None}
    assert len(draws) == 1
    n = draws.pop()
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert f"95 % world interval ({n} draws of the level's worlds" in docs and "k = 0-30 on `associations`" in docs
    own = benchmark_pr_areas(STANDARD, draws=n)
    checked = 0
    for e in board.levels:
        assert e.curves is not None and e.curves.score == "associations", e.name
        for m, c in e.curves.methods.items():
            mine = own[f"{e.name}|{m}"]
            assert c.auc == pytest.approx(mine["auc"], abs=1e-12), (e.name, m)
            assert c.auc_worlds == pytest.approx(mine["auc_worlds"], abs=1e-12), (e.name, m)
            assert [p.threshold for p in c.points] == list(range(31)), (e.name, m)
            checked += 1
    assert checked == 3 * len(board.methods)
