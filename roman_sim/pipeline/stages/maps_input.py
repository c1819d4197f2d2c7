"""One robot's input to the maps stage, opened once: ``open_robot`` gives its ``RobotInput``.

A ``RobotInput`` holds everything mapping one robot reads, whatever kind of robot it is:

- ``frames``: its ``FrameSource`` as the mapper reads it: a simulated robot rendered along its
  planned path (RGB only where something reads it, ``rgb_frames``), the same read back from the
  run's recording of it (``record_frames``: ``recordings/<robot>``, rendered into it when its
  frames are first read), or a recorded TUM RGB-D folder (``source``,
  ``roman_sim.pipeline.stages.maps_sources``);
- ``rgb``: the same robot with RGB on every frame (the report's front-end snapshot, the view);
- ``families`` and ``looks``: what the simulated encoder knows of the objects: the world's, or
  the sequence's object table;
- ``world``: the world, for the counterfactuals that need it (``mapping.whole_surface``, ``complete``); None
  for a sequence, which has none;
- ``odometry``: which odometry its frames carry, in words: the robot's own, or a TUM file
  brought in from outside in its place (``odometry``, ``roman_sim.interop.odometry_in``), which
  every kind of robot takes the same way.

Every choice that depends on the kind of robot is made here: ``robot_kind`` names it and
``open_robot`` calls that kind's opener (``_simulated``, ``_sequence``); the mapping job
(``roman_sim.pipeline.stages.maps_robot``) reads a ``RobotInput`` and never asks what kind of
robot it maps. Opening renders and writes nothing: a simulated robot is planned and driven
(poses only), a sequence associated, an odometry file read and matched to the frames.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Literal, TypeGuard

import numpy as np

from roman_sim.align.visual.keyframes import keyframe_mask
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.core.sensors import Frame, FrameSource, FrameSourceView
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.components import encoder_spec
from roman_sim.interop.odometry_in import MatchedOdometry, WithOdometry, match_odometry
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.plugin_guard import is_plugin

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from roman_sim.pipeline.scenario import ScenarioRobot
    from roman_sim.sim.recording import Recording
    from roman_sim.sim.source import SimulatedRobot
    from roman_sim.world import HasTruth, World

log = logging.getLogger(__name__)

#: The world, fetched only by a robot that needs it (a simulated one); None where there is none.
WorldSupply = Callable[[], "HasTruth | None"]
#: The kinds of robot a scenario may hold.
RobotKind = Literal["simulated", "sequence"]


@dataclass(frozen=True, eq=False)
class RobotInput:
    """Everything the maps stage reads of one robot (see the module docstring)."""

    name: str
    frames: FrameSource
    rgb: FrameSource
    families: dict[int, str] | None
    looks: SceneLooks | None
    world: World | None
    odometry: str


def robot_kind(cfg: ScenarioRobot) -> RobotKind:
    """What the robot's frames come from: the simulator, or a recorded sequence (``source``)."""
    return "simulated" if cfg.source is None else "sequence"


def open_robot(ctx: RunContext, cfg: ScenarioRobot, world: WorldSupply) -> RobotInput:
    """The robot's ``RobotInput``, opened by the opener of its kind (``world`` is called only if it needs it).

    Raises:
        ConfigError: no world for a simulated robot, a bad sequence folder, an encoder that needs
            families the sequence has no table for, or a bad odometry file (one line each).
    """
    return _OPENERS[robot_kind(cfg)](ctx, cfg, world)


def odometry_used(cfg: ScenarioRobot) -> str:
    """Which odometry the robot's frames carry, in words (without opening the robot)."""
    if cfg.odometry is not None:
        return f"brought in {cfg.odometry.describe()}"
    return _OWN_ODOMETRY[robot_kind(cfg)](cfg)


def check_inputs(ctx: RunContext) -> None:
    """Open every robot that reads files from outside (a sequence, an odometry file) before any work, so a bad
    folder or file fails in one line before anything is written (a world is generated, without its
    model, only for a simulated robot with an odometry file)."""
    from roman_sim.world import generate_truth

    sc = ctx.scenario
    world = cache(lambda: generate_truth(sc.world.spec(), sc.seed))
    for cfg in sc.robots:
        if robot_kind(cfg) == "sequence" or cfg.odometry is not None:
            open_robot(ctx, cfg, world)


def _simulated(ctx: RunContext, cfg: ScenarioRobot, world_of: WorldSupply) -> RobotInput:
    """A simulated robot: planned with the scenario's other simulated robots, driven, rendered as it is read."""
    from roman_sim.interop.looks import robot_looks
    from roman_sim.sim.source import robot_sources

    sc = ctx.scenario
    world = world_of()
    if world is None:
        raise ConfigError(f"robot {cfg.name}: a simulated robot needs the world")
    sim = robot_sources(world, sc.simulated_robots(), sc.seed, [cfg.name])[0]
    odometry = _outside(cfg, sim.run.t, sim.T_body_cam)
    frames: FrameSource = _Recorded(sim, ctx) if sc.record_frames else _rgb_where_read(ctx, sim, odometry)
    own = world if _is_world(world) else None  # a world with its model (validation opens a truth-only one)
    looks = robot_looks(own, cfg.name, cfg.lighting, sc.seed) if _reads_truth(ctx) else None
    families = {o.id: o.family for o in world.truth.objects}
    return RobotInput(
        cfg.name, _with(frames, odometry), _with(sim.with_rgb(), odometry), families, looks, own, odometry_used(cfg)
    )


def _sequence(ctx: RunContext, cfg: ScenarioRobot, world_of: WorldSupply) -> RobotInput:
    """A robot read from its TUM RGB-D folder, with the families and looks of the folder's object table."""
    from roman_sim.interop.looks import sequence_looks
    from roman_sim.pipeline.stages.maps_sources import object_table_path, open_sequence, sequence_families

    sc = ctx.scenario
    seq = open_sequence(cfg, sc.seed)
    assert cfg.source is not None  # the kind of a robot with a source
    families = sequence_families(cfg.source)
    if families is None and _reads_truth(ctx):
        raise ConfigError(
            f"robot {cfg.name}: the {sc.frontend.encoder.name} encoder needs the objects' families, and "
            f"source.tum {cfg.source.tum} has no objects.json (set source.objects, or frontend.encoder to an "
            "image encoder such as image or clip)"
        )
    table = object_table_path(cfg.source)
    looks = sequence_looks(table, cfg.name) if table is not None and _reads_truth(ctx) else None
    frames = _with(seq, _outside(cfg, seq.times, seq.T_body_cam))
    return RobotInput(cfg.name, frames, frames, families, looks, None, odometry_used(cfg))


_OPENERS: dict[RobotKind, Callable[[RunContext, ScenarioRobot, WorldSupply], RobotInput]] = {
    "simulated": _simulated,
    "sequence": _sequence,
}


def _own_simulated(cfg: ScenarioRobot) -> str:
    drift = cfg.drift if isinstance(cfg.drift, str) else "configured"
    return f"its own, simulated (drift {drift})"


def _own_sequence(cfg: ScenarioRobot) -> str:
    assert cfg.source is not None  # the kind of a robot with a source
    return f"its sequence's ({cfg.source.tum}, odometry {cfg.source.odometry})"


_OWN_ODOMETRY: dict[RobotKind, Callable[[ScenarioRobot], str]] = {
    "simulated": _own_simulated,
    "sequence": _own_sequence,
}


def _reads_truth(ctx: RunContext) -> bool:
    return encoder_spec(ctx.scenario.frontend.encoder).reads_truth


def _is_world(world: HasTruth) -> TypeGuard[World]:
    from roman_sim.world import World

    return isinstance(world, World)


def _outside(cfg: ScenarioRobot, times: NDArray[np.float64], T_body_cam: NDArray[np.float64]) -> MatchedOdometry | None:
    """The robot's odometry file matched to its frames (None: it keeps its own)."""
    return None if cfg.odometry is None else match_odometry(cfg.odometry, cfg.name, times, T_body_cam)


def _with(frames: FrameSource, odometry: MatchedOdometry | None) -> FrameSource:
    """``frames`` carrying the odometry from outside, where there is one."""
    return frames if odometry is None else WithOdometry(frames, odometry)


def _rgb_where_read(ctx: RunContext, sim: SimulatedRobot, odometry: MatchedOdometry | None) -> SimulatedRobot:
    """``sim`` rendering RGB only on the frames whose RGB is read (``rgb_frames``, on the odometry it maps with)."""
    run = sim.run
    keep = np.arange(len(sim)) if odometry is None else odometry.keep
    T = run.T_odom_body if odometry is None else odometry.T_odom_body
    flags = rgb_frames(ctx, run.t[keep], T)
    if flags is None:
        return sim
    if odometry is None:
        return sim.rgb_at(flags)
    every = np.zeros(len(sim), dtype=bool)
    every[keep] = flags
    return sim.rgb_at(every)


def rgb_frames(
    ctx: RunContext, t: NDArray[np.float64], T_odom_body: NDArray[np.float64]
) -> NDArray[np.bool_] | list[bool] | None:
    """Frames (times ``t``, odometry poses) whose RGB is read (None: all): a plug-in or an RGB front end reads
    all, the visual method its keyframes."""
    sc = ctx.scenario
    fe = sc.frontend
    if is_plugin(fe.segmenter.name) or is_plugin(fe.encoder.name) or fe.needs_rgb:
        return None
    if not sc.uses_visual:
        return [False] * len(t)
    return keyframe_mask(t, T_odom_body, fe.keyframes)


def _recording_key(ctx: RunContext, name: str) -> str:
    """What a robot's rendered frames depend on: seed, world, every robot (paths may refer to others)."""
    sc = ctx.scenario.model_dump(mode="json")
    return stable_hash(sc["seed"], sc["world"], sc["robots"], name)


@dataclass(frozen=True, eq=False)
class _Recorded(FrameSourceView):
    """A simulated robot (``inner``) read through the run's recording of it (``recordings/<robot>``): read back
    when its key matches, else rendered into it (every frame with RGB) when its frames are first read."""

    ctx: RunContext

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """The recorded frames (recorded first when the recording is missing or of other robots)."""
        yield from self._recording().frames(indices)

    def _recording(self) -> Recording:
        from roman_sim.sim.recording import Recording, RecordingOrigin, recording_info, write_recording

        sc = self.ctx.scenario
        rec_dir = self.ctx.run_dir / "recordings" / self.name
        key = _recording_key(self.ctx, self.name)
        if not self.ctx.fresh:
            try:
                origin = recording_info(rec_dir).extra
                if origin is not None and origin.key == key:
                    return Recording(rec_dir)
            except RomanSimError:
                pass
        write_recording(self.inner.frames(), rec_dir, overwrite=True, origin=RecordingOrigin(sc.name, sc.seed, key))
        return Recording(rec_dir)


__all__ = ["RobotInput", "WorldSupply", "check_inputs", "odometry_used", "open_robot", "rgb_frames", "robot_kind"]
