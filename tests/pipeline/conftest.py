"""Shared runs (seeded, cached per test session); the smoke run is in the suite's own conftest."""

from __future__ import annotations

import pytest

from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario


@pytest.fixture(scope="session", params=[0, 1], ids=["seed0", "seed1"])
def opposite_run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The small opposite-direction case (dense off-road loop) for two seeds."""
    sc = load_scenario("opposite_small", [f"seed={request.param}"])
    return Experiment(sc, tmp_path_factory.mktemp("opposite") / f"seed{request.param}").run()
