"""The benchmark on a chosen confidence score, on a hand-built level of three worlds with float scores:
leave-one-world-out thresholds among the calibration pairs' own values, the pooled precision-recall curve
and its area by the trapezoid rule, world intervals by the documented draws, the board's records and
tables; and a score a method does not offer refused in one line with nothing written."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from fractions import Fraction as Fr
from pathlib import Path

import numpy as np
import pytest
from committed_results import STANDARD
from typer.testing import CliRunner

from roman_sim.benchmark.board_curves import area, level_curves
from roman_sim.benchmark.board_markdown import _deployable_section, auc_readme_line, auc_table
from roman_sim.benchmark.board_records import BoardCell, BoardLevel, Leaderboard, read_leaderboard
from roman_sim.benchmark.board_records import write_leaderboard_json as write_board
from roman_sim.benchmark.deployable import deployable
from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.evaluation.operating_points import pr_area

EDGES = [0.0, 90.0, 180.0]
K = list(range(0, 21))
TARGET = 0.75

#: Per world the pairs of method ``m``: (objective, relevant, correct); None: no objective (a failed alignment).
#: Hits are relevant and correct; the wrong pairs (not correct) are irrelevant but one, which has no score.
WORLDS = {
    "w0": [(0.9, True, True), (0.7, True, True), (0.5, False, False), (0.3, True, True)],
    "w1": [(0.8, True, True), (0.6, False, False), (0.4, True, True), (None, True, False)],
    "w2": [(0.95, True, True), (0.65, True, True), (0.55, False, False), (0.2, False, False)],
}


def _pairs(make_score, worlds=WORLDS, method: str = "m"):
    out = []
    for w, rows in worlds.items():
        for i, (v, rel, ok) in enumerate(rows):
            s = make_score(f"{i}", rel, 0 if v is None else int(10 * v), ok, method, 30.0 if i % 2 else 120.0)
            t = s.truth
            s = replace(s, truth=replace(t, a=f"{w}:{t.a}", b=f"{w}:{t.b}", robot_b=f"b{i % 2}"))
            out.append(replace(s, named=() if v is None else (("objective", v),)))
    return out


def test_thresholds_on_a_float_score_are_chosen_on_the_other_worlds_as_by_hand(make_score, tmp_path: Path) -> None:
    """By hand, target 3/4, the smallest own value of the calibration pairs whose precision reaches it:
    without w0 (w1 + w2): 0.55 gives 3 hits / 5, 0.6 gives 3 / 4 -> 0.6; w0 at 0.6: 0.9, 0.7 (2 hits, 0 wrong).
    Without w1 (w0 + w2): 0.5 gives 4 / 6, 0.55 gives 4 / 5 -> 0.55; w1 at 0.55: 0.8 and the wrong 0.6 (1, 1).
    Without w2 (w0 + w1): 0.5 gives 3 / 5, 0.6 gives 3 / 4 -> 0.6; w2 at 0.6: 0.95, 0.65 (2, 0).
    Every world: 0.55 gives 5 / 7, 0.6 gives 5 / 6 -> 0.6. The pair without a score is accepted at no threshold."""
    dep = deployable(_pairs(make_score), ["m"], EDGES, K, TARGET, score="objective")
    assert dep.thresholds == {"m": {"w0": 0.6, "w1": 0.55, "w2": 0.6}}
    assert dep.deployed == {"m": 0.6}
    assert dep.overall is not None
    c = dep.overall.methods["m"]
    assert (c.hits, c.false_positives, c.n_relevant) == (5, 1, 8)  # relevant: 3 + 3 (the unscored one) + 2
    assert c.precision == 5 / 6 and c.recall == 5 / 8
    # the association count (a tenth of the objective, rounded down) is chosen on as before: whole k
    ints = deployable(_pairs(make_score), ["m"], EDGES, K, TARGET)
    assert ints.thresholds is not None and ints.thresholds["m"]["w0"] == 6  # w1 + w2 at k = 6: 3 hits, 1 wrong
    assert all(type(k) is int for k in ints.thresholds["m"].values())
    # both kinds of threshold round-trip through leaderboard.json with their type
    level = BoardLevel("one", 0.0, ["w0"], None, overall=BoardCell("all", 0, 0, {}, {}, None), deployable=dep)
    board = Leaderboard("t", "", ["m"], [], list(EDGES), 0.1, {}, [level], target_precision=TARGET, score="objective")
    board_k = replace(board, levels=[replace(level, deployable=ints)], score="associations")
    for b in (board, board_k):
        back = read_leaderboard(write_board(tmp_path / f"{b.score}.json", b))
        assert back == b
        got = back.levels[0].deployable
        want = b.levels[0].deployable
        assert got is not None and want is not None and got.thresholds is not None and want.thresholds is not None
        assert [type(k) for k in got.thresholds["m"].values()] == [type(k) for k in want.thresholds["m"].values()]
    md = "\n".join(_deployable_section(board))
    assert "one threshold on the score `objective`" in md and "w0: 0.6, w1: 0.55, w2: 0.6" in md
    assert "thresholds (held-out world: objective)" in md


#: The pooled curve by hand: at each own value t ascending, (hits, wrong accepted) over the 8 relevant pairs.
SWEEP = {
    0.2: (7, 4),
    0.3: (7, 3),
    0.4: (6, 3),
    0.5: (5, 3),
    0.55: (5, 2),
    0.6: (5, 1),
    0.65: (5, 0),
    0.7: (4, 0),
    0.8: (3, 0),
    0.9: (2, 0),
    0.95: (1, 0),
}


def test_the_curve_and_its_area_are_the_hand_trapezoid(make_score) -> None:
    """Best precision per recall: 1 up to recall 5/8, 6/9 at 6/8, max(7/11, 7/10) at 7/8; begun at (0, 1).
    Area = 5/8 * 1 + 1/8 * (1 + 2/3) / 2 + 1/8 * (2/3 + 7/10) / 2 = 391/480."""
    curves = level_curves(_pairs(make_score), ["m"], "objective", K)
    assert curves is not None and curves.score == "objective"
    c = curves.methods["m"]
    assert (c.n_pairs, c.n_relevant) == (12, 8)
    assert [p.threshold for p in c.points] == list(SWEEP)
    assert [(p.hits, p.false_positives) for p in c.points] == list(SWEEP.values())
    assert [p.precision for p in c.points] == [h / (h + f) for h, f in SWEEP.values()]
    hand = Fr(5, 8) + Fr(1, 8) * (1 + Fr(2, 3)) / 2 + Fr(1, 8) * (Fr(2, 3) + Fr(7, 10)) / 2
    assert hand == Fr(391, 480) and c.auc == pytest.approx(float(hand), abs=1e-15)
    # the world interval: the documented draws (default_rng(0).integers(0, 3, (draws, 3))), each draw's pooled
    # curve and its area by the package's own rule, the 2.5 and 97.5 % quantiles
    per = {w: _pairs(make_score, {w: rows}) for w, rows in WORLDS.items()}
    names = list(WORLDS)
    areas = []
    for pick in np.random.default_rng(0).integers(0, 3, (curves.draws, 3)):
        rows = [s for i in pick for s in per[names[i]]]
        tp = np.array(
            [
                sum(1 for s in rows if s.truth.relevant and s.correct and (s.score("objective") or -1) >= t)
                for t in SWEEP
            ],
            dtype=float,
        )
        fp = np.array(
            [sum(1 for s in rows if not s.correct and (s.score("objective") or -1) >= t) for t in SWEEP], dtype=float
        )
        rel = sum(1 for s in rows if s.truth.relevant)
        with np.errstate(invalid="ignore", divide="ignore"):
            areas.append(pr_area(np.where(tp + fp > 0, tp / (tp + fp), np.nan), tp / rel))
    assert c.auc_worlds == pytest.approx(list(np.quantile(areas, [0.025, 0.975])), abs=1e-12)
    assert c.auc_worlds[0] < c.auc < c.auc_worlds[1]


def test_identical_worlds_give_a_zero_width_interval_and_the_fast_area_is_pr_area(make_score) -> None:
    same = {w: WORLDS["w0"] for w in ("a", "b", "c")}
    c = level_curves(_pairs(make_score, same), ["m"], "objective", K)
    assert c is not None
    m = c.methods["m"]
    # w0 alone: hits at 0.9, 0.7, 0.3 and one wrong at 0.5: (1/3, 1), (2/3, 1), (2/3, 2/3), (1, 3/4)
    hand = 2 / 3 + (1 / 3) * (1 + 0.75) / 2
    assert m.auc == pytest.approx(hand, abs=1e-15) and m.auc_worlds == pytest.approx([hand, hand], abs=1e-15)
    assert m.auc_mc_error == 0.0
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        p = np.where(rng.random(n) < 0.2, np.nan, rng.integers(0, 5, n) / 4)
        r = np.where(rng.random(n) < 0.1, np.nan, rng.integers(0, 5, n) / 4)
        a, b = area(p, r), pr_area(p, r)
        assert (np.isnan(a) and np.isnan(b)) or a == b


def test_the_auc_table_readme_line_and_figure_read_the_board(make_score, tmp_path: Path) -> None:
    scores = _pairs(make_score) + _pairs(make_score, method="n")
    curves = level_curves(scores, ["m", "n"], "objective", K)
    dep = deployable(scores, ["m", "n"], EDGES, K, TARGET, score="objective")
    assert curves is not None
    c = curves.methods["m"]
    assert c.auc_worlds is not None and c.auc is not None
    lines = auc_table(curves, ["m", "n"])
    assert lines[0].startswith("Area under the precision-recall curve on `objective`")
    assert f"| m | {c.auc:.3f} [{c.auc_worlds[0]:.3f}, {c.auc_worlds[1]:.3f}] |" in lines
    level = BoardLevel(
        "one", 0.0, [], None, overall=BoardCell("all", 0, 0, {}, {}, None), deployable=dep, curves=curves
    )
    board = Leaderboard(
        "t", "", ["m", "n"], [], list(EDGES), 0.1, {}, [level], target_precision=TARGET, score="objective"
    )
    assert "\n".join(lines) in "\n".join(_deployable_section(board))
    from roman_sim.benchmark.board_plots import benchmark_figures, plot_score_pr
    from roman_sim.core.figures import read_png_data

    assert "score_pr.png" in benchmark_figures(board)
    shown = read_png_data(plot_score_pr(board, tmp_path / "score_pr.png"))
    assert shown["one"]["m"]["auc"] == c.auc
    assert shown["one"]["m"]["points"] == [
        [p.threshold, p.recall, p.precision, *(p.precision_worlds or [None, None])] for p in c.points
    ]
    assert [r[0] for r in shown["one"]["n"]["points"]] == list(SWEEP)
    line = auc_readme_line(board)
    assert line is not None and f"one m {c.auc:.2f} [{c.auc_worlds[0]:.2f}, {c.auc_worlds[1]:.2f}]" in line


@pytest.fixture(name="two_cells")
def _two_cells(tmp_path: Path) -> Path:
    """Two committed cells of the standard benchmark (low, seeds 0 and 1) as a folder of their own."""
    if not (STANDARD / "benchmark.json").is_file():
        pytest.skip("no committed standard benchmark results")
    out = tmp_path / "two"
    rec = json.loads((STANDARD / "benchmark.json").read_text(encoding="utf-8"))
    rec["cells"] = [c for c in rec["cells"] if c["id"] in ("low-s0", "low-s1")]
    (out / "cells").mkdir(parents=True)
    for c in rec["cells"]:
        shutil.copytree(STANDARD / "cells" / c["id"], out / "cells" / c["id"])
    (out / "benchmark.json").write_text(json.dumps(rec), encoding="utf-8")
    return out


def test_a_score_a_method_does_not_offer_is_one_line_and_nothing_is_written(two_cells: Path) -> None:
    before = sorted(p.relative_to(two_cells) for p in two_cells.rglob("*"))
    res = CliRunner().invoke(
        app, ["benchmark", "standard", "--out", str(two_cells), "--report-only", "--score", "objective"]
    )
    lines = [x for x in res.output.splitlines() if x.strip()]
    assert res.exit_code == 1 and len(lines) == 1, res.output
    assert "score 'objective': method ransac100k does not offer it (it offers: associations, inliers)" in lines[0]
    assert sorted(p.relative_to(two_cells) for p in two_cells.rglob("*")) == before
    res = CliRunner().invoke(app, ["benchmark", "standard", "--out", str(two_cells), "--score", "Not A Score"])
    assert res.exit_code == 1 and res.output.startswith("--score: 'Not A Score' is no score name"), res.output
    from roman_sim.benchmark.cells import Cell
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite

    # a score a built-in method declares it cannot give: refused when the job is made, before any cell runs
    with pytest.raises(ConfigError, match=r"method ransac100k does not offer it \(it can offer: associations, inliers"):
        BenchmarkJob(load_suite("standard"), two_cells, score="objective")
    # a declared score a result can lack (CLIPPER without semantics gives no ``semantic``): a run checks the first
    # finished cell before the next one runs, with the same line as the job's error
    job = BenchmarkJob(load_suite("standard"), two_cells, methods=["roman", "clipper"], score="semantic")
    cell = Cell("low", 0, job.scenes["low"])
    assert cell.id == "low-s0"
    with pytest.raises(ConfigError, match=r"--score: score 'semantic': method clipper does not offer it .*low-s0"):
        job.check_score([cell])
    assert sorted(p.relative_to(two_cells) for p in two_cells.rglob("*")) == before


def test_a_named_score_in_the_pairs_tables_is_chosen_on_end_to_end(two_cells: Path) -> None:
    """The two committed cells with a named score added to their pairs tables: a tenth of the association count.
    On the calibration world it accepts the same sets of pairs as the count, in the same order, so each threshold
    is a tenth of a count at least the association board's k: the same where the calibration world has a pair
    with k associations (then every held-out figure is the association board's), the next count it has where
    not (a threshold is one of the calibration pairs' own values: a held-out pair between is not accepted)."""
    import csv
    import gzip
    import io

    from roman_sim.benchmark.board import leaderboard
    from roman_sim.core.records import to_json

    counts: dict[str, set[tuple[str, int]]] = {}
    for cell in ("low-s0", "low-s1"):
        path = two_cells / "cells" / cell / "pairs.csv.gz"
        rows = list(csv.DictReader(io.StringIO(gzip.decompress(path.read_bytes()).decode("utf-8"))))
        counts[cell] = {(r["method"], int(r["n_assoc"])) for r in rows if r["kind"] == "inter"}
        out = io.StringIO()
        w = csv.DictWriter(out, [*rows[0], "score_objective"], lineterminator="\n")
        w.writeheader()
        w.writerows({**r, "score_objective": repr(int(r["n_assoc"]) / 10)} for r in rows)
        path.write_bytes(gzip.compress(out.getvalue().encode("utf-8")))
    res = CliRunner().invoke(
        app, ["benchmark", "standard", "--out", str(two_cells), "--report-only", "--score", "objective"]
    )
    assert res.exit_code == 0, res.output
    assert "threshold on objective chosen on other worlds" in " ".join(res.output.split())
    board, on_counts = read_leaderboard(two_cells / "leaderboard.json"), leaderboard(two_cells)[0]
    assert board.score == "objective" and on_counts.score == "associations"
    (lv,) = [e for e in board.levels if e.name == "low"]
    (lk,) = [e for e in on_counts.levels if e.name == "low"]
    d, k = lv.deployable, lk.deployable
    assert d is not None and k is not None and d.thresholds is not None and k.thresholds is not None
    same = 0
    for m, per in d.thresholds.items():
        for world, t in per.items():
            other = next(w for w in counts if w != world)
            kk = k.thresholds[m][world]
            assert (t is None) == (kk is None), (m, world)
            if t is None or kk is None:
                continue
            assert type(t) is float and (m, round(10 * t)) in counts[other], (m, world, t)
            assert round(10 * t) == min(n for mm, n in counts[other] if mm == m and n >= kk), (m, world, t, kk)
        if all(t is not None and round(10 * t) == k.thresholds[m][w] for w, t in per.items()):
            same += 1
            for a, b in zip(d.cells(), k.cells(), strict=True):
                assert to_json(a.methods[m]) == to_json(b.methods[m]), (m, a.heading)
    assert same >= 5  # every method but one: the visual method's k = 8 is no count of low-s0
    assert lv.curves is not None and lv.curves.score == "objective"
    md = (two_cells / "leaderboard.md").read_text(encoding="utf-8")
    assert "Area under the precision-recall curve on `objective`" in md and "(held-out world: objective)" in md


#: One world's pairs of a better method (its one wrong pair scored below two hits) and a worse one (its wrong
#: pair scored highest). Hand areas: better 2/3 + 1/3 * (1 + 3/4) / 2 = 23/24; worse, from (0, 0) through
#: (1/3, 1/2), (2/3, 2/3) and (1, 3/4): 1/3 * (0 + 1/2) / 2 + 1/3 * (1/2 + 2/3) / 2 + 1/3 * (2/3 + 3/4) / 2 = 37/72.
BETTER = [(0.9, True, True), (0.7, True, True), (0.5, False, False), (0.3, True, True)]
WORSE = [(0.9, False, False), (0.7, True, True), (0.5, True, True), (0.3, True, True)]


def _two_methods(make_score, better_in: int) -> list:
    """Six worlds; method ``m`` is the better one in the first ``better_in`` worlds and the same as ``n`` after."""
    worlds_m = {f"w{i}": BETTER if i < better_in else WORSE for i in range(6)}
    worlds_n = {f"w{i}": WORSE for i in range(6)}
    return _pairs(make_score, worlds_m, "m") + _pairs(make_score, worlds_n, "n")


def test_the_paired_area_verdict_is_the_exact_sign_flip_test_by_hand(make_score) -> None:
    """Six worlds where m's area is 23/24 and n's 37/72: each difference 0.444 (rounded to 444 thousandths), the
    exact two-sided p-value 2 / 2^6 = 0.03125: m ahead. One world's truth flipped so that m there is n: five
    moving worlds, p = 2 / 2^5 = 0.0625: no difference shown. The verdict reads the same from either side."""
    from roman_sim.benchmark.board_curves import auc_verdict
    from roman_sim.benchmark.board_markdown import auc_verdict_text

    curves = level_curves(_two_methods(make_score, 6), ["m", "n"], "objective", K)
    assert curves is not None
    m, n = curves.methods["m"], curves.methods["n"]
    assert m.world_auc == pytest.approx([23 / 24] * 6, abs=1e-15) and n.world_auc == pytest.approx([37 / 72] * 6)
    assert (m.max_hits, n.max_hits) == (18, 18)
    (v,) = curves.verdicts
    assert (v.a, v.b, v.verdict, v.p_value, v.worlds) == ("m", "n", "a ahead", 2 / 64, 6)
    assert v.diff == pytest.approx(23 / 24 - 37 / 72, abs=1e-15)
    assert auc_verdict("n", "m", n, m).verdict == "b ahead"
    assert auc_verdict_text(v) == "m ahead: +0.444 (p 0.031, 6 worlds)"
    flipped = level_curves(_two_methods(make_score, 5), ["m", "n"], "objective", K)
    assert flipped is not None
    (v,) = flipped.verdicts
    assert (v.verdict, v.p_value, v.worlds) == ("no difference shown", 2 / 32, 6)
    table = "\n".join(auc_table(flipped, ["m", "n"]))
    assert "- m - n: no difference shown: +0.370 (p 0.062, 6 worlds)" in table


def test_a_paired_area_verdict_below_the_floor_says_too_few_hits(make_score) -> None:
    """Both methods reach fewer than 10 hits at their loosest threshold: too few hits, whatever the p-value."""
    worlds_m = {f"w{i}": BETTER for i in range(3)}
    worlds_n = {f"w{i}": WORSE for i in range(3)}
    scores = _pairs(make_score, worlds_m, "m") + _pairs(make_score, worlds_n, "n")
    curves = level_curves(scores, ["m", "n"], "objective", K)
    assert curves is not None and curves.methods["m"].max_hits == 9
    assert curves.verdicts[0].verdict == "too few hits"


def test_a_score_no_method_declares_is_refused_before_any_cell_runs(tmp_path: Path) -> None:
    """The built-in methods declare the named scores they can give: a score one of them cannot give is refused
    when the job is made, before the folder exists; a plug-in that declares none is checked on its first cell."""
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite

    out = tmp_path / "board"
    with pytest.raises(ConfigError) as err:
        BenchmarkJob(load_suite("quick"), out, methods=["roman", "ransac100k"], score="inliers")
    assert str(err.value) == (
        "--score: score 'inliers': method roman does not offer it (it can offer: associations, objective, density, "
        "percent_associations, margin, semantic); nothing run or written"
    )
    with pytest.raises(ConfigError, match="method ransac100k does not offer it .*associations, inliers\\)"):
        BenchmarkJob(load_suite("quick"), out, methods=["ransac100k"], score="margin")
    assert not out.exists()
    plugin = "roman_sim.examples.mutual_nn_aligner:MutualNNAligner"
    job = BenchmarkJob(load_suite("quick"), out, methods=["roman", plugin], score="margin")
    assert job.score == "margin" and not out.exists()
