"""``roman-sim tune SOURCE``: tune one method's declared parameters for a target precision over worlds."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import _executor as X
from roman_sim.cli import app
from roman_sim.cli.progress import LineProgress, interactive, rich_progress

if TYPE_CHECKING:
    from roman_sim.benchmark.tune_result import TuneResult


def _seeds(text: str | None) -> list[int] | None:
    """``0,1,2`` or ``0:3`` (0, 1, 2) -> the seeds (None: the source's)."""
    from roman_sim.core.errors import ConfigError

    if text is None:
        return None
    try:
        if ":" in text:
            lo, hi = (int(x) for x in text.split(":", 1))
            if lo >= hi:
                raise ConfigError(f"--seeds: empty or reversed range {text} (LO:HI takes LO < HI)")
            return list(range(lo, hi))
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(f"--seeds: expected 0,1,2 or LO:HI, got {text!r}") from None


def _num(v: float | None, fmt: str = "{:.2f}") -> str:
    return "-" if v is None else fmt.format(v)


def _ci(v: list[float] | None) -> str:
    return "" if v is None else f" [{v[0]:.2f}, {v[1]:.2f}]"


def _table(result: TuneResult) -> Table:
    level = "" if result.level is None else f" (level {result.level})"
    t = Table(
        title=f"tune {result.method}{level}: held-out (thresholds chosen on other worlds), target precision "
        f"{result.target_precision:g}"
    )
    for col in ("config", "recall", "precision", "false / km", "time / pair (ms)", "front"):
        t.add_column(col, justify="left" if col == "config" else "right", no_wrap=col == "config")
    rec = None if result.recommended is None else result.recommended.config
    for c in result.configs:
        name = ", ".join(f"{k}={v}" for k, v in c.values.items()) or "(defaults)"
        flag = "" if c.transfers else " (does not transfer)"
        t.add_row(
            ("* " if c.id == rec else "") + name,
            _num(c.recall) + _ci(c.recall_worlds),
            _num(c.precision) + _ci(c.precision_worlds) + flag,
            _num(c.false_per_km),
            _num(None if c.time_per_pair_s is None else 1000 * c.time_per_pair_s, "{:.1f}"),
            "yes" if c.on_front else "",
        )
    return t


@app.command("tune")
@X.executor_options
def tune_cmd(
    source: str = typer.Argument(..., help="scenario (name or YAML), sweep YAML, or benchmark suite (quick, ...)"),
    method: str = typer.Option("roman", "--method", "-m", help="the method tuned (name or package.module:Class)"),
    params: list[str] | None = typer.Option(
        None,
        "--param",
        "-p",
        help="NAME=LO:HI, NAME=LO:HI:N or NAME=V1,V2 (repeat; default: the method's declared defaults)",
    ),
    target_precision: float = typer.Option(0.9, "--target-precision", help="precision to reach, in (0, 1]"),
    seeds: str | None = typer.Option(None, "--seeds", help="worlds: seeds 0,1,2 or LO:HI (default: the source's)"),
    level: str | None = typer.Option(
        None, "--level", help="a suite's ambiguity level: tune on its worlds only (default: every level)"
    ),
    rule: str = typer.Option(
        "world",
        "--rule",
        help="recommend by the share of new worlds within 0.05 of the target (world: at least 90 %), by the "
        "pooled precision (point) or by the lower end of the one-new-world precision interval (lower)",
    ),
    sets: list[str] | None = typer.Option(None, "--set", help="scenario override for every world (key=value)"),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="folder (default results/tune/<method>-<source>[-<level>][-<rule>])"
    ),
    flags: X.ExecutorFlags = X.NO_FLAGS,
) -> None:
    """Tune a method's declared parameters for a target precision (resumable); write tune.json,
    front.png and recommended.yaml (for a scenario or ``roman-sim run --set @recommended.yaml``).
    With ``--level``, a suite's calibration and held-out worlds are that level's only. Under ``--rule world`` (the
    default) a setting qualifies when the spread of the worlds' precisions at it puts at least 90 % of new worlds
    within 0.05 of the target; under ``point`` when its pooled precision reaches the target; under ``lower`` when
    the lower end of its one-new-world precision interval does."""
    from roman_sim.benchmark.tune import FRONT_PNG, RECOMMENDED_YAML, TuneJob, spread_lines
    from roman_sim.benchmark.tune_choice import check_rule
    from roman_sim.core.atomic import output_folder
    from roman_sim.core.errors import ConfigError

    check_rule(rule)

    if not 0 < target_precision <= 1:
        raise ConfigError(f"--target-precision: must lie in (0, 1], got {target_precision:g}")
    stem = Path(source).stem if source.endswith((".yaml", ".yml")) else source
    name = f"{method.replace(':', '_').replace('.', '_')}-{stem}" + ("" if level is None else f"-{level}")
    name += "" if rule == "world" else f"-{rule}"
    folder = output_folder(out or Path("results") / "tune" / name, "--out", create=False)
    ex = flags.config()
    lines = LineProgress()
    bar: Any = None

    def progress(done: int, total: int, what: str) -> None:
        if bar is not None:
            bar[0].update(bar[1], completed=done, total=total, description=f"tune: {what}")
        else:
            lines.line(f"tune {method}: alignment {what} done ({done}/{total})")

    job = TuneJob(
        source, method, folder, list(params or []), target_precision, _seeds(seeds), sets, ex, progress, level, rule
    )
    with rich_progress(Console(stderr=True)) if interactive() else contextlib.nullcontext() as p:
        if p is not None:
            bar = (p, p.add_task("tune", total=len(job.worlds) * len(job.grid.alignments())))
        result = job.run()
    Console().print(_table(result))
    h = result.held_out
    Console().print(
        f"held-out over {len(result.worlds)} worlds (setting chosen on the others): precision "
        f"{_num(h.precision)}{_ci(h.precision_worlds)}, recall {_num(h.recall)}{_ci(h.recall_worlds)}"
        + ("" if h.transfers else " - the chosen setting does not transfer")
    )
    per_world = ", ".join(f"{w} {_num(p.precision)}" for w, p in h.per_world.items())
    Console().print(
        f"precision per held-out world: {per_world}; in one new world:{_ci(h.precision_new_world) or ' -'} "
        "(every world's Wilson interval and the pooled one)"
    )
    rec = result.recommended
    if rec is None and rule == "lower":
        Console().print(
            "no setting's one-new-world precision interval reaches the target precision at its lower end "
            "(--rule lower): nothing recommended"
        )
    elif rec is None and rule == "world":
        from roman_sim.benchmark.transfer import PRECISION_SLACK
        from roman_sim.benchmark.tune_choice import WORLD_SHARE

        Console().print(
            f"no setting's spread over the worlds puts {WORLD_SHARE:.0%} of new worlds within {PRECISION_SLACK:g} "
            "of the target precision (--rule world): nothing recommended"
        )
    elif rec is None:
        Console().print("no setting reaches the target precision on these worlds: nothing recommended")
    else:
        values = ", ".join(f"{k}={v}" for k, v in rec.values.items())
        Console().print(f"recommended: threshold {rec.threshold}" + (f", {values}" if values else ""))
        for line in spread_lines(rec.spread, result.target_precision):
            Console().print(line.removeprefix("# "))
        Console().print(f"written: {folder / RECOMMENDED_YAML}")
    Console().print(f"front: {folder / FRONT_PNG}")
