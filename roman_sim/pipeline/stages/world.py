"""Stage ``world``: generate the scenario's world (deterministic in the seed, never cached)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from roman_sim.core.jsontypes import JSON
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import NoInputs, Stage, Timings
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from roman_sim.world import World


@dataclass
class WorldOutput:
    """The generated world and its notes."""

    world: World
    notes: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)


class WorldStage(Stage[NoInputs, WorldOutput]):
    """Generate the world of ``scenario.world`` with ``scenario.seed``."""

    name = "world"
    input_type = NoInputs
    cached = False

    def applies(self, ctx: RunContext) -> bool:
        """Not when starting from saved submaps, nor when every robot is read from a sequence."""
        return ctx.submaps_dir is None and ctx.scenario.needs_world

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["seed"], sc["world"]]

    def run(self, ctx: RunContext, inputs: NoInputs, tasks: TaskRunner) -> WorldOutput:
        from roman_sim.world import generate

        return WorldOutput(generate(ctx.scenario.world.spec(), ctx.scenario.seed))
