"""``roman-sim list [WHAT]``: print registered names (worlds, families, ...).

Other areas add their own listings: ``LISTINGS["aligners"] = lambda: ALIGNERS.names()``.
"""

from __future__ import annotations

from collections.abc import Callable

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError

LISTINGS: dict[str, Callable[[], list[str]]] = {}


def _worlds() -> list[str]:
    from roman_sim.world.presets import WORLD_PRESETS

    return WORLD_PRESETS.names()


def _families() -> list[str]:
    from roman_sim.world.assets import FAMILIES

    return FAMILIES.names()


LISTINGS["worlds"] = _worlds
LISTINGS["families"] = _families


@app.command("list")
def list_cmd(what: str | None = typer.Argument(None, help="what to list (default: everything)")) -> None:
    """List world presets, object families and everything else registered."""
    if what is not None and what not in LISTINGS:
        raise ConfigError(f"list: unknown {what!r} (valid: {', '.join(sorted(LISTINGS))})")
    table = Table("kind", "names")
    for kind in [what] if what else sorted(LISTINGS):
        table.add_row(kind, ", ".join(LISTINGS[kind]()))
    Console().print(table)
