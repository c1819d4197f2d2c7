"""``roman-sim export``: a scenario's robots as TUM RGB-D folders, ROS 2 bags or EuRoC MAV folders."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app
from roman_sim.cli.listing import LISTINGS
from roman_sim.core.jsontypes import JSONScalar


@app.command("export")
def export_cmd(
    scenario: Annotated[str, typer.Argument(help="scenario YAML path or bundled scenario name")],
    fmt: Annotated[
        str,
        typer.Option(
            "--format",
            "-f",
            help="tum (TUM RGB-D folders), rosbag2 (ROS 2 bags), roman (bags + ROMAN parameter folders) "
            "or euroc (EuRoC MAV folders with IMU, stereo and Kalibr calibration)",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="export folder (one sub-folder per robot)")],
    sets: Annotated[list[str] | None, typer.Option("--set", "-s", help="override, e.g. --set seed=3")] = None,
    robots: Annotated[str | None, typer.Option("--robots", "-r", help="only these robots: a,b")] = None,
    depth_scale: Annotated[float, typer.Option("--depth-scale", help="tum: depth PNG units per metre")] = 5000.0,
    storage: Annotated[
        str | None, typer.Option("--storage", help="rosbag2 (default mcap), roman (default sqlite3): mcap or sqlite3")
    ] = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="replace robot folders holding files")] = False,
) -> None:
    """Render the robots of a scenario and write them with exact ground truth, masks and the object table."""
    from roman_sim.cli.run import RichProgress, _progress
    from roman_sim.core.errors import ConfigError
    from roman_sim.interop.base import FORMATS
    from roman_sim.interop.export import export_scenario
    from roman_sim.pipeline.scenario import load_scenario

    FORMATS.get(fmt)
    by_format: dict[str, dict[str, JSONScalar]] = {
        "tum": {"depth_scale": depth_scale},
        "rosbag2": {"storage": storage or "mcap"},
        "roman": {"storage": storage or "sqlite3"},
    }
    options = by_format.get(fmt, {})
    if depth_scale <= 0:
        raise ConfigError(f"--depth-scale: must be a positive number of units per metre, got {depth_scale}")
    names = [n.strip() for n in robots.split(",") if n.strip()] if robots else None
    sc = load_scenario(scenario, list(sets or []))
    with _progress() as p:
        result = export_scenario(sc, fmt, out, robots=names, progress=RichProgress(p), overwrite=overwrite, **options)
    table = Table(title=f"{sc.name} (seed {sc.seed}) exported as {fmt} -> {out}")
    for col in ("robot", "frames", "render s", "write s", "folder"):
        table.add_column(col, justify="left" if col in ("robot", "folder") else "right")
    for name, robot in result.robots.items():
        table.add_row(
            name, str(robot.written.frames), f"{result.render_s[name]:.1f}", f"{result.write_s[name]:.1f}", robot.path
        )
    Console().print(table)


def _formats() -> list[str]:
    from roman_sim.interop.export import FORMATS

    return FORMATS.names()


LISTINGS["formats"] = _formats
