"""What a stage sees of a run: the scenario, the run folder, progress and where inputs come from."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from roman_sim.pipeline.scenario import Scenario


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


@dataclass
class RunContext:
    """The run a stage works for.

    Attributes:
        scenario: the validated scenario.
        run_dir: the run folder (stages write their outputs here).
        progress: progress sink.
        fresh: ignore every cached output (recordings included).
        submaps_dir: start from the user's saved submaps (``<robot>.npz``) instead of
            simulating and mapping.
        timings: wall-clock figures stages report (seconds), kept out of the
            reproducible outputs and written to ``timings.json``.
        executor: where independent tasks run (``roman_sim.pipeline.executors``; None: here).
        stage_key: cache key of the running stage (checkpoints of finished tasks are kept under it).
        chunk_pairs: submap pairs per alignment task.
    """

    scenario: Scenario
    run_dir: Path
    progress: Progress = field(default_factory=NullProgress)
    fresh: bool = False
    submaps_dir: Path | None = None
    timings: dict[str, object] = field(default_factory=dict)
    executor: Any = None
    stage_key: str | None = None
    chunk_pairs: int = 32

    def tasks(self) -> Any:
        """The run's executor (a serial one when none was given)."""
        from roman_sim.pipeline.executors import SerialExecutor

        if self.executor is None:
            self.executor = SerialExecutor()
        return self.executor
