"""``roman-sim benchmark [SUITE]``: the heading x ambiguity benchmark as one resumable job; ``roman-sim benchmark
check FOLDER --seeds A:B``: its board checked on worlds it never saw."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.table import Table
from typer.core import TyperCommand

from roman_sim.cli import _executor as X
from roman_sim.cli import app, echo_traceback
from roman_sim.cli.progress import LineProgress

if TYPE_CHECKING:
    from roman_sim.benchmark.board_records import Deployable, Leaderboard
    from roman_sim.benchmark.cells import Cell, CellPlan
    from roman_sim.benchmark.check_records import BoardCheck
    from roman_sim.benchmark.run import BenchmarkOutcome


def _methods(values: list[str] | None) -> list[str] | None:
    """``--methods a,b --methods c`` -> ``[a, b, c]`` (None: the suite's)."""
    if not values:
        return None
    return [m.strip() for v in values for m in v.split(",") if m.strip()]


def _plan_table(cells: list[Cell], plans: dict[str, CellPlan], edges: list[float]) -> Table:
    labels = [f"{lo:g}-{hi:g}" for lo, hi in zip(edges, edges[1:])]
    t = Table(title="planned relevant cross-robot pairs per heading bin (deg), before rendering")
    for col in ["cell", *labels, "pairs", "submaps"]:
        t.add_column(col, justify="right" if col != "cell" else "left")
    totals: dict[str, list[int]] = {}
    for c in cells:
        p = plans.get(c.id)
        if p is None or not p.ok or p.relevant is None:
            t.add_row(c.id, *(["-"] * len(labels)), "failed", (p.error or "") if p is not None else "")
            continue
        tot = totals.setdefault(c.level, [0] * len(labels))
        for i, v in enumerate(p.relevant):
            tot[i] += v
        t.add_row(c.id, *map(str, p.relevant), str(p.pairs), str(p.submaps))
    for level, tot in totals.items():
        t.add_row(f"[bold]{level} (all seeds)", *map(str, tot), "", "")
    return t


def _deployable_text(dep: Deployable | None, method: str) -> str:
    """A level's deployable point of ``method``: held-out hits / relevant and precision, flagged when the
    precision falls short of the target (the threshold chosen on other worlds does not transfer)."""
    if dep is None or dep.note is not None:
        return "n/a (one world)"
    c = None if dep.overall is None else dep.overall.methods.get(method)
    if c is None:
        return "failed"
    p = c.precision
    text = f"{c.hits}/{c.n_relevant} P " + ("-" if p is None else f"{p:.2f}")
    return text if c.transfers else f"{text} [red]does not transfer[/red]"


def _board_table(board: Leaderboard) -> Table:
    target = board.target_precision if board.target_precision is not None else 0.9
    on = "" if board.score == "associations" else f" on {board.score}"
    t = Table(
        title=f"benchmark {board.suite}: the deployable point (threshold{on} chosen on other worlds for precision "
        f"{target:g}; held-out hits / relevant and precision over all headings), then max recall"
    )
    t.add_column("method", no_wrap=True, min_width=max(map(len, board.methods), default=6))  # a row's name whole
    levels = [e for e in board.finished_levels() if e.overall is not None]
    for e in levels:
        t.add_column(f"{e.name}: deployable", justify="right")
    for e in levels:
        t.add_column(f"{e.name}: max recall", justify="right")
    for m in board.methods:
        row = [m]
        for e in levels:
            row.append(_deployable_text(e.deployable, m))
        for e in levels:
            assert e.overall is not None
            a = e.overall.point(m, "max_recall")
            row.append("failed" if a is None else f"{a.hits}/{a.n_relevant}")
        t.add_row(*row)
    return t


check_app = typer.Typer(add_completion=False, pretty_exceptions_enable=False)


@check_app.command()
@X.executor_options
def check_cmd(
    folder: Path = typer.Argument(..., help="a finished benchmark folder (its benchmark.json and leaderboard.json)"),
    seeds: str | None = typer.Option(
        None, "--seeds", help="fresh seeds A:B (A to B-1, at least two) at every level; none the board used"
    ),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Check a finished benchmark's board on worlds it never saw: run fresh seeds at every level into
    FOLDER/check-A-B (resumable), score them at the board's deployed thresholds, and report whether the
    precision target and each stated paired verdict held (check.json, check.md); exit 1 on bad input."""
    from roman_sim.benchmark.check import CHECK_MD, check_dir, run_check

    if seeds is None:
        typer.echo("error: --seeds: give the fresh seeds as A:B (e.g. --seeds 100:104)", err=True)
        raise typer.Exit(1)
    lines = LineProgress()

    def progress(done: int, total: int, what: str) -> None:
        if total:
            lines.line(f"check: cell {what} done ({done}/{total})")

    result, outcome = run_check(folder, seeds, flags.config(), progress)
    prec, verd = _check_tables(result)
    Console().print(prec)
    Console().print(verd if verd.row_count else "the board states no paired verdict (a ahead or b ahead)")
    Console().print(f"check: {check_dir(folder, (result.seeds[0], result.seeds[1])) / CHECK_MD}")
    _exit_on_failures(outcome, "fresh cell(s) failed")


def _exit_on_failures(outcome: BenchmarkOutcome, what: str) -> None:
    """Each failed cell and its traceback, then ``N <what>; run the command again to retry`` and exit 1."""
    if outcome.failures:
        for c, err in outcome.failures.items():
            typer.echo(f"cell {c} failed: {err}", err=True)
            if c in outcome.errors:
                echo_traceback(outcome.errors[c])
        typer.echo(f"{len(outcome.failures)} {what}; run the command again to retry", err=True)
        raise typer.Exit(1)


def _check_tables(result: BoardCheck) -> tuple[Table, Table]:
    """The check's precision rows and stated verdicts as two tables."""
    from roman_sim.benchmark.check_markdown import precision_row, verdict_row

    a, b = result.seeds
    prec = Table(title=f"{result.suite} on fresh seeds {a}-{b - 1}: precision at the deployed thresholds")
    for col in ("level", "method", "k", "fresh precision", "target held", "stated interval", "worlds inside"):
        prec.add_column(col)
    verd = Table(title="paired verdicts the board states, on the fresh worlds")
    for col in ("level", "heading", "methods", "board", "fresh difference", "sign held", "fresh test"):
        verd.add_column(col)
    for e in result.levels:
        for p in e.precision:
            prec.add_row(*(c.replace("**", "") for c in precision_row(e.name, p)[:7]))
        for v in e.verdicts:
            verd.add_row(*(c.replace("**", "") for c in verdict_row(e.name, v)))
    return prec, verd


class _BenchmarkCommand(TyperCommand):
    """``roman-sim benchmark [SUITE]``, and ``roman-sim benchmark check FOLDER --seeds A:B`` (``check_cmd``)."""

    def make_context(self, info_name: str | None, args: list[str], parent: Any = None, **extra: Any) -> Any:
        """``check ...`` as the check command's own context (Any: typer's vendored click context; no data)."""
        if args and args[0] == "check":
            cmd = typer.main.get_command(check_app)
            return cmd.make_context(f"{info_name} check", list(args[1:]), parent=parent, **extra)
        return super().make_context(info_name, args, parent=parent, **extra)


@app.command("benchmark", cls=_BenchmarkCommand)
@X.executor_options
def benchmark_cmd(
    suite: str = typer.Argument(
        "quick",
        help="suite: quick (the default, minutes), standard (about 80 min on 2 cores), envelope (its levels with"
        " three front ends), or a YAML; "
        "`benchmark check FOLDER --seeds A:B` checks a finished board on fresh worlds",
    ),
    methods: list[str] | None = typer.Option(
        None, "--methods", "-m", help="methods to score (comma-separated or repeated; package.module:Class plug-ins)"
    ),
    sets: list[str] | None = typer.Option(None, "--set", help="scenario override for every cell (key=value)"),
    out: Path | None = typer.Option(None, "--out", "-o", help="folder (default results/benchmark/<suite>)"),
    plan: bool = typer.Option(False, "--plan", help="only plan the cells and print their relevant pairs"),
    target_precision: float = typer.Option(
        0.9,
        "--target-precision",
        help="precision the deployable thresholds are chosen for on the other worlds of a level, in (0, 1]",
    ),
    report_only: bool = typer.Option(
        False, "--report-only", help="run nothing: re-render the leaderboard of the folder's finished cells"
    ),
    score: str = typer.Option(
        "associations",
        "--score",
        help="confidence score the deployable thresholds and the precision-recall curves are on: the "
        "association count (associations) or a score every method offers (e.g. objective, margin)",
    ),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Run a benchmark suite (resumable); write leaderboard.json, leaderboard.md and plots; exit 1 if a cell failed."""
    from roman_sim.benchmark.board import LEADERBOARD_JSON, LEADERBOARD_MD
    from roman_sim.benchmark.board_records import read_leaderboard
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite

    if not 0 < target_precision <= 1:
        typer.echo(f"--target-precision: must lie in (0, 1], got {target_precision:g}", err=True)
        raise typer.Exit(1)
    from roman_sim.align.base import SCORE_NAME

    if score != "associations" and not SCORE_NAME.match(score):
        typer.echo(
            f"--score: {score!r} is no score name (associations, or lower-case letters, digits and _, a letter "
            "first, at most 40); a method's scores are listed by roman-sim report RUN --score",
            err=True,
        )
        raise typer.Exit(1)
    spec = load_suite(suite)
    folder = out or Path("results") / "benchmark" / spec.name
    if report_only:
        from roman_sim.benchmark.board import write_leaderboard

        if not (folder / "benchmark.json").is_file():
            typer.echo(f"--report-only: no benchmark.json in {folder}; run the suite first", err=True)
            raise typer.Exit(1)
        write_leaderboard(folder, target_precision, score)
        Console().print(_board_table(read_leaderboard(folder / LEADERBOARD_JSON)))
        Console().print(f"leaderboard: {folder / LEADERBOARD_MD}")
        return
    ex = flags.config()
    lines = LineProgress()

    def progress(done: int, total: int, what: str) -> None:
        if total:
            lines.line(f"benchmark {spec.name}: cell {what} done ({done}/{total})")
        else:
            lines.line(f"benchmark {spec.name}: {done} cells planned")

    if spec.frontends and not plan:
        from roman_sim.benchmark.envelope import ENVELOPE_MD, run_envelope

        env, outcomes = run_envelope(
            spec,
            folder,
            _methods(methods),
            sets,
            executor=ex,
            progress=progress,
            target_precision=target_precision,
            score=score,
        )
        if env is not None:
            held = sum(r.holds == "holds for every front end" for r in env.rows)
            Console().print(f"{held} of {len(env.rows)} verdicts hold for every front end: {folder / ENVELOPE_MD}")
        for fe, outcome in outcomes.items():
            _exit_on_failures(outcome, f"cell(s) of front end {fe} failed, the others ran")
        return
    job = BenchmarkJob(spec, folder, _methods(methods), sets, ex, progress, target_precision, score)
    if plan:
        cells, plans = job.plan_only()
        Console().print(_plan_table(cells, plans, spec.heading_edges()))
        return
    outcome = job.run()
    Console().print(_board_table(read_leaderboard(outcome.out_dir / LEADERBOARD_JSON)))
    Console().print(f"leaderboard: {outcome.out_dir / LEADERBOARD_MD}")
    _exit_on_failures(outcome, "cell(s) failed, the others ran")
