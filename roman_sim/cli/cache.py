"""``roman-sim cache``: where the shared stage cache is, what it holds, and clearing it."""

from __future__ import annotations

import typer
from rich.console import Console

from roman_sim.cli import app


@app.command("cache")
def cache_cmd(
    clear: bool = typer.Option(False, "--clear", help="delete every entry (run folders keep their own files)"),
) -> None:
    """Show the shared stage cache (folder, entries per stage, size); --clear empties it.

    Its folder is $ROMAN_SIM_CACHE (off: no shared cache), else ~/.cache/roman_sim.
    """
    from roman_sim.pipeline.stagecache import CACHE_ENV, StageCache

    out = Console()
    cache = StageCache.default()
    if cache is None:
        out.print(f"the shared stage cache is off (${CACHE_ENV})")
        return
    if clear:
        n = cache.clear()
        out.print(f"removed {n} entries from {cache.root}")
        return
    entries = cache.entries()
    per_stage: dict[str, int] = {}
    for e in entries:
        per_stage[e.parent.name] = per_stage.get(e.parent.name, 0) + 1
    listing = ", ".join(f"{s} {n}" for s, n in sorted(per_stage.items())) or "none"
    out.print(f"{cache.root}: {len(entries)} entries ({listing}), {cache.size_bytes() / 1e6:.1f} MB")
