"""Scripted robot runs: terrain-following poses, odometry, frames, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import SimError
from roman_sim.core.geometry import gravity_aligned, inv_T
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.kinematics import PlanarState, body_pose_on_terrain, integrate_unicycle
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.planner import Obstacles
from roman_sim.sim.robot import RobotConfig, render_trajectory
from roman_sim.sim.source import SimulatedRobot, robot_sources
from roman_sim.world.truth import Terrain

SMALL = CameraConfig(width=64, height=48)


def _cfg(**kw) -> RobotConfig:
    base = dict(name="r1", path=PathConfig(kind="loop", radius_m=5.0), camera=SMALL)
    base.update(kw)
    return RobotConfig(**base)


def _source(world, cfg: RobotConfig, seed: int) -> SimulatedRobot:
    return robot_sources(world, [cfg], seed)[0]


def test_unicycle_arc_is_exact() -> None:
    s = integrate_unicycle(PlanarState(0.0, 0.0, 0.0), 1.0, np.pi / 2, 1.0)  # quarter circle, radius 2/pi
    r = 2 / np.pi
    assert (s.x, s.y, s.heading) == pytest.approx((r, r, np.pi / 2))


def test_body_pose_follows_terrain_slope() -> None:
    x = np.linspace(-10, 10, 21)
    heights = np.tile(0.2 * x, (21, 1))  # z = 0.2 x: slope along x
    ter = Terrain(20.0, 20.0, heights)
    T = body_pose_on_terrain(ter, PlanarState(1.0, 2.0, 0.0), 0.1)
    assert T[2, 3] == pytest.approx(0.2 * 1.0 + 0.1)
    n = np.array([-0.2, 0.0, 1.0]) / np.linalg.norm([-0.2, 0.0, 1.0])
    np.testing.assert_allclose(T[:3, 2], n, atol=1e-9)
    assert np.degrees(np.arctan2(T[2, 0], T[0, 0])) == pytest.approx(np.degrees(np.arctan(0.2)))  # nose up
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)


def test_trajectory_follows_path_on_terrain(tiny_world) -> None:
    cfg = _cfg(drift="zero")
    t, T_wb, T_ob = _source(tiny_world, cfg, 3).run
    assert np.allclose(np.diff(t), 1 / 6.0)
    speed = np.linalg.norm(np.diff(T_wb[:, :2, 3], axis=0), axis=1) * 6.0
    assert np.median(speed) == pytest.approx(1.0, rel=0.05)
    ter = tiny_world.truth.terrain
    np.testing.assert_allclose(T_wb[:, 2, 3], ter.height_at(T_wb[:, 0, 3], T_wb[:, 1, 3]) + 0.1, atol=1e-9)
    assert Obstacles(tiny_world.truth).clearance(T_wb[:, :2, 3]).min() > 0.3
    T_wo = gravity_aligned(T_wb[0])
    np.testing.assert_allclose(T_ob, np.stack([inv_T(T_wo) @ T for T in T_wb]), atol=1e-9)


def test_limits_stop_the_run(tiny_world) -> None:
    t, T_wb, _ = _source(tiny_world, _cfg(max_duration_s=5.0), 3).run
    assert t[-1] <= 5.0 + 1e-9 and len(t) == 31
    t, T_wb, _ = _source(tiny_world, _cfg(max_length_m=3.0), 3).run
    assert 3.0 <= np.linalg.norm(np.diff(T_wb[:, :2, 3], axis=0), axis=1).sum() < 3.5


def test_frames_are_consistent_and_deterministic(tiny_world) -> None:
    cfg = _cfg(max_duration_s=0.5)
    a = list(_source(tiny_world, cfg, 1).frames())
    b = list(_source(tiny_world, cfg, 1).frames())
    assert [f.index for f in a] == [0, 1, 2, 3]
    for fa, fb in zip(a, b):
        np.testing.assert_array_equal(fa.depth, fb.depth)
        np.testing.assert_array_equal(fa.truth.object_ids, fb.truth.object_ids)
        np.testing.assert_array_equal(fa.rgb, fb.rgb)
        np.testing.assert_array_equal(fa.T_odom_body, fb.T_odom_body)
    f = a[0]
    assert f.rgb.shape == (48, 64, 3) and f.depth.shape == (48, 64) and f.truth.object_ids.dtype == np.int32
    np.testing.assert_allclose(f.T_body_cam, SMALL.T_body_cam())
    assert f.depth.max() <= SMALL.max_depth_m
    c = list(_source(tiny_world, cfg.model_copy(update={"render_rgb": False}), 2).frames())
    assert c[0].rgb is None
    assert not np.array_equal(c[1].T_odom_body, a[1].T_odom_body)


def test_plan_paths_resolves_references_in_order(tiny_world) -> None:
    from roman_sim.core.errors import SimError
    from roman_sim.sim.robot import plan_paths

    a = _cfg(name="a")
    b = _cfg(name="b", path=PathConfig(kind="reverse_of", of="a"))
    paths = plan_paths(tiny_world, [a, b], seed=0)
    np.testing.assert_allclose(paths["b"].xy[0], paths["a"].xy[-1])
    t, T_wb, _ = robot_sources(tiny_world, [a, b], 0, ["b"])[0].run
    assert np.linalg.norm(T_wb[0, :2, 3] - paths["a"].xy[-1]) < 1e-9
    with pytest.raises(SimError, match="path.of='a'"):
        plan_paths(tiny_world, [b, a], seed=0)
    with pytest.raises(SimError, match="used twice"):
        plan_paths(tiny_world, [a, a], seed=0)


def test_rgb_only_on_the_frames_asked_for_and_the_rest_unchanged(tiny_world) -> None:
    cfg = _cfg(max_duration_s=0.5)
    run = _source(tiny_world, cfg, 1).run
    full = list(render_trajectory(tiny_world, cfg, 1, run))
    part = list(render_trajectory(tiny_world, cfg, 1, run, [False, True, False, True]))
    assert [f.rgb is not None for f in part] == [False, True, False, True]
    for fa, fb in zip(full, part):  # same depth noise stream and ids whatever gets RGB
        np.testing.assert_array_equal(fa.depth, fb.depth)
        np.testing.assert_array_equal(fa.truth.object_ids, fb.truth.object_ids)
        if fb.rgb is not None:
            np.testing.assert_array_equal(fa.rgb, fb.rgb)
    no_rgb = list(render_trajectory(tiny_world, cfg.model_copy(update={"render_rgb": False}), 1, run, [True] * 4))
    assert all(f.rgb is None for f in no_rgb)  # a robot without RGB never renders it
    with pytest.raises(SimError, match="rgb_frames has 3 flags for 4 frames"):
        next(render_trajectory(tiny_world, cfg, 1, run, [True] * 3))
