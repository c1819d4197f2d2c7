"""The robots of a scenario as lazy frame streams, for exporters (one frame in memory at a time).

The world is generated once; paths are planned for every robot in order (so ``reverse_of``
and ``cross`` resolve even when only a later robot is exported); each selected robot's
trajectory is driven (cheap, poses only) and its frames are rendered only while the stream
is consumed. The streams are exactly those of a pipeline run of the same scenario (same
seed, same random streams), except that RGB is always rendered: a standard RGB-D sequence
has colour images.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.sim.robot import DrivenRun, RobotConfig, plan_paths, render_trajectory, trajectory_along

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


@dataclass
class RobotStream:
    """One robot of a scenario, ready to render.

    Attributes:
        cfg: the robot's configuration (RGB rendering switched on).
        world: the generated world.
        seed: the scenario seed.
        trajectory: times (N,), true ``T_world_body`` (N, 4, 4), drifted ``T_odom_body`` (N, 4, 4).
    """

    cfg: RobotConfig
    world: World
    seed: int
    trajectory: DrivenRun

    @property
    def name(self) -> str:
        """The robot's name."""
        return self.cfg.name

    @property
    def n_frames(self) -> int:
        """Number of frames the stream yields."""
        return len(self.trajectory[0])

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera intrinsics."""
        return self.cfg.camera.intrinsics()

    @property
    def T_body_cam(self) -> NDArray[np.float64]:
        """The camera (RDF optical) pose in the body (FLU) frame."""
        return self.cfg.camera.T_body_cam()

    def frames(self) -> Iterator[Frame]:
        """Rendered frames with truth (instance ids and true body pose), in order."""
        return render_trajectory(self.world, self.cfg, self.seed, self.trajectory)


def select_robots(robots: Sequence[RobotConfig], names: Sequence[str] | None) -> list[RobotConfig]:
    """The simulated robots named in ``names`` (all simulated ones when None or empty), in order.

    A scenario robot read from a recorded sequence (``source``) has nothing to render.

    Raises: ConfigError naming unknown or recorded robots and the valid names.
    """
    simulated = [r for r in robots if getattr(r, "source", None) is None]
    known = [r.name for r in simulated]
    unknown = [n for n in names or [] if n not in known]
    if unknown or not simulated:
        recorded = sorted({r.name for r in robots} - set(known))
        extra = f"; read from recorded sequences: {', '.join(recorded)}" if recorded else ""
        raise ConfigError(
            f"--robots: no simulated robot {', '.join(unknown)} (simulated robots: {', '.join(known) or 'none'}{extra})"
        )
    return [r for r in simulated if not names or r.name in set(names)]


def scenario_streams(scenario: SimScenario, names: Sequence[str] | None = None) -> tuple[World, list[RobotStream]]:
    """The generated world and a ``RobotStream`` per selected robot of ``scenario``.

    Args:
        scenario: a validated ``Scenario`` (world, robots, seed).
        names: robot names to keep (all when None).
    """
    from roman_sim.world import generate

    chosen = select_robots(scenario.robots, names)
    world = generate(scenario.world.spec(), scenario.seed)
    paths = plan_paths(world, [r for r in scenario.robots if getattr(r, "source", None) is None], scenario.seed)
    streams = []
    for cfg in chosen:
        trajectory = trajectory_along(world, cfg, scenario.seed, paths[cfg.name])
        cfg_rgb = cfg.model_copy(update={"render_rgb": True})
        streams.append(RobotStream(cfg_rgb, world, int(scenario.seed), trajectory))
    return world, streams
