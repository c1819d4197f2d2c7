"""Virtual ground robots: camera, rendering, paths, kinematics, odometry drift, env, recordings.

Modules: ``camera`` (CameraConfig, intrinsics, mount, project/backproject), ``render``
(SensorRenderer: MuJoCo RGB, depth, instance ids), ``noise`` (depth noise), ``pyrender_check``
(independent depth renderer), ``paths`` + ``planner`` (PathConfig, make_path, Path2D),
``kinematics`` (terrain-following unicycle, PathFollower), ``odometry`` (DriftConfig,
presets, DriftModel), ``robot`` (RobotConfig, robot_trajectory, simulate_robot,
record_robot), ``env`` (GroundRobotEnv), ``recording`` (write/read recordings).

Importing this package is cheap: it only registers the gymnasium environment
``roman_sim/GroundRobot-v0`` (string entry point); renderers load on first use.
"""

from __future__ import annotations

import gymnasium as gym

ENV_ID = "roman_sim/GroundRobot-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="roman_sim.sim.env:GroundRobotEnv")

__all__ = ["ENV_ID"]
