"""``roman-sim cache``: where the shared stage cache is, what it holds, verifying and clearing it."""

from __future__ import annotations

import typer
from rich.console import Console

from roman_sim.cli import app


@app.command("cache")
def cache_cmd(
    clear: bool = typer.Option(False, "--clear", help="delete every entry (run folders keep their own files)"),
    verify: bool = typer.Option(
        False,
        "--verify",
        help="check every entry's files against their recorded SHA-256, drop the bad ones; exit code 1 if any",
    ),
) -> None:
    """Show the shared stage cache (folder, entries per stage, size); --verify checks it, --clear empties it.

    Its folder is $ROMAN_SIM_CACHE (off: no shared cache), else ~/.cache/roman_sim. An entry is
    reused only after its files are checked against their recorded SHA-256; one that fails is
    dropped and its stage computed again.
    """
    from roman_sim.pipeline.stagecache import CACHE_ENV, StageCache, default_cache_dir, not_a_folder

    out = Console()
    where = default_cache_dir()
    why = None if where is None else not_a_folder(where)
    if where is None or why is not None:
        reason = f"${CACHE_ENV} is off" if where is None else why
        out.print(f"the shared stage cache is off: {reason}", soft_wrap=True, highlight=False)
        return
    cache = StageCache(where)
    if clear:
        n = cache.clear()
        out.print(f"removed {n} entries from {cache.root}")
        return
    if verify:
        good, bad = cache.verify()
        for entry, problem in bad:
            what = entry if problem.file is None else entry / "files" / problem.file
            out.print(f"[red]dropped:[/red] {what}: {problem.what}", highlight=False, soft_wrap=True)
        out.print(f"{cache.root}: {good} entries verified, {len(bad)} dropped", highlight=False, soft_wrap=True)
        if bad:
            raise typer.Exit(1)
        return
    entries = cache.entries()
    per_stage: dict[str, int] = {}
    for e in entries:
        per_stage[e.parent.name] = per_stage.get(e.parent.name, 0) + 1
    listing = ", ".join(f"{s} {n}" for s, n in sorted(per_stage.items())) or "none"
    out.print(f"{cache.root}: {len(entries)} entries ({listing}), {cache.size_bytes() / 1e6:.1f} MB")
