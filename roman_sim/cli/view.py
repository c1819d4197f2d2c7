"""``roman-sim view``: a 3D view (rerun recording) of a finished run."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from roman_sim.cli import app


@app.command("view")
def view_cmd(
    run_dir: Annotated[Path, typer.Argument(help="a results folder of `roman-sim run`")],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="recording file (default <run>/view.rrd)")] = None,
    open_: Annotated[bool, typer.Option("--open", help="open rerun's viewer (needs a display)")] = False,
    images: Annotated[int, typer.Option("--images", min=0, help="camera frames per robot (0: none)")] = 60,
) -> None:
    """Write a rerun recording of a run: objects, trajectories, maps, submaps, closures, camera images."""
    import importlib.util

    from roman_sim.core.atomic import output_file
    from roman_sim.core.errors import ConfigError
    from roman_sim.viz import open_viewer, write_run_view

    if importlib.util.find_spec("rerun") is None:
        raise ConfigError("roman-sim view needs the rerun SDK of the interop extra: pip install 'roman_sim[interop]'")
    if out is not None:
        output_file(out, "--out", create=False)

    console = Console(stderr=True)
    with console.status("writing the recording ..."):
        result = write_run_view(run_dir, out, max_images=images)
    for note in result.notes:
        console.print(f"[yellow]note:[/yellow] {note}")
    shown = ", ".join(f"{r}: {n}" for r, n in result.images.items()) or "none"
    closures = ", ".join(f"{n} {k}" for k, n in result.closures.items())
    Console().print(f"recording: {result.path} (camera frames {shown}; loop closures {closures})")
    if open_ and not open_viewer(result.path):
        console.print(f"no display: open it elsewhere with `rerun {result.path}`")
