"""A sweep's record and its aggregate over seeds: ``sweep.json``, ``sweep_summary.csv``, the plot, the table.

``sweep.json`` names the sweep, its swept keys, seeds and runs. The aggregate reads every
finished run's summary (``RunSummary``) and pools its max-recall hits per method, pair set
and heading bin over the seeds (``roman_sim.evaluation.sweepstats``); it is written to
``sweep_summary.csv`` (the file keeps its name) and ``roman-sim report SWEEP_DIR`` prints it.
"""

from __future__ import annotations

import csv
import io
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import read_record, write_record

if TYPE_CHECKING:
    from rich.console import Console

    from roman_sim.evaluation.sweepstats import SeedRow, SweepCell
    from roman_sim.pipeline.sweep_spec import RunSpec, SweepConfig

log = logging.getLogger(__name__)

SWEEP_JSON = "sweep.json"
SWEEP_SCHEMA = "roman_sim.sweep/1"
AGGREGATE_CSV = "sweep_summary.csv"
AGGREGATE_PLOT = "plots/sweep_summary.png"


@dataclass
class SweepRun:
    """One run of a sweep: its folder name, seed and swept values (dotted key -> value)."""

    run_id: str
    seed: int
    params: dict[str, Any]


@dataclass
class SweepRecord:
    """What ``sweep.json`` holds: the sweep's name, scenario, swept keys (sorted), seeds and runs."""

    name: str
    scenario: str
    grid: list[str]
    seeds: list[int]
    runs: list[SweepRun]


def write_sweep_json(cfg: "SweepConfig", runs: "list[RunSpec]", out_dir: Path) -> Path:
    """``sweep.json``: the sweep's name, swept keys, seeds and runs (what the summary is made of)."""
    record = SweepRecord(
        cfg.name,
        cfg.scenario,
        sorted(cfg.grid),
        list(cfg.seeds),
        [SweepRun(r.run_id, r.seed, dict(r.params)) for r in runs],
    )
    return write_record(out_dir / SWEEP_JSON, record, SWEEP_SCHEMA)


def read_sweep_json(out_dir: Path) -> SweepRecord:
    """A sweep folder's ``sweep.json`` (RecordError naming the file and the field when it is not one)."""
    return read_record(out_dir / SWEEP_JSON, SweepRecord, SWEEP_SCHEMA)


def aggregate_sweep(out_dir: Path) -> tuple[list[str], list[SweepCell], list[str]]:
    """(swept keys, aggregate rows, notes on runs left out) of a sweep folder's finished runs."""
    from roman_sim.evaluation.sweepstats import aggregate, seed_rows
    from roman_sim.pipeline.result import RunResult

    data = read_sweep_json(out_dir)
    keys: list[str] = list(data.grid)
    rows: list[SeedRow] = []
    notes: list[str] = []
    for r in data.runs:
        try:
            summary = RunResult.load(out_dir / r.run_id).summary()
        except RomanSimError as err:
            notes.append(f"run {r.run_id} left out: {err}")
            continue
        rows += seed_rows({k: r.params[k] for k in keys}, r.seed, summary)
    return keys, aggregate(rows, keys), notes


def write_sweep_aggregate(out_dir: Path) -> Path:
    """``sweep_summary.csv`` and ``plots/sweep_summary.png`` with its PDF (when there are two swept values)."""
    from roman_sim.core.figures import remove_figure
    from roman_sim.evaluation.sweepstats import AGGREGATE_FIELDS
    from roman_sim.report.sweepplot import plot_sweep

    keys, rows, notes = aggregate_sweep(out_dir)
    for n in notes:
        log.warning(n)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=[*keys, *AGGREGATE_FIELDS], lineterminator="\n")
    w.writeheader()
    w.writerows([{k: ("" if v is None else v) for k, v in r.csv_row().items()} for r in rows])
    path = out_dir / AGGREGATE_CSV
    write_text(path, buf.getvalue())
    kind = "inter" if any(r.kind == "inter" and r.relevant for r in rows) else "intra"
    if plot_sweep(rows, keys, out_dir / AGGREGATE_PLOT, kind) is None:
        remove_figure(out_dir / AGGREGATE_PLOT)  # and its PDF: an earlier aggregate's figure is stale
    return path


def print_sweep_aggregate(out_dir: Path, console: Console) -> None:
    """Print the sweep's aggregate over seeds: one table per pair set with relevant pairs (rich console)."""
    from rich.table import Table

    from roman_sim.evaluation.sweepstats import OVERALL, cell
    from roman_sim.evaluation.types import PAIR_SET_LABELS

    keys, rows, notes = aggregate_sweep(out_dir)
    name = read_sweep_json(out_dir).name
    for kind in ("inter", "intra"):
        mine = [r for r in rows if r.kind == kind]
        if not any(r.relevant for r in mine):
            continue
        bins = list(dict.fromkeys(r.bin for r in mine))
        t = Table(title=f"sweep {name}, {PAIR_SET_LABELS[kind]} pairs: max recall, mean over seeds [95 % interval]")
        for k in [*keys, "method"]:
            t.add_column(k.rsplit(".", 1)[-1])
        for b in bins:
            t.add_column("overall" if b == OVERALL else f"{b}°", justify="right")
        groups: dict[tuple[str, ...], dict[str, str]] = {}
        for r in mine:
            groups.setdefault((*(json.dumps(r.params[k]) for k in keys), r.method), {})[r.bin] = cell(r)
        for g, cells in groups.items():
            t.add_row(*g, *[cells.get(b, "n/a") for b in bins])
        console.print(t)
    for n in notes:
        console.print(f"[yellow]note:[/yellow] {n}")
    console.print(f"summary table: {out_dir / AGGREGATE_CSV}")
