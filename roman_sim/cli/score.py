"""``roman-sim score``: any system's loop closures (and trajectories) scored against a run's truth."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roman_sim.cli import app


@app.command("score")
def score_cmd(
    source: Annotated[Path, typer.Argument(help="a finished run folder, or an export folder (its scenario is run)")],
    closures: Annotated[Path, typer.Option("--closures", "-c", help="loop closures: .g2o or .csv")],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="new run folder (default: SOURCE-LABEL)")] = None,
    times: Annotated[
        Path | None, typer.Option("--times", help="g2o: timestamps file (robot_id keyframe_index time_ns per line)")
    ] = None,
    robots: Annotated[
        str | None, typer.Option("--robots", "-r", help="g2o: robot order of the Symbol keys 'a', 'b', ...: a,b")
    ] = None,
    trajectories: Annotated[
        Path | None,
        typer.Option(
            "--trajectories", "-t", help="folder of the system's <robot>.tum (or reference ROMAN <robot>.csv)"
        ),
    ] = None,
    label: Annotated[str, typer.Option("--label", "-l", help="the system's name in tables")] = "external",
) -> None:
    """Score an external system's loop closures against the truth, as a run of its own (report, plots, ATE)."""
    from roman_sim.cli.run import RichProgress, _progress, print_summary
    from roman_sim.pipeline.external import score_external

    names = [n.strip() for n in robots.split(",") if n.strip()] if robots else None
    target = out if out is not None else source.with_name(f"{source.name}-{label}")
    with _progress() as p:
        res = score_external(
            source,
            closures,
            target,
            times=times,
            robots=names,
            trajectories=trajectories,
            label=label,
            progress=RichProgress(p),
        )
    print_summary(res.run)
    typer.echo(
        f"{label} (external system): {res.n_closures} closures read, {res.n_pairs} submap pairs scored, "
        f"{len(res.unscored)} closures unscored; results: {target} (report: {target / 'report.md'})"
    )
