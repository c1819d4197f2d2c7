"""`roman-sim scenario stats`: relevant cross-robot pairs from planned trajectories, as a run counts them."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.scenario_stats import scenario_stats

MULTI_ROBOT = ["multi_robot_hybrid", "multi_robot_outdoor", "multi_robot_tunnel"]
#: Paper-scale scenarios: about 20 s each to generate and drive.
PAPER_SCALE = ["kimera_hybrid", "kimera_outdoor", "kimera_tunnel"]


@pytest.mark.parametrize("name", MULTI_ROBOT)
def test_multi_robot_scenarios_meet(name):
    """Every robot pair of the multi-robot scenarios shares at least 10 relevant pairs: a connected graph."""
    st = scenario_stats(load_scenario(name))
    assert st.graph.connected, st.graph.describe()
    assert len(st.centres) == 3 and min(st.counts.values()) >= 10, st.counts
    assert all(abs(o) >= 0.3 for o in st.offset_m.values())  # each drives its own side of the track


@pytest.mark.slow
@pytest.mark.parametrize("name", PAPER_SCALE)
def test_paper_scale_robots_meet(name):
    """Every robot's path planned and driven clear of objects (``trajectory_along`` raises
    otherwise), and the robots' overlap graph connected with more edges than a chain."""
    st = scenario_stats(load_scenario(name))
    assert st.graph.connected, st.graph.describe()
    assert len(st.graph.edges) >= len(st.centres)  # more than a chain: robots meet several others


def test_stats_count_the_pairs_a_run_scores(smoke_run):
    """Centres placed from the planned odometry give the run's relevant pairs per robot pair exactly."""
    st = scenario_stats(smoke_run.scenario)
    by_pair = {tuple(k.split("|")): v.n_relevant for k, v in smoke_run.metrics.robot_pairs.items()}
    assert by_pair == st.counts == {("a", "b"): 19}
    assert {r: len(c) for r, c in st.centres.items()} == {"a": 9, "b": 9}
    report = (smoke_run.run_dir / "report.md").read_text(encoding="utf-8")
    assert "| a, b | 81 | 19 | yes |" in report
    assert "Overlap graph (robot pairs with >= 10 relevant cross-robot pairs): connected" in report


def test_cli_prints_and_writes_the_figures(tmp_path):
    out = tmp_path / "stats.json"
    res = CliRunner().invoke(app, ["scenario", "stats", "smoke", "--min-pairs", "20", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "NOT connected, 2 groups {a} {b}" in " ".join(res.output.split())
    data = json.loads(out.read_text())
    assert data["relevant_pairs"] == {"a|b": 19} and data["connected"] is False and data["min_pairs"] == 20


def test_stats_refuse_what_they_cannot_count():
    sc = load_scenario("smoke", ["evaluation.relevance=shared_objects"])
    with pytest.raises(ConfigError, match="only by distance"):
        scenario_stats(sc)
    res = CliRunner().invoke(app, ["scenario", "stats", "no_such_scenario"])
    assert res.exit_code == 1 and res.output.startswith("error: scenario 'no_such_scenario'")
