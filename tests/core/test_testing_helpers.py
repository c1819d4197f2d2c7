"""``roman_sim.testing``: bad arguments are errors naming the argument, never a silent pass or ``None < 0.3``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.evaluation.atetable import AteTable, VariantAte
from roman_sim.evaluation.metrics import PairScore, summary
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_ate_below, assert_not_worse, assert_recall, names_list, run_scenario


def _score(i: int, method: str, correct: bool) -> PairScore:
    """A relevant pair at 30 deg heading difference: right with 10 associations, or wrong with 4."""
    truth = PairTruth(
        a=f"a/{i}",
        b=f"b/{i}",
        robot_a="a",
        robot_b="b",
        index_a=i,
        index_b=i,
        T_a_b_true=np.eye(4),
        center_dist_m=5.0,
        heading_diff_deg=30.0,
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
    return RunResult(Path("."), load_scenario("smoke"), summary(scores), ate, None)  # type: ignore[arg-type]


def test_figures_pass_and_fail_against_hand_computed_values(run: RunResult) -> None:
    assert run.metrics.figure("roman", None, "max_recall") == pytest.approx(0.75)
    assert_recall(run, "roman", 0.75)
    assert_recall(run, "roman", {"0-60": 0.75}, key="max_recall")
    assert_recall(run, "roman", 0.75, key="recall_at_precision_1")
    with pytest.raises(AssertionError, match=r"roman max_recall overall: 0\.750 < 0\.76"):
        assert_recall(run, "roman", 0.76)
    with pytest.raises(AssertionError, match="roman max_recall heading 120-180 deg: undefined .no relevant pairs."):
        assert_recall(run, "roman", {"120-180": 0.1})
    assert_not_worse(run, "roman", "clipper")
    with pytest.raises(AssertionError, match=r"clipper max_recall overall: 0\.500 < roman 0\.750"):
        assert_not_worse(run, "clipper", "roman")
    assert_not_worse(run, "clipper", "roman", tolerance=0.25)
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
    with pytest.raises(ConfigError, match="key: unknown figure 'f1'"):
        assert_not_worse(run, "roman", "clipper", key="f1")
    with pytest.raises(EvaluationError, match=r"method 'ransac' not in this run \(methods: clipper, roman\)"):
        assert_recall(run, "ransac", 0.1)
    with pytest.raises(EvaluationError, match=r"heading bin '50-70' unknown \(bins: 0-60, 60-120, 120-180"):
        assert_recall(run, "roman", {"50-70": 0.1})
    with pytest.raises(ConfigError, match="tolerance: expected a finite number in"):
        assert_not_worse(run, "roman", "clipper", tolerance=math.nan)
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
