"""The maps stage's worker job: map one robot (``map_robot_task``), in a worker process or on Dask.

The task gets the scenario as JSON (the worker validates it again) and returns plain data;
the calling process writes every file. It gets the world pickled (``PickledWorld``, from a
local pool) or regenerates it from the scenario (Dask workers, possibly on other machines;
worlds are deterministic in spec and seed). A worker keeps the last world it generated, so
consecutive tasks of one run do not rebuild it.
"""

from __future__ import annotations

import logging
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.world import PickledWorld

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import Scenario
    from roman_sim.pipeline.stages.maps_input import WorldSupply
    from roman_sim.pipeline.stages.maps_robot import RobotMapping
    from roman_sim.world import World

log = logging.getLogger(__name__)


@lru_cache(maxsize=2)
def _scenario(scenario_json: str) -> Scenario:
    from roman_sim.pipeline.scenario import Scenario

    return Scenario.model_validate_json(scenario_json)


@lru_cache(maxsize=1)
def _world(world_json: str, seed: int) -> World:
    from roman_sim.pipeline.scenario import WorldRef
    from roman_sim.world import generate

    return generate(WorldRef.model_validate_json(world_json).spec(), seed)


def map_robot_task(
    scenario_json: str, robot: str, run_dir: str, world: World | PickledWorld | None = None
) -> RobotMapping:
    """Map ``robot``: its ``RobotInput`` (``roman_sim.pipeline.stages.maps_input.open_robot``) into its ``SegmentMap``.

    ``world`` is the world itself in-process, pickled from a local pool, None on Dask: workers
    then regenerate it from the scenario (same bytes). The world is unpickled or generated only
    when the robot asks for it. A robot read from a TUM folder needs that folder on the worker.
    """
    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.stages.maps_robot import map_one

    sc = _scenario(scenario_json)
    cfg = next(r for r in sc.robots if r.name == robot)
    return map_one(RunContext(sc, Path(run_dir)), _world_supply(sc, world), cfg)


def _world_supply(sc: Scenario, world: World | PickledWorld | None) -> WorldSupply:
    """The world as given, unpickled, or generated from the scenario, fetched when called."""
    if isinstance(world, PickledWorld):
        return world.load
    if world is not None:
        return lambda: world
    return lambda: _world(sc.world.model_dump_json(), sc.seed)
