"""Virtual ground robots: camera, rendering, paths, kinematics, odometry drift, env, recordings.

Modules: ``camera`` (CameraConfig, intrinsics, mount, project/backproject), ``render``
(SensorRenderer: MuJoCo RGB, depth, instance ids), ``noise`` (depth noise), ``pyrender_check``
(independent depth renderer), ``paths`` + ``planner`` (PathConfig, make_path, Path2D),
``kinematics`` (terrain-following unicycle, PathFollower), ``odometry`` (DriftConfig,
presets, DriftModel), ``robot`` (RobotConfig, plan_paths, trajectory_along,
render_trajectory), ``source`` (robot_sources: one frame source per robot), ``env``
(GroundRobotEnv), ``recording`` (write/read recordings, ``Recording``).

Importing this package is cheap: ``import roman_sim`` registers the gymnasium environment
``roman_sim/GroundRobot-v0`` (string entry point) once gymnasium is imported; renderers
load on first use.
"""

from __future__ import annotations

from roman_sim.core.gymreg import ENV_ID

__all__ = ["ENV_ID"]
