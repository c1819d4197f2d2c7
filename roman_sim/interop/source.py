"""The simulated robots of a scenario as frame sources, for exporters (one frame in memory at a time).

The world is generated once; ``roman_sim.sim.source.robot_sources`` plans every robot's
path in order (so ``reverse_of`` and ``cross`` resolve even when only a later robot is
exported), drives each selected robot (cheap, poses only) and renders its frames only while
they are read. The frames are exactly those of a pipeline run of the same scenario (same
seed, same random streams), except that RGB is always rendered (a standard RGB-D sequence
has colour images) and so is a robot's second camera, when it has one.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from roman_sim.core.errors import ConfigError
from roman_sim.sim.robot import RobotConfig
from roman_sim.sim.source import SimulatedRobot, robot_sources

if TYPE_CHECKING:
    from roman_sim.world import World
    from roman_sim.world.spec import WorldSpec


class WorldSource(Protocol):
    """What names a scenario's world: its generator spec."""

    def spec(self) -> WorldSpec: ...


class SimScenario(Protocol):
    """The parts of a ``Scenario`` the streams read (world, robots, seed)."""

    @property
    def seed(self) -> int: ...

    @property
    def robots(self) -> Sequence[RobotConfig]: ...

    @property
    def world(self) -> WorldSource: ...

    def simulated_robots(self) -> Sequence[RobotConfig]:
        """The robots the simulator renders, in order (not those read from recorded sequences)."""
        ...


def select_robots(scenario: SimScenario, names: Sequence[str] | None) -> list[RobotConfig]:
    """The simulated robots of ``scenario`` named in ``names`` (all when None or empty), in order.

    A scenario robot read from a recorded sequence has nothing to render.

    Raises: ConfigError naming unknown or recorded robots and the valid names.
    """
    simulated = list(scenario.simulated_robots())
    known = [r.name for r in simulated]
    unknown = [n for n in names or [] if n not in known]
    if unknown or not simulated:
        recorded = sorted({r.name for r in scenario.robots} - set(known))
        extra = f"; read from recorded sequences: {', '.join(recorded)}" if recorded else ""
        raise ConfigError(
            f"--robots: no simulated robot {', '.join(unknown)} (simulated robots: {', '.join(known) or 'none'}{extra})"
        )
    return [r for r in simulated if not names or r.name in set(names)]


def scenario_streams(scenario: SimScenario, names: Sequence[str] | None = None) -> tuple[World, list[SimulatedRobot]]:
    """The generated world and a frame source per selected simulated robot of ``scenario`` (RGB, second camera on).

    Args:
        scenario: a validated ``Scenario`` (world, robots, seed).
        names: robot names to keep (all simulated ones when None).
    """
    from roman_sim.world import generate

    chosen = [r.name for r in select_robots(scenario, names)]
    world = generate(scenario.world.spec(), scenario.seed)
    streams = robot_sources(world, scenario.simulated_robots(), int(scenario.seed), chosen, rgb=True)
    return world, [s.with_stereo() for s in streams]
