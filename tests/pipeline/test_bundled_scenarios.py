"""Every bundled scenario: its purpose stated, its aligners built, its world's truth generated and
every robot's path planned and driven clear of objects (no model, no rendering)."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.pipeline.scenario import bundled_scenarios, load_scenario


@pytest.mark.parametrize("name", sorted(bundled_scenarios()))
def test_every_bundled_scenario_builds_and_drives(name):
    """World truth generated, every robot's path planned and driven clear of objects (no rendering)."""
    from roman_sim.align import build_aligner
    from roman_sim.sim.robot import plan_paths, trajectory_along
    from roman_sim.world import generate_truth
    from roman_sim.world.query import clearance

    sc = load_scenario(name)
    text = bundled_scenarios()[name].read_text()
    assert text.startswith("#"), "each scenario states its purpose in a comment at its top"
    for entry in sc.aligners:
        build_aligner(entry.method, entry.params)
    if name.startswith("kimera_"):
        return  # paper scale: planned and driven (clearance checked) by test_paper_scale_robots_meet
    world = generate_truth(sc.world.spec(), sc.seed)
    paths = plan_paths(world, sc.robots, sc.seed)
    for cfg in sc.robots:
        t, T_wb, T_ob = trajectory_along(world, cfg, sc.seed, paths[cfg.name])
        assert len(t) > 10 and np.all(np.diff(t) > 0)
        assert clearance(world.truth, T_wb[:, :2, 3]).min() > 0.0
