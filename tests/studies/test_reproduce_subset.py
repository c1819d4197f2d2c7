"""``reproduce`` of some scenarios updates the committed summary instead of replacing it.

The reference folder is built from the smoke run (collected under several names, with a
one-run ambiguity sweep); the experiment is replaced by that run, so nothing is simulated
here beyond the shared smoke fixture.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from roman_sim.core.atomic import write_json
from roman_sim.core.records import to_json, write_record
from roman_sim.evaluation.run_summary import PairCounts, RunSummary
from roman_sim.pipeline import experiment, scenario
from roman_sim.report.recompute import compare
from roman_sim.studies.pages import RESULTS_MARKERS, results_block
from roman_sim.studies.reference import (
    AMBIGUITY_KEY,
    RESULTS_PAGE,
    build_reference,
    collect,
    read_reference,
    rederive,
    reproduce,
)


class _Replay:
    """Stands in for ``Experiment``: every scenario 'runs' to the given result."""

    def __init__(self, result):
        self.result, self.ran = result, []

    def __call__(self, sc, run_dir, from_stage=None, executor=None):
        self.ran.append(sc)
        return self

    def run(self):
        return self.result


@pytest.fixture()
def committed(smoke_run, tmp_path: Path) -> Path:
    out = tmp_path / "reference"
    for name in ("alpha", "beta"):
        collect(smoke_run.run_dir, out / name)
    collect(smoke_run.run_dir, out / "ambiguity_sweep" / "r0", trajectories=False, plots=False, packets=False)
    write_json(
        out / "ambiguity_sweep" / "sweep.json",
        {
            "schema": "roman_sim.sweep/1",
            "name": "ambiguity_sweep",
            "scenario": "smoke",
            "seeds": [0],
            "grid": [AMBIGUITY_KEY],
            "runs": [{"run_id": "r0", "seed": 0, "params": {AMBIGUITY_KEY: 0.25}}],
        },
    )
    stale = RunSummary("inter", {"stale": PairCounts(n_pairs=1, n_relevant=0)}, 0)
    # gamma was listed once but its folder is gone; beta's entry is stale until it is re-run
    write_record(out / "summary.json", build_reference({"alpha": stale, "beta": stale, "gamma": stale}, []))
    return out


def test_subset_run_keeps_the_other_scenarios_and_the_sweep(committed, smoke_run, monkeypatch, tmp_path):
    replay = _Replay(smoke_run)
    monkeypatch.setattr(experiment, "Experiment", replay)
    monkeypatch.setattr(scenario, "load_scenario", lambda name: name)
    page = tmp_path / "repo" / RESULTS_PAGE
    page.parent.mkdir(parents=True)
    page.write_text(f"intro\n{RESULTS_MARKERS[0]}\nold block\n{RESULTS_MARKERS[1]}\noutro\n", encoding="utf-8")

    reproduce(committed, ["beta", "delta"], tmp_path / "work", root=tmp_path / "repo")

    assert replay.ran == ["beta", "delta"]
    summary = json.loads((committed / "summary.json").read_text(encoding="utf-8"))
    assert list(summary["runs"]) == ["alpha", "beta", "delta"]  # committed order, gamma dropped, delta appended
    fresh = json.loads(json.dumps(to_json(smoke_run.summary())))
    for name in ("alpha", "beta", "delta"):  # alpha recomputed from its raw files, beta and delta from the run
        assert not compare(fresh, summary["runs"][name], name, rel_tol=1e-6, abs_tol=1e-9)
    assert [r["ambiguity"] for r in summary["ambiguity_sweep"]] == [0.25] * len(summary["ambiguity_sweep"])
    assert {r["method"] for r in summary["ambiguity_sweep"]} == set(fresh["methods"])
    again = json.loads(json.dumps(to_json(rederive(committed)), sort_keys=True))
    assert not compare(summary, again, "summary.json", rel_tol=1e-6, abs_tol=1e-9)
    block = results_block(read_reference(committed / "summary.json"))
    assert page.read_text(encoding="utf-8") == f"intro\n{block}\noutro\n"


def test_subset_run_into_an_empty_folder_writes_only_its_scenarios(smoke_run, monkeypatch, tmp_path):
    monkeypatch.setattr(experiment, "Experiment", _Replay(smoke_run))
    monkeypatch.setattr(scenario, "load_scenario", lambda name: name)
    reproduce(tmp_path / "ref", ["beta"], tmp_path / "work")
    summary = json.loads((tmp_path / "ref" / "summary.json").read_text(encoding="utf-8"))
    assert list(summary["runs"]) == ["beta"] and summary["ambiguity_sweep"] == []
