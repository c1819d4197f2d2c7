"""A TUM RGB-D folder and a simulated robot are both ``FrameSource``s, and give the same frames."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from roman_sim.core.sensors import FrameSource
from roman_sim.interop.tum_reader import read_tum_sequence
from roman_sim.pipeline.scenario import Scenario
from roman_sim.sim.source import robot_sources

from .conftest import FRAMES


def test_a_tum_folder_is_the_frame_source_it_was_exported_from(
    tiny_scenario: Scenario, tum_export: Path, direct_frames: dict[str, list[Any]]
) -> None:
    from roman_sim.world import generate

    world = generate(tiny_scenario.world.spec(), tiny_scenario.seed)
    simulated = robot_sources(world, tiny_scenario.robots, tiny_scenario.seed, rgb=True)
    for sim in simulated:
        seq = read_tum_sequence(tum_export / sim.name, robot=sim.name)
        for src in (sim, seq):
            assert isinstance(src, FrameSource)
        assert (seq.name, len(seq)) == (sim.name, len(sim)) == (sim.name, FRAMES[sim.name])
        assert seq.intrinsics == sim.intrinsics
        np.testing.assert_allclose(seq.T_body_cam, sim.T_body_cam, atol=1e-9)
        frames = list(seq.frames())
        assert [f.index for f in frames] == list(range(len(sim)))
        for f, g in zip(frames, direct_frames[sim.name]):  # ground truth as simulated, depth to the 0.2 mm unit
            np.testing.assert_allclose(f.truth.T_world_body, g.truth.T_world_body, atol=1e-6)
            np.testing.assert_array_equal(f.truth.object_ids, g.truth.object_ids)
            np.testing.assert_allclose(f.depth, g.depth, atol=1e-4)
        np.testing.assert_allclose(np.stack([f.truth.T_world_body for f in frames]), sim.run.T_world_body, atol=1e-6)
        picked = [f.index for f in seq.frames([0, 3])]
        assert picked == [0, 3]
