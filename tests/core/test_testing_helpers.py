"""``roman_sim.testing``: bad arguments are errors naming the argument, never a silent pass or ``None < 0.3``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from roman_sim.benchmark.board_records import BoardCell, BoardLevel, Leaderboard
from roman_sim.core.errors import ConfigError, EvaluationError, StorageError
from roman_sim.evaluation.atetable import AteTable, VariantAte
from roman_sim.evaluation.metrics import PairScore, compute_metrics
from roman_sim.evaluation.operating_points import OperatingPoint
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.results import write_pairs_csv
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import (
    assert_ate_below,
    assert_hits,
    assert_not_worse,
    assert_recall,
    benchmark_pins,
    check_benchmark,
    names_list,
    run_scenario,
)


def _score(i: int, method: str, correct: bool, heading: float = 30.0) -> PairScore:
    """A relevant pair at ``heading`` deg heading difference: right with 10 associations, or wrong with 4."""
    truth = PairTruth(
        a=f"a/{i}",
        b=f"b/{i}",
        robot_a="a",
        robot_b="b",
        index_a=i,
        index_b=i,
        T_a_b_true=np.eye(4),
        center_dist_m=5.0,
        heading_diff_deg=heading,
        overlap=0.5,
        ambiguity=float("nan"),
        relevant=True,
        kind="inter",
    )
    err = 0.1 if correct else 40.0
    return PairScore(truth, method, 10 if correct else 4, err, err, correct, 0.01)


@pytest.fixture(scope="module")
def run() -> RunResult:
    """roman aligns 3 of 4 relevant pairs (max recall 0.75), clipper 2 of 4; no pair lies in 120-180 deg."""
    scores = [_score(i, "roman", i < 3) for i in range(4)] + [_score(i, "clipper", i < 2) for i in range(4)]
    ate = AteTable(
        ["a"],
        ["a"],
        {
            v: VariantAte(v, "joint", ["a"], {"se3": {"common": e, "all": e, "a": e}}, v)
            for v, e in (("odometry", 1.0), ("roman", 0.5))
        },
    )
    return RunResult(Path("."), load_scenario("smoke"), compute_metrics(scores), ate, None)  # type: ignore[arg-type]


def test_figures_pass_and_fail_against_hand_computed_values(run: RunResult) -> None:
    assert run.metrics.figure("roman", None, "max_recall") == pytest.approx(0.75)
    assert_recall(run, "roman", 0.75)
    assert_recall(run, "roman", {"0-60": 0.75}, key="max_recall")
    assert_recall(run, "roman", 0.75, key="recall_at_precision_1")
    with pytest.raises(AssertionError, match=r"roman max_recall overall: 0\.750 < 0\.76"):
        assert_recall(run, "roman", 0.76)
    with pytest.raises(AssertionError, match="roman max_recall heading 120-180 deg: undefined .no relevant pairs."):
        assert_recall(run, "roman", {"120-180": 0.1})
    assert_ate_below(run, "roman")


@pytest.mark.parametrize(
    ("minimum", "expect"),
    [
        (math.nan, "minimum: expected a finite number in [0, 1], got nan"),
        (math.inf, "minimum: expected a finite number in [0, 1], got inf"),
        (1.5, "minimum: expected a finite number in [0, 1], got 1.5"),
        (-0.1, "minimum: expected a finite number in [0, 1], got -0.1"),
        (True, "minimum: expected a number in [0, 1], got True"),
        ("0.3", "minimum: expected a number in [0, 1], got '0.3'"),
        ({"0-60": math.nan}, "minimum['0-60']: expected a finite number in [0, 1], got nan"),
        ({}, "minimum: an empty mapping checks nothing"),
        ({60: 0.2}, "minimum: heading bin labels are strings such as '0-60', got 60"),
    ],
)
def test_bad_bounds_are_rejected(run: RunResult, minimum: object, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        assert_recall(run, "roman", minimum)  # type: ignore[arg-type]
    assert str(e.value).startswith(expect), str(e.value)


def test_unknown_names_list_the_valid_ones(run: RunResult) -> None:
    with pytest.raises(
        ConfigError, match="key: unknown figure 'recall' .valid: max_recall, recall_at_precision_1, best_f1, auc."
    ):
        assert_recall(run, "roman", 0.1, key="recall")
    with pytest.raises(ConfigError, match="key: 'f1' cannot be compared pair by pair .valid: max_recall, "):
        assert_not_worse(run, "roman", "clipper", key="f1")
    with pytest.raises(ConfigError, match="key: 'best_f1' cannot be compared pair by pair"):
        assert_not_worse(run, "roman", "clipper", key="best_f1")
    with pytest.raises(EvaluationError, match=r"method 'ransac' not in this run \(methods: clipper, roman\)"):
        assert_recall(run, "ransac", 0.1)
    with pytest.raises(EvaluationError, match=r"heading bin '50-70' unknown \(bins: 0-60, 60-120, 120-180"):
        assert_recall(run, "roman", {"50-70": 0.1})
    for bad in (math.nan, 1.0, 0.3, True):
        with pytest.raises(ConfigError, match="level: expected a one-sided confidence level in"):
            assert_not_worse(run, "roman", "clipper", level=bad)
    with pytest.raises(ConfigError, match="heading_bin: expected a bin label"):
        assert_not_worse(run, "roman", "clipper", heading_bin=120)  # type: ignore[arg-type]
    with pytest.raises(EvaluationError, match=r"ATE variant 'gnc' unknown \(variants: odometry, roman\)"):
        assert_ate_below(run, "gnc")
    with pytest.raises(EvaluationError, match=r"ATE alignment 'sim3' unknown \(alignments: se3\)"):
        assert_ate_below(run, "roman", alignment="sim3")


@pytest.mark.parametrize(
    ("kw", "expect"),
    [
        (
            {"aligners": "roman"},
            "aligners: expected a list of strings, got the string 'roman' (write aligners=['roman'])",
        ),
        (
            {"overrides": "seed=2"},
            "overrides: expected a list of strings, got the string 'seed=2' (write overrides=['seed=2'])",
        ),
        ({"aligners": ["roman", 3]}, "aligners: every entry must be a string, got 3"),
        ({"aligners": 5}, "aligners: expected a list of strings, got int"),
    ],
)
def test_run_scenario_rejects_a_string_where_a_list_is_meant(tmp_path: Path, kw: dict, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        run_scenario("smoke", out=tmp_path, **kw)
    assert str(e.value) == expect
    assert not any(tmp_path.iterdir())  # nothing ran


def test_names_list_accepts_any_iterable_of_strings() -> None:
    assert names_list(("a", "b"), "x") == ["a", "b"]
    assert names_list((n for n in ["c"]), "x") == ["c"]
    assert names_list([], "x") == []


def _run_of(tmp: Path, hits: dict[str, list[int]], n: int, heading: float = 30.0) -> RunResult:
    """Each method aligns the relevant pairs ``hits[method]`` (indices) of ``n``; pairs.csv written to ``tmp``."""
    scores = [_score(i, m, i in set(h), heading) for m, h in hits.items() for i in range(n)]
    write_pairs_csv(tmp / "pairs.csv", scores)
    return RunResult(tmp, load_scenario("smoke"), compute_metrics(scores, acceptance_k=4), AteTable([], [], {}), None)  # type: ignore[arg-type]


def test_a_regression_from_six_to_one_of_fifteen_fails(tmp_path: Path) -> None:
    """The sample the old interval check let through: the same 15 pairs, 6 hits then 1."""
    run = _run_of(tmp_path, {"clipper": [0, 1, 2, 3, 4, 5], "MyAligner": [0]}, 15, heading=150.0)
    with pytest.raises(AssertionError) as e:
        assert_not_worse(run, "MyAligner", "clipper", heading_bin="120-180")
    assert str(e.value).startswith(
        "MyAligner max_recall 120-180: 1/15 against clipper's 6/15 on the same pairs (5 lost, 0 gained, "
        "McNemar p = 0.0312); the recall lost is at most 0.616 at 95%, above the margin 0.1: MyAligner is worse"
    ), str(e.value)
    assert_not_worse(run, "clipper", "MyAligner", heading_bin="120-180")  # 1 of 15 more hits can only gain


def test_a_true_tie_passes_on_a_large_sample_and_not_on_a_small_one(tmp_path: Path) -> None:
    same = list(range(0, 300, 2))  # both hit the same 150 of 300 pairs
    assert_not_worse(_run_of(tmp_path, {"roman": same, "copy": same}, 300), "copy", "roman")
    # equal recall with swaps: 10 lost, 10 gained of 300 still shows it within 0.1
    swapped = same[10:] + [1 + 2 * i for i in range(10)]
    assert_not_worse(_run_of(tmp_path, {"roman": same, "swapped": swapped}, 300), "swapped", "roman")
    # the same tie on 15 pairs cannot show anything: it fails and names the sample it would need
    small = _run_of(tmp_path, {"roman": [0, 1, 2], "copy": [0, 1, 2]}, 15)
    with pytest.raises(AssertionError) as e:
        assert_not_worse(small, "copy", "roman")
    assert "(0 lost, 0 gained, McNemar p = 1); the recall lost is at most 0.218" in str(e.value)
    assert str(e.value).endswith("this sample cannot show it is not worse; it would need about 36 relevant pairs")
    assert_not_worse(_run_of(tmp_path, {"roman": [0], "copy": [0]}, 36), "copy", "roman")
    with pytest.raises(AssertionError, match="would need about 36 relevant pairs"):
        assert_not_worse(_run_of(tmp_path, {"roman": [0], "copy": [0]}, 35), "copy", "roman")


def test_the_margin_and_the_operating_point_are_the_ones_asked(tmp_path: Path) -> None:
    """41 against 45 of 50 (4 lost): the loss may reach 0.19, within a margin of 0.25, not of 0.1."""
    run = _run_of(tmp_path, {"roman": list(range(45)), "slightly": list(range(41))}, 50)
    with pytest.raises(AssertionError) as e:
        assert_not_worse(run, "slightly", "roman")
    assert str(e.value).endswith(
        "at most 0.192 at 95%, above the margin 0.1: this sample cannot show it is not worse; it would need about "
        "898 relevant pairs"
    )
    assert_not_worse(run, "slightly", "roman", margin=0.25)
    with pytest.raises(AssertionError, match="slightly recall_at_precision_90 overall: 41/50 against roman's 45/50"):
        assert_not_worse(run, "slightly", "roman", key="recall_at_precision_90")
    assert_not_worse(run, "roman", "slightly", key="recall_at_acceptance")
    for bad in (0, 1.0, math.nan, True, "0.1"):
        with pytest.raises(ConfigError, match="margin: expected a recall difference in .0, 1., got"):
            assert_not_worse(run, "slightly", "roman", margin=bad)  # type: ignore[arg-type]


def test_a_paired_check_needs_the_pairs_of_the_run(tmp_path: Path) -> None:
    run = _run_of(tmp_path, {"roman": [0], "copy": [0]}, 40)
    (tmp_path / "pairs.csv").unlink()
    with pytest.raises(StorageError, match="pairs.csv: missing; a paired comparison needs the run's per-pair"):
        assert_not_worse(run, "copy", "roman")


def test_assert_hits_pins_hits_and_relevant_together(run: RunResult) -> None:
    assert_hits(run, "roman", {None: (3, 4), "0-60": (3, 4)})
    assert_hits(run, "roman", {None: (2, 4)}, tolerance=1)
    with pytest.raises(AssertionError, match=r"roman hits overall: 3/4 hits, pinned 2/4 \+- 0"):
        assert_hits(run, "roman", {None: (2, 4)})
    with pytest.raises(AssertionError) as e:  # the relevant pairs grew: fails whatever the hits, with both numbers
        assert_hits(run, "roman", {None: (3, 40)}, tolerance=5)
    assert "relevant pairs changed: pinned 3/40, now 3/4" in str(e.value)


@pytest.mark.parametrize(
    ("pinned", "kw", "expect"),
    [
        ({}, {}, "pinned: an empty pin checks nothing"),
        ([], {}, "pinned: expected a mapping"),
        ({None: 3}, {}, "pinned[None]: expected (hits, relevant), got 3 (a pin of hits alone"),
        ({None: (math.nan, 4)}, {}, "pinned[None] hits: expected a non-negative integer count, got nan"),
        ({None: (True, 4)}, {}, "pinned[None] hits: expected a non-negative integer count, got True"),
        ({None: (3.0, 4)}, {}, "pinned[None] hits: expected a non-negative integer count, got 3.0"),
        ({None: (3, False)}, {}, "pinned[None] relevant: expected a non-negative integer count, got False"),
        ({None: (-1, 4)}, {}, "pinned[None] hits: expected a non-negative integer count, got -1"),
        ({None: (5, 4)}, {}, "pinned[None]: 5 hits out of 4 relevant pairs"),
        ({None: (3, 4)}, {"tolerance": math.nan}, "tolerance: expected a finite number >= 0 of hits, got nan"),
        ({None: (3, 4)}, {"tolerance": -1}, "tolerance: expected a finite number >= 0 of hits, got -1"),
        ({None: (3, 4)}, {"tolerance": True}, "tolerance: expected a finite number >= 0 of hits, got True"),
        ({60: (3, 4)}, {}, "pinned: heading bin labels are strings"),
    ],
)
def test_assert_hits_rejects_pins_that_cannot_fail(run: RunResult, pinned: object, kw: dict, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        assert_hits(run, "roman", pinned, **kw)  # type: ignore[arg-type]
    assert str(e.value).startswith(expect), str(e.value)


def _board() -> Leaderboard:
    """A leaderboard of two methods on one level: roman 9/20 and 30/60, degraded 4/20 and 30/60."""

    def pt(h: int, n: int) -> dict[str, OperatingPoint | None]:
        return {"max_recall": OperatingPoint(0, True, h, n, 0, h / n, None, 1.0, None)}

    def cell(heading: str, roman: tuple[int, int], degraded: tuple[int, int]) -> BoardCell:
        return BoardCell(heading, 100, roman[1], {"roman": pt(*roman), "degraded": pt(*degraded)}, {}, None)

    level = BoardLevel(
        "low", 0.0, ["low-s0"], 4, overall=cell("all", (30, 60), (30, 60)), bins=[cell("0-30", (9, 20), (4, 20))]
    )
    return Leaderboard("tiny", "", ["roman", "degraded"], [], [0.0, 30.0], 0.1, {}, [level])


def test_benchmark_pins_pass_for_the_method_and_fail_for_a_degraded_one() -> None:
    board = _board()
    pins = benchmark_pins(board, "roman")
    assert pins == {"low/0-30": (9, 20), "low/all": (30, 60)}
    check_benchmark(board, "roman", pins)
    with pytest.raises(AssertionError, match=r"degraded max_recall low/0-30: 4/20 hits, pinned 9/20 \+- 0"):
        check_benchmark(board, "degraded", pins)
    check_benchmark(board, "degraded", pins, tolerance=5)
    with pytest.raises(AssertionError, match="relevant pairs changed: pinned 9/21, now 9/20"):
        check_benchmark(board, "roman", {"low/0-30": (9, 21)}, tolerance=3)
    with pytest.raises(ConfigError, match=r"pinned\['low/90-120'\]: no such cell \(cells: low/0-30, low/all\)"):
        check_benchmark(board, "roman", {"low/90-120": (1, 2)})
    with pytest.raises(ConfigError, match="method 'visual' is not in this leaderboard"):
        check_benchmark(board, "visual", pins)
    with pytest.raises(ConfigError, match="pinned: an empty pin checks nothing"):
        check_benchmark(board, "roman", {})
    with pytest.raises(ConfigError, match="point: unknown operating point 'f1'"):
        check_benchmark(board, "roman", pins, point="f1")
