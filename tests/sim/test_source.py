"""``robot_sources``: one frame source per robot, the same frames as the simulator's steps chained by hand."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import ConfigError, SimError
from roman_sim.core.sensors import FrameSource
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.robot import RobotConfig, plan_paths, render_trajectory, trajectory_along
from roman_sim.sim.source import SimulatedRobot, robot_sources

SMALL = CameraConfig(width=64, height=48)


def _robots() -> list[RobotConfig]:
    a = RobotConfig(name="a", path=PathConfig(kind="loop", radius_m=5.0), camera=SMALL, max_duration_s=1.0)
    b = RobotConfig(
        name="b", path=PathConfig(kind="reverse_of", of="a"), camera=SMALL, max_duration_s=0.5, render_rgb=False
    )
    return [a, b]


def test_sources_give_the_frames_of_the_planned_driven_and_rendered_runs(tiny_world) -> None:
    robots = _robots()
    sources = robot_sources(tiny_world, robots, 4)
    paths = plan_paths(tiny_world, robots, 4)
    assert [s.name for s in sources] == ["a", "b"]
    for src, cfg in zip(sources, robots):
        assert isinstance(src, FrameSource)
        by_hand = list(render_trajectory(tiny_world, cfg, 4, trajectory_along(tiny_world, cfg, 4, paths[cfg.name])))
        frames = list(src.frames())
        assert len(frames) == len(by_hand) == len(src) == {"a": 7, "b": 4}[cfg.name]  # 6 Hz, both ends
        np.testing.assert_array_equal(src.T_body_cam, SMALL.T_body_cam())
        for f, g in zip(frames, by_hand):
            assert (f.robot, f.index, f.t, f.intrinsics) == (g.robot, g.index, g.t, src.intrinsics)
            np.testing.assert_array_equal(f.depth, g.depth)
            np.testing.assert_array_equal(f.truth.object_ids, g.truth.object_ids)
            np.testing.assert_array_equal(f.truth.T_world_body, g.truth.T_world_body)
            np.testing.assert_array_equal(f.T_odom_body, g.T_odom_body)
            assert (f.rgb is None) == (cfg.name == "b")
        np.testing.assert_array_equal(np.stack([f.truth.T_world_body for f in frames]), src.run.T_world_body)
    # robot b alone starts where a ends (its path refers to a's), as in the whole scenario
    alone = robot_sources(tiny_world, robots, 4, ["b"])
    assert [s.name for s in alone] == ["b"]
    np.testing.assert_array_equal(alone[0].run.T_world_body, sources[1].run.T_world_body)
    np.testing.assert_allclose(alone[0].path.xy[0], sources[0].path.xy[-1])


def test_rgb_switches_and_frame_subsets(tiny_world) -> None:
    robots = _robots()
    b = robot_sources(tiny_world, robots, 4, ["b"], rgb=True)[0]
    assert all(f.rgb is not None for f in b.frames())  # RGB forced on for a robot without it
    a = robot_sources(tiny_world, robots, 4, ["a"])[0]
    full = list(a.frames())
    flags = [i % 3 == 0 for i in range(len(a))]
    part = list(a.rgb_at(flags).frames())
    assert [f.rgb is not None for f in part] == flags
    for f, g in zip(full, part):  # the same depth noise stream whatever gets RGB
        np.testing.assert_array_equal(f.depth, g.depth)
    picked = list(a.frames([1, 4, 6]))
    assert [f.index for f in picked] == [1, 4, 6]  # frames keep their index
    for f in picked:
        np.testing.assert_array_equal(f.truth.object_ids, full[f.index].truth.object_ids)
        np.testing.assert_array_equal(f.T_odom_body, full[f.index].T_odom_body)
    with pytest.raises(SimError, match="ascending"):
        list(a.frames([4, 1]))
    with pytest.raises(SimError, match="rgb_frames has 3 flags for 7 frames"):
        a.rgb_at([True] * 3)


def test_bad_requests_name_the_robot(tiny_world) -> None:
    from roman_sim.world import generate_truth, load_world_spec

    robots = _robots()
    with pytest.raises(ConfigError, match="no robot c"):
        robot_sources(tiny_world, robots, 4, ["c"])
    with pytest.raises(ConfigError, match="need the world"):
        robot_sources(None, robots, 4)
    truth_only = robot_sources(generate_truth(load_world_spec("tiny"), 0), robots, 4, ["a"])[0]
    assert isinstance(truth_only, SimulatedRobot) and len(truth_only) == 7  # poses without a model
    with pytest.raises(SimError, match="without a model"):
        next(truth_only.frames())
