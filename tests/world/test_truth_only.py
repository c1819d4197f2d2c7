"""``generate_truth`` gives ``generate``'s truth without building the model."""

from __future__ import annotations

import numpy as np

from roman_sim.pipeline.scenario import load_scenario
from roman_sim.sim.robot import plan_paths, trajectory_along
from roman_sim.world import generate, generate_truth


def test_truth_only_world_has_the_full_worlds_truth_and_drives_the_same_paths() -> None:
    sc = load_scenario("demo", ["robots.0.max_length_m=30", "robots.1.max_length_m=30"])
    full, light = generate(sc.world.spec(), sc.seed), generate_truth(sc.world.spec(), sc.seed)
    assert len(light.truth.objects) == len(full.truth.objects) > 50
    for a, b in zip(full.truth.objects, light.truth.objects):
        assert (a.id, a.family, a.mesh_names) == (b.id, b.family, b.mesh_names)
        assert np.array_equal(a.T_world_obj, b.T_world_obj) and np.array_equal(a.extents, b.extents)
        assert a.geom_ids and not b.geom_ids  # geom ids exist only in a compiled model
    assert full.truth.meta == light.truth.meta
    assert np.array_equal(full.truth.terrain.heights, light.truth.terrain.heights)
    for cfg in sc.robots:
        paths_full, paths_light = plan_paths(full, sc.robots, sc.seed), plan_paths(light, sc.robots, sc.seed)
        a = trajectory_along(full, cfg, sc.seed, paths_full[cfg.name])
        b = trajectory_along(light, cfg, sc.seed, paths_light[cfg.name])
        assert np.array_equal(a.T_world_body, b.T_world_body) and np.array_equal(a.T_odom_body, b.T_odom_body)
