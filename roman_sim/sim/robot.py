"""A scripted robot run: path -> pure-pursuit driving on the terrain -> odometry -> frames.

The steps, each distinct: ``plan_paths`` (every robot's path, in order), ``trajectory_along``
(drive one path: true poses and drifted odometry, cheap) and ``render_trajectory`` (a
``Frame`` per pose). ``roman_sim.sim.source.robot_sources`` chains them into one frame source
per robot. Random streams (per robot name, from ``seeding.child_rng``): ``path``
(placement), ``drift`` (odometry), ``depth_noise`` (sensor).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, SerializerFunctionWrapHandler, field_validator, model_serializer, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import SimError
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame, FrameTruth
from roman_sim.core.trajectory import Trajectory
from roman_sim.sim.camera import CameraConfig, StereoConfig
from roman_sim.sim.imu import ImuConfig
from roman_sim.sim.kinematics import PathFollower, PlanarState, body_pose_on_terrain, integrate_unicycle
from roman_sim.sim.noise import apply_depth_noise
from roman_sim.sim.odometry import DRIFT_PRESETS, DriftConfig, DriftModel, resolve_drift
from roman_sim.sim.paths import Path2D, PathConfig, make_path
from roman_sim.sim.planner import Obstacles
from roman_sim.world.appearance import LIGHTING
from roman_sim.world.relight import robot_lighting

if TYPE_CHECKING:
    from roman_sim.world import HasTruth, World

log = logging.getLogger(__name__)


#: Optional sensors: left out of the dumped configuration when absent, so a scenario without
#: them has the same resolved configuration (and hash) as before they existed.
OPTIONAL_SENSORS = ("imu", "stereo")


class RobotConfig(StrictModel):
    """One robot: its path, motion, camera, odometry drift, run limits and optional sensors
    (an IMU, ``roman_sim.sim.imu``; a second camera, ``StereoConfig``)."""

    name: str = Field("robot", min_length=1)
    path: PathConfig = Field(default_factory=PathConfig)
    speed_mps: float = Field(1.0, gt=0.0, le=5.0)
    rate_hz: float = Field(6.0, gt=0.0, le=100.0)
    substeps: int = Field(10, ge=1, le=100)
    body_height_m: float = Field(0.1, ge=0.0, le=2.0)
    lookahead_m: float = Field(0.4, gt=0.05, le=10.0)
    max_yaw_rate: float = Field(1.5, gt=0.0, le=10.0)
    camera: CameraConfig = Field(default_factory=CameraConfig)
    drift: str | DriftConfig = "typical"
    render_rgb: bool = True
    lighting: str | None = Field(None, description="lighting preset of this robot's RGB (None: the world's)")
    max_duration_s: float | None = Field(None, gt=0.0)
    max_length_m: float | None = Field(None, gt=0.0)
    imu: ImuConfig | None = Field(None, description="an IMU on the body (None: no IMU)")
    stereo: StereoConfig | None = Field(None, description="a second camera beside the first (None: one camera)")

    #: Fields left out of the dump when None (``OPTIONAL_SENSORS``; a subclass may add its own).
    omitted_when_absent: ClassVar[tuple[str, ...]] = OPTIONAL_SENSORS

    @model_serializer(mode="wrap")
    def _without_absent_sensors(self, handler: SerializerFunctionWrapHandler) -> dict[str, object]:
        data: dict[str, object] = handler(self)
        for key in self.omitted_when_absent:
            if key in data and data[key] is None:
                del data[key]
        return data

    @model_validator(mode="after")
    def _imu_rate_fits_frames(self) -> RobotConfig:
        if self.imu is not None:
            self.imu.per_frame(self.rate_hz)  # raises ValueError naming imu.rate_hz
        return self

    @field_validator("drift")
    @classmethod
    def _known_preset(cls, v: str | DriftConfig) -> str | DriftConfig:
        if isinstance(v, str) and v not in DRIFT_PRESETS:
            raise ValueError(f"unknown drift preset {v!r} (valid: {', '.join(DRIFT_PRESETS.names())})")
        return v

    @field_validator("lighting")
    @classmethod
    def _known_lighting(cls, v: str | None) -> str | None:
        if v is not None and v not in LIGHTING:
            raise ValueError(f"unknown lighting preset {v!r} (valid: {', '.join(LIGHTING.names())}, or null)")
        return v

    def drift_config(self) -> DriftConfig:
        """The resolved drift parameters."""
        return resolve_drift(self.drift)


def _robot_path(world: HasTruth, cfg: RobotConfig, seed: int, paths_by_name: Mapping[str, Path2D]) -> Path2D:
    """The robot's validated path (seeded by ``seed`` and the robot name; the world's road width bounds its offset)."""
    roads = getattr(getattr(world, "spec", None), "roads", None)
    width = None if roads is None else float(roads.width_m)
    return make_path(cfg.path, world.truth, child_rng(seed, "path", cfg.name), cfg.name, paths_by_name, width)


def plan_paths(world: HasTruth, robots: Sequence[RobotConfig], seed: int) -> dict[str, Path2D]:
    """Every robot's path, in order, so ``reverse_of`` / ``cross`` can refer to earlier robots.

    Raises: SimError for duplicate robot names or a reference to a later/unknown robot.
    """
    paths: dict[str, Path2D] = {}
    for cfg in robots:
        if cfg.name in paths:
            raise SimError(f"robot name {cfg.name!r} is used twice")
        paths[cfg.name] = _robot_path(world, cfg, seed, paths)
    return paths


def _drive(world: HasTruth, cfg: RobotConfig, path: Path2D) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Drive the path with pure pursuit; returns times (N,) and true ``T_world_body`` (N, 4, 4).

    One pose per sensor step (``rate_hz``); the kinematics integrate ``substeps`` times per step.
    """
    dt = 1.0 / cfg.rate_hz
    follower = PathFollower(path, cfg.speed_mps, cfg.lookahead_m, cfg.max_yaw_rate)
    state = PlanarState(float(path.xy[0, 0]), float(path.xy[0, 1]), float(path.heading[0]))
    limit_t = cfg.max_duration_s if cfg.max_duration_s is not None else 2.0 * path.length / cfg.speed_mps + 30.0
    limit_s = cfg.max_length_m if cfg.max_length_m is not None else np.inf
    ter = world.truth.terrain
    times, poses, travelled, k = [], [], 0.0, 0
    while True:
        t = k * dt
        times.append(t)
        poses.append(body_pose_on_terrain(ter, state, cfg.body_height_m))
        if follower.done or t + dt > limit_t + 1e-9 or travelled >= limit_s:
            break
        for _ in range(cfg.substeps):
            v, w = follower.act(state.x, state.y, state.heading)
            nxt = integrate_unicycle(state, v, w, dt / cfg.substeps)
            travelled += float(np.hypot(nxt.x - state.x, nxt.y - state.y))
            state = nxt
        if not ter.contains(state.x, state.y):
            raise SimError(f"robot {cfg.name!r}: left the world at ({state.x:.2f}, {state.y:.2f})")
        k += 1
    return np.asarray(times), np.stack(poses)


def _check_driven_clearance(world: HasTruth, cfg: RobotConfig, T_wb: NDArray[np.float64]) -> None:
    """The path is clear by construction; the controller may cut corners slightly."""
    clear = Obstacles(world.truth).clearance(T_wb[:, :2, 3])
    i = int(np.argmin(clear)) if len(clear) else 0
    if len(clear) and clear[i] < 0.0:
        raise SimError(f"robot {cfg.name!r}: drove into an object footprint at step {i} (path too tight to follow)")
    if len(clear) and clear[i] < cfg.path.clearance_m:
        log.warning(
            "robot %s: came %.2f m close to an object (clearance %.2f m)", cfg.name, clear[i], cfg.path.clearance_m
        )


class DrivenRun(NamedTuple):
    """A robot's scripted run (unpacks as ``t, T_world_body, T_odom_body``).

    Attributes:
        t: (N,) times (s).
        T_world_body: (N, 4, 4) true poses.
        T_odom_body: (N, 4, 4) drifted odometry poses.
    """

    t: NDArray[np.float64]
    T_world_body: NDArray[np.float64]
    T_odom_body: NDArray[np.float64]

    @property
    def truth(self) -> Trajectory:
        """The true trajectory."""
        return Trajectory(self.t, self.T_world_body)

    @property
    def odom(self) -> Trajectory:
        """The odometry trajectory."""
        return Trajectory(self.t, self.T_odom_body)


def trajectory_along(world: HasTruth, cfg: RobotConfig, seed: int, path: Path2D) -> DrivenRun:
    """Drive the planned ``path`` (from ``plan_paths``): times (N,), true ``T_world_body`` and drifted
    ``T_odom_body`` (N, 4, 4); no rendering."""
    t, T_wb = _drive(world, cfg, path)
    _check_driven_clearance(world, cfg, T_wb)
    drift = DriftModel(cfg.drift_config(), child_rng(seed, "drift", cfg.name))
    return DrivenRun(t, T_wb, np.stack([drift.step(T) for T in T_wb]))


def render_trajectory(
    world: World,
    cfg: RobotConfig,
    seed: int,
    trajectory: DrivenRun,
    rgb_frames: NDArray[np.bool_] | Sequence[bool] | None = None,
    stereo: bool = False,
) -> Iterator[Frame]:
    """Rendered ``Frame`` objects along a trajectory from ``trajectory_along``.

    Depth and ids are rendered for every frame (the depth noise stream does not depend on
    ``rgb_frames``). RGB, when the robot renders it (``render_rgb``), is drawn on every frame, or
    only where ``rgb_frames`` (one flag per frame) is true; the other frames have ``rgb`` None.
    With ``stereo`` and a second camera (``cfg.stereo``), each frame with RGB also has
    ``rgb_right``, drawn by the same renderer from the second camera's pose.

    Raises: SimError when ``rgb_frames`` does not hold one flag per frame.
    """
    from roman_sim.sim.render import SensorRenderer  # the renderer needs an OpenGL context

    t, T_wb, T_ob = trajectory
    if rgb_frames is None:
        with_rgb = np.full(len(t), cfg.render_rgb)
    else:
        with_rgb = np.asarray(rgb_frames, dtype=bool) & cfg.render_rgb
        if with_rgb.shape != (len(t),):
            raise SimError(f"robot {cfg.name!r}: rgb_frames has {with_rgb.size} flags for {len(t)} frames")
    T_bc = cfg.camera.T_body_cam()
    T_bc2 = T_bc @ cfg.stereo.T_cam_cam2() if stereo and cfg.stereo is not None else None
    noise_rng = child_rng(seed, "depth_noise", cfg.name)
    lighting = robot_lighting(cfg.lighting, seed, cfg.name)
    renderer = SensorRenderer(world, cfg.camera, rgb=cfg.render_rgb, lighting=lighting)
    try:
        for i in range(len(t)):
            rgb, depth, ids = renderer.render(T_wb[i] @ T_bc, rgb=bool(with_rgb[i]))
            noisy = apply_depth_noise(depth, cfg.camera.depth_noise, cfg.camera.max_depth_m, noise_rng)
            right = renderer.render_rgb(T_wb[i] @ T_bc2) if T_bc2 is not None and rgb is not None else None
            truth = FrameTruth(ids, T_wb[i])
            yield Frame(cfg.name, i, float(t[i]), rgb, noisy, T_ob[i], T_bc, renderer.intrinsics, truth, right)
    finally:
        renderer.close()
