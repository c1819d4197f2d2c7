"""The stage contract: typed inputs and output, a cache key, ``run`` that computes, ``save`` that writes.

A stage is a ``Stage[InputsT, OutputT]`` subclass:

- ``name``: its name in the stage table, the manifest and ``--from-stage``.
- ``input_type``: a dataclass whose fields are named after the stages whose outputs it
  takes (typed with those stages' output classes). A field without a default is required;
  one that defaults to None is optional (None when that stage does not apply to the run,
  e.g. no world when the run starts from saved submaps). The experiment builds it from the
  upstream outputs (``build_inputs``); ``inputs`` (the upstream stage names) is derived
  from it.
- ``config_parts``: the scenario sections (JSON-ready) its output depends on, as the run
  resolved them (every component's parameters with their defaults filled in,
  ``roman_sim.pipeline.resolve``). The cache key hashes them with the package version,
  the stage's name, its ``format``, its inputs' keys and the fingerprint of its code
  (``code_fingerprint``: its modules' sources and the installed versions of the libraries
  they import), so a change anywhere upstream, a changed default, a change to code the
  stage runs or another version of a library it runs recomputes it. Bump ``format`` when the files ``save`` writes
  change, so run folders of the old layout recompute the stage instead of failing to
  load it.
- ``code`` and ``components``: the roots of the code fingerprint besides the stage's own
  module: modules its worker jobs run that the module does not import itself, and the
  kinds of configured component it runs (``aligners``, ``segmenter``, ``encoder``: their
  modules, plug-ins' included). The fingerprint hashes the source of every module these
  roots import statically from the package (``roman_sim.core.codehash``), except
  ``NOT_FINGERPRINTED`` (where tasks run, not what they compute) and the other stages'
  modules (their outputs reach this stage through their keys); ``FINGERPRINTED_ONLY``
  modules are hashed without following their imports.
- ``run(ctx, inputs, tasks)``: computes the output and returns it; it writes nothing.
  Independent tasks (a robot to map, a chunk of pairs to align) go through ``tasks`` (a
  ``TaskRunner``), which runs them on the run's executor and checkpoints each finished
  one, so an interrupted stage resumes; the stage never sees the checkpoint files. The
  task functions are the stage's worker job (top-level functions of an importable module);
  ``worker_preload`` names the modules they import.
- ``parts(ctx)``: parts of the output the shared cache keeps under their own keys besides
  the stage's entry (``CachePart``), so a run whose stage key changed still takes the
  unchanged parts (the evaluation: each aligner's results). The experiment publishes them
  with the stage; the stage takes them from ``ctx.cache`` while it runs.
- ``save(out, ctx)``: writes the output atomically into the run folder and returns the
  files written (relative paths); ``load(ctx, files)`` reads exactly those files back.
  What later stages receive is always the loaded output, so a fresh and a cached stage
  give the same bytes downstream.

Outputs carry their own ``notes`` (statements for the report) and ``timings`` (wall-clock
figures for ``timings.json``; never saved with the output, empty when loaded).

Adding a stage is one module (the input dataclass, the output dataclass and the
``Stage`` subclass) plus one line in the table of ``roman_sim.pipeline.stages``, after
every stage it takes inputs from.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import TYPE_CHECKING, ClassVar, Generic, Protocol, TypeVar, cast

from roman_sim import __version__
from roman_sim.core.codehash import code_fingerprint
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError
from roman_sim.core.jsontypes import JSON
from roman_sim.pipeline.context import RunContext
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

    from roman_sim.pipeline.resolve import ComponentKind

#: Modules no code fingerprint includes or follows: the run machinery (where and how tasks run,
#: checkpoints, progress), which does not decide what a stage computes, and the resolution of
#: the scenario's components, whose results reach the keys by value (``config_parts``).
NOT_FINGERPRINTED: tuple[str, ...] = (
    "roman_sim.runner",
    "roman_sim.pipeline.resolve",
    "roman_sim.pipeline.context",
    "roman_sim.pipeline.folder_lock",
    "roman_sim.pipeline.plugin_guard",
)
#: Modules hashed without following their imports: the scenario model (its values reach the
#: keys through ``config_parts``) and the maps stage's worker job (a stage names the modules
#: its jobs run in ``code``).
FINGERPRINTED_ONLY: tuple[str, ...] = (
    "roman_sim.pipeline.scenario",
    "roman_sim.pipeline.stages.maps_job",
)

#: Wall-clock figures a stage reports (``timings.json``): name -> JSON value.
Timings = dict[str, JSON]


@dataclasses.dataclass(frozen=True)
class CachePart:
    """A part of a stage's output the shared cache keeps under its own key (``Stage.parts``).

    Attributes:
        name: the kind of part (the cache's folder for it, e.g. ``alignment``).
        key: what the part depends on, hashed (a run with the same key may take it).
        files: its files, relative to the run folder (among those the stage's ``save`` wrote).
    """

    name: str
    key: str
    files: list[str]


class StageOutput(Protocol):
    """What every stage output has: notes for the report and wall-clock timings."""

    notes: list[str]
    timings: Timings


InputsT = TypeVar("InputsT", bound="DataclassInstance")
OutputT = TypeVar("OutputT", bound=StageOutput)


@dataclasses.dataclass(frozen=True)
class NoInputs:
    """The inputs of a stage that takes no other stage's output."""


class Stage(ABC, Generic[InputsT, OutputT]):
    """One step of the pipeline (see the module docstring)."""

    name: ClassVar[str]
    input_type: type[InputsT]
    #: Whether the output is saved and reused (the world is cheap to regenerate: never cached).
    cached: ClassVar[bool] = True
    #: Layout of the saved files (part of the cache key when set).
    format: ClassVar[str | None] = None
    #: Whether ``run`` hands tasks to the run's workers (the experiment then starts them ahead of the run).
    uses_workers: ClassVar[bool] = False
    #: Modules its worker jobs run that its own module does not import (roots of the code fingerprint).
    code: ClassVar[tuple[str, ...]] = ()
    #: Kinds of configured component it runs (their modules are roots of the code fingerprint).
    components: ClassVar[tuple[ComponentKind, ...]] = ()
    #: What the workers of the stage's tasks import: its job's module first, then what the job uses
    #: (``module``, or ``module:function`` for a warm-up called once). A run's local pool imports
    #: them before it forks a worker (``roman_sim.runner.preload``); nothing else depends on them.
    worker_preload: ClassVar[tuple[str, ...]] = ()

    @property
    def inputs(self) -> tuple[str, ...]:
        """Names of the stages whose outputs this one takes."""
        return tuple(f.name for f in dataclasses.fields(self.input_type))

    def required(self) -> tuple[str, ...]:
        """The inputs without which the stage cannot run."""
        return tuple(
            f.name
            for f in dataclasses.fields(self.input_type)
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        )

    def build_inputs(self, outputs: Mapping[str, StageOutput]) -> InputsT:
        """The input dataclass from the upstream outputs (ConfigError when a required one is missing)."""
        missing = [n for n in self.required() if outputs.get(n) is None]
        if missing:
            raise ConfigError(f"stage {self.name} needs the output of {', '.join(missing)}, which this run has not")
        given = {n: outputs[n] for n in self.inputs if outputs.get(n) is not None}
        return cast(InputsT, self.input_type(**given))

    def applies(self, ctx: RunContext) -> bool:
        """Whether the stage runs at all for this run (e.g. no simulation from saved submaps)."""
        return True

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        """The scenario sections (JSON-ready) the output depends on."""
        return []

    def code_roots(self, ctx: RunContext) -> list[str]:
        """The modules the code fingerprint starts from: its own, ``code`` and its components'."""
        from roman_sim.pipeline.resolve import component_modules

        roots = [type(self).__module__, *self.code]
        for kind in self.components:
            roots += component_modules(ctx.scenario, kind)
        return roots

    def code_fingerprint(self, ctx: RunContext) -> str:
        """Hash of the source of the code the stage runs (see the module docstring)."""
        return self.fingerprint(self.code_roots(ctx))

    def fingerprint(self, roots: list[str]) -> str:
        """Hash of the source of ``roots`` and what they import, as the stage's fingerprint skips and follows."""
        others = {c.__module__ for c in _stage_classes() if c.__module__ != type(self).__module__}
        skip = (*NOT_FINGERPRINTED, *sorted(others - {__name__}))
        return code_fingerprint(roots, skip, FINGERPRINTED_ONLY)

    def parts(self, ctx: RunContext) -> list[CachePart]:
        """The parts of the output kept apart in the shared cache under their own keys (none by default)."""
        return []

    def key(self, ctx: RunContext, input_keys: dict[str, str | None]) -> str:
        """Cache key: package version, stage name, file layout, its config sections, its inputs' keys, its code."""
        own: list[JSON] = [self.name] if self.format is None else [self.name, self.format]
        return stable_hash(
            __version__, *own, self.config_parts(ctx), sorted(input_keys.items()), self.code_fingerprint(ctx)
        )

    @abstractmethod
    def run(self, ctx: RunContext, inputs: InputsT, tasks: TaskRunner) -> OutputT:
        """Compute the output from the inputs (writes nothing)."""

    def save(self, out: OutputT, ctx: RunContext) -> list[str]:
        """Write ``out`` into the run folder; the relative paths written."""
        return []

    def load(self, ctx: RunContext, files: list[str]) -> OutputT:
        """Read the output back from ``files`` (those ``save`` returned)."""
        raise NotImplementedError(f"stage {self.name} is not cached")


def _stage_classes() -> list[type[Stage]]:
    """Every concrete ``Stage`` subclass imported so far."""
    out: list[type[Stage]] = []
    todo: list[type[Stage]] = list(Stage.__subclasses__())
    while todo:
        cls = todo.pop()
        out.append(cls)
        todo += cls.__subclasses__()
    return out
