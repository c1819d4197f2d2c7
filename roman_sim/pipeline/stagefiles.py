"""Per-robot stage folders (``<folder>/<robot>.npz`` + ``<folder>/notes.json``) and stage notes.

The writers here are called from the stages' ``save`` only (stage code itself writes nothing
outside ``save``; a test checks it), the readers from their ``load``. The robots' files are
written at the same time, one thread each: compressing them (zlib) runs outside the GIL.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from roman_sim.core.records import read_record, write_record
from roman_sim.pipeline.context import RunContext

T = TypeVar("T")


@dataclass
class NotesRecord:
    """A stage's notes file: the statements it makes for the report."""

    notes: list[str]


def write_notes(path: Path, notes: list[str]) -> None:
    """Write the notes atomically."""
    write_record(path, NotesRecord(list(notes)))


def read_notes(path: Path) -> list[str]:
    """Read notes written by ``write_notes`` (RecordError naming the file and the field when unreadable)."""
    return read_record(path, NotesRecord).notes


def save_per_robot(
    ctx: RunContext, folder: str, items: dict[str, T], writer: Callable[[Path, T], None], notes: list[str]
) -> list[str]:
    """``writer(<folder>/<robot>.npz, item)`` per robot (on threads) and the notes; the relative paths written."""
    files = [f"{folder}/{robot}.npz" for robot in items]
    each(lambda robot: writer(ctx.run_dir / folder / f"{robot}.npz", items[robot]), list(items))
    write_notes(ctx.run_dir / folder / "notes.json", notes)
    return [*files, f"{folder}/notes.json"]


def each(fn: Callable[[str], object], keys: list[str]) -> None:
    """``fn(key)`` for every key, on up to one thread per core (in this thread for a single key).

    For writers that spend their time compressing (outside the GIL). Raises the error of the
    first key that failed, once every call has ended.
    """
    if len(keys) <= 1:
        for k in keys:
            fn(k)
        return
    with ThreadPoolExecutor(max_workers=min(len(keys), os.cpu_count() or 1)) as pool:
        list(pool.map(fn, keys))


def load_per_robot(ctx: RunContext, folder: str, reader: Callable[[Path], T]) -> tuple[dict[str, T], list[str]]:
    """The items of the scenario's robots (only theirs) and the notes, as ``save_per_robot`` wrote them."""
    items = {r.name: reader(ctx.run_dir / folder / f"{r.name}.npz") for r in ctx.scenario.robots}
    return items, read_notes(ctx.run_dir / folder / "notes.json")
