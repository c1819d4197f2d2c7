"""gymnasium environment: API compliance, determinism, driving it with the path follower."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import roman_sim.sim  # noqa: F401  (registers the environment)
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.env import GroundRobotEnv
from roman_sim.sim.kinematics import PathFollower
from roman_sim.sim.paths import path_from_points

SMALL = {"width": 64, "height": 48}


@pytest.fixture(scope="module")
def env(tiny_world):
    e = GroundRobotEnv(world=tiny_world, camera=SMALL, max_steps=20)
    yield e
    e.close()


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")
def test_check_env_passes(env) -> None:
    check_env(env, skip_render_check=True)


def test_reset_is_deterministic(env) -> None:
    o1, i1 = env.reset(seed=5)
    a = env.step(np.array([1.0, 0.3], dtype=np.float32))[0]
    o2, i2 = env.reset(seed=5)
    b = env.step(np.array([1.0, 0.3], dtype=np.float32))[0]
    np.testing.assert_array_equal(i1["T_world_body"], i2["T_world_body"])
    for k in o1:
        np.testing.assert_array_equal(o1[k], o2[k])
        np.testing.assert_array_equal(a[k], b[k])
    o3, i3 = env.reset(seed=6)
    assert not np.array_equal(i1["T_world_body"], i3["T_world_body"])


def test_actions_are_clipped_and_leaving_terminates(tiny_world) -> None:
    ter = tiny_world.truth.terrain
    e = GroundRobotEnv(world=tiny_world, camera=SMALL, start=(ter.size_x / 2 - 0.5, 0.0, 0.0), drift="zero")
    try:
        e.reset(seed=0)
        x0 = ter.size_x / 2 - 0.5
        for k in range(1, 4):
            _, r, terminated, truncated, info = e.step(np.array([50.0, 0.0]))  # clipped to 2 m/s
            if terminated:
                break
            assert info["T_world_body"][0, 3] == pytest.approx(x0 + k * 2.0 / 6.0)
        assert r == 0.0 and terminated and not truncated and info["left_world"] and k == 2
        assert info["T_world_body"][0, 3] <= ter.size_x / 2
    finally:
        e.close()


def test_path_follower_drives_the_env(tiny_world) -> None:
    from roman_sim.sim.planner import Obstacles

    obstacles_free_line = None

    obs = Obstacles(tiny_world.truth)
    for y in np.arange(-15.0, 15.0, 0.5):  # a straight free line for a short drive
        line = np.column_stack([np.linspace(-6.0, 6.0, 50), np.full(50, y)])
        if obs.clearance(line).min() > 1.0:
            obstacles_free_line = line
            break
    assert obstacles_free_line is not None
    path = path_from_points(obstacles_free_line[[0, -1]], 0.05)
    e = GroundRobotEnv(world=tiny_world, camera=SMALL, start=(-6.0, float(path.xy[0, 1]), 0.3), max_steps=200)
    try:
        _, info = e.reset(seed=0)
        follower = PathFollower(path, speed_mps=1.0)
        for _ in range(200):
            T = info["T_world_body"]
            v, w = follower.act(T[0, 3], T[1, 3], float(np.arctan2(T[1, 0], T[0, 0])))
            if follower.done:
                break
            _, _, term, trunc, info = e.step(np.array([v, w], dtype=np.float32))
            assert not term
        assert follower.done
        assert np.linalg.norm(info["T_world_body"][:2, 3] - path.xy[-1]) < 0.3
    finally:
        e.close()


def test_registered_with_gymnasium(tiny_world) -> None:
    e = gym.make("roman_sim/GroundRobot-v0", world=tiny_world, camera=CameraConfig(**SMALL))
    try:
        obs, _ = e.reset(seed=1)
        assert obs["depth"].shape == (48, 64) and obs["odom_pose"].shape == (4, 4)
    finally:
        e.close()
