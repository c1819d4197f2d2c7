"""``roman-sim score``: any system's loop closures (and trajectories) scored against a run's truth."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roman_sim.cli import app


@app.command("score")
def score_cmd(
    source: Annotated[Path, typer.Argument(help="a finished run folder, or an export folder (its scenario is run)")],
    closures: Annotated[
        Path,
        typer.Option(
            "--closures",
            "-c",
            help="loop closures: .csv, .g2o, the reference ROMAN's align.g2o or align folder, Kimera-Multi's "
            "loop_closures.csv or log folder",
        ),
    ],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="new run folder (default: SOURCE-LABEL)")] = None,
    times: Annotated[
        Path | None,
        typer.Option(
            "--times",
            help="keyframe times: a g2o file's timestamps file (robot_id keyframe_index time_ns per line), also "
            "for the reference's align files; Kimera-Multi's odometry_poses.csv file or folder",
        ),
    ] = None,
    robots: Annotated[
        str | None,
        typer.Option(
            "--robots", "-r", help="robot order of g2o Symbol keys 'a', 'b', ..., and Kimera-Multi's indices: a,b"
        ),
    ] = None,
    trajectories: Annotated[
        Path | None,
        typer.Option(
            "--trajectories", "-t", help="folder of the system's <robot>.tum (or reference ROMAN <robot>.csv)"
        ),
    ] = None,
    label: Annotated[str, typer.Option("--label", "-l", help="the system's name in tables")] = "external",
    quaternion_order: Annotated[
        str | None,
        typer.Option("--quaternion-order", help="the order of the file's quaternion numbers: xyzw (default) or wxyz"),
    ] = None,
    invert_edges: Annotated[
        bool, typer.Option("--invert-edges", help="the file's relative poses are T_b_a (b's frame), not T_a_b")
    ] = False,
    swap_robots: Annotated[
        bool, typer.Option("--swap-robots", help="the file's two robots are exchanged (a run of two robots)")
    ] = False,
) -> None:
    """Score an external system's loop closures against the truth, as a run of its own (report, plots, ATE)."""
    from roman_sim.cli.run import RichProgress, _progress, print_summary
    from roman_sim.scoring.external import score_external

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
            quaternion_order=quaternion_order,  # type: ignore[arg-type]  # checked by score_external
            invert_edges=invert_edges,
            swap_robots=swap_robots,
            progress=RichProgress(p),
        )
    print_summary(res.run)
    if res.warning is not None:
        typer.echo(f"warning: {res.warning}", err=True)
    typer.echo(
        f"{label} (external system): {res.n_closures} closures read, {res.n_pairs} submap pairs scored, "
        f"{len(res.unscored)} closures unscored; results: {target} (report: {target / 'report.md'})"
    )
