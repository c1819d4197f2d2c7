"""What a stage sees of a run: the scenario, the run folder, progress and where inputs come from.

The context is the same for every stage of a run and no stage changes it: what a stage
produces (its output, notes and timings) is returned, and where its tasks run comes with
its ``TaskRunner``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from roman_sim.pipeline.scenario import Scenario

if TYPE_CHECKING:
    from roman_sim.pipeline.stagecache import StageCache


class Progress(Protocol):
    """Progress sink (the CLI draws bars; the library default ignores everything)."""

    def start(self, stage: str, total: int | None = None) -> None: ...

    def advance(self, stage: str, n: int = 1) -> None: ...

    def end(self, stage: str) -> None: ...


class NullProgress:
    """A ``Progress`` that reports nothing."""

    def start(self, stage: str, total: int | None = None) -> None:
        pass

    def advance(self, stage: str, n: int = 1) -> None:
        pass

    def end(self, stage: str) -> None:
        pass


@dataclass(frozen=True)
class RunContext:
    """The run a stage works for.

    Attributes:
        scenario: the validated scenario.
        run_dir: the run folder (stages' ``save`` writes their outputs here).
        progress: progress sink.
        fresh: ignore every cached output (recordings included).
        submaps_dir: start from the user's saved submaps (``<robot>.npz``) instead of
            simulating and mapping.
        chunk_pairs: submap pairs per alignment task.
        keys: every stage's cache key in this run (empty outside a run).
        cache: the shared stage cache (None when off): a stage that keeps parts of its
            output apart (``Stage.parts``) takes the parts it can from there.
        environment: the library versions the run computes with (the cache entries' names).
        figures: draw the report's figures (a benchmark cell, which keeps only its pairs and
            runtimes, sets it off: the report then writes its statistics and text only, under
            its own stage key).
    """

    scenario: Scenario
    run_dir: Path
    progress: Progress = field(default_factory=NullProgress)
    fresh: bool = False
    submaps_dir: Path | None = None
    chunk_pairs: int = 32
    keys: dict[str, str] = field(default_factory=dict)
    cache: StageCache | None = None
    environment: dict[str, str] = field(default_factory=dict)
    figures: bool = True
