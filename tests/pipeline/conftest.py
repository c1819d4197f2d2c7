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


@pytest.fixture
def as_summaries():
    """``as_summaries(runs)``: hand-made JSON run summaries as ``RunSummary`` objects.

    Fields a test leaves out (the ones its claims and tables do not read) get neutral values.
    """
    from roman_sim.report.summaries import RunSummary

    set_defaults = {
        "n_pairs": 0,
        "recall_at_precision_1": None,
        "hits_at_precision_1": 0,
        "best_f1": None,
        "auc": None,
        "assoc_precision": None,
        "assoc_recall": None,
    }
    run_defaults = {
        "headline": "inter",
        "pairs": {},
        "n_skipped": 0,
        "methods": {},
        "ate": {},
        "ate_robots": {},
        "map": {},
        "frontend": None,
    }

    def convert(runs: dict) -> dict[str, RunSummary]:
        out = {}
        for name, run in runs.items():
            methods = {
                m: {k: {**set_defaults, **v} if k in ("inter", "intra") else v for k, v in entry.items()}
                for m, entry in run.get("methods", {}).items()
            }
            out[name] = RunSummary.from_json({**run_defaults, **run, "methods": methods})
        return out

    return convert
