"""Stage ``world``: generate the scenario's world (deterministic in the seed, never cached)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage


@dataclass
class WorldOutput:
    """The generated world (``roman_sim.world.World``) and its notes."""

    world: Any
    notes: list[str] = field(default_factory=list)


class WorldStage(Stage[WorldOutput]):
    """Generate the world of ``scenario.world`` with ``scenario.seed``."""

    name = "world"
    cached = False

    def applies(self, ctx: RunContext) -> bool:
        """Not when starting from saved submaps, nor when every robot is read from a sequence."""
        return ctx.submaps_dir is None and ctx.scenario.needs_world

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["seed"], sc["world"]]

    def run(self, ctx: RunContext, **inputs: Any) -> WorldOutput:
        from roman_sim.world import generate

        return WorldOutput(generate(ctx.scenario.world.spec(), ctx.scenario.seed))
