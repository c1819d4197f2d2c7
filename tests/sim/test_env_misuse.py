"""The gym environment under misuse: clear errors that name the argument and leave the env usable.

Gymnasium conventions: ``step`` before ``reset`` or after the episode ended raises
``gymnasium.error.ResetNeeded``, use after ``close`` raises ``ClosedEnvironmentError``.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError, ResetNeeded

from roman_sim.core.errors import ConfigError, SimError
from roman_sim.sim.env import GroundRobotEnv

SMALL = {"width": 32, "height": 24}


@pytest.fixture
def env(tiny_world):
    e = GroundRobotEnv(world=tiny_world, camera=SMALL, max_steps=3, drift="zero", start=(0.0, -18.5, 0.0))
    yield e
    e.close()


@pytest.mark.parametrize(
    ("kwargs", "expect"),
    [
        ({"rate_hz": 0}, "rate_hz must be a finite number > 0, got 0"),
        ({"rate_hz": math.nan}, "rate_hz must be a finite number > 0, got nan"),
        ({"max_steps": -1}, "max_steps must be an integer >= 1, got -1"),
        ({"max_steps": 2.5}, "max_steps must be an integer >= 1, got 2.5"),
        ({"max_speed_mps": -2.0}, "max_speed_mps must be a finite number > 0, got -2.0"),
        ({"max_yaw_rate": math.inf}, "max_yaw_rate must be a finite number > 0, got inf"),
        ({"body_height_m": "low"}, "body_height_m must be a number, got 'low'"),
        ({"clearance_m": -0.5}, "clearance_m must be a finite number >= 0, got -0.5"),
        ({"start": (100.0, 0.0, 0.0)}, "start (100, 0) lies outside the world (x in [-20, 20], y in [-20, 20])"),
        ({"start": (math.nan, 0.0, 0.0)}, "start must be finite, got (nan, 0.0, 0.0)"),
        ({"start": (1.0, 2.0)}, "start must be (x, y, heading rad), got (1.0, 2.0)"),
        (
            {"clearance_m": 8.0},
            "clearance_m=8 is impossible in this 40 x 40 m world: no start pose is 17 m from the edge",
        ),
        ({"clearance_m": 40.0}, "(the world is too small for that margin)"),
        ({"render_mode": "human"}, "render_mode 'human' unknown (valid: None, rgb_array)"),
    ],
)
def test_bad_constructor_arguments_are_named(tiny_world, kwargs: dict, expect: str) -> None:
    with pytest.raises(SimError) as e:
        GroundRobotEnv(world=tiny_world, camera=SMALL, **kwargs)
    assert expect in str(e.value) and str(e.value).startswith("GroundRobotEnv: "), str(e.value)


def test_start_inside_an_object_and_bad_camera(tiny_world) -> None:
    obj = tiny_world.truth.objects[0]
    x, y = obj.T_world_obj[:2, 3]
    with pytest.raises(SimError, match="lies inside an object footprint"):
        GroundRobotEnv(world=tiny_world, camera=SMALL, start=(x, y, 0.0))
    with pytest.raises(ConfigError, match=r"GroundRobotEnv camera: width: Input should be greater than or equal to 8"):
        GroundRobotEnv(world=tiny_world, camera={"width": 2})
    with pytest.raises(ConfigError, match=r"GroundRobotEnv camera: fov: unknown key \(allowed: depth_noise"):
        GroundRobotEnv(world=tiny_world, camera={"fov": 2})


def test_step_before_reset_and_after_the_episode(env: GroundRobotEnv) -> None:
    with pytest.raises(ResetNeeded, match="call reset\\(\\) before step\\(\\)"):
        env.step(np.array([1.0, 0.0]))
    env.reset(seed=0)
    for _ in range(3):
        _, _, terminated, truncated, _ = env.step(np.array([1.0, 0.0]))
    assert truncated and not terminated
    with pytest.raises(ResetNeeded, match="the episode ended \\(reached max_steps=3\\)"):
        env.step(np.array([1.0, 0.0]))
    env.reset(seed=0)
    env.step(np.array([1.0, 0.0]))  # usable again after reset


def test_leaving_the_world_ends_the_episode(tiny_world) -> None:
    e = GroundRobotEnv(world=tiny_world, camera=SMALL, drift="zero", start=(19.7, 0.0, 0.0))
    try:
        e.reset(seed=0)
        _, _, terminated, _, info = e.step(np.array([2.0, 0.0]))
        assert terminated and info["left_world"]
        with pytest.raises(ResetNeeded, match="the episode ended \\(left the world\\)"):
            e.step(np.array([1.0, 0.0]))
    finally:
        e.close()


@pytest.mark.parametrize(
    ("action", "expect"),
    [
        ([math.nan, 0.0], "action must be finite, got [nan, 0.0] (the episode is unchanged)"),
        ([1.0, math.inf], "action must be finite, got [1.0, inf]"),
        ([1.0, 0.0, 0.0], "action must hold 2 numbers (speed m/s, yaw rate rad/s), got shape (3,)"),
        ([[1.0]], "got shape (1, 1)"),
        ("fast", "action must be 2 numbers (speed m/s, yaw rate rad/s), got 'fast'"),
        (None, "action must hold 2 numbers (speed m/s, yaw rate rad/s), got shape ()"),
        ([None, 1.0], "action must be finite, got [nan, 1.0]"),
    ],
)
def test_bad_actions_do_not_poison_the_env(env: GroundRobotEnv, action: object, expect: str) -> None:
    env.reset(seed=0)
    _, info0 = env.reset(seed=0)
    with pytest.raises(SimError) as e:
        env.step(action)  # type: ignore[arg-type]
    assert expect in str(e.value), str(e.value)
    _, _, _, _, info = env.step(np.array([1.5, 0.0]))  # the next good step continues from the start pose
    assert info["T_world_body"][0, 3] == pytest.approx(info0["T_world_body"][0, 3] + 1.5 / 6.0)
    assert np.all(np.isfinite(info["T_world_body"]))


def test_use_after_close(tiny_world) -> None:
    e = GroundRobotEnv(world=tiny_world, camera=SMALL)
    e.reset(seed=0)
    e.close()
    e.close()  # closing twice is fine
    with pytest.raises(ClosedEnvironmentError, match="step\\(\\) after close\\(\\)"):
        e.step(np.array([1.0, 0.0]))
    with pytest.raises(ClosedEnvironmentError, match="reset\\(\\) after close\\(\\)"):
        e.reset()


def _python(code: str) -> subprocess.CompletedProcess[str]:
    env = {"PYTHONPATH": str(Path(__file__).resolve().parents[2]), "PATH": "", "MUJOCO_GL": "egl"}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)


def test_import_roman_sim_registers_the_env_without_importing_gymnasium_or_mujoco() -> None:
    code = (
        "import sys, roman_sim, roman_sim.mapping\n"
        "assert 'gymnasium' not in sys.modules and 'mujoco' not in sys.modules, 'imported early'\n"
        "import gymnasium as gym\n"
        "assert 'roman_sim/GroundRobot-v0' in gym.registry\n"
        "assert 'mujoco' not in sys.modules\n"
        "assert type(gym.__spec__.loader).__name__ == 'SourceFileLoader'\n"
        "print('ok')"
    )
    out = _python(code)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr
    out = _python("import gymnasium as gym, roman_sim; print('roman_sim/GroundRobot-v0' in gym.registry)")
    assert out.returncode == 0 and out.stdout.strip() == "True", out.stderr
