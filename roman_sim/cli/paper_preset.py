"""``roman-sim paper-preset``: fit the paper front-end preset's severity to one figure, then predict."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError

console = Console(stderr=True)


def _fmt(v: Any) -> str:
    return "n/a" if v is None else f"{v:.3f}"


paper_app = typer.Typer(
    help="The paper front-end preset: fit its severity to one figure, then run the held-out predictions.",
    no_args_is_help=True,
)
app.add_typer(paper_app, name="paper-preset")


def _fit_config(scenario: str | None, grid: str | None, refine: int | None, overrides: list[str]) -> Any:
    from roman_sim.core.config import validate_model
    from roman_sim.studies.paper_preset import PaperFitConfig

    data: dict[str, Any] = {"overrides": list(overrides)}
    if scenario is not None:
        data["scenario"] = scenario
    if grid is not None:
        try:
            data["grid"] = [float(x) for x in grid.split(",") if x.strip()]
        except ValueError:
            raise ConfigError(f"--grid: {grid!r} is not a comma-separated list of severities") from None
    if refine is not None:
        data["refine"] = refine
    return validate_model(PaperFitConfig, data, source="paper-preset fit")


@paper_app.command("fit")
def paper_fit_cmd(
    out: Path = typer.Option(Path("paper_fit"), "--out", "-o", help="folder of the fit's runs, state and result"),
    scenario: str | None = typer.Option(None, "--scenario", help="scenario fitted on (default same_direction)"),
    grid: str | None = typer.Option(None, "--grid", help="severities run first, e.g. 0,0.5,1,1.5,2,3"),
    refine: int | None = typer.Option(None, "--refine", help="bisection steps inside the bracketing interval"),
    overrides: list[str] = typer.Option([], "--set", help="override a scenario field in every run, key=value"),
) -> None:
    """Fit the preset's severity to ROMAN's same-direction max recall in the paper (0.67), resumably."""
    from roman_sim.core.atomic import output_folder
    from roman_sim.studies.paper_preset import FIT_YAML, fit_paper_preset

    output_folder(out, "--out", create=False)
    res = fit_paper_preset(out, _fit_config(scenario, grid, refine, overrides))
    t = Table(title=f"paper fit: {res.figure} (paper {res.paper})")
    for col in ("severity", "hits / relevant", "max recall", "95 % Wilson", "admitted"):
        t.add_column(col, justify="right")
    for r in res.runs:
        t.add_row(
            f"{r.severity:g}" + (" (fitted)" if r.severity == res.severity else ""),
            f"{'n/a' if r.hits is None else r.hits}/{'n/a' if r.relevant is None else r.relevant}",
            _fmt(r.max_recall),
            "n/a" if r.ci is None else f"{r.ci[0]:.3f}-{r.ci[1]:.3f}",
            "yes" if r.admitted else "no",
        )
    Console().print(t)
    console.print(f"wrote {out / FIT_YAML}")


@paper_app.command("predict")
def paper_predict_cmd(
    out: Path = typer.Option(Path("paper_fit"), "--out", "-o", help="the fit's folder (holds paper_fit.yaml)"),
    no_run: bool = typer.Option(
        False, "--no-run", help="run nothing: write the predictions from the runs done, the others marked not run"
    ),
) -> None:
    """Run the held-out predictions (opposite direction) at every admitted severity and judge the paper's claims."""
    from roman_sim.studies.paper_preset import PREDICTIONS, predict_paper_preset, range_cell, verdict_cell

    res = predict_paper_preset(out, run_missing=not no_run)
    admitted = ", ".join(f"{s:g}" for s in res.admitted.severities)
    t = Table(title=f"paper preset, admitted severities {admitted} (fitted {res.severity:g}): held-out predictions")
    for col in ("claim", "paper", "range over the settings run", "verdict"):
        t.add_column(col)
    for c in res.claims:
        t.add_row(c.claim, str(c.paper), range_cell(c), verdict_cell(c))
    Console().print(t)
    console.print(f"wrote {out / PREDICTIONS}")


@paper_app.command("collect")
def paper_collect_cmd(
    out: Path = typer.Option(Path("paper_fit"), "--out", "-o", help="the fit's folder (fit and predictions done)"),
    to: Path = typer.Option(Path("results/reference"), "--to", help="reference results folder"),
    pages: Path | None = typer.Option(
        Path("."), "--pages", help="repository whose results page's paper-preset block is rewritten"
    ),
) -> None:
    """Keep a finished fit and its predictions in the reference results (raw pairs included)."""
    from roman_sim.studies.pages import update_block
    from roman_sim.studies.paper_preset import PAPER_PRESET_DIR, PRESET_MARKERS, collect_paper_preset, preset_block
    from roman_sim.studies.reference import RESULTS_PAGE

    dest = collect_paper_preset(out, to / PAPER_PRESET_DIR)
    console.print(f"collected {out} into {dest}")
    if pages is not None:
        page = pages / RESULTS_PAGE
        if page.is_file() and update_block(page, PRESET_MARKERS, preset_block(dest)):
            console.print(f"rewrote the paper-preset block of {page}")
        else:
            console.print(f"note: {page} has no paper-preset markers; its block was not written")
