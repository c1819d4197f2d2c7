"""A scenario's robots as frame sources: ``robot_sources`` gives one ``FrameSource`` per robot.

It is the one way robots and a world become streams of frames. The simulated robots' paths
are planned together, in order (so ``reverse_of`` and ``cross`` resolve even when only a
later robot is wanted); each wanted robot is driven up front (poses and odometry, cheap:
``SimulatedRobot.run``) and rendered only while its frames are read, one frame in memory at
a time. A robot read from a recorded sequence is no simulated robot: the maps stage opens it
(``roman_sim.pipeline.stages.maps_input``), since the formats live in the layers above.
Random streams are those of ``roman_sim.sim.robot`` (per seed and robot name), so the same
robots, world and seed give the same frames wherever they are read.
"""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError, SimError
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.sim.imu import ImuData, SmoothTrajectory, imu_readings
from roman_sim.sim.robot import DrivenRun, RobotConfig, plan_paths, render_trajectory, trajectory_along

if TYPE_CHECKING:
    from roman_sim.sim.paths import Path2D
    from roman_sim.world import HasTruth

#: Paths planned lately, per (world, seed, robots): the world held weakly, the paths read-only.
#: A run maps each robot in a task of its own, and each task needs every earlier robot's path.
_PLANNED: OrderedDict[tuple[int, int, tuple[str, ...]], tuple[weakref.ref[Any], dict[str, Path2D]]] = OrderedDict()
_PLANNED_MAX = 4
_PLANNED_LOCK = threading.Lock()  # a Dask worker may map robots in threads


def _frozen(path: Path2D) -> Path2D:
    """``path`` with its arrays (and its base's) made read-only, so a shared path cannot change."""
    for a in (path.xy, path.heading, path.s):
        a.setflags(write=False)
    if path.base is not None:
        _frozen(path.base)
    return path


def planned_paths(world: HasTruth, robots: Sequence[RobotConfig], seed: int) -> dict[str, Path2D]:
    """``plan_paths(world, robots, seed)``, planned once per world, seed and robots in this process
    (the same world object: a run's robot tasks share it); the paths are read-only."""
    try:
        ref = weakref.ref(world)
    except TypeError:  # an object that cannot be held weakly: planned each time
        return plan_paths(world, robots, seed)
    key = (id(world), int(seed), tuple(r.model_dump_json() for r in robots))
    with _PLANNED_LOCK:
        hit = _PLANNED.get(key)
        if hit is not None and hit[0]() is world:
            _PLANNED.move_to_end(key)
            return dict(hit[1])
    paths = {name: _frozen(path) for name, path in plan_paths(world, robots, seed).items()}
    with _PLANNED_LOCK:
        _PLANNED[key] = (ref, paths)
        while len(_PLANNED) > _PLANNED_MAX:
            _PLANNED.popitem(last=False)
    return dict(paths)


@dataclass(frozen=True, eq=False)
class SensorRig:
    """What a simulated robot carries beyond its RGB-D camera, for the writers that export it.

    Attributes:
        trajectory: the true body trajectory made continuous (``SmoothTrajectory``), None
            for a robot of a single frame.
        imu: the IMU's readings (``roman_sim.sim.imu``), or None without an IMU.
        T_cam_cam2: 4x4 pose of the second camera in the first's optical frame, or None
            without one.
    """

    trajectory: SmoothTrajectory | None
    imu: ImuData | None = None
    T_cam_cam2: NDArray[np.float64] | None = None


@dataclass(frozen=True, eq=False)
class SimulatedRobot:
    """One simulated robot as a ``FrameSource``: driven up front, rendered lazily.

    Attributes:
        cfg: the robot's configuration.
        world: the world it drives in (a truth-only world gives poses but no frames).
        seed: the scenario seed.
        path: its planned path.
        run: its times, true and odometry poses, one per frame.
        rgb_frames: one flag per frame: RGB is rendered where true (None: every frame), and
            only when the robot renders RGB (``render_rgb``).
        stereo: frames with RGB also carry the second camera's image (``rgb_right``), when
            the robot has one (``cfg.stereo``).
    """

    cfg: RobotConfig
    world: HasTruth
    seed: int
    path: Path2D
    run: DrivenRun
    rgb_frames: NDArray[np.bool_] | None = None
    stereo: bool = False

    @property
    def name(self) -> str:
        """The robot's name."""
        return self.cfg.name

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera intrinsics."""
        return self.cfg.camera.intrinsics()

    @property
    def T_body_cam(self) -> NDArray[np.float64]:
        """The camera (RDF optical) pose in the body (FLU) frame."""
        return self.cfg.camera.T_body_cam()

    def __len__(self) -> int:
        return len(self.run.t)

    def with_rgb(self) -> SimulatedRobot:
        """This robot rendering RGB on every frame, even with ``render_rgb: false``."""
        return replace(self, cfg=self.cfg.model_copy(update={"render_rgb": True}), rgb_frames=None)

    def with_stereo(self) -> SimulatedRobot:
        """This robot rendering its second camera too (``rgb_right``), when it has one."""
        return replace(self, stereo=True)

    def rig(self) -> SensorRig:
        """Its continuous true trajectory, IMU readings and second camera (``SensorRig``).

        The IMU draws its noise from its own stream (``imu`` and the robot name under the seed).

        Raises: SimError for an IMU on a robot of a single frame.
        """
        t, T_wb = self.run.t, self.run.T_world_body
        trajectory = SmoothTrajectory(t, T_wb) if len(t) > 1 else None
        imu = None
        if self.cfg.imu is not None:
            if trajectory is None:
                raise SimError(f"robot {self.name!r}: an IMU needs at least two frames")
            rng = child_rng(self.seed, "imu", self.name)
            imu = imu_readings(trajectory, t, self.cfg.rate_hz, self.cfg.imu, rng)
        T_cc2 = None if self.cfg.stereo is None else self.cfg.stereo.T_cam_cam2()
        return SensorRig(trajectory, imu, T_cc2)

    def rgb_at(self, rgb_frames: NDArray[np.bool_] | Sequence[bool]) -> SimulatedRobot:
        """This robot rendering RGB only where ``rgb_frames`` (one flag per frame) is true (and ``render_rgb``).

        Raises: SimError when ``rgb_frames`` does not hold one flag per frame.
        """
        flags = np.asarray(rgb_frames, dtype=bool)
        if flags.shape != (len(self),):
            raise SimError(f"robot {self.name!r}: rgb_frames has {flags.size} flags for {len(self)} frames")
        return replace(self, rgb_frames=flags)

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """Rendered frames with truth (instance ids, true body pose), in order.

        With ``indices`` only those frames are rendered, each keeping its index; the depth
        noise stream draws once per rendered frame, so their noise is not that of the same
        frames in the whole run.

        Raises: SimError for a truth-only world or indices that are not ascending frame indices.
        """
        from roman_sim.world import World

        if not isinstance(self.world, World):
            raise SimError(f"robot {self.name!r}: the world was generated without a model; nothing to render")
        if indices is None:
            yield from render_trajectory(self.world, self.cfg, self.seed, self.run, self.rgb_frames, self.stereo)
            return
        idx = np.asarray(list(indices), dtype=np.int64)
        if len(idx) and (idx.min() < 0 or idx.max() >= len(self) or np.any(np.diff(idx) <= 0)):
            raise SimError(f"robot {self.name!r}: frame indices must be ascending, in [0, {len(self)})")
        t, T_wb, T_ob = self.run
        run = DrivenRun(t[idx], T_wb[idx], T_ob[idx])
        flags = None if self.rgb_frames is None else self.rgb_frames[idx]
        for k, frame in zip(idx, render_trajectory(self.world, self.cfg, self.seed, run, flags, self.stereo)):
            yield replace(frame, index=int(k))


def robot_sources(
    world: HasTruth | None,
    robots: Sequence[RobotConfig],
    seed: int,
    names: Sequence[str] | None = None,
    *,
    rgb: bool = False,
) -> list[SimulatedRobot]:
    """One ``SimulatedRobot`` per robot of ``robots`` named in ``names`` (all when None), in order.

    Args:
        world: the world the robots drive in.
        robots: every simulated robot of the scenario, in order (paths may refer to earlier ones).
        seed: the scenario seed.
        names: the robots wanted.
        rgb: render RGB on every frame even when a robot's ``render_rgb`` is off.

    Raises:
        ConfigError: an unknown name, or no world.
        SimError: a path cannot be planned or driven.
    """
    known = [r.name for r in robots]
    unknown = [n for n in names or [] if n not in known]
    if unknown:
        raise ConfigError(f"robots: no robot {', '.join(unknown)} (robots: {', '.join(known)})")
    if world is None:
        raise ConfigError("simulated robots need the world")
    paths = planned_paths(world, robots, seed)
    out = []
    for cfg in robots:
        if names is None or cfg.name in names:
            source = SimulatedRobot(
                cfg, world, int(seed), paths[cfg.name], trajectory_along(world, cfg, seed, paths[cfg.name])
            )
            out.append(source.with_rgb() if rgb else source)
    return out
