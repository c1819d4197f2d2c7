"""Task-level checkpoints: what an interrupted stage already finished (a robot, a chunk of pairs).

The experiment gives each stage that runs many tasks a ``Checkpoint`` under the stage's
cache key (through ``roman_sim.runner.taskrunner.TaskRunner``); stage code never touches
it. Each finished task is kept as ``partial/<stage>/<item>.json`` (the record: schema, key,
the codec's JSON data and the SHA-256 of each payload file) beside the payload files the
task's ``TaskCodec`` wrote (``partial/<stage>/<item>.<part>``). A re-run of an interrupted
stage reads back the tasks whose record has the same key and whose payload files are intact
(anything else is ignored and overwritten). Records and payloads are written atomically;
once the stage completes (the manifest records it) its ``partial/<stage>`` folder is
removed, so a finished run folder holds no checkpoints.
"""

from __future__ import annotations

import hashlib
import logging
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeVar

from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import RecordError, read_record, write_record

log = logging.getLogger(__name__)

PARTIAL_DIR = "partial"
CHECKPOINT_SCHEMA = "roman_sim.checkpoint/2"

T = TypeVar("T")


@dataclass(frozen=True)
class Kept:
    """What a codec kept of one task's result: JSON data for the record and the payload files it wrote."""

    data: JSON
    files: list[Path] = field(default_factory=list)


class TaskCodec(Protocol[T]):
    """How one kind of task result is kept in a checkpoint and read back."""

    def write(self, value: T, stem: Path) -> Kept:
        """Write the payload of ``value`` to files named ``<stem>.<part>``; the record's data and those files."""
        ...

    def read(self, data: JSON, stem: Path) -> T:
        """The value ``write`` kept (``data`` is the record's, read back from its JSON file)."""
        ...


@dataclass(frozen=True)
class CheckpointRecord:
    """``partial/<stage>/<item>.json``: the stage key it was made under, the codec's data, its files' SHA-256."""

    key: str
    data: Any
    files: dict[str, str]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


class Checkpoint:
    """Finished tasks of one stage under one cache key."""

    def __init__(self, run_dir: Path, stage: str, key: str) -> None:
        self.folder = run_dir / PARTIAL_DIR / stage
        self.key = key

    def stem(self, item: str) -> Path:
        """Where ``item``'s payload files go (``<stem>.<part>``)."""
        return self.folder / item

    def _record(self, item: str) -> Path:
        return self.folder / f"{item}.json"

    def get(self, item: str, codec: TaskCodec[T]) -> T | None:
        """The result recorded for ``item`` under this key, or None (absent, other key, damaged)."""
        path = self._record(item)
        try:
            rec = read_record(path, CheckpointRecord, CHECKPOINT_SCHEMA)
        except RecordError as err:
            if path.exists():
                log.info("checkpoint %s ignored: %s", item, err)
            return None
        if rec.key != self.key:
            return None
        for name, digest in rec.files.items():
            path = self.folder / str(name)
            if not path.is_file() or _sha256(path) != digest:
                log.info("checkpoint %s: payload %s missing or changed; recomputing", item, name)
                return None
        return codec.read(rec.data, self.stem(item))

    def put(self, item: str, value: T, codec: TaskCodec[T]) -> None:
        """Record ``item`` as finished with ``value`` (payload first, then the record that names it)."""
        kept = codec.write(value, self.stem(item))
        files = {p.relative_to(self.folder).as_posix(): _sha256(p) for p in kept.files}
        record = CheckpointRecord(self.key, kept.data, files)
        write_record(self._record(item), record, CHECKPOINT_SCHEMA, indent=None)  # compact: faster to write


def clear_checkpoints(run_dir: Path, stage: str | None = None) -> None:
    """Remove the checkpoints of ``stage`` (all stages when None)."""
    root = run_dir / PARTIAL_DIR
    target = root if stage is None else root / stage
    if target.exists():
        shutil.rmtree(target, ignore_errors=True)
    if root.is_dir() and not any(root.iterdir()):
        root.rmdir()
