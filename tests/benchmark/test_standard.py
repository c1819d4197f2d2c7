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
#: The committed check of the board on fresh worlds (``roman-sim benchmark check ... --seeds 100:104``).
CHECK = "check-100-104"

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
WORLDS = {"low": 22, "mild": 20, "moderate": 16, "medium": 12, "high": 8}
LEVELS = list(WORLDS)


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
    assert not board.failed_cells and [e.name for e in board.levels] == LEVELS
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
    from roman_sim.benchmark.check_records import read_check

    start, end = readme.index(README_BEGIN), readme.index(README_END) + len(README_END)
    check = read_check(STANDARD / CHECK / "check.json")
    assert readme[start:end] == readme_block(_committed(), FIGURE, check)
    assert check.suite == "standard" and check.seeds == [100, 104] and not check.failed_cells


def test_readme_figure_shows_the_rederived_leaderboard(again, by_hand_points):
    from roman_sim.benchmark.board_plots import recall_heading_data
    from roman_sim.core.figures import read_png_data

    shown = read_png_data(ROOT / FIGURE)
    assert shown == json.loads(json.dumps(recall_heading_data(again)))
    hand = by_hand_points(STANDARD)
    for level in LEVELS:
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
    assert checked == len(LEVELS) * 4 * len(board.methods)


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
    assert checked == len(LEVELS) * 4 * len(board.methods)
    assert widened > 0  # worlds that disagree widen some intervals beyond the pooled Wilson ones


def test_the_readme_and_docs_state_the_suite_and_its_committed_figures():
    """The README's and the docs' words on the standard suite: its definition and the committed counts."""
    from roman_sim.benchmark.suites import load_suite

    suite = load_suite("standard")
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    n = {lv: suite.worlds_needed(lv) for lv in suite.levels}
    worlds = ", ".join(str(n[lv]) for lv in LEVELS[:-1]) + f" and {n[LEVELS[-1]]} worlds"
    assert (
        f"runs every built-in method on {suite.scene.robots}-robot crossing scenes at five ambiguity levels "
        f"(index 0.05 to 0.85; {worlds}, as many as a paired difference of 0.10 needs for power 0.8) at "
        f"{suite.scene.image_width} x {suite.scene.image_height}" in readme
    )
    assert list(n) == LEVELS and f"every level x {suite.heading_bin_deg:g} deg bin" in readme
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    sc = suite.scene
    row = (
        f"| `standard` | {sc.robots} robots, {sc.length_m:g} m drives, {sc.extent_m:g} m world, RGB "
        f"{sc.image_width} x {sc.image_height} | " + ", ".join(f"{lv} {n[lv]}" for lv in LEVELS) + " "
        f"(`min_worlds`) | {', '.join(suite.methods)} |"
    )
    assert row in docs and suite.min_relevant_per_bin == 100 and sc.site_radius_m == 6.0
    board = _committed()
    rel = {e.name: [b.n_relevant for b in e.bins] for e in board.levels}
    flat = [v for vs in rel.values() for v in vs]
    assert f"| {min(flat)}-{max(flat)} per 60 deg bin and level, pooled over its worlds |" in docs
    assert f"deg bin gets the fewest relevant pairs (at low {rel['low'][1]} over {WORLDS['low']} worlds)" in docs
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
    assert checked == len(LEVELS) * 4 * n * (n - 1) // 2


def test_the_one_new_world_intervals_follow_from_the_independent_scorer(scored):
    """Each method's one-new-world precision interval: the independent scorer fits the beta-binomial to each
    world's held-out hits out of its accepted pairs with an optimiser of its own; the board's Beta(a, b) is at least
    as likely as the scorer's maximum (to 1e-4 of log-likelihood), and the stated interval is the central 95 % of
    it."""
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
            # the maximum as far as an independent optimiser can tell: it finds nothing more likely (to 1e-4)
            assert stated >= fit["loglik"] - 1e-4, (e.name, m, stated, fit["loglik"])
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
    whole = {k for k, s in spreads.items() if f"{s.interval[0]:.2f} {s.interval[1]:.2f}" == "0.00 1.00"}
    assert whole == {("medium", "roman"), ("medium", "clipper_prune")}
    assert "two medium intervals are [0.00, 1.00] (ROMAN's and pruned CLIPPER's)" in docs
    narrow = spreads[("medium", "visual")]
    assert narrow.worlds == 12 and f"[{narrow.interval[0]:.2f}, {narrow.interval[1]:.2f}]" == "[0.91, 0.91]"
    assert narrow.a + narrow.b == pytest.approx(1e5)  # the upper concentration bound
    assert "the visual method's at medium is [0.91, 0.91] (twelve worlds" in docs


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
    assert floors == [("high", "120-180")]
    assert "in the committed board high 120-180 deg is such a bin" in docs


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
    assert checked == len(LEVELS) * len(board.methods)
    # the paired area verdicts, from each world's own area as the independent scorer computes it
    from roman_sim.studies.independent_scorer import benchmark_auc_verdicts

    mine = benchmark_auc_verdicts(own)
    n_methods = len(board.methods)
    verdicts = 0
    for e in board.levels:
        assert e.curves is not None
        for m, c in e.curves.methods.items():
            for x, y in zip(c.world_auc, own[f"{e.name}|{m}"]["world_auc"], strict=True):
                assert (x is None) == (y is None) and (x is None or abs(x - y) <= 1e-12), (e.name, m)
        for v in e.curves.verdicts:
            a, b = sorted((v.a, v.b))
            got = mine[f"{e.name}|{a}|{b}"]
            flip = {"a ahead": "b ahead", "b ahead": "a ahead"}
            assert (got["verdict"] if v.a == a else flip.get(got["verdict"], got["verdict"])) == v.verdict
            assert got["p_value"] == v.p_value and got["worlds"] == v.worlds, (e.name, a, b)
            verdicts += 1
    assert verdicts == len(LEVELS) * n_methods * (n_methods - 1) // 2


def test_the_committed_check_on_fresh_worlds_follows_from_the_independent_scorer():
    """The board's check on seeds 100-103 (committed beside it): every precision row, fresh world and stated
    verdict of its check.json as the independent scorer re-derives them from the raw pairs of the board's cells
    and of the fresh ones."""
    from roman_sim.benchmark.check_records import read_check
    from roman_sim.studies.independent_scorer import benchmark_check

    check = read_check(STANDARD / CHECK / "check.json")
    mine = benchmark_check(STANDARD, STANDARD / CHECK)
    rows = 0
    for level in check.levels:
        for p in level.precision:
            own = mine[f"{level.name}|{p.method}"]
            assert (p.k, p.hits, p.false_positives, p.target_held) == (
                own["k"],
                own["hits"],
                own["false_positives"],
                own["target_held"],
            ), (level.name, p.method)
            for w in p.worlds:
                got = own["worlds"][w.world]
                assert (w.hits, w.accepted, w.hits_interval, w.inside) == (
                    got["hits"],
                    got["accepted"],
                    got["hits_interval"],
                    got["inside"],
                ), (level.name, p.method, w.world)
            rows += 1
        for v in level.verdicts:
            own = mine[f"{level.name}|{v.heading}|{v.a}|{v.b}"]
            assert (v.hits_a, v.hits_b, v.n_relevant, v.held) == (
                own["hits_a"],
                own["hits_b"],
                own["relevant"],
                own["held"],
            ), (level.name, v.heading, v.a, v.b)
            rows += 1
    assert rows == len(mine)
    # docs/benchmark.md's account of it
    docs = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    held, n_rows = check.precision_held()
    inside, tested = check.worlds_inside()
    kept, _, stated = check.verdicts_held()
    assert f"the precision target held in {held} of {n_rows} level x method rows" in docs
    assert f"{inside} of {tested} fresh worlds lie in their stated one-new-world interval" in docs
    assert f"and {kept} of {stated} stated paired verdicts kept their sign" in docs
    flipped = [(lv.name, v) for lv in check.levels for v in lv.verdicts if v.held is False]
    assert len(flipped) == stated - kept == 8 and max(abs(v.board_diff) for _, v in flipped) <= 0.043
    assert sum(1 for name, _ in flipped if name == "mild") == 7
    short = [(lv.name, p.method) for lv in check.levels for p in lv.precision if p.target_held is False]
    assert short == [("medium", "ransac100k"), ("high", "ransac100k")]
    assert all(
        (p.hits, p.hits + p.false_positives) == (6, 8)
        for lv in check.levels
        for p in lv.precision
        if p.target_held is False
    )
