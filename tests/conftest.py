"""Fixtures shared by every test area."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING

import pytest
from typer.testing import CliRunner

# Tests never share stages through the user's cache (nor fill it): each run computes what its
# own folder lacks. The tests of the shared cache give it a folder of their own.
os.environ["ROMAN_SIM_CACHE"] = "off"

if TYPE_CHECKING:
    from roman_sim.pipeline.result import RunResult


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The bundled smoke scenario, seed 0 (run once per test session)."""
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    return Experiment(load_scenario("smoke"), tmp_path_factory.mktemp("smoke") / "seed0").run()


@pytest.fixture
def cli_fails() -> Callable[..., str]:
    """``cli_fails(*args)``: run ``roman-sim ARGS``, assert one clean error line and exit code 1, return the line.

    ``allow_progress=True`` also accepts progress-bar lines drawn before the error line.

    Fails the test when an exception other than ``SystemExit`` escapes the command (a
    traceback in a real shell) or stderr holds anything but the one ``error: ...`` line.
    """
    from roman_sim.cli import app

    def run(*args: object, allow_progress: bool = False) -> str:
        result = CliRunner().invoke(app, [str(a) for a in args])
        escaped = result.exception is not None and not isinstance(result.exception, SystemExit)
        assert not escaped, f"uncaught {type(result.exception).__name__}: {result.exception}"
        assert result.exit_code == 1, (result.exit_code, result.output)
        assert "Traceback" not in result.output
        lines = result.stderr.strip().splitlines()
        if allow_progress:  # a progress bar drawn before the failure (its lines hold no "error:")
            assert not any("error" in line.lower() for line in lines[:-1]), result.stderr
            lines = lines[-1:]
        assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
        return lines[0]

    return run


#: The test files that take longest (a minute or more of CPU each), longest first. With
#: ``--dist loadfile`` each file runs on one worker, in collection order: starting these first
#: keeps one long file from running alone at the end of the suite.
LONGEST_FIRST = (
    "tests/benchmark/test_quick.py",
    "tests/pipeline/test_visual.py",
    "tests/pipeline/test_regression.py",
    "tests/runner/test_executors.py",
    "tests/pipeline/test_scenario_stats.py",
    "tests/robustness/test_interrupts.py",
    "tests/pipeline/test_run_features.py",
    "tests/benchmark/test_run.py",
    "tests/runner/test_dask_security.py",
    "tests/pipeline/test_wheel.py",
    "tests/pipeline/test_sweep.py",
    "tests/pipeline/test_bundled_scenarios.py",
)


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    """Collect the longest files first (a stable sort: every other file keeps its order)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda it: rank.get(it.nodeid.split("::", 1)[0], len(rank)))
