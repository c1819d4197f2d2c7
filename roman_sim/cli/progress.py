"""Progress reporting of the pipeline commands: rich bars on a terminal, one line per finished stage elsewhere.

When stderr is not a terminal (CI, ``nohup``, a pipe) a bar would be redrawn into a log as
escape codes, or not at all; ``LineProgress`` instead prints one plain line per finished
stage, flushed at once, so a run that is killed leaves a log of what it completed.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn


class LineProgress:
    """A ``Progress`` sink (start/advance/end) writing ``stage <name>: done (n items, s s)`` lines."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream
        self._t0: dict[str, float] = {}
        self._n: dict[str, int] = {}
        self._total: dict[str, int | None] = {}

    def start(self, stage: str, total: int | None = None) -> None:
        self._t0[stage], self._n[stage], self._total[stage] = time.perf_counter(), 0, total

    def advance(self, stage: str, n: int = 1) -> None:
        self._n[stage] = self._n.get(stage, 0) + n

    def end(self, stage: str) -> None:
        secs = time.perf_counter() - self._t0.pop(stage, time.perf_counter())
        n, total = self._n.pop(stage, 0), self._total.pop(stage, None)
        items = f"{n}/{total}, " if total else (f"{n}, " if n else "")
        self.line(f"stage {stage}: done ({items}{secs:.1f} s)")

    def line(self, text: str) -> None:
        """Write one line and flush it (a killed process keeps what was written)."""
        stream = self.stream or sys.stderr
        stream.write(text + "\n")
        stream.flush()


class StageTracker:
    """A ``Progress`` that passes every call on to ``inner`` and remembers the stage running (``running``)."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.running: str | None = None

    def start(self, stage: str, total: int | None = None) -> None:
        if ":" not in stage:  # a stage; "maps:a" is a robot of the maps stage
            self.running = stage
        self.inner.start(stage, total)

    def advance(self, stage: str, n: int = 1) -> None:
        self.inner.advance(stage, n)

    def end(self, stage: str) -> None:
        self.inner.end(stage)
        if stage == self.running:
            self.running = None

    def where(self) -> str:
        """``in stage maps`` (``while no stage ran`` before the first stage or between two)."""
        return f"in stage {self.running}" if self.running else "while no stage ran"


def interactive(stream: Any = None) -> bool:
    """Whether ``stream`` (default stderr) is a terminal, i.e. progress bars can be drawn."""
    stream = stream or sys.stderr
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def rich_progress(console: Any) -> Progress:
    """The rich progress bars of the pipeline commands."""
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=False,
    )
