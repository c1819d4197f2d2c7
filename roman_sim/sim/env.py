"""``GroundRobotEnv``: a gymnasium environment of one ground robot with an RGB-D camera.

Observation (``Dict``): ``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres (noisy,
0 invalid), ``object_ids`` (H, W) int32 (-1 background), ``odom_pose`` (4, 4) float64
drifted ``T_odom_body``. Action (``Box``): (forward speed m/s, yaw rate rad/s) within
``[0, max_speed] x [-max_yaw_rate, max_yaw_rate]``. Reward 0. The episode terminates when
the robot leaves the world or touches an object footprint, and is truncated after
``max_steps``. ``info`` carries the true ``T_world_body`` and the time, so a scripted
``PathFollower`` (or any user policy) can drive the same kinematics as ``trajectory_along``.

Misuse is an error that leaves the environment usable: a NaN, infinite or wrongly shaped
action raises ``SimError`` before any state changes; ``step`` before ``reset`` or after the
episode ended raises ``EnvResetNeeded`` (a ``gymnasium.error.ResetNeeded``), any call after
``close`` raises ``EnvClosed`` (a ``gymnasium.error.ClosedEnvironmentError``). Constructor
arguments and ``reset`` options (only ``start``) are checked up front and a bad one is named.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ClosedEnvironmentError, ResetNeeded

from roman_sim.core.config import validate_model
from roman_sim.core.errors import SimError
from roman_sim.core.seeding import child_rng
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.kinematics import PlanarState, body_pose_on_terrain, integrate_unicycle
from roman_sim.sim.noise import apply_depth_noise
from roman_sim.sim.odometry import DriftConfig, DriftModel, resolve_drift
from roman_sim.sim.planner import Obstacles

if TYPE_CHECKING:
    from roman_sim.world import World

log = logging.getLogger(__name__)

ObsDict = dict[str, np.ndarray]
#: The ``info`` of ``reset`` and ``step``: poses (arrays), the time and the step's flags.
InfoDict = dict[str, np.ndarray | float | bool]
_ACTION = "speed m/s, yaw rate rad/s"
#: Keys ``GroundRobotEnv.reset(options=...)`` accepts.
RESET_OPTIONS = ("start",)


class EnvResetNeeded(SimError, ResetNeeded):
    """``step`` was called before ``reset`` or after the episode terminated or was truncated."""


class EnvClosed(SimError, ClosedEnvironmentError):
    """The environment was used after ``close``."""


def _positive(name: str, value: float, allow_zero: bool = False) -> float:
    """``value`` as a float, or ``SimError`` naming ``name`` unless it is finite and > 0 (>= 0)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SimError(f"GroundRobotEnv: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise SimError(f"GroundRobotEnv: {name} must be a finite number {'>=' if allow_zero else '>'} 0, got {value!r}")
    return v


def _load_world(world: World | None, preset: str, world_seed: int) -> World:
    if world is not None:
        return world
    from roman_sim.world import generate, load_world_spec

    return generate(load_world_spec(preset), world_seed)


class GroundRobotEnv(gym.Env):
    """One Jackal-like robot in a roman_sim world.

    Args:
        world: a generated world (``.model``, ``.truth``); generated from ``preset`` when None.
        preset: world preset used when ``world`` is None.
        world_seed: seed of that world.
        camera: camera configuration (or a dict of its fields).
        drift: drift preset name or ``DriftConfig``.
        rate_hz: control and sensor rate.
        max_speed_mps: speed limit of the action.
        max_yaw_rate: yaw-rate limit of the action (rad/s).
        body_height_m: body origin above the terrain.
        clearance_m: a start pose keeps this distance from objects.
        max_steps: truncation horizon.
        start: optional fixed start (x, y, heading rad); random free pose when None.
        render_rgb: also render RGB (else the ``rgb`` observation is all zeros).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 6}

    def __init__(
        self,
        world: World | None = None,
        preset: str = "tiny",
        world_seed: int = 0,
        camera: CameraConfig | Mapping[str, object] | None = None,
        drift: str | DriftConfig = "typical",
        rate_hz: float = 6.0,
        max_speed_mps: float = 2.0,
        max_yaw_rate: float = 1.5,
        body_height_m: float = 0.1,
        clearance_m: float = 0.6,
        max_steps: int = 500,
        start: tuple[float, float, float] | None = None,
        render_rgb: bool = True,
        render_mode: str | None = None,
    ) -> None:
        from roman_sim.sim.render import SensorRenderer

        self._renderer: Any = None
        self.dt = 1.0 / _positive("rate_hz", rate_hz)
        max_speed_mps, max_yaw_rate = _positive("max_speed_mps", max_speed_mps), _positive("max_yaw_rate", max_yaw_rate)
        self.body_height_m = _positive("body_height_m", body_height_m, allow_zero=True)
        self.clearance_m = _positive("clearance_m", clearance_m, allow_zero=True)
        if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
            raise SimError(f"GroundRobotEnv: max_steps must be an integer >= 1, got {max_steps!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise SimError(
                f"GroundRobotEnv: render_mode {render_mode!r} unknown (valid: None, "
                f"{', '.join(self.metadata['render_modes'])})"
            )
        self.camera = (
            camera
            if isinstance(camera, CameraConfig)
            else validate_model(CameraConfig, camera, "GroundRobotEnv camera")
        )
        self.drift_cfg = resolve_drift(drift)
        self.world = _load_world(world, preset, world_seed)
        self.max_steps, self.render_mode = int(max_steps), render_mode
        self._obstacles = Obstacles(self.world.truth)
        self.start = self._check_start(start)
        if start is None:
            self._check_clearance_possible()
        self._renderer = SensorRenderer(self.world, self.camera, rgb=render_rgb)
        self._T_body_cam = self.camera.T_body_cam()
        h, w = self.camera.height, self.camera.width
        self._low = np.array([0.0, -max_yaw_rate], dtype=np.float32)
        self._high = np.array([max_speed_mps, max_yaw_rate], dtype=np.float32)
        self.action_space = spaces.Box(self._low, self._high)
        n_obj = max(len(self.world.truth.objects), 1)
        self.observation_space = spaces.Dict(
            {
                "rgb": spaces.Box(0, 255, (h, w, 3), np.uint8),
                "depth": spaces.Box(0.0, np.float32(self.camera.far_m * 2), (h, w), np.float32),
                "object_ids": spaces.Box(-1, n_obj - 1, (h, w), np.int32),
                "odom_pose": spaces.Box(-1e6, 1e6, (4, 4), np.float64),
            }
        )
        self._state = PlanarState(0.0, 0.0, 0.0)
        self._steps = 0
        self._last_rgb: np.ndarray | None = None
        self._needs_reset: str | None = "call reset() before step()"

    def _check_start(self, start: object) -> tuple[float, float, float] | None:
        """The fixed start pose, checked: three finite numbers, inside the world, clear of objects."""
        if start is None:
            return None
        try:
            x, y, heading = (float(v) for v in np.asarray(start, dtype=np.float64).reshape(3))
        except (TypeError, ValueError):
            raise SimError(f"GroundRobotEnv: start must be (x, y, heading rad), got {start!r}") from None
        if not all(math.isfinite(v) for v in (x, y, heading)):
            raise SimError(f"GroundRobotEnv: start must be finite, got ({x}, {y}, {heading})")
        ter = self.world.truth.terrain
        if not ter.contains(x, y):
            raise SimError(
                f"GroundRobotEnv: start ({x:g}, {y:g}) lies outside the world "
                f"(x in [{-ter.size_x / 2:g}, {ter.size_x / 2:g}], "
                f"y in [{-ter.size_y / 2:g}, {ter.size_y / 2:g}])"
            )
        free = float(self._obstacles.clearance(np.array([[x, y]]))[0])
        if free < 0.0:
            raise SimError(f"GroundRobotEnv: start ({x:g}, {y:g}) lies inside an object footprint")
        return (x, y, heading)

    def _check_clearance_possible(self) -> None:
        """``SimError`` when no random start can keep ``clearance_m`` (sampled on a grid of the start region)."""
        ter = self.world.truth.terrain
        margin = 2.0 * self.clearance_m + 1.0
        hx, hy = ter.size_x / 2 - margin, ter.size_y / 2 - margin
        best = -math.inf
        if hx > 0 and hy > 0:
            step = max(0.5, max(hx, hy) / 200.0)
            gx, gy = np.meshgrid(np.arange(-hx, hx + 1e-9, step), np.arange(-hy, hy + 1e-9, step))
            best = float(np.max(self._obstacles.clearance(np.column_stack([gx.ravel(), gy.ravel()]))))
        if best < self.clearance_m:
            found = "the world is too small for that margin" if best == -math.inf else f"the most found is {best:.2f} m"
            raise SimError(
                f"GroundRobotEnv: clearance_m={self.clearance_m:g} is impossible in this {ter.size_x:g} x "
                f"{ter.size_y:g} m world: no start pose is {margin:g} m from the edge and "
                f"{self.clearance_m:g} m from every object ({found})"
            )

    def _random_start(self, rng: np.random.Generator) -> PlanarState:
        ter = self.world.truth.terrain
        margin = 2.0 * self.clearance_m + 1.0
        for _ in range(1000):
            x, y = (
                rng.uniform(-ter.size_x / 2 + margin, ter.size_x / 2 - margin),
                rng.uniform(-ter.size_y / 2 + margin, ter.size_y / 2 - margin),
            )
            if self._obstacles.clearance(np.array([[x, y]]))[0] >= self.clearance_m:
                return PlanarState(float(x), float(y), float(rng.uniform(-np.pi, np.pi)))
        raise SimError(f"GroundRobotEnv: no free start pose with clearance {self.clearance_m} m found")

    def reset(
        self, *, seed: int | None = None, options: Mapping[str, object] | None = None
    ) -> tuple[ObsDict, InfoDict]:
        """Start a new episode; the same ``seed`` gives the same episode.

        ``options`` (a dict, or None): ``start``, the start (x, y, heading rad) of this
        episode (None: a random free pose) instead of the constructor's ``start``. Anything
        else (an unknown key, options that are not a dict) is a ``SimError`` and the
        environment is unchanged.
        """
        self._check_open("reset")
        start = self._reset_start(options)
        super().reset(seed=seed)
        base = int(self.np_random.integers(0, 2**31 - 1))
        if start is not None:
            self._state = PlanarState(*start)
        else:
            self._state = self._random_start(child_rng(base, "env", "start"))
        self._drift = DriftModel(self.drift_cfg, child_rng(base, "env", "drift"))
        self._noise_rng = child_rng(base, "env", "depth_noise")
        self._steps = 0
        self._needs_reset = None
        return self._observe()

    def _reset_start(self, options: object) -> tuple[float, float, float] | None:
        """The start pose ``reset(options=...)`` asks for (checked like the constructor's ``start``)."""
        if options is None:
            return self.start
        if not isinstance(options, Mapping):
            raise SimError(
                f"GroundRobotEnv: reset options must be a dict (keys: {', '.join(RESET_OPTIONS)}), "
                f"got {type(options).__name__} {options!r}"
            )
        unknown = [k for k in options if k not in RESET_OPTIONS]
        if unknown:
            raise SimError(
                f"GroundRobotEnv: unknown reset option {', '.join(map(repr, unknown))} "
                f"(valid: {', '.join(RESET_OPTIONS)})"
            )
        return self._check_start(options["start"]) if "start" in options else self.start

    def _check_open(self, what: str) -> None:
        if self._renderer is None:
            raise EnvClosed(f"GroundRobotEnv: {what}() after close(); make a new environment")

    def _action(self, action: object) -> np.ndarray:
        """``action`` as (speed, yaw rate) clipped to the limits; ``SimError`` for a bad shape or value."""
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise SimError(f"GroundRobotEnv: action must be 2 numbers ({_ACTION}), got {action!r}") from None
        if a.size != 2:
            raise SimError(f"GroundRobotEnv: action must hold 2 numbers ({_ACTION}), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise SimError(
                f"GroundRobotEnv: action must be finite, got {a.reshape(2).tolist()} (the episode is unchanged)"
            )
        return np.clip(a.reshape(2), self._low, self._high)

    def _observe(self) -> tuple[ObsDict, InfoDict]:
        T_wb = body_pose_on_terrain(self.world.truth.terrain, self._state, self.body_height_m)
        T_ob = self._drift.step(T_wb)
        rgb, depth, ids = self._renderer.render(T_wb @ self._T_body_cam)
        depth = apply_depth_noise(depth, self.camera.depth_noise, self.camera.max_depth_m, self._noise_rng)
        if rgb is None:
            rgb = np.zeros((self.camera.height, self.camera.width, 3), dtype=np.uint8)
        self._last_rgb = rgb
        obs = {"rgb": rgb, "depth": depth, "object_ids": ids, "odom_pose": T_ob}
        info: InfoDict = {"T_world_body": T_wb, "t": self._steps * self.dt, "T_body_cam": self._T_body_cam.copy()}
        return obs, info

    def step(self, action: np.ndarray) -> tuple[ObsDict, float, bool, bool, InfoDict]:
        """Apply (forward speed, yaw rate) for one sensor period (clipped to the limits)."""
        self._check_open("step")
        if self._needs_reset:
            raise EnvResetNeeded(f"GroundRobotEnv: {self._needs_reset}")
        a = self._action(action)
        substeps = 10
        for _ in range(substeps):
            self._state = integrate_unicycle(self._state, float(a[0]), float(a[1]), self.dt / substeps)
        self._steps += 1
        ter = self.world.truth.terrain
        xy = np.array([[self._state.x, self._state.y]])
        left = not ter.contains(self._state.x, self._state.y)
        hit = bool(self._obstacles.clearance(xy)[0] < 0.0)
        if left:
            self._state = PlanarState(
                float(np.clip(self._state.x, -ter.size_x / 2, ter.size_x / 2)),
                float(np.clip(self._state.y, -ter.size_y / 2, ter.size_y / 2)),
                self._state.heading,
            )
        obs, info = self._observe()
        info.update(left_world=left, collision=hit)
        terminated, truncated = bool(left or hit), self._steps >= self.max_steps
        if terminated or truncated:
            why = (
                "left the world"
                if left
                else "collided with an object"
                if hit
                else f"reached max_steps={self.max_steps}"
            )
            self._needs_reset = f"the episode ended ({why}): call reset() before step()"
        return obs, 0.0, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """The last RGB observation (``rgb_array`` mode)."""
        return self._last_rgb

    def close(self) -> None:
        """Free the renderer."""
        if getattr(self, "_renderer", None) is not None:
            self._renderer.close()
            self._renderer = None
