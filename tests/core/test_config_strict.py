"""Strict configuration: repeated YAML keys, non-finite numbers, nested unknown keys, override paths.

Every case is one ``ConfigError`` line that names the field (or key and line) and says what
is allowed; the CLI cases also check that no traceback escapes and the exit code is 1.
"""

from __future__ import annotations

import math

import pytest
from pydantic import Field

from roman_sim.core.config import (
    FiniteTree,
    StrictModel,
    apply_overrides,
    override_model,
    parse_yaml,
    read_yaml,
    validate_model,
)
from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.scenario import load_scenario

SMOKE_ROBOT = "robots: [{name: a, path: {kind: road}}]\n"


class Leaf(StrictModel):
    x: float = 1.0
    pair: tuple[float, float] = (0.0, 1.0)


class Tree(StrictModel):
    edges: list[float] = Field(default_factory=lambda: [0.0, 1.0])
    leaves: list[Leaf] = Field(default_factory=list)
    either: str | Leaf = "name"
    free: dict[str, FiniteTree] = Field(default_factory=dict)
    maybe: float | None = None


def _err(data: dict) -> str:
    with pytest.raises(ConfigError) as e:
        validate_model(Tree, data, "t.yaml")
    return str(e.value)


@pytest.mark.parametrize(
    ("text", "key", "first", "again"),
    [
        ("seed: 0\nname: x\nseed: 1\n", "seed", 1, 3),
        ("a:\n  b: 1\n  c: 2\n  b: 3\n", "b", 2, 4),
        ("robots:\n  - {name: a, name: b}\n", "name", 2, 2),
    ],
)
def test_repeated_keys_are_an_error_naming_key_and_lines(text: str, key: str, first: int, again: int) -> None:
    with pytest.raises(ConfigError) as e:
        parse_yaml(text, "s.yaml")
    assert str(e.value).startswith("s.yaml: malformed YAML")
    assert f"duplicate key {key!r} (first at line {first}, again at line {again})" in str(e.value)


def test_merge_keys_may_be_overridden_and_repeats_elsewhere_are_fine() -> None:
    data = parse_yaml("base: &b {x: 1, y: 2}\nd:\n  <<: *b\n  x: 5\ne: {x: 1}\n", "s.yaml")
    assert data["d"] == {"x": 5, "y": 2} and data["e"] == {"x": 1}


@pytest.mark.parametrize(
    ("data", "field", "got"),
    [
        ({"edges": [0.0, math.nan, 2.0]}, "edges.1", "nan"),
        ({"edges": [0.0, math.inf]}, "edges.1", "inf"),
        ({"leaves": [{}, {"x": -math.inf}]}, "leaves.1.x", "-inf"),
        ({"leaves": [{"pair": [math.nan, 1.0]}]}, "leaves.0.pair.0", "nan"),
        ({"either": {"x": math.nan}}, "either.x", "nan"),
        ({"free": {"a": {"b": [1.0, math.nan]}}}, "free.a.b.1", "nan"),
        ({"maybe": math.nan}, "maybe", "nan"),
        ({"maybe": "nan"}, "maybe", "'nan'"),
    ],
)
def test_non_finite_numbers_are_rejected_naming_the_field(data: dict, field: str, got: str) -> None:
    msg = _err(data)
    assert msg == f"t.yaml: {field}: must be a finite number (got {got})", msg


def test_unknown_nested_keys_list_the_allowed_ones() -> None:
    msg = _err({"leaves": [{}, {"y": 1}]})
    assert msg == "t.yaml: leaves.1.y: unknown key (allowed: pair, x)"
    assert _err({"either": {"y": 1}}) == "t.yaml: either.y: unknown key (allowed: pair, x)"
    msg = _err({"nope": 1})
    assert msg == "t.yaml: nope: unknown key (allowed: edges, either, free, leaves, maybe)"


def test_a_union_field_reports_what_it_accepts() -> None:
    msg = _err({"either": 5})
    assert msg == "t.yaml: either: expected a string or a mapping of Leaf fields (got 5)"


@pytest.mark.parametrize(
    ("sets", "expect"),
    [
        (
            ["robots.5.drift=poor"],
            "--set robots.5.drift: position 5 out of range: robots has 2 entries (positions: 0..1)",
        ),
        (["robots.x.drift=poor"], "--set robots.x.drift: robots is a list of 2 entries, 'x' is not a position in it"),
        (["robots.-1.drift=poor"], "'-1' is not a position in it (positions: 0..1)"),
        (["seed.x=1"], "--set seed.x: seed is a number (0), not a mapping or list, so it has no 'x'"),
        (["a..b=1"], "empty key or empty part in 'a..b'"),
        (["noequals"], "--set 'noequals': expected key=value"),
        (["x={a: 1, a: 2}"], "--set x: value '{a: 1, a: 2}': malformed YAML (line 1, column 8): duplicate key 'a'"),
        (
            ["robots.0.camera.bogus=1"],
            "robots.0.camera.bogus: unknown key (allowed: depth_noise, far_m, height, hfov_deg",
        ),
        (
            ["evaluation.heading_bins_deg=[0, .nan, 180]"],
            "evaluation.heading_bins_deg.1: must be a finite number (got nan)",
        ),
        (
            ["mapping.obs_plane_extents_m=[3, .inf, 0.2]"],
            "mapping.obs_plane_extents_m.1: must be a finite number (got inf)",
        ),
        (
            ["robots.0.path.waypoints=[[0, .nan], [5, 5]]"],
            "robots.0.path.waypoints.0.1: must be a finite number (got nan)",
        ),
        (["world.overrides={extent_m: [.nan, 50]}"], "world.overrides.extent_m.0: must be a finite number (got nan)"),
        (
            ["aligners=[{method: roman, params: {sigma: .inf}}]"],
            "aligners.0.params.sigma: must be a finite number (got inf)",
        ),
        (["robots.0.speed_mps=nan"], "robots.0.speed_mps: must be a finite number (got 'nan')"),
        (
            ["frontend.segmenter={miss_prob: 3}"],
            "frontend.segmenter.params: miss_prob: Input should be less than or equal to 1 (got 3)",
        ),
    ],
)
def test_scenario_errors_name_the_field(sets: list[str], expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        load_scenario("smoke", sets)
    assert expect in str(e.value), str(e.value)
    assert "\n" not in str(e.value)


def test_nan_is_not_blamed_on_another_field() -> None:
    """A NaN extent used to fail the range check as 'each side must be in [10, 2000] m'."""
    with pytest.raises(ConfigError) as e:
        load_scenario("smoke", ["evaluation.heading_bins_deg=[0, .nan]"])
    assert "strictly increasing" not in str(e.value) and "[0, 180]" not in str(e.value)


def test_overrides_keep_working_for_valid_paths() -> None:
    data = {"robots": [{"a": 1}, {"a": 2}], "m": {}}
    assert apply_overrides(data, ["robots.1.a=3", "m.n.o=[1, 2]"]) == {
        "robots": [{"a": 1}, {"a": 3}],
        "m": {"n": {"o": [1, 2]}},
    }


def test_a_model_with_overrides_is_validated_again() -> None:
    tree = Tree(leaves=[Leaf(x=2.0)])
    got = override_model(tree, ["leaves.0.x=5", "maybe=0.5"], "tree.yaml")
    assert got == Tree(leaves=[Leaf(x=5.0)], maybe=0.5) and tree.leaves[0].x == 2.0  # a new model
    with pytest.raises(ConfigError, match=r"^tree.yaml: leaves.0.x: "):
        override_model(tree, ["leaves.0.x=wide"], "tree.yaml")


def test_a_directory_is_reported_as_a_directory(tmp_path) -> None:
    with pytest.raises(ConfigError, match="is a directory, expected a scenario YAML file"):
        load_scenario(tmp_path)
    with pytest.raises(ConfigError, match="is a directory, expected a YAML file"):
        read_yaml(tmp_path)
    (tmp_path / "smoke").mkdir()
    assert load_scenario("smoke").name == "smoke"  # a bundled name wins over a same-named folder elsewhere


def test_cli_one_line_for_scenario_errors(tmp_path, cli_fails) -> None:
    dup = tmp_path / "dup.yaml"
    dup.write_text("name: d\nseed: 0\nseed: 1\n" + SMOKE_ROBOT)
    line = cli_fails("run", dup, "--out", tmp_path / "o")
    assert "duplicate key 'seed' (first at line 2, again at line 3)" in line
    line = cli_fails("run", tmp_path, "--out", tmp_path / "o")
    assert "is a directory" in line
    line = cli_fails("run", "smoke", "--set", "robots.5.drift=poor", "--out", tmp_path / "o")
    assert line == "error: --set robots.5.drift: position 5 out of range: robots has 2 entries (positions: 0..1)"
    line = cli_fails("run", "smoke", "--set", "evaluation.heading_bins_deg=[0,.nan,180]", "--out", tmp_path / "o")
    assert line.endswith("evaluation.heading_bins_deg.1: must be a finite number (got nan)")
    assert not (tmp_path / "o").exists()
