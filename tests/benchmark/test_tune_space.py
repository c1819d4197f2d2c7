"""What ``roman-sim tune`` may vary: declared parameters, value ranges, bad input in one line, ``--set @file``."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.align.base import Tunable, declared_tunables
from roman_sim.benchmark.tune_space import DEFAULT_COUNT, build_grid, declared, parse_params
from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.core.overrides import apply_overrides


class _Plugin:
    """A plug-in that declares one parameter of its own."""

    name = "plug"
    tunable_params = {"radius": Tunable(0.5, 5.0, default=(1.0, 2.0), doc="search radius")}

    def __init__(self, radius: float = 1.0) -> None:
        self.radius = radius


def test_declared_parameters():
    assert list(declared("roman")) == ["threshold", "gating.top_k", "gating.min_similarity", "cos_min", "cos_max"]
    assert "cos_min" not in declared("clipper")  # no semantics, no pruning: no semantic gate
    assert list(declared("clipper_prune"))[-1] == "cos_min"  # its pruning reads cos_min only
    assert "cos_min" in declared("semantic_gravity") and "cos_max" in declared("semantic_gravity")
    assert list(declared_tunables(_Plugin)) == ["radius"]  # the plug-in hook
    assert list(declared(f"{__name__}:_Plugin"))[-1] == "radius"


def test_values():
    v = parse_params("roman", ["threshold=2:5", "cos_min=0.8:0.9:3", "gating.top_k=8,2,4"])
    assert v["threshold"] == [2.0, 3.0, 4.0, 5.0]
    assert v["cos_min"] == [0.8, 0.85, 0.9]
    assert v["gating.top_k"] == [2.0, 4.0, 8.0]
    assert len(parse_params("roman", ["cos_max=0.9:1"])["cos_max"]) == DEFAULT_COUNT
    assert parse_params("roman", ["cos_min="])["cos_min"] == [0.8, 0.85, 0.9]  # named alone: its defaults
    default = parse_params("roman", [])
    assert default == {"threshold": [float(k) for k in range(1, 31)], "cos_min": [0.8, 0.85, 0.9]}
    grid = build_grid("roman", v)
    assert len(grid.configs) == 3 * 3 and grid.thresholds == [2, 3, 4, 5] and len(grid.alignments()) == 3
    assert grid.configs[0].gating_config() == {"enabled": True, "top_k": 2, "min_similarity": None}


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("radius=1", "--param radius: roman does not declare it (declared: threshold, gating.top_k"),
        ("cos_min=0.9:0.8", "--param cos_min: reversed range 0.9:0.8"),
        ("cos_min=0.8:0.9:0", "--param cos_min: empty range 0.8:0.9:0"),
        ("cos_max=", "--param cos_max: empty range"),
        ("cos_min=,", "--param cos_min: empty list of values"),
        ("cos_min=1.5", "--param cos_min: 1.5 is outside the allowed [-1, 1]"),
        ("threshold=2.5", "--param threshold: takes integers, got 2.5"),
        ("threshold=x", "--param threshold: 'x' is not a number"),
    ],
)
def test_bad_parameters_name_the_field(item: str, message: str):
    with pytest.raises(ConfigError) as err:
        parse_params("roman", [item])
    assert str(err.value).startswith(message)


def test_a_combination_the_aligner_refuses():
    with pytest.raises(ConfigError, match="roman refuses cos_max=0.8, cos_min=0.9"):
        build_grid("roman", parse_params("roman", ["cos_min=0.9", "cos_max=0.8"]))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--target-precision", "0"], "--target-precision: must lie in (0, 1], got 0"),
        (["--target-precision", "1.2"], "--target-precision: must lie in (0, 1], got 1.2"),
        (["--param", "foo=1:2"], "--param foo: roman does not declare it"),
        (["--param", "threshold=9:3"], "--param threshold: reversed range 9:3"),
        (["--seeds", "0"], "worlds: smoke gives 1 world; tuning needs at least two"),
        (["--seeds", "3:3"], "--seeds: empty or reversed range 3:3"),
    ],
)
def test_cli_bad_input_in_one_line_before_anything_runs(tmp_path: Path, args: list[str], message: str):
    out = tmp_path / "t"
    res = CliRunner().invoke(app, ["tune", "smoke", "--out", str(out), *args])
    assert res.exit_code == 1, res.output
    lines = [x for x in res.output.splitlines() if x.strip()]
    assert len(lines) == 1 and message in lines[0], res.output
    assert not out.exists()  # nothing ran


def test_set_file_applies_scenario_sections(tmp_path: Path):
    f = tmp_path / "rec.yaml"
    f.write_text(
        "# comment\naligners:\n- method: roman\n  params: {cos_min: 0.9}\n"
        "posegraph: {lc_association_thresh: 3}\ngating: {enabled: true, top_k: 4, min_similarity: null}\n"
    )
    data = {"aligners": ["roman", "clipper"], "posegraph": {"lc_association_thresh": 4, "other": 1}, "seed": 2}
    got = apply_overrides(data, [f"@{f}", "seed=5"])
    assert got == {
        "aligners": [{"method": "roman", "params": {"cos_min": 0.9}}],
        "posegraph": {"lc_association_thresh": 3, "other": 1},
        "gating": {"enabled": True, "top_k": 4, "min_similarity": None},
        "seed": 5,
    }
    with pytest.raises(ConfigError, match="cannot read the file"):
        apply_overrides(data, [f"@{tmp_path / 'missing.yaml'}"])
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(ConfigError, match="expected a mapping of scenario sections"):
        apply_overrides(data, [f"@{tmp_path / 'list.yaml'}"])


def test_worlds_of_a_scenario_a_sweep_and_a_suite():
    from roman_sim.benchmark.tune import load_worlds, tuned_scenario

    ws = load_worlds("smoke", "roman", [3, 5], [])
    assert [w.id for w in ws] == ["s3", "s5"] and [w.scenario.seed for w in ws] == [3, 5]  # type: ignore[union-attr]
    sweep = Path(__file__).resolve().parents[2] / "scenarios" / "sweeps" / "ambiguity_sweep.yaml"
    ws = load_worlds(str(sweep), "roman", None, [])
    assert len(ws) == 5 and len({w.id for w in ws}) == 5
    knobs = sorted(w.scenario.world.overrides["ambiguity"] for w in ws)  # type: ignore[union-attr]
    assert knobs == [0.0, 0.5, 0.75, 0.9, 1.0]
    ws = load_worlds("quick", "roman", [0, 4], [])
    assert [w.id for w in ws] == ["low-s0", "low-s4", "medium-s0", "medium-s4", "high-s0", "high-s4"]
    sc = tuned_scenario(load_worlds("smoke", "roman", [0, 1], [])[0].scenario, "roman", {"cos_min": 0.8}, "x")  # type: ignore[arg-type]
    assert [(e.method, e.params) for e in sc.aligners] == [("roman", {"cos_min": 0.8})]
    assert sc.posegraph_method is None and not sc.gating.enabled
