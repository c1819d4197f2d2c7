"""Shared smoke runs (seeded, cached per test session)."""

from __future__ import annotations

import pytest

from roman_sim.experiment import Experiment, RunResult
from roman_sim.scenario import load_scenario


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The bundled smoke scenario, seed 0."""
    sc = load_scenario("smoke")
    return Experiment(sc, tmp_path_factory.mktemp("smoke") / "seed0").run()


@pytest.fixture(scope="session")
def smoke_run_seed1(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The smoke scenario with seed 1 (another world, other drift)."""
    sc = load_scenario("smoke", ["seed=1"])
    return Experiment(sc, tmp_path_factory.mktemp("smoke") / "seed1").run()
