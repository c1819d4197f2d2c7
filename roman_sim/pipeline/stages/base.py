"""The stage contract: typed inputs and output, a cache key, save and load.

A stage names the stages whose outputs it takes (``inputs``; passed to ``run`` as keyword
arguments, None when that stage does not apply to the run) and the scenario sections it
depends on (``config_parts``). Its cache key hashes those sections, the package version
and its inputs' keys, so a change anywhere upstream recomputes it. ``save`` writes the
output atomically and returns the files written (relative to the run folder); ``load``
reads exactly those files back. Outputs carry their own notes (statements for the report).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

from roman_sim import __version__
from roman_sim.core.config import stable_hash
from roman_sim.pipeline.context import RunContext

OutputT = TypeVar("OutputT")


class Stage(ABC, Generic[OutputT]):
    """One step of the pipeline (see the module docstring)."""

    name: ClassVar[str]
    inputs: ClassVar[tuple[str, ...]] = ()
    #: Whether the output is saved and reused (the world is cheap to regenerate: never cached).
    cached: ClassVar[bool] = True

    def applies(self, ctx: RunContext) -> bool:
        """Whether the stage runs at all for this run (e.g. no simulation from saved submaps)."""
        return True

    def config_parts(self, ctx: RunContext) -> list[Any]:
        """The scenario sections (JSON-ready) the output depends on."""
        return []

    def key(self, ctx: RunContext, input_keys: dict[str, str | None]) -> str:
        """Cache key: package version, stage name, its config sections, its inputs' keys."""
        return stable_hash(__version__, self.name, self.config_parts(ctx), sorted(input_keys.items()))

    @abstractmethod
    def run(self, ctx: RunContext, **inputs: Any) -> OutputT:
        """Compute the output from the inputs."""

    def save(self, out: OutputT, ctx: RunContext) -> list[str]:
        """Write ``out`` into the run folder; the relative paths written."""
        return []

    def load(self, ctx: RunContext, files: list[str]) -> OutputT:
        """Read the output back from ``files`` (those ``save`` returned)."""
        raise NotImplementedError(f"stage {self.name} is not cached")


def rel(ctx: RunContext, path: Path) -> str:
    """``path`` relative to the run folder, with forward slashes."""
    return path.relative_to(ctx.run_dir).as_posix()
