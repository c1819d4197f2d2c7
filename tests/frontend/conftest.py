"""Rendered frames of the tiny world, and the mapping tests' synthetic scenes (``mapping_synth``)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent.parent / "mapping"))


import pytest


@pytest.fixture(scope="session")
def tiny_rgb_frames():
    """Rendered RGB-D frames of the tiny world (160 x 120, a short road drive)."""
    from roman_sim.sim.camera import CameraConfig
    from roman_sim.sim.robot import RobotConfig
    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate, load_world_spec

    world = generate(load_world_spec("tiny"), 0)
    cfg = RobotConfig(
        name="a", camera=CameraConfig(width=160, height=120), drift="zero", render_rgb=True, max_duration_s=12.0
    )
    return list(robot_sources(world, [cfg], 0)[0].frames())
