"""Task-level checkpoints: what an interrupted stage already finished (a robot, a chunk of pairs).

A stage that runs many tasks records each finished one in ``partial/<stage>/<item>.json``
with the stage's cache key, so a re-run of an interrupted stage skips the finished tasks
(a record under another key is ignored and overwritten). Records are written atomically;
once the stage completes (the manifest records it) its ``partial/<stage>`` folder is
removed, so a finished run folder holds no checkpoints.
"""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_json

log = logging.getLogger(__name__)

PARTIAL_DIR = "partial"
CHECKPOINT_SCHEMA = "roman_sim.checkpoint/1"


class Checkpoint:
    """Finished tasks of one stage under one cache key (``key`` None: nothing is kept)."""

    def __init__(self, run_dir: Path, stage: str, key: str | None) -> None:
        self.folder = run_dir / PARTIAL_DIR / stage
        self.key = key

    def _path(self, item: str) -> Path:
        return self.folder / f"{item}.json"

    def get(self, item: str) -> Any | None:
        """The data recorded for ``item`` under this key, or None (absent, other key, unreadable)."""
        if self.key is None:
            return None
        try:
            d = json.loads(self._path(item).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(d, dict) or d.get("schema") != CHECKPOINT_SCHEMA or d.get("key") != self.key:
            return None
        return d.get("data")

    def put(self, item: str, data: Any) -> None:
        """Record ``item`` as finished with ``data`` (JSON-ready)."""
        if self.key is not None:
            write_json(self._path(item), {"schema": CHECKPOINT_SCHEMA, "key": self.key, "data": data}, indent=0)


def clear_checkpoints(run_dir: Path, stage: str | None = None) -> None:
    """Remove the checkpoints of ``stage`` (all stages when None)."""
    root = run_dir / PARTIAL_DIR
    target = root if stage is None else root / stage
    if target.exists():
        shutil.rmtree(target, ignore_errors=True)
    if root.is_dir() and not any(root.iterdir()):
        root.rmdir()
