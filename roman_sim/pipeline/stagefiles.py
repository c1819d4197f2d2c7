"""Per-robot stage folders (``<folder>/<robot>.npz`` + ``<folder>/notes.json``) and stage notes.

The writers here are called from the stages' ``save`` only (stage code itself writes nothing
outside ``save``; a test checks it), the readers from their ``load``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.pipeline.context import RunContext

T = TypeVar("T")


def write_notes(path: Path, notes: list[str]) -> None:
    """Write the notes atomically."""
    write_json(path, {"notes": list(notes)})


def read_notes(path: Path) -> list[str]:
    """Read notes written by ``write_notes`` (StorageError when unreadable)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return [str(n) for n in data["notes"]]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise StorageError(f"{path}: unreadable notes ({type(err).__name__})") from None


def save_per_robot(
    ctx: RunContext, folder: str, items: dict[str, T], writer: Callable[[Path, T], None], notes: list[str]
) -> list[str]:
    """``writer(<folder>/<robot>.npz, item)`` per robot and the notes; the relative paths written."""
    files = []
    for robot, item in items.items():
        writer(ctx.run_dir / folder / f"{robot}.npz", item)
        files.append(f"{folder}/{robot}.npz")
    write_notes(ctx.run_dir / folder / "notes.json", notes)
    return [*files, f"{folder}/notes.json"]


def load_per_robot(ctx: RunContext, folder: str, reader: Callable[[Path], T]) -> tuple[dict[str, T], list[str]]:
    """The items of the scenario's robots (only theirs) and the notes, as ``save_per_robot`` wrote them."""
    items = {r.name: reader(ctx.run_dir / folder / f"{r.name}.npz") for r in ctx.scenario.robots}
    return items, read_notes(ctx.run_dir / folder / "notes.json")
