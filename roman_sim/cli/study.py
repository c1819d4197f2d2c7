"""``roman-sim study attribution``: which heading mechanism explains how much of the same -> opposite drop."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError

if TYPE_CHECKING:
    from roman_sim.studies.attribution import AttributionRow

console = Console(stderr=True)

study_app = typer.Typer(help="Studies over several runs: the heading mechanisms' attribution.", no_args_is_help=True)
app.add_typer(study_app, name="study")


def _names(values: list[str] | None) -> list[str] | None:
    """``--mechanism a,b --mechanism c`` -> ``[a, b, c]`` (None: the default)."""
    if not values:
        return None
    return [m.strip() for v in values for m in v.split(",") if m.strip()]


def attribution_table(rows: list[AttributionRow]) -> Table:
    """The attribution table as rich prints it."""
    from roman_sim.studies.attribution import recall_cell, share_cell

    t = Table(title="same -> opposite drop in max recall (cross-robot pairs), each mechanism switched off in turn")
    for col in (
        "mechanism off",
        "method",
        "same: hits/relevant [95 %] precision",
        "opposite",
        "drop [95 % Newcombe]",
        "drop [95 % world bootstrap]",
        "explained",
    ):
        t.add_column(col, justify="left" if col in ("mechanism off", "method") else "right")
    for r in rows:
        drop = "n/a" if r.drop is None else f"{r.drop:+.2f} [{r.drop_lo:+.2f}, {r.drop_hi:+.2f}]"
        lo, hi = r.drop_worlds_lo, r.drop_worlds_hi
        boot = "n/a" if lo is None or hi is None else f"[{lo:+.2f}, {hi:+.2f}]"
        same, opposite = recall_cell(r, "same", " "), recall_cell(r, "opposite", " ")
        t.add_row(r.mechanism, r.method, same, opposite, drop, boot, share_cell(r))
    return t


@study_app.command("attribution")
def attribution_cmd(
    out: Path = typer.Option(Path("attribution"), "--out", "-o", help="folder of the study's runs and table"),
    mechanisms: list[str] | None = typer.Option(
        None, "--mechanism", "-m", help="mechanisms switched off in turn, e.g. partial_views,road_side (default: all)"
    ),
    methods: list[str] | None = typer.Option(
        None, "--methods", help="methods scored, e.g. roman,ransac1m (the default)"
    ),
    same: str | None = typer.Option(None, "--same", help="same-direction scenario (default same_direction)"),
    opposite: str | None = typer.Option(
        None, "--opposite", help="opposite-direction scenario (default opposite_direction)"
    ),
    seeds: str | None = typer.Option(
        None,
        "--seeds",
        help="world seeds, every run in each world, e.g. 0,1,2,3 (default: the scenarios' own world, once)",
    ),
    overrides: list[str] | None = typer.Option(
        None, "--set", help="override a scenario field in every run, key=value (replaces the study's size overrides)"
    ),
    results: Path | None = typer.Option(
        None, "--results", help="also keep the finished study's table and raw pairs here (e.g. results/attribution)"
    ),
    page: Path | None = typer.Option(
        None, "--page", help="with --results: rewrite this page's attribution block (docs/heading_mechanisms.md)"
    ),
) -> None:
    """Run both scenarios with every heading mechanism on, then each switched off in turn; table the drop.

    Resumable: finished runs with an unchanged configuration are not run again.
    """
    from roman_sim.core.atomic import output_folder
    from roman_sim.core.config import validate_model
    from roman_sim.studies.attribution import (
        TABLE,
        AttributionConfig,
        collect_attribution,
        parse_seeds,
        run_attribution,
    )

    if page is not None and results is None:
        raise ConfigError("--page: needs --results (the block is made from the kept study)")
    output_folder(out, "--out", create=False)
    if results is not None:
        output_folder(results, "--results", create=False)
    data: dict[str, Any] = {}
    named = (("mechanisms", _names(mechanisms)), ("methods", _names(methods)), ("same", same), ("opposite", opposite))
    for key, value in named:
        if value is not None:
            data[key] = value
    if seeds is not None:
        data["seeds"] = parse_seeds(seeds, "seeds")
    if overrides:
        data["overrides"] = list(overrides)
    cfg = validate_model(AttributionConfig, data, source="study attribution")

    def on_run(i: int, n: int, name: str, reused: bool) -> None:
        console.print(f"run {i}/{n} {name}: {'reused' if reused else 'done'}")

    rows = run_attribution(cfg, out, on_run)
    Console().print(attribution_table(rows))
    console.print(f"wrote {out / TABLE}")
    if results is not None:
        console.print(f"kept the study in {collect_attribution(out, results)}")
        if page is not None:
            from roman_sim.studies.attribution import MARKERS, attribution_block
            from roman_sim.studies.pages import update_block

            if not update_block(page, MARKERS, attribution_block(results)):
                raise ConfigError(f"--page: {page} has no attribution markers ({' and '.join(MARKERS)})")
            console.print(f"rewrote the attribution block of {page}")
