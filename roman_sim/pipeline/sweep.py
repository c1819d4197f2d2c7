"""Parameter x seed sweeps over a scenario, on a local process pool or a Dask cluster.

A sweep file names a base scenario, a grid of dotted overrides and a list of seeds. Every
combination becomes one run folder ``<out>/<run_id>/`` produced by the same pipeline as
``roman-sim run``. Sweeps are resumable: a run that completed (its manifest says so) and whose
resolved configuration is unchanged is not run again. Written atomically into ``<out>/``:
``sweep.json`` (the sweep and its runs), ``sweep.csv`` (one row per run and method),
``sweep_summary.csv`` (per swept value, method, pair set and heading bin: mean recall over
the seeds with its 95 % interval, and the pooled hits / relevant with a Wilson interval) and
``plots/sweep_summary.png``; ``roman-sim report <out>`` prints the summary.
Any exception inside one run (a user plug-in's included) is recorded as that run's failure
in the table; the other runs go on.

Cells run as tasks of the run executor interface (``roman_sim.runner.executors``: serial,
local pool, Dask). Every path a task gets is absolute, so a worker in another folder writes
where the table is read; ``sweep_failures`` lists the cells that failed or left no complete
run (the CLI prints them and exits 1).
"""

from __future__ import annotations

import csv
import io
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_text
from roman_sim.core.config import read_yaml, validate_model
from roman_sim.core.errors import RomanSimError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import to_json_object
from roman_sim.core.registry import one_line
from roman_sim.pipeline.sweep_spec import RunSpec, SweepConfig, expand
from roman_sim.runner.executors import TaskError, open_executor

log = logging.getLogger(__name__)


def load_sweep(path: str | Path) -> tuple[SweepConfig, Path]:
    """Load a sweep YAML; returns the config and the resolved base scenario path."""
    from roman_sim.pipeline.scenario import resolve_scenario_path

    path = Path(path)
    cfg = validate_model(SweepConfig, read_yaml(path), source=str(path))
    return cfg, resolve_scenario_path(cfg.scenario, relative_to=path.parent)


def _run_one(
    scenario_path: str, overrides: tuple[str, ...], seed: int, run_dir: str, from_stage: str | None = None
) -> dict[str, Any]:
    """Run one sweep job (top-level so that process pools and Dask can pickle it)."""
    from roman_sim.pipeline.experiment import run_scenario_file

    try:
        run_scenario_file(scenario_path, list(overrides) + [f"seed={seed}"], Path(run_dir), from_stage=from_stage)
        return {"ok": True}
    except RomanSimError as err:
        return {"ok": False, "error": str(err)}
    except Exception as err:  # a user plug-in (or a bug) in one cell must not abort the whole sweep
        log.debug("sweep run %s failed", run_dir, exc_info=True)
        return {"ok": False, "error": f"{type(err).__name__}: {one_line(err)}"}


def _is_done(run_dir: Path, scenario_path: str, overrides: tuple[str, ...], seed: int) -> bool:
    """Whether the cell's run completed with exactly the cell's resolved configuration and current code."""
    from roman_sim.pipeline.experiment import is_current_run
    from roman_sim.pipeline.scenario import load_scenario

    try:
        return is_current_run(run_dir, load_scenario(scenario_path, list(overrides) + [f"seed={seed}"]))
    except RomanSimError:  # a bad cell value: the cell runs and fails as that cell, not the whole sweep
        return False


def run_sweep(
    cfg: SweepConfig,
    scenario_path: str | Path,
    out_dir: str | Path,
    progress: Callable[[int, int], None] | None = None,
    from_stage: str | None = None,
) -> Path:
    """Run (or resume) every cell of the sweep on ``cfg.executor``; returns the path of ``sweep.csv``.

    ``from_stage`` recomputes that stage and later ones in every run (finished runs included).
    Paths are resolved here, once: the cells get absolute ones whatever the workers' folders
    (a bundled scenario name stays a name).
    """
    out_dir = Path(out_dir).resolve()
    if Path(scenario_path).is_file():
        scenario_path = Path(scenario_path).resolve()
    runs = expand(cfg)
    todo = [
        r
        for r in runs
        if from_stage is not None or not _is_done(out_dir / r.run_id, str(scenario_path), r.overrides, r.seed)
    ]
    log.info("sweep %s: %d runs, %d to do", cfg.name, len(runs), len(todo))
    args = [(str(scenario_path), r.overrides, r.seed, str(out_dir / r.run_id), from_stage) for r in todo]
    failures: dict[str, str] = {}
    done = len(runs) - len(todo)
    if progress:
        progress(done, len(runs))
    finished: set[int] = set()
    if todo:
        try:
            with open_executor(cfg.executor) as ex:
                for i, outcome in ex.run_tasks(_run_one, args, [f"sweep cell {r.run_id}" for r in todo]):
                    finished.add(i)
                    if not outcome["ok"]:
                        failures[todo[i].run_id] = outcome["error"]
                    done += 1
                    if progress:
                        progress(done, len(runs))
        except TaskError as err:  # a lost worker: every unfinished cell failed with it
            failures.update({r.run_id: str(err) for i, r in enumerate(todo) if i not in finished})
    for k, v in failures.items():
        log.warning("run %s failed: %s", k, v)
    from roman_sim.pipeline.sweep_aggregate import write_sweep_aggregate, write_sweep_json

    write_sweep_json(cfg, runs, out_dir)
    table = write_sweep_table(runs, out_dir, failures)
    write_sweep_aggregate(out_dir)
    return table


def write_sweep_table(runs: list[RunSpec], out_dir: Path, failures: dict[str, str] | None = None) -> Path:
    """Collect each finished run into ``sweep.csv`` (one row per run and method)."""
    from roman_sim.pipeline.result import RunResult

    failures = failures or {}
    rows: list[dict[str, Any]] = []
    for r in runs:
        base = {"run_id": r.run_id, "seed": r.seed, **r.params}
        if r.run_id in failures:
            rows.append({**base, "status": "failed", "error": failures[r.run_id]})
            continue
        try:
            summary = RunResult.load(out_dir / r.run_id).summary()
        except RomanSimError as err:
            rows.append({**base, "status": "missing", "error": str(err)})
            continue
        for method, m in sorted(summary.methods.items()):
            rows.append({**base, "status": "ok", "method": method, **_flatten(to_json_object(m))})
    cols: list[str] = []
    for row in rows:
        cols.extend(k for k in row if k not in cols)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, restval="")
    w.writeheader()
    w.writerows(rows)
    path = out_dir / "sweep.csv"
    write_text(path, buf.getvalue())
    return path


@dataclass(frozen=True)
class SweepFailure:
    """A row of ``sweep.csv`` whose run did not finish: its run, seed, status and error (as written)."""

    run_id: str
    seed: str
    status: str
    error: str


def sweep_failures(table: Path) -> list[SweepFailure]:
    """The rows of ``sweep.csv`` whose run did not finish (status ``failed``, ``missing`` or ``corrupt``)."""
    with open(table, newline="", encoding="utf-8") as fh:
        rows = [row for row in csv.DictReader(fh) if row.get("status") != "ok"]
    return [SweepFailure(*(r.get(k) or "" for k in ("run_id", "seed", "status", "error"))) for r in rows]


def _flatten(d: dict[str, JSON], prefix: str = "") -> dict[str, JSON]:
    out: dict[str, JSON] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        elif not isinstance(v, list):
            out[key] = v
    return out
