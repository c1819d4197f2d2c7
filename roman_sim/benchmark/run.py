"""Running a benchmark suite as one resumable job: plan the cells, run them, keep what finished.

A cell is one (ambiguity level, seed): one crossing scenario, one run folder. The job

1. plans every cell (``scenes.build_crossing``: world, drives, the relevant pairs,
   no rendering) as tasks of the executor; a suite with ``min_worlds`` or
   ``min_relevant_per_bin`` adds seeds per level, in order, until the level holds that many
   worlds and every heading bin plans that many relevant pairs;
2. runs each cell with the pipeline (``Experiment``) on the same executor, so a cell's
   robots and chunks of pairs spread over the workers (and a Dask cluster);
3. keeps what each finished cell needs for the leaderboard in ``cells/<cell>/`` (the
   scenario, ``pairs.csv.gz``, per-method runtime statistics) and writes the leaderboard.

Everything resumes: a cell whose record matches its configuration and code (``cell_key``:
its plan's key and every stage key of its run) is not run again, an
interrupted cell continues from its run folder's checkpoints (robots mapped, chunks of
pairs aligned), plans are kept in ``plan.json``. A cell that fails (a plug-in raising on
one pair, a drive that cannot be placed) is recorded as failed with its one-line error and
the other cells run. The run folders are under ``work/`` (large; ``.gitignore`` keeps them
out of a repository); everything else in the folder is small and is the committed result.
Files: ``benchmark.json`` (suite, methods, overrides, cells and their status),
``plan.json``, ``cells/``, ``leaderboard.json``, ``leaderboard.md``, ``plots/``.

The leaderboard's confidence score (``score``: the association count unless a method's own
named score is chosen) is known to be offered only once pairs are aligned: the first cell
that finishes (or is reused) is checked before the next one runs; a method without the score
stops the job there (``ConfigError``, one line naming score, method and the scores it offers)
and no leaderboard is written.
"""

from __future__ import annotations

import gzip
import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.cells import (
    BENCHMARK_JSON,
    BENCHMARK_SCHEMA,
    CELL_JSON,
    CELLS_DIR,
    PAIRS_GZ,
    PLAN_JSON,
    RUNTIMES_JSON,
    SCENARIO_JSON,
    WORK_DIR,
    BenchmarkRecord,
    Cell,
    CellEntry,
    CellExperiment,
    CellPlan,
    CellStatus,
    LevelSpec,
    PlanRecord,
    cell_runtime_stats,
    plan_task,
    planned_totals,
)
from roman_sim.benchmark.suites import BenchmarkSuite, check_methods
from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.config import dump_yaml, stable_hash, validate_model
from roman_sim.core.errors import ConfigError, EvaluationError, RomanSimError
from roman_sim.core.records import RecordError, read_json, read_record, write_record
from roman_sim.core.registry import one_line
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import Scenario, method_label
from roman_sim.runner.executors import Executor, ExecutorConfig, open_executor

log = logging.getLogger(__name__)

#: ``progress(done, total, what)`` after each planned or finished cell.
ProgressFn = Callable[[int, int, str], None]


@dataclass
class BenchmarkOutcome:
    """What a benchmark job did: its folder, its cells in order, and the cells that failed."""

    out_dir: Path
    cells: list[str]
    failures: dict[str, str] = field(default_factory=dict)
    reused: list[str] = field(default_factory=list)
    #: The exception of each cell that failed in this job (its tracebacks, for ``--debug``).
    errors: dict[str, Exception] = field(default_factory=dict, repr=False)


class BenchmarkJob:
    """One suite, methods and overrides into one folder (see the module docstring).

    Args:
        suite: the suite.
        out_dir: the benchmark folder.
        methods: methods to score (None: the suite's); names or ``package.module:Class``.
        overrides: dotted scenario overrides for every cell (realism options).
        executor: where tasks run (None: this process).
        progress: called after each planned or finished cell.
        target_precision: precision the leaderboard's deployable thresholds are chosen for.
        score: the confidence score they are chosen on (and the curves drawn on).
    """

    def __init__(
        self,
        suite: BenchmarkSuite,
        out_dir: str | Path,
        methods: list[str] | None = None,
        overrides: list[str] | None = None,
        executor: ExecutorConfig | None = None,
        progress: ProgressFn | None = None,
        target_precision: float = 0.9,
        score: str = DEFAULT_SCORE,
    ) -> None:
        self.suite = suite
        self.target_precision = target_precision
        self.score = score
        self.out = Path(out_dir).resolve()
        self.methods = check_methods(list(methods) if methods else list(suite.methods))
        check_declared_score(self.methods, score)
        self.overrides = list(overrides or [])
        self.executor = executor
        self.progress = progress or (lambda done, total, what: None)
        self.scenes = {lv: suite.scene_at(lv, self.methods, self.overrides) for lv in suite.levels}

    # -- the folder -------------------------------------------------------------
    def guard(self) -> None:
        """Refuse a folder that holds another suite's benchmark (or the same suite with other overrides)."""
        path = self.out / BENCHMARK_JSON
        if self.out.exists() and not self.out.is_dir():
            raise ConfigError(f"--out {self.out}: not a folder")
        if not path.is_file():
            if (self.out / "manifest.json").is_file() or (self.out / "sweep.json").is_file():
                raise ConfigError(f"--out {self.out}: holds a run or a sweep, not a benchmark (choose another --out)")
            return
        old = read_record(path, BenchmarkRecord, BENCHMARK_SCHEMA)
        name, overrides = old.suite, old.overrides
        if name != self.suite.name:
            raise ConfigError(
                f"--out {self.out}: holds the {name!r} benchmark, not {self.suite.name!r} (choose another --out)"
            )
        if overrides != self.overrides:
            raise ConfigError(
                f"--out {self.out}: holds the {name!r} benchmark with overrides {overrides}, not {self.overrides} "
                "(choose another --out)"
            )

    def _record(self, cells: list[Cell], status: dict[str, str]) -> None:
        record = BenchmarkRecord(
            suite=self.suite.name,
            suite_spec=self.suite.model_dump(mode="json"),
            methods=self.methods,
            overrides=self.overrides,
            levels=[LevelSpec(lv, a) for lv, a in self.suite.levels.items()],
            heading_edges_deg=self.suite.heading_edges(),
            cells=[CellEntry(c.id, c.level, c.seed, status.get(c.id, "pending")) for c in cells],
        )
        write_record(self.out / BENCHMARK_JSON, record, BENCHMARK_SCHEMA)
        write_text(self.out / ".gitignore", f"{WORK_DIR}/\n")

    # -- planning ---------------------------------------------------------------
    def _plans(self) -> dict[str, CellPlan]:
        """The cells planned so far (none when ``plan.json`` is missing or damaged: they are planned again)."""
        try:
            return dict(read_record(self.out / PLAN_JSON, PlanRecord).cells)
        except RecordError as err:
            if (self.out / PLAN_JSON).exists():
                log.warning("%s; planning again", err)
            return {}

    def _plan_batch(self, ex: Executor, cells: list[Cell], plans: dict[str, CellPlan]) -> None:
        """Plan the cells whose plan is missing or stale (executor tasks); results into ``plans``."""
        edges = self.suite.heading_edges()
        todo = [c for c in cells if (old := plans.get(c.id)) is None or old.key != c.key()]
        args = [(c.scene.model_dump_json(), c.seed, f"{self.suite.name}-{c.id}", edges) for c in todo]
        for i, rec in ex.run_tasks(plan_task, args, [f"planning cell {c.id}" for c in todo]):
            c = todo[i]
            if rec.ok:
                write_text(self.out / CELLS_DIR / c.id / SCENARIO_JSON, json.dumps(rec.scenario, indent=1))
            plans[c.id] = rec.plan(c.key(), c.level, c.seed)
            write_record(self.out / PLAN_JSON, PlanRecord(edges, plans))

    def plan(self, ex: Executor) -> list[Cell]:
        """Every cell of the suite, planned (adding seeds per level when the suite asks for a count)."""
        plans = self._plans()
        s = self.suite
        if not s.adds_seeds:
            cells = [Cell(lv, seed, self.scenes[lv]) for lv in s.levels for seed in s.seeds]
            self._plan_batch(ex, cells, plans)
            return cells
        chosen: dict[str, list[Cell]] = {lv: [] for lv in s.levels}
        open_levels = list(s.levels)
        while open_levels:
            # a level's next seed, up to the worlds it needs whatever they plan: one batch (parallel tasks)
            ranges = {lv: range(len(chosen[lv]), max(len(chosen[lv]) + 1, s.worlds_needed(lv))) for lv in open_levels}
            batch = sorted(
                (Cell(lv, sd, self.scenes[lv]) for lv, r in ranges.items() for sd in r),
                key=lambda c: (c.seed, open_levels.index(c.level)),
            )
            self._plan_batch(ex, batch, plans)
            for c in batch:
                if c.level not in open_levels:
                    continue
                chosen[c.level].append(c)
                totals = planned_totals([plans[x.id] for x in chosen[c.level]], len(s.heading_edges()) - 1)
                if s.level_done(c.level, len(chosen[c.level]), totals):
                    open_levels.remove(c.level)
            self.progress(sum(len(v) for v in chosen.values()), 0, "planning")
        return [c for lv in s.levels for c in chosen[lv]]

    # -- running ----------------------------------------------------------------
    def _scenario(self, c: Cell) -> Scenario:
        """The cell's planned scenario (``scenario.json``)."""
        path = self.out / CELLS_DIR / c.id / SCENARIO_JSON
        return validate_model(Scenario, read_json(path), source=str(path))

    def cell_key(self, c: Cell) -> str:
        """What a cell's results depend on: its plan's key and its run's (``Experiment.run_key``: every
        stage's resolved parameters and code), so a changed default or changed code runs it again."""
        try:
            sc = self._scenario(c)
        except RomanSimError:  # not planned (or its plan is damaged): the cell cannot have run
            return c.key()
        return stable_hash(c.key(), Experiment(sc, self.out / WORK_DIR / c.id, cache=False).run_key())

    def finished(self, c: Cell) -> bool:
        """Whether the cell finished under its current key (``cell_key``) with every file it keeps."""
        path = self.out / CELLS_DIR / c.id / CELL_JSON
        try:
            rec = read_record(path, CellStatus)
        except RecordError as err:
            if path.exists():
                log.warning("%s; running the cell again", err)
            return False
        files = (self.out / CELLS_DIR / c.id / n for n in (PAIRS_GZ, RUNTIMES_JSON, "config.yaml"))
        return rec.status == "ok" and all(f.is_file() for f in files) and rec.key == self.cell_key(c)

    def _run_cell(self, c: Cell, ex: Executor) -> None:
        folder = self.out / CELLS_DIR / c.id
        sc = self._scenario(c)
        chunk = self.executor.chunk_pairs if self.executor is not None else ExecutorConfig().chunk_pairs
        res = CellExperiment(sc, self.out / WORK_DIR / c.id, executor=ex, chunk_pairs=chunk).run()
        raw = (res.run_dir / "pairs.csv").read_bytes()
        write_bytes(folder / PAIRS_GZ, gzip.compress(raw, mtime=0))
        write_text(folder / "config.yaml", dump_yaml(res.scenario))  # resolved, as the run used it
        ev = res.timings.stages.get("evaluation")
        per_method = {} if ev is None or ev.alignment is None else ev.alignment
        runtimes = {m: cell_runtime_stats(list(a.per_pair_s or [])) for m, a in sorted(per_method.items())}
        write_record(folder / RUNTIMES_JSON, runtimes)

    def _finish(self, c: Cell, status: Literal["ok", "failed"], error: str | None = None) -> None:
        key = self.cell_key(c)
        write_record(self.out / CELLS_DIR / c.id / CELL_JSON, CellStatus(key, c.level, c.seed, status, error))

    def plan_only(self) -> tuple[list[Cell], dict[str, CellPlan]]:
        """Plan every cell (nothing rendered); the cells and their plans (``plan.json``'s records)."""
        self.guard()
        self.out.mkdir(parents=True, exist_ok=True)
        with open_executor(self.executor) as ex:
            cells = self.plan(ex)
        self._record(cells, {})
        return cells, self._plans()

    def run(self, board: bool = True) -> BenchmarkOutcome:
        """Plan and run every cell (reusing finished ones), then write the leaderboard (not with ``board`` False:
        a check of another board on fresh worlds scores the cells itself)."""
        from roman_sim.benchmark.board import write_leaderboard

        self.guard()
        self.out.mkdir(parents=True, exist_ok=True)
        outcome = BenchmarkOutcome(self.out, [])
        status: dict[str, str] = {}
        with open_executor(self.executor) as ex:
            cells = self.plan(ex)
            outcome.cells = [c.id for c in cells]
            plans = self._plans()
            self._record(cells, status)
            checked = False
            for n, c in enumerate(cells):
                p = plans.get(c.id)
                if p is None or not p.ok:
                    outcome.failures[c.id] = f"planning failed: {p.error if p is not None else 'no plan'}"
                    self._finish(c, "failed", outcome.failures[c.id])
                elif self.finished(c):
                    outcome.reused.append(c.id)
                else:
                    self._attempt(c, ex, outcome)
                if not checked and c.id not in outcome.failures:
                    self.check_score([c])  # the first finished cell: before another one runs
                    checked = True
                status[c.id] = "failed" if c.id in outcome.failures else "ok"
                self._record(cells, status)
                self.progress(n + 1, len(cells), c.id)
        if board:
            write_leaderboard(self.out, self.target_precision, self.score)
        return outcome

    def check_score(self, cells: list[Cell]) -> None:
        """Raise ``ConfigError`` (one line) unless every method of the finished ``cells`` offers the score.

        A cell's methods whose every alignment failed give no named score: the check refuses them too."""
        if self.score == DEFAULT_SCORE:
            return
        from roman_sim.evaluation.results import read_pairs_csv
        from roman_sim.evaluation.score_curves import check_score

        for c in cells:
            try:
                check_score(read_pairs_csv(self.out / CELLS_DIR / c.id / PAIRS_GZ), self.score)
            except EvaluationError as err:
                raise ConfigError(f"--score: {err} (cell {c.id}; no leaderboard written)") from None

    def _attempt(self, c: Cell, ex: Executor, outcome: BenchmarkOutcome) -> None:
        try:
            self._run_cell(c, ex)
        except RomanSimError as err:
            outcome.failures[c.id], outcome.errors[c.id] = str(err), err
        except Exception as err:  # a plug-in's own error or a bug: this cell fails, the others run
            log.debug("cell %s failed", c.id, exc_info=True)
            outcome.failures[c.id], outcome.errors[c.id] = f"{type(err).__name__}: {one_line(err)}", err
        if c.id in outcome.failures:
            log.warning("cell %s failed: %s", c.id, outcome.failures[c.id])
            self._finish(c, "failed", outcome.failures[c.id])
        else:
            self._finish(c, "ok")


def check_declared_score(methods: list[str], score: str) -> None:
    """Refuse ``score`` before any cell runs when a method declares the scores it can give and it is not one
    (``align.base.declared_scores``); a method that declares none is checked on its first finished cell.

    Raises:
        ConfigError: one line naming the score, the method and the scores it can give.
    """
    from roman_sim.align import ALIGNERS
    from roman_sim.align.base import declared_scores

    if score == DEFAULT_SCORE:
        return
    for m in methods:
        offered = declared_scores(ALIGNERS.get(m))
        if offered is not None and score not in offered:
            raise ConfigError(
                f"--score: score {score!r}: method {method_label(m)} does not offer it (it can offer: "
                f"{', '.join(offered)}); nothing run or written"
            )


def _floats(values: object) -> list[float]:
    """The numbers of a JSON list (anything else: empty)."""
    if not isinstance(values, list):
        return []
    return [float(v) for v in values if isinstance(v, (int, float))]
