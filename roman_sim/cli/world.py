"""``roman-sim world ...``: generate, preview and measure worlds."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app

if TYPE_CHECKING:
    from roman_sim.world import World, WorldSpec

world_app = typer.Typer(help="Generate, preview and measure procedural worlds.", no_args_is_help=True)
app.add_typer(world_app, name="world")

SEED = typer.Option(0, "--seed", help="world seed (same seed, same world)")
SETS = typer.Option(None, "--set", help="override a spec field, e.g. --set extent_m=[80,80]")


def _spec(preset: str, sets: list[str] | None) -> "WorldSpec":
    """The spec of a preset or YAML, with ``--set`` overrides applied and re-validated."""
    from roman_sim.core.config import override_model
    from roman_sim.world import load_world_spec

    spec = load_world_spec(preset)
    if not sets:
        return spec
    return override_model(spec, sets, preset)


def _print_world(world: "World", where: Path) -> None:
    counts = Counter(o.family for o in world.truth.objects)
    meta = world.truth.meta
    requested = {} if meta is None else {f: n for f, (_, n) in meta.placed_requested.items()}
    table = Table("family", "objects", "requested", title=f"{world.spec.name} (seed {world.seed}) -> {where}")
    for fam in sorted(set(counts) | set(requested)):
        table.add_row(fam, str(counts.get(fam, 0)), str(requested.get(fam, "")))
    table.add_row("[b]total[/b]", f"[b]{len(world.truth.objects)}[/b]", f"({world.model.ngeom} geoms)")
    Console().print(table)


@world_app.command("generate")
def generate_cmd(
    preset: str = typer.Argument(..., help="preset name or world YAML"),
    seed: int = SEED,
    out: Path = typer.Option(..., "--out", help="output folder (world.xml, meshes/, truth.json)"),
    sets: list[str] | None = SETS,
) -> None:
    """Generate a world and export it as a folder that plain MuJoCo loads."""
    from roman_sim.core.atomic import output_folder
    from roman_sim.world import export_world, generate

    spec = _spec(preset, sets)
    output_folder(out, "--out", create=False)
    world = generate(spec, seed)
    xml = export_world(world, out)
    _print_world(world, xml)


@world_app.command("preview")
def preview_cmd(
    source: str = typer.Argument(..., help="preset name, world YAML or exported world folder"),
    seed: int = SEED,
    out: Path = typer.Option(..., "--out", help="PNG file (X.png + X.pdf + X_view.png) or folder"),
    width: int = typer.Option(640, help="rendered view width (16..1280)"),
    height: int = typer.Option(480, help="rendered view height (16..960)"),
) -> None:
    """Write a top-down map with families coloured and one rendered RGB view."""
    from roman_sim.world import generate, load_world
    from roman_sim.world.preview import preview_paths, write_preview

    src = Path(source)
    spec = None if src.is_dir() else _spec(_missing_folder(source), None)
    preview_paths(out, "--out")
    world = load_world(src) if spec is None else generate(spec, seed)
    paths = write_preview(world, out, width, height)
    Console().print("wrote " + ", ".join(str(p) for p in paths))


def _missing_folder(source: str) -> str:
    """``source`` when it can name a preset or a world YAML, else a ``ConfigError``: no folder is there."""
    from roman_sim.core.errors import ConfigError
    from roman_sim.world import WORLD_PRESETS

    p = Path(source)
    if source in WORLD_PRESETS or p.suffix in (".yaml", ".yml") or p.is_file():
        return source
    raise ConfigError(
        f"world preview {source}: no such folder (an exported world folder holds world.xml, truth.json "
        f"and spec.yaml; or give a world YAML or a preset: {', '.join(WORLD_PRESETS.names())})"
    )


@world_app.command("ambiguity")
def ambiguity_cmd(
    preset: str = typer.Argument(..., help="preset name or world YAML"),
    seed: int = SEED,
    places: int = typer.Option(50, min=1, help="number of random discs"),
    radius: float = typer.Option(15.0, min=1.0, help="disc radius (m), about a submap"),
    sets: list[str] | None = SETS,
) -> None:
    """Print the ground-truth ambiguity index of a world."""
    from roman_sim.world import generate
    from roman_sim.world.ambiguity import ambiguity_index

    world = generate(_spec(preset, sets), seed)
    value = ambiguity_index(world.truth, n_places=places, radius_m=radius, seed=seed)
    Console().print(f"{world.spec.name} seed {seed}: ambiguity index {value:.3f} ({len(world.truth.objects)} objects)")
