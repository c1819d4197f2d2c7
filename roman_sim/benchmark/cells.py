"""The cells of a benchmark: what one (level, seed) is, how it is planned and run, its kept files.

``plan_task`` plans one cell as an executor task (``scenes.build_crossing``: its
scenario and relevant pairs per heading bin, or its one-line error); ``CellExperiment`` runs
a cell's scenario on an executor the job keeps open; ``cell_runtime_stats`` is what a cell keeps
of its per-pair runtimes. File names of a benchmark folder are defined here.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from roman_sim.benchmark.plan import relevant_per_bin
from roman_sim.benchmark.scenes import CrossingScene, build_crossing
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import OMIT_NONE
from roman_sim.core.registry import one_line
from roman_sim.evaluation.bins import runtime_stats
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import Scenario
from roman_sim.runner.executors import Executor

BENCHMARK_JSON = "benchmark.json"
BENCHMARK_SCHEMA = "roman_sim.benchmark/1"
PLAN_JSON = "plan.json"
CELL_JSON = "cell.json"
CELLS_DIR = "cells"
WORK_DIR = "work"
PAIRS_GZ = "pairs.csv.gz"
RUNTIMES_JSON = "runtimes.json"
SCENARIO_JSON = "scenario.json"


@dataclass(frozen=True)
class CellPlan:
    """One cell's plan (``plan.json``): its key and, planned, its relevant pairs per heading bin; else its error."""

    key: str
    level: str
    seed: int
    ok: bool
    error: str | None = field(default=None, metadata=OMIT_NONE)
    relevant: list[int] | None = field(default=None, metadata=OMIT_NONE)
    pairs: int | None = field(default=None, metadata=OMIT_NONE)
    submaps: int | None = field(default=None, metadata=OMIT_NONE)
    km: float | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class PlanRecord:
    """``plan.json``: the suite's heading bin edges and every cell planned so far."""

    heading_edges_deg: list[float]
    cells: dict[str, CellPlan]


@dataclass(frozen=True)
class CellStatus:
    """``cells/<cell>/cell.json``: how a cell ended, under which key."""

    key: str
    level: str
    seed: int
    status: Literal["ok", "failed"]
    error: str | None


@dataclass(frozen=True)
class RuntimeStats:
    """One method's time per pair in one cell (s; ``runtimes.json`` holds one per method)."""

    n: int
    mean: float | None
    median: float | None
    p90: float | None
    p10: float | None


@dataclass(frozen=True)
class LevelSpec:
    """An ambiguity level of ``benchmark.json``: its name and knob."""

    name: str
    knob: float


@dataclass(frozen=True)
class CellEntry:
    """A cell of ``benchmark.json`` and its status."""

    id: str
    level: str
    seed: int
    status: str


@dataclass(frozen=True)
class BenchmarkRecord:
    """``benchmark.json``: the suite (and its spec), methods, overrides, levels, bins, cells."""

    suite: str
    suite_spec: dict[str, Any]
    methods: list[str]
    overrides: list[str]
    levels: list[LevelSpec]
    heading_edges_deg: list[float]
    cells: list[CellEntry]


@dataclass(frozen=True)
class Cell:
    """One (ambiguity level, seed) of a suite and its scene."""

    level: str
    seed: int
    scene: CrossingScene

    @property
    def id(self) -> str:
        """``<level>-s<seed>``: the cell's folder name."""
        return f"{self.level}-s{self.seed}"

    def key(self) -> str:
        """What the cell's plan depends on: its scene (methods and overrides included) and seed (its results:
        ``BenchmarkJob.cell_key``, which adds every stage key of its run)."""
        return stable_hash(self.scene.model_dump(mode="json"), self.seed)


@dataclass(frozen=True)
class PlannedCell:
    """What planning one cell gives: its plan (without key, level and seed) and its scenario (None: failed)."""

    ok: bool
    error: str | None = None
    scenario: dict[str, Any] | None = None
    relevant: list[int] | None = None
    pairs: int | None = None
    submaps: int | None = None
    km: float | None = None

    def plan(self, key: str, level: str, seed: int) -> CellPlan:
        """The cell's ``plan.json`` entry."""
        return CellPlan(key, level, seed, self.ok, self.error, self.relevant, self.pairs, self.submaps, self.km)


def plan_task(scene_json: str, seed: int, name: str, edges: list[float]) -> PlannedCell:
    """Plan one cell (a top-level task): its scenario and relevant pairs per heading bin, or its error."""
    try:
        plan = build_crossing(CrossingScene.model_validate_json(scene_json), seed, name)
    except RomanSimError as err:
        return PlannedCell(False, str(err))
    except Exception as err:  # a bug, or an override the generator did not foresee: this cell fails alone
        return PlannedCell(False, f"{type(err).__name__}: {one_line(err)}")
    subs = {t.a for t in plan.truths} | {t.b for t in plan.truths}
    return PlannedCell(
        ok=True,
        scenario=plan.scenario.model_dump(mode="json"),
        relevant=relevant_per_bin(plan.truths, edges),
        pairs=len(plan.truths),
        submaps=len(subs),
        km=round(plan.trajectory_km, 4),
    )


class CellExperiment(Experiment):
    """An ``Experiment`` on an executor the job keeps open, with the job's chunk size; the report draws no
    figures (a cell keeps only its pairs and runtimes; drawing them cost about an eighth of a cell)."""

    def __init__(self, scenario: Scenario, run_dir: Path, executor: Executor, chunk_pairs: int) -> None:
        super().__init__(scenario, run_dir, executor=executor)
        self.chunk_pairs = chunk_pairs

    def context(self) -> RunContext:
        return dataclasses.replace(super().context(), chunk_pairs=self.chunk_pairs, figures=False)


def planned_totals(plans: list[CellPlan], n_bins: int) -> list[int]:
    """Planned relevant pairs per bin summed over the plans that succeeded."""
    out = [0] * n_bins
    for p in plans:
        for i, v in enumerate(p.relevant or []):
            out[i] += int(v)
    return out


def cell_runtime_stats(per_pair: list[float]) -> RuntimeStats:
    """Runtime statistics of one method in one cell (s): n, mean, median, p90 and p10."""
    stats = runtime_stats(per_pair)
    r = np.asarray([x for x in per_pair if x is not None and np.isfinite(x)], dtype=np.float64)
    p10 = float(np.percentile(r, 10)) if len(r) else None
    return RuntimeStats(int(stats["n"]), stats["mean"], stats["median"], stats["p90"], p10)
