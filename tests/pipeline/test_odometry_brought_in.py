"""A robot's odometry brought back in from a TUM file: run on the smoke scenario with robot a's odometry replaced
by its own truth, and by the drifted odometry an export of the scenario wrote for it."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario, with_odometry

#: The pairs.csv columns an estimate gives: they move with the odometry's last digits.
ESTIMATE_COLUMNS = {"rot_err_deg", "trans_err_m"}


def _run(folder: Path, files: dict[str, Path]) -> RunResult:
    return Experiment(with_odometry(load_scenario("smoke"), files), folder).run()


def _rows(run: RunResult) -> list[dict[str, str]]:
    with (run.run_dir / "pairs.csv").open(newline="") as fh:
        return list(csv.DictReader(fh))


def _ate(run: RunResult, variant: str) -> dict[str, float]:
    ate = json.loads((run.run_dir / "ate.json").read_text())
    return next(v for v in ate["variants"] if v["name"] == variant)["rmse"]["se3"]


@pytest.fixture(scope="module")
def on_truth(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """Robot a's odometry replaced by its true trajectory (the run's trajectories/a.truth.tum)."""
    return _run(tmp_path_factory.mktemp("truth") / "run", {"a": smoke_run.run_dir / "trajectories" / "a.truth.tum"})


@pytest.fixture(scope="module")
def on_export(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """Robot a's odometry replaced by the drifted body odometry ``roman-sim export`` writes (the export's clock)."""
    from roman_sim.interop import export_scenario

    out = tmp_path_factory.mktemp("export") / "smoke"
    export_scenario(load_scenario("smoke"), "tum", out, robots=["a"])
    return _run(tmp_path_factory.mktemp("drift") / "run", {"a": out / "a" / "odometry_body.txt"})


def test_a_robot_on_its_own_truth_has_no_error_and_the_same_relevant_pairs(smoke_run, on_truth) -> None:
    own, ran = _ate(smoke_run, "odometry_no_prior"), _ate(on_truth, "odometry_no_prior")
    assert own["a"] > 0.1 and ran["a"] < 1e-6  # each robot aligned on its own: a's odometry is its truth
    assert ran["b"] == own["b"]  # b kept its own odometry
    relevant = [
        {(r["a"], r["b"], r["kind"]) for r in _rows(run) if r["relevant"] == "true"} for run in (smoke_run, on_truth)
    ]
    assert relevant[0] == relevant[1] and len(relevant[0]) == 21
    assert sum(kind == "inter" for _, _, kind in relevant[1]) == 19
    notes = [n for n in on_truth.notes if n.startswith("robot ")]
    assert notes[0].startswith(f"robot a: odometry brought in from {smoke_run.run_dir / 'trajectories/a.truth.tum'}")
    assert notes[1] == "robot b: odometry its own, simulated (drift typical); 536 frames mapped"
    report = (on_truth.run_dir / "report.md").read_text()
    assert all(f"- {n}" in report for n in notes)
    assert not [n for n in smoke_run.notes if "odometry" in n]  # a run on its own odometry says nothing new


def test_a_robot_on_its_exported_drift_gives_the_run_back(smoke_run, on_export) -> None:
    assert (on_export.run_dir / "metrics.json").read_bytes() == (smoke_run.run_dir / "metrics.json").read_bytes()
    own, ran = _rows(smoke_run), _rows(on_export)
    assert len(ran) == len(own) == 274
    for x, y in zip(own, ran):
        moved = ESTIMATE_COLUMNS | {k for k in x if k.startswith("score_")}  # a method's own float scores
        assert {k: v for k, v in x.items() if k not in moved} == {k: v for k, v in y.items() if k not in moved}
        for k in moved:  # the TUM file's nine decimals move the estimates and scores by less than 1e-6
            assert (x[k] == y[k] == "") or abs(float(x[k]) - float(y[k])) < 1e-6
    for variant in ("odometry", "odometry_no_prior", "roman", "oracle"):
        for robot, rmse in _ate(smoke_run, variant).items():
            assert _ate(on_export, variant)[robot] == pytest.approx(rmse, abs=1e-8)


def test_editing_the_file_re_keys_the_maps_stage_and_after(smoke_run, tmp_path: Path) -> None:
    odom = tmp_path / "a.tum"
    odom.write_bytes((smoke_run.run_dir / "trajectories" / "a.truth.tum").read_bytes())
    sc = with_odometry(load_scenario("smoke"), {"a": odom})
    before = Experiment(sc, tmp_path / "run").stage_keys()
    with odom.open("a") as fh:
        fh.write("# edited\n")
    after = Experiment(sc, tmp_path / "run").stage_keys()
    assert sorted(s for s in before if before[s] != after[s]) == [
        "ate",
        "evaluation",
        "maps",
        "posegraph",
        "report",
        "submaps",
    ]
    plain = Experiment(load_scenario("smoke"), tmp_path / "plain").stage_keys()
    assert plain["maps"] not in (before["maps"], after["maps"]) and plain["world"] == before["world"]
