"""Sweeps: expansion, serial and Dask execution, resumption, the sweep table, bad input."""

from __future__ import annotations

import csv
import json

import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.sweep import SweepConfig, expand, load_sweep, run_sweep

# A very short smoke variant: both robots stop after 12 m.
MICRO = {"robots.0.max_length_m": [12.0], "robots.1.max_length_m": [12.0]}


def _write(tmp_path, **kw):
    data = {"name": "micro", "scenario": "smoke", "grid": MICRO, "seeds": [0, 1], **kw}
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_expand_grid_times_seeds():
    cfg = SweepConfig(name="s", scenario="smoke", grid={"a.b": [1, 2, 3], "c": ["x", "y"]}, seeds=[0, 5])
    runs = expand(cfg)
    assert len(runs) == 3 * 2 * 2
    assert len({r.run_id for r in runs}) == len(runs)
    assert runs == expand(cfg)  # stable order and ids
    assert "a.b=1" in runs[0].overrides


def test_bad_sweeps(tmp_path):
    with pytest.raises(ConfigError, match="grid.x: needs at least one value"):
        expand(SweepConfig(name="s", scenario="smoke", grid={"x": []}))
    path = _write(tmp_path, executor={"kind": "cluster"})
    with pytest.raises(ConfigError, match="executor.kind"):
        load_sweep(path)
    path = _write(tmp_path, scenario="no_such_scenario")
    with pytest.raises(ConfigError, match="no_such_scenario"):
        load_sweep(path)


def _metrics(path):
    m = json.loads(path.read_text())
    return {k: {kk: vv for kk, vv in v.items() if kk not in ("runtime_s",)} for k, v in m["methods"].items()}


@pytest.fixture(scope="module")
def serial_sweep(tmp_path_factory):
    """The micro sweep over seeds 0 and 1, run serially once for this module: (config, scenario, out, table)."""
    tmp = tmp_path_factory.mktemp("sweep")
    cfg, scenario = load_sweep(_write(tmp))
    out = tmp / "serial"
    return cfg, scenario, out, run_sweep(cfg, scenario, out)


def test_serial_sweep_resumes_and_matches_dask(serial_sweep, tmp_path):
    cfg, scenario, out, table = serial_sweep
    cfg = cfg.model_copy(deep=True)
    rows = list(csv.DictReader(table.open()))
    assert {r["status"] for r in rows} == {"ok"}
    assert {r["seed"] for r in rows} == {"0", "1"}
    assert {r["method"] for r in rows} == {"roman", "clipper"}
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("metrics.json")}
    assert len(stamps) == 2
    run_sweep(cfg, scenario, out)  # resumed: nothing is run again
    assert stamps == {p: p.stat().st_mtime_ns for p in out.rglob("metrics.json")}

    cfg.seeds = [0]
    cfg.executor.kind = "dask"
    dask_out = tmp_path / "dask"
    run_sweep(cfg, scenario, dask_out)
    (serial_run,) = [p for p in out.rglob("metrics.json") if p.parent.name.endswith("-s0")]
    (dask_run,) = list(dask_out.rglob("metrics.json"))
    assert _metrics(serial_run) == _metrics(dask_run)


def test_sweep_summary_over_seeds_and_report(serial_sweep):
    from roman_sim.evaluation.intervals import mean_interval
    from roman_sim.pipeline.result import RunResult

    _, _, out, _ = serial_sweep
    rows = list(csv.DictReader((out / "sweep_summary.csv").open()))
    row = next(r for r in rows if r["method"] == "roman" and r["kind"] == "inter" and r["bin"] == "all")
    runs = [RunResult.load(out / r["run_id"]) for r in json.loads((out / "sweep.json").read_text())["runs"]]
    per_seed = [r.metrics.stats("roman", kind="inter") for r in runs]
    used = [s for s in per_seed if s.n_relevant]
    assert int(row["n_seeds"]) == len(used) and int(row["relevant"]) == sum(s.n_relevant for s in used)
    assert int(row["hits"]) == sum(s.max_hits for s in used)
    mean, ci = mean_interval([s.max_hits / s.n_relevant for s in used])
    assert float(row["mean_recall"]) == pytest.approx(mean)
    if ci is not None:
        assert (float(row["ci_low"]), float(row["ci_high"])) == pytest.approx(ci)
    res = CliRunner().invoke(app, ["report", str(out)])
    assert res.exit_code == 0, res.output
    assert "sweep micro, cross-robot pairs" in res.output and "roman" in res.output


def test_sweep_cli_bad_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nscenario: smoke\ngrid: {a: [1]}\nseeds: []\n")
    res = CliRunner().invoke(app, ["sweep", str(bad)])
    assert res.exit_code == 1 and "seeds" in res.output and "Traceback" not in res.output


def test_relative_out_folder_on_a_local_pool_and_failed_cells_exit_nonzero(tmp_path, monkeypatch):
    """Workers resolve nothing themselves (absolute paths); a failed cell is a table and exit code 1."""
    monkeypatch.chdir(tmp_path)
    grid = {**MICRO, "robots.1.speed_mps": [1.0, 99.0]}  # 99 m/s is out of range: that cell fails
    path = _write(tmp_path, grid=grid, seeds=[0], executor={"kind": "local", "workers": 2})
    res = CliRunner().invoke(app, ["sweep", str(path), "--out", "rel/out"])
    assert res.exit_code == 1, res.output
    assert "1 sweep run(s) failed" in res.output and "speed_mps" in res.output
    rows = list(csv.DictReader((tmp_path / "rel" / "out" / "sweep.csv").open()))
    assert sorted({(r["robots.1.speed_mps"], r["status"]) for r in rows}) == [("1.0", "ok"), ("99.0", "failed")]
    assert len([r for r in rows if r["status"] == "ok"]) == 2  # roman and clipper of the good cell
    cfg, scenario = load_sweep(_write(tmp_path, seeds=[0], executor={"kind": "local", "workers": 2}))
    table = run_sweep(cfg, scenario, "rel/out")  # a relative folder, resolved here once
    assert table == (tmp_path / "rel" / "out" / "sweep.csv").resolve()
    assert {r["status"] for r in csv.DictReader(table.open())} == {"ok"}
