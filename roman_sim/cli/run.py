"""``roman-sim run``, ``demo``, ``record``, ``report`` and ``sweep``: the pipeline commands."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from roman_sim.cli import _executor as X
from roman_sim.cli import _signals as S
from roman_sim.cli import app
from roman_sim.cli.listing import LISTINGS
from roman_sim.cli.progress import LineProgress, StageTracker, interactive, rich_progress
from roman_sim.core.errors import RomanSimError, RunFolderBusy, StorageError

if TYPE_CHECKING:
    from roman_sim.evaluation.run_summary import RecallSummary, RunSummary
    from roman_sim.pipeline.result import RunResult
    from roman_sim.pipeline.scenario import Scenario
    from roman_sim.pipeline.sweep import SweepFailure

console = Console(stderr=True)
DEMO_SCENARIO = "demo"
NO_SHARED_CACHE = typer.Option(
    False,
    "--no-shared-cache",
    help="neither take stages from nor store them in the shared stage cache (see `roman-sim cache`)",
)


class RichProgress:
    """Rich progress bars for the stages of ``Experiment`` (implements its ``Progress``)."""

    def __init__(self, progress: Progress) -> None:
        self.p = progress
        self.tasks: dict[str, Any] = {}

    def start(self, stage: str, total: int | None = None) -> None:
        if total is None and ":" not in stage:
            self.tasks[stage] = self.p.add_task(f"[bold]{stage}", total=None)
        else:
            self.tasks[stage] = self.p.add_task(f"  {stage}", total=total)

    def advance(self, stage: str, n: int = 1) -> None:
        if stage in self.tasks:
            self.p.advance(self.tasks[stage], n)

    def end(self, stage: str) -> None:
        task = self.tasks.get(stage)
        if task is not None:
            total = self.p.tasks[task].total if task < len(self.p.tasks) else None
            self.p.update(task, total=total or 1, completed=total or 1)


def _progress() -> Progress:
    return rich_progress(console)


def _fmt(v: Any, digits: int = 2) -> str:
    from roman_sim.report.tables import fmt

    return fmt(v, digits)


def _recall_cell(max_recall: float | None, hits: int, n_relevant: int, min_n: int, undefined: bool = False) -> str:
    """``0.77 33/43`` (``n<5 1/2`` for small sets, ``n/a`` without relevant pairs, ``undefined``: nothing to align)."""
    if undefined:
        return "undefined"
    if not n_relevant or max_recall is None:
        return "n/a"
    if n_relevant < min_n:
        return f"n<{min_n} {hits}/{n_relevant}"
    return f"{max_recall:.2f} {hits}/{n_relevant}"


def _recall(r: RecallSummary, min_n: int, undefined: bool) -> str:
    return _recall_cell(r.max_recall, r.max_hits, r.n_relevant, min_n, undefined)


def _recall_tables(s: RunSummary, kind: str, label: str, min_n: int, undefined: bool = False) -> list[Table]:
    """Two tables that fit 80 columns: the overall figures and runtime, then max recall per heading bin.

    ``undefined``: the submaps held nothing to align, so every recall cell is undefined.
    """
    from rich import box

    first = next(iter(s.methods.values())).set(kind)
    overall = Table(title=f"{label} pairs: recall (hits/relevant) and median ms per pair", box=box.SIMPLE_HEAD)
    bins = Table(title=f"{label} pairs: max recall (hits/relevant) per heading bin", box=box.SIMPLE_HEAD)
    overall.add_column("method", no_wrap=True)
    bins.add_column("method", no_wrap=True)
    for col in ("max R", "R@P=1", "F1", "ms"):
        overall.add_column(col, justify="right", no_wrap=True)
    for b in first.bins:
        bins.add_column(f"{b} deg", justify="right", no_wrap=True)
    for name, m in s.methods.items():
        k = m.set(kind)
        ms = None if m.runtime_median_s is None else m.runtime_median_s * 1000
        p1 = _recall_cell(k.recall_at_precision_1, k.hits_at_precision_1, k.n_relevant, min_n, undefined)
        f1 = "undefined" if undefined else _fmt(k.best_f1)
        overall.add_row(name, _recall(k, min_n, undefined), p1, f1, _fmt(ms, 1))
        bins.add_row(name, *[_recall(b, min_n, undefined) for b in k.bins.values()])
    return [overall, bins]


def print_summary(result: RunResult) -> None:
    """The summary tables: recall (hits/relevant) per heading bin per method for cross-robot and
    same-robot pairs, runtime; ATE over the same robots; map size."""
    from rich import box

    from roman_sim.evaluation.metrics import NO_SEGMENTS_NOTE
    from roman_sim.evaluation.types import PAIR_SET_LABELS
    from roman_sim.report.lead import lead_paragraph

    s = result.summary()
    empty = NO_SEGMENTS_NOTE in result.metrics.notes  # nothing to align (the lead says so): figures undefined, not 0
    cfg = result.metrics.config
    out = Console()
    cap = (
        "no distance cap"
        if cfg.max_pair_dist_m is None
        else (f"distance cap {cfg.max_pair_dist_m:g} m: {s.n_skipped} pairs skipped")
    )
    out.print(
        f"{result.scenario.name} (seed {result.scenario.seed}): {result.metrics.n_pairs} pairs scored, {cap}; "
        f"relevant: {cfg.relevance}; correct: <= {cfg.rot_tol_deg:g} deg, <= {cfg.trans_tol_m:g} m"
    )
    for line in lead_paragraph(result.metrics, result.ate, markdown=False):
        out.print(line, markup=False, highlight=False)
    kinds = [s.headline] + [k for k in ("inter", "intra") if k != s.headline]
    for kind in kinds:
        if s.methods and s.pairs[kind].n_pairs:
            label = PAIR_SET_LABELS[kind] + (" (headline)" if kind == s.headline else "")
            for table in _recall_tables(s, kind, label, cfg.min_relevant, empty):
                out.print(table)
    if s.ate and s.ate_robots is not None:
        robots, common = s.ate_robots.robots, s.ate_robots.common
        a = Table(
            title=f"ATE RMSE (m), SE(3) aligned: over the robots every row placed ({', '.join(common) or 'none'}) "
            f"and over all {len(robots)}",
            box=box.SIMPLE_HEAD,
        )
        for col in ("trajectory", "placed", "common", "all robots"):
            a.add_column(col, justify="left" if col == "trajectory" else "right")
        n = len(robots)
        for k, v in s.ate.items():
            a.add_row(k, f"{v.connected}/{n}", _fmt(v.common), _fmt(v.all) if v.connected == n else "not connected")
        out.print(a)
    mp = s.map
    out.print(
        f"map: {None if mp is None else mp.segments} segments, {None if mp is None else mp.submaps} submaps, "
        f"{_fmt(None if mp is None else mp.kb_per_submap, 1)} KB/submap, "
        f"{_fmt(None if mp is None else mp.mb_per_km)} MB/km"
    )
    for note in result.notes:
        out.print(f"[yellow]note:[/yellow] {note}")
    out.print(f"results: {result.run_dir} (report: {result.run_dir / 'report.md'})")


def _run(
    scenario: str,
    out: Path | None,
    sets: list[str] | None,
    fresh: bool,
    submaps: Path | None,
    aligners: list[str] | None,
    from_stage: str | None = None,
    executor: Any = None,
    share: bool = True,
    odometry: list[str] | None = None,
) -> None:
    """Lock the results folder first, then start up and run: a refused run answers before any heavy work.

    With ``--out`` the lock comes before anything else; the default folder is named by the
    scenario, which is loaded first (the lock then comes before the pool and the pipeline's
    imports). ``odometry``: ``ROBOT=FILE.tum`` values of ``--odometry``.
    """
    from roman_sim.pipeline.folder_lock import hold_run_folder

    sc: Scenario | None = None
    if out is None:
        from roman_sim.pipeline.scenario import default_run_dir

        sc = _load(scenario, sets, aligners, odometry)
        out = default_run_dir(sc)
    with hold_run_folder(out):
        from roman_sim.runner.executors import prestart

        # a local pool's forkserver imports the stages' worker modules while this process imports its own
        prestart(executor, ("roman_sim.pipeline.stages:WORKER_PRELOAD",))
        if sc is None:
            sc = _load(scenario, sets, aligners, odometry)
        _run_locked(sc, out, fresh, submaps, from_stage, executor, share)


def _load(scenario: str, sets: list[str] | None, aligners: list[str] | None, odometry: list[str] | None) -> Scenario:
    """The scenario with its overrides and added aligners, each ``--odometry ROBOT=FILE`` in its robot."""
    from roman_sim.core.errors import ConfigError
    from roman_sim.pipeline.scenario import load_scenario, with_odometry

    sc = load_scenario(scenario, list(sets or []), list(aligners or []))
    files = {}
    for value in odometry or []:
        robot, sep, file = value.partition("=")
        if not (sep and robot and file):
            raise ConfigError(f"--odometry {value}: expected ROBOT=FILE.tum (a robot's name and a TUM file)")
        files[robot] = Path(file).resolve()
    return with_odometry(sc, files) if files else sc


def _run_locked(
    sc: Scenario, out: Path, fresh: bool, submaps: Path | None, from_stage: str | None, executor: Any, share: bool
) -> None:
    """Validate and run ``sc`` into ``out``, whose lock this thread holds; print the summary."""
    from roman_sim.pipeline.experiment import Experiment

    exp = Experiment(sc, out, fresh=fresh, submaps_dir=submaps, from_stage=from_stage, executor=executor, cache=share)
    exp.validate()
    tracker = StageTracker(LineProgress())
    try:
        if interactive():
            with _progress() as p:
                exp.progress = tracker = StageTracker(RichProgress(p))
                result = exp.run()
        else:  # CI, nohup, a pipe: one line per finished stage, so a killed run leaves a log
            exp.progress = tracker
            result = exp.run()
    except KeyboardInterrupt as err:  # Ctrl-C or SIGTERM: the executor has ended its workers
        typer.echo(f"{S.stop_word(err)}: {_kept(exp.run_dir)}; run the same command again to resume", err=True)
        raise typer.Exit(S.stop_code(err)) from None
    except RunFolderBusy:  # the folder's files are the other run's: nothing of this run to report
        raise
    except RomanSimError as err:  # what failed (after the memory cap and the stage, under one), what was kept
        head = S.capped(f"failed {tracker.where()}: ") if S.memory_limit_note() else ""
        err.args = (f"{head}{err} ({_kept(exp.run_dir)})",)
        raise
    except Exception as err:
        raise _limit_error(err, tracker, exp.run_dir) from None
    print_summary(result)


def _limit_error(err: Exception, tracker: StageTracker, run_dir: Path) -> Exception:
    """``err`` as one line when it is a limit (no memory, a full disk, anything under a memory rlimit), else ``err``."""
    if isinstance(err, OSError) and S.is_disk_full(err):
        return StorageError(f"{S.disk_full_line(err, str(run_dir))} ({_kept(run_dir)})")
    if isinstance(err, MemoryError) or S.memory_limit_note() is not None:
        return RomanSimError(f"{S.limit_line(err, tracker.where())} ({_kept(run_dir)})")
    return err


def _kept(run_dir: Path) -> str:
    """What an interrupted or failed run leaves: its completed stages, kept in ``run_dir``."""
    from roman_sim.pipeline.manifest import existing_manifest

    man = existing_manifest(run_dir)
    done = sorted(man.stages) if man is not None else []
    if not done:
        return f"no stage completed in {run_dir}"
    return f"completed stages kept in {run_dir}: {', '.join(done)}"


@app.command("run")
@X.executor_options
def run_cmd(
    scenario: str = typer.Argument(..., help="scenario YAML path or bundled scenario name"),
    out: Path | None = typer.Option(None, "--out", "-o", help="results folder (default results/<name>/...)"),
    sets: list[str] | None = typer.Option(None, "--set", "-s", help="override, e.g. --set seed=3"),
    fresh: bool = typer.Option(False, "--fresh", help="recompute every stage (ignore cached results)"),
    no_shared_cache: bool = NO_SHARED_CACHE,
    submaps: Path | None = typer.Option(None, "--submaps", help="start from saved submaps (<robot>.npz)"),
    aligner: list[str] | None = typer.Option(
        None, "--aligner", "-a", help="add an aligner (name or package.module:Class)"
    ),
    from_stage: str | None = typer.Option(
        None, "--from", help="recompute from this stage on (maps, submaps, evaluation, posegraph, ate, report)"
    ),
    odometry: list[str] | None = typer.Option(
        None,
        "--odometry",
        help="ROBOT=FILE.tum: the robot's odometry from a TUM file of body poses (e.g. a VIO's) instead of its own",
    ),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Run a scenario end to end and print the summary (robots and pairs spread over the workers)."""
    ex = flags.config()
    _run(scenario, out, sets, fresh, submaps, aligner, from_stage, ex, not no_shared_cache, odometry)


@app.command("demo")
@X.executor_options
def demo_cmd(
    out: Path | None = typer.Option(None, "--out", "-o", help="results folder (default results/demo/...)"),
    fresh: bool = typer.Option(False, "--fresh", help="recompute every stage"),
    no_shared_cache: bool = NO_SHARED_CACHE,
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Run the demo scenario: ROMAN against CLIPPER and RANSAC on opposite-direction traversals."""
    ex = flags.config()
    _run(DEMO_SCENARIO, out, None, fresh, None, None, None, ex, not no_shared_cache)


@app.command("record")
def record_cmd(
    scenario: str = typer.Argument(..., help="scenario YAML path or bundled scenario name"),
    out: Path = typer.Option(..., "--out", "-o", help="folder for the recordings (one sub-folder per robot)"),
    sets: list[str] | None = typer.Option(None, "--set", "-s", help="override, e.g. --set seed=3"),
    robot: list[str] | None = typer.Option(None, "--robot", "-r", help="only these robots"),
) -> None:
    """Render and store the robots' frames (chunked, compressed) with TUM trajectories."""
    from roman_sim.core.atomic import output_folder
    from roman_sim.core.errors import ConfigError
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.recording import RecordingOrigin, write_recording
    from roman_sim.sim.source import SimulatedRobot, robot_sources
    from roman_sim.world import generate

    sc = load_scenario(scenario, list(sets or []))
    names = [r.name for r in sc.simulated_robots()]
    unknown = sorted(set(robot or []) - set(names))
    if unknown or not names:
        raise ConfigError(
            f"--robot: no simulated robot {', '.join(unknown)} (simulated robots: {', '.join(names) or 'none'})"
        )
    output_folder(out, "--out", create=False)
    for cfg in sc.simulated_robots():
        if (out / cfg.name).exists() and not (out / cfg.name).is_dir():
            raise ConfigError(f"--out {out}: {cfg.name} there is an existing file, not a recording folder")
    world = generate(sc.world.spec(), sc.seed)
    sources = robot_sources(world, sc.simulated_robots(), sc.seed, [n for n in names if not robot or n in robot])
    progress: Any = None
    with _progress() if interactive() else contextlib.nullcontext() as p:
        progress = RichProgress(p) if p is not None else LineProgress()
        for src in sources:
            stage = f"record:{src.name}"
            progress.start(stage, len(src))

            def frames(src: SimulatedRobot = src, stage: str = stage) -> Any:
                for f in src.frames():
                    progress.advance(stage)
                    yield f

            write_recording(frames(), out / src.name, overwrite=True, origin=RecordingOrigin(sc.name, sc.seed))
            progress.end(stage)
    Console().print(f"recordings written to {out}")


@app.command("report")
def report_cmd(
    run_dir: Path = typer.Argument(..., help="a results folder of `roman-sim run`, or a sweep folder"),
    verify: bool = typer.Option(
        False,
        "--verify",
        help="recompute metrics.json from pairs.csv and ate.json from the TUM files; exit code 1 when they differ",
    ),
    rewrite: bool = typer.Option(
        False,
        "--rewrite",
        help="write report.md again in the current layout from the folder's own files (nothing else changes)",
    ),
) -> None:
    """Print the summary of a finished run or sweep (an incomplete run is an error naming its missing stages)."""
    from roman_sim.pipeline.result import RunResult
    from roman_sim.pipeline.sweep_aggregate import SWEEP_JSON, print_sweep_aggregate

    if rewrite:
        from roman_sim.studies.reference import rewrite_report

        Console().print(f"rewrote {rewrite_report(run_dir)}")

    if (run_dir / SWEEP_JSON).is_file():
        print_sweep_aggregate(run_dir, Console())
        return
    # reference results keep the raw data compressed and no maps: verify them, nothing to summarise
    compressed = not (run_dir / "pairs.csv").is_file() and (run_dir / "pairs.csv.gz").is_file()
    if not compressed:
        print_summary(RunResult.load(run_dir))
    if verify:
        from roman_sim.studies.verify import verify_run

        res = verify_run(
            run_dir, pairs_file="pairs.csv.gz" if compressed else "pairs.csv", tum_suffix=".gz" if compressed else ""
        )
        out = Console()
        for d in res.differences:
            out.print(f"[red]differs:[/red] {d}")
        out.print(
            ("[green]verified:[/green] " if res.ok else "[red]NOT verified:[/red] ")
            + "; ".join(res.checked)
            + ("" if res.ok else f" ({len(res.differences)} differences)")
        )
        if not res.ok:
            raise typer.Exit(1)


@app.command("sweep")
@X.executor_options
def sweep_cmd(
    sweep_file: Path = typer.Argument(..., help="sweep YAML (scenario, grid, seeds, executor)"),
    out: Path | None = typer.Option(None, "--out", "-o", help="folder (default results/sweeps/<name>)"),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Run a parameter x seed sweep (resumable) and write sweep.csv; exit 1 with a table if a cell failed."""
    from roman_sim.core.atomic import output_folder
    from roman_sim.pipeline.sweep import load_sweep, run_sweep, sweep_failures

    cfg, scenario_path = load_sweep(sweep_file)
    cfg.executor = flags.config(cfg.executor.model_dump())
    out_dir = out or Path("results") / "sweeps" / cfg.name
    output_folder(out_dir, "--out", create=False)
    if interactive():
        with _progress() as p:
            task = p.add_task(f"sweep {cfg.name}", total=None)

            def cb(done: int, total: int) -> None:
                p.update(task, completed=done, total=total)

            path = run_sweep(cfg, scenario_path, out_dir, progress=cb)
    else:  # one line per finished run
        lines = LineProgress()
        last = [0]

        def cb_lines(done: int, total: int) -> None:
            if done > last[0]:
                lines.line(f"sweep {cfg.name}: {done}/{total} runs done")
            last[0] = done

        path = run_sweep(cfg, scenario_path, out_dir, progress=cb_lines)
    Console().print(f"sweep table: {path}")
    failed = sweep_failures(path)
    if failed:
        _failure_table(failed, path)
        raise typer.Exit(1)


def _failure_table(failed: list[SweepFailure], path: Path) -> None:
    """The runs of a sweep that did not finish, on stderr."""
    t = Table(title=f"{len(failed)} sweep run(s) failed (all rows in {path})")
    for col in ("run", "seed", "status", "error"):
        t.add_column(col, overflow="fold")
    for row in failed:
        t.add_row(row.run_id, row.seed, row.status, row.error)
    console.print(t)


def _scenarios() -> list[str]:
    from roman_sim.pipeline.scenario import bundled_scenarios

    return list(bundled_scenarios())


def _aligners() -> list[str]:
    from roman_sim.align import ALIGNERS

    return ALIGNERS.names()


def _segmenters() -> list[str]:
    from roman_sim.frontend.components import SEGMENTER_TYPES

    return SEGMENTER_TYPES.names()


def _drift() -> list[str]:
    from roman_sim.sim.odometry import DRIFT_PRESETS

    return DRIFT_PRESETS.names()


LISTINGS.update(scenarios=_scenarios, aligners=_aligners, segmenters=_segmenters, drift=_drift)


@app.command("reproduce")
@X.executor_options
def reproduce_cmd(
    out: Path = typer.Option(Path("results/reference"), "--out", "-o", help="where the small results go"),
    work: Path = typer.Option(Path("results/work"), "--work", help="full run folders (cached)"),
    scenario: list[str] | None = typer.Option(
        None,
        "--scenario",
        help="only these (default: the paper's); the summary keeps the other committed scenarios and the sweep",
    ),
    from_stage: str | None = typer.Option(None, "--from", help="recompute from this stage on"),
    pages: Path | None = typer.Option(
        Path("."),
        "--pages",
        help="repository whose generated pages are rewritten: docs/results.md, the README's demo excerpt and figure",
    ),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Run the paper's experiments and write results/reference/summary.md next to the paper's figures."""
    from roman_sim.core.atomic import output_folder
    from roman_sim.studies.reference import reproduce

    output_folder(out, "--out", create=False)
    output_folder(work, "--work", create=False)
    ex = flags.config()
    path = reproduce(
        out,
        list(scenario or []) or None,
        work,
        on_start=lambda n: console.print(f"running {n} ..."),
        from_stage=from_stage,
        root=pages,
        executor=ex,
    )
    Console().print(path.read_text())
