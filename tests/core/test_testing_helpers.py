"""``roman_sim.testing``: bad arguments are errors naming the argument, never a silent pass or ``None < 0.3``."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.pipeline.experiment import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_ate_below, assert_not_worse, assert_recall, names_list, run_scenario

BINS = [{"label": "0-60", "max_recall": 0.8, "best_f1": 0.7},
        {"label": "120-180", "max_recall": None, "best_f1": None}]
METRICS = {"methods": {
    "roman": {"max_recall": 0.6, "best_f1": 0.5, "recall_at_precision_1": 0.4, "auc": 0.3, "heading_bins": BINS},
    "clipper": {"max_recall": 0.4, "best_f1": 0.3, "recall_at_precision_1": 0.2, "auc": 0.1, "heading_bins": BINS},
}}
ATE = {"odometry": {"se3": {"all": 1.0}}, "roman": {"se3": {"all": 0.5}}}


@pytest.fixture(scope="module")
def run() -> RunResult:
    return RunResult(Path("."), load_scenario("smoke"), METRICS, ATE, {})


def test_figures_pass_and_fail_against_hand_computed_values(run: RunResult) -> None:
    assert_recall(run, "roman", 0.6)
    assert_recall(run, "roman", {"0-60": 0.8}, key="max_recall")
    assert_recall(run, "roman", 0.5, key="best_f1")
    with pytest.raises(AssertionError, match=r"roman auc overall: 0\.300 < 0\.31"):
        assert_recall(run, "roman", 0.31, key="auc")
    with pytest.raises(AssertionError, match="roman max_recall heading 120-180 deg: undefined .no relevant pairs."):
        assert_recall(run, "roman", {"120-180": 0.1})
    assert_not_worse(run, "roman", "clipper")
    with pytest.raises(AssertionError, match=r"clipper max_recall overall: 0\.400 < roman 0\.600"):
        assert_not_worse(run, "clipper", "roman")
    assert_not_worse(run, "clipper", "roman", tolerance=0.2)
    assert_ate_below(run, "roman")


@pytest.mark.parametrize(("minimum", "expect"), [
    (math.nan, "minimum: expected a finite number in [0, 1], got nan"),
    (math.inf, "minimum: expected a finite number in [0, 1], got inf"),
    (1.5, "minimum: expected a finite number in [0, 1], got 1.5"),
    (-0.1, "minimum: expected a finite number in [0, 1], got -0.1"),
    (True, "minimum: expected a number in [0, 1], got True"),
    ("0.3", "minimum: expected a number in [0, 1], got '0.3'"),
    ({"0-60": math.nan}, "minimum['0-60']: expected a finite number in [0, 1], got nan"),
    ({}, "minimum: an empty mapping checks nothing"),
    ({60: 0.2}, "minimum: heading bin labels are strings such as '0-60', got 60"),
])
def test_bad_bounds_are_rejected(run: RunResult, minimum: object, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        assert_recall(run, "roman", minimum)  # type: ignore[arg-type]
    assert str(e.value).startswith(expect), str(e.value)


def test_unknown_names_list_the_valid_ones(run: RunResult) -> None:
    with pytest.raises(ConfigError, match="key: unknown figure 'recall' .valid: max_recall, recall_at_precision_1, "
                                          "best_f1, auc."):
        assert_recall(run, "roman", 0.1, key="recall")
    with pytest.raises(ConfigError, match="key: unknown figure 'f1'"):
        assert_not_worse(run, "roman", "clipper", key="f1")
    with pytest.raises(EvaluationError, match=r"method 'ransac' not in this run \(methods: clipper, roman\)"):
        assert_recall(run, "ransac", 0.1)
    with pytest.raises(EvaluationError, match=r"heading bin '60-120' unknown \(bins: 0-60, 120-180\)"):
        assert_recall(run, "roman", {"60-120": 0.1})
    with pytest.raises(ConfigError, match="tolerance: expected a finite number in"):
        assert_not_worse(run, "roman", "clipper", tolerance=math.nan)
    with pytest.raises(ConfigError, match="heading_bin: expected a bin label"):
        assert_not_worse(run, "roman", "clipper", heading_bin=120)  # type: ignore[arg-type]
    with pytest.raises(EvaluationError, match=r"variant: no pose-graph variant 'gnc' in this run \(variants: "
                                              r"odometry, roman\)"):
        assert_ate_below(run, "gnc")
    with pytest.raises(ConfigError, match="alignment: unknown 'sim3' .valid: se3, 4dof, none."):
        assert_ate_below(run, "roman", alignment="sim3")


@pytest.mark.parametrize(("kw", "expect"), [
    ({"aligners": "roman"}, "aligners: expected a list of strings, got the string 'roman' (write aligners=['roman'])"),
    ({"overrides": "seed=2"}, "overrides: expected a list of strings, got the string 'seed=2' (write overrides=['seed=2'])"),
    ({"aligners": ["roman", 3]}, "aligners: every entry must be a string, got 3"),
    ({"aligners": 5}, "aligners: expected a list of strings, got int"),
])
def test_run_scenario_rejects_a_string_where_a_list_is_meant(tmp_path: Path, kw: dict, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        run_scenario("smoke", out=tmp_path, **kw)
    assert str(e.value) == expect
    assert not any(tmp_path.iterdir())  # nothing ran


def test_names_list_accepts_any_iterable_of_strings() -> None:
    assert names_list(("a", "b"), "x") == ["a", "b"]
    assert names_list((n for n in ["c"]), "x") == ["c"]
    assert names_list([], "x") == []
