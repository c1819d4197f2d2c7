"""A world pickled for local workers loads back as the generated one, without its spec."""

from __future__ import annotations

import pickle

from roman_sim.world import PickledWorld, generate, load_world_spec


def test_a_pickled_world_loads_as_the_generated_one() -> None:
    world = generate(load_world_spec("tiny"), 0)
    back = PickledWorld.of(world).load()
    assert world.mjspec is not None and back.mjspec is None  # the spec stays home; the original keeps it
    assert pickle.dumps(back.model) == pickle.dumps(world.model)
    assert pickle.dumps(back.truth) == pickle.dumps(world.truth)
    assert back.meshes.keys() == world.meshes.keys()
    assert (back.spec, back.seed) == (world.spec, world.seed)
